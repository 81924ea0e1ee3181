"""Benchmarks (not tests): `mission bench`."""
