"""Errors raised while loading or changing the configuration."""

from __future__ import annotations

from collections.abc import Sequence

from navd.errors import NavdError

__all__ = ["ConfigError"]


class ConfigError(NavdError):
    """The configuration is invalid; ``problems`` has one line per bad key, naming it.

    Args:
        problems: one human-readable line per problem, each starting with the key path.
        source: where the config came from (a file path, "config change"...).
    """

    def __init__(self, problems: Sequence[str], source: str = "config") -> None:
        self.problems = tuple(problems)
        self.source = source
        count = len(self.problems)
        header = f"{source}: {count} problem{'s' if count != 1 else ''}"
        super().__init__(header + "".join(f"\n  - {p}" for p in self.problems))
