"""Errors that stop start-up with one line naming what is wrong and where."""

from __future__ import annotations

from collections.abc import Sequence


class MissionError(Exception):
    """Base class: every error the user can cause carries a one-line message."""


class ConfigError(MissionError):
    """A config, scenario or plugin parameter is wrong.

    The message names the file (when there is one), the dotted key and what was expected,
    e.g. ``config.yaml: perception.sources[0].params.marker_size_m: expected a number > 0, got 'big'``.
    A file with several problems gives one such line per problem (:meth:`several`); `key` and `detail`
    are the first problem's, `problems` all of them as (key, message) pairs.
    """

    def __init__(
        self,
        message: str,
        *,
        file: str | None = None,
        key: str | None = None,
        more: Sequence[tuple[str | None, str]] = (),
    ) -> None:
        self.file = file
        self.key = key
        self.detail = message
        self.problems: list[tuple[str | None, str]] = [(key, message), *more]
        super().__init__("\n".join(": ".join(p for p in (file, k, m) if p) for k, m in self.problems))

    @classmethod
    def several(cls, problems: Sequence[tuple[str | None, str]], *, file: str | None = None) -> ConfigError:
        """One error for all of `problems` (at least one): a line each, in order."""
        (key, message), *more = problems
        return cls(message, file=file, key=key, more=more)

    def within(self, prefix: str, *, file: str | None = None, sep: str = ".") -> ConfigError:
        """The same problems with every key under `prefix` (``aruco`` params → ``perception.sources[0].params``),
        in this error's file, else in `file`."""

        def under(key: str | None) -> str:
            if not key or key == "(top level)":
                return prefix
            return prefix + ("" if key.startswith("[") else sep) + key

        return ConfigError.several([(under(k), m) for k, m in self.problems], file=self.file or file)


class TreeError(MissionError):
    """A tree file is malformed or names something that does not exist (file:line: element: why)."""


class PluginError(MissionError):
    """A perception plugin is unknown or failed to load."""
