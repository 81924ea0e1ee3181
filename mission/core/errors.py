"""Errors that stop start-up with one line naming what is wrong and where."""

from __future__ import annotations


class MissionError(Exception):
    """Base class: every error the user can cause carries a one-line message."""


class ConfigError(MissionError):
    """A config, scenario or plugin parameter is wrong.

    The message names the file (when there is one), the dotted key and what was expected,
    e.g. ``config.yaml: perception.sources[0].params.marker_size_m: expected a number > 0, got 'big'``.
    """

    def __init__(self, message: str, *, file: str | None = None, key: str | None = None) -> None:
        self.file = file
        self.key = key
        self.detail = message
        parts = [p for p in (file, key) if p]
        super().__init__(": ".join([*parts, message]))


class TreeError(MissionError):
    """A tree file is malformed or names something that does not exist (file:line: element: why)."""


class PluginError(MissionError):
    """A perception plugin is unknown or failed to load."""
