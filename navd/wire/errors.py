"""Errors of navd's wire protocol: a frame the protocol does not allow, and a client's
failures to reach navd or to be answered as it expected."""

from __future__ import annotations

from typing import TYPE_CHECKING

from navd.errors import NavdError

if TYPE_CHECKING:
    from navd.wire.replies import ErrorFrame

__all__ = [
    "ClientError",
    "ConnectionClosedError",
    "MissionDocumentError",
    "ProtocolError",
    "RequestRefusedError",
    "WireError",
]


class ProtocolError(NavdError):
    """Base of the errors raised by navd.wire."""


class WireError(ProtocolError):
    """A frame the protocol does not allow (a client's line, or a reply a client reads).

    Args:
        field: the offending field's path ("ranges.3"), or "" for the frame as a whole.
        reason: what is wrong and what is expected.
    """

    def __init__(self, field: str, reason: str) -> None:
        super().__init__(f"{field}: {reason}" if field else reason)
        self.field = field
        self.reason = reason


class MissionDocumentError(ProtocolError):
    """A mission file's table is not a mission.

    Attributes:
        problems: one line per wrong field, each starting with the field's path.
    """

    def __init__(self, problems: list[str]) -> None:
        super().__init__("; ".join(problems))
        self.problems = problems


class ClientError(ProtocolError):
    """navd could not be reached, refused the connection, or answered what was not expected."""


class ConnectionClosedError(ClientError):
    """navd closed the connection."""


class RequestRefusedError(ClientError):
    """navd answered a request (or the hello) with an error frame.

    Attributes:
        error: the error frame.
    """

    def __init__(self, what: str, error: ErrorFrame) -> None:
        super().__init__(f"navd refused the {what}: {error.describe()}")
        self.error = error
