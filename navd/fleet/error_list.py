"""The vehicle's errors as its state reports them (VDA 5050 2.1, §6.10.6): one of each kind,
with what it refers to, kept until what caused it is resolved."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

__all__ = ["ErrorList"]


class ErrorList:
    """The errors reported now, one per kind, each a state message's ``errors`` item."""

    def __init__(self) -> None:
        self._errors: list[dict[str, Any]] = []

    def __iter__(self) -> Iterator[dict[str, Any]]:
        return iter(self._errors)

    def __len__(self) -> int:
        return len(self._errors)

    def report(self, kind: str, why: str, refs: list[tuple[str, str]]) -> None:
        """Report ``kind`` (replacing an earlier one of its kind) with its description and
        references (key, value)."""
        self._errors = [e for e in self._errors if e["errorType"] != kind]
        self._errors.append(
            {
                "errorType": kind,
                "errorLevel": "WARNING",
                "errorDescription": why,
                "errorReferences": [{"referenceKey": k, "referenceValue": v} for k, v in refs],
            }
        )

    def clear(self, kind: str | None = None) -> bool:
        """Resolve the errors of ``kind`` (None: all); True if any went."""
        kept = [] if kind is None else [e for e in self._errors if e["errorType"] != kind]
        if kept == self._errors:
            return False
        self._errors = kept
        return True
