"""mission: behaviour-tree missions for camera-equipped mobile robots."""

__version__ = "0.1.0"
