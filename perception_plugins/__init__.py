"""Perception sources (aruco, apriltag, vlm_stub) and the registry that finds them by entry point."""
