"""The root of navd's error tree: every error navd raises on purpose derives from NavdError."""

from __future__ import annotations

__all__ = ["NavdError"]


class NavdError(Exception):
    """Base of every error navd raises on purpose; its message says what to fix."""
