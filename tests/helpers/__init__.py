"""Helpers shared by tests of several floors, imported by full name: ``from tests.helpers.behaviour_world import …``."""
