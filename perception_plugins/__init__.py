"""Perception sources (aruco, apriltag, vlm/) and the registry that finds them by entry point."""
