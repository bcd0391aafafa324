"""Errors of the Chromosphere client: every failure is a ChromosphereError
whose message names what was wrong (the daemon's field, the file, the
session), subclassed by kind so a caller can catch the one it handles."""
from __future__ import annotations

from typing import Optional

import grpc


class ChromosphereError(Exception):
    """Base of every error the package raises. ``call`` names the API call
    (e.g. "MapsService.ReadMaps"), ``code`` the gRPC status name or None."""

    def __init__(self, message: str, call: str = "", code: Optional[str] = None) -> None:
        super().__init__(f"{call}: {message}" if call else message)
        self.call = call
        self.code = code
        self.detail = message


class InvalidArgument(ChromosphereError, ValueError):
    """The request (or a file it named) was refused; the message names the field."""


class NotFound(ChromosphereError, LookupError):
    """An unknown session or operation id, or a file that is not there."""


class FailedPrecondition(ChromosphereError):
    """Not now: e.g. a session is running, results are not available yet."""


class ResourceExhausted(ChromosphereError):
    """Past a bound: too many streams, a map read larger than one call sends."""


class Unavailable(ChromosphereError, ConnectionError):
    """The daemon cannot be reached (not running, wrong socket) or a device did not answer."""


class PermissionDenied(ChromosphereError, PermissionError):
    """Missing or wrong bearer token."""


class StoredSessionError(ChromosphereError):
    """A stored session folder that cannot be read (open_session); names the file."""


_BY_CODE = {
    grpc.StatusCode.INVALID_ARGUMENT: InvalidArgument,
    grpc.StatusCode.OUT_OF_RANGE: InvalidArgument,
    grpc.StatusCode.NOT_FOUND: NotFound,
    grpc.StatusCode.FAILED_PRECONDITION: FailedPrecondition,
    grpc.StatusCode.RESOURCE_EXHAUSTED: ResourceExhausted,
    grpc.StatusCode.UNAVAILABLE: Unavailable,
    grpc.StatusCode.UNAUTHENTICATED: PermissionDenied,
    grpc.StatusCode.PERMISSION_DENIED: PermissionDenied,
}


def from_rpc_error(error: grpc.RpcError, call: str) -> ChromosphereError:
    """The package's exception for a gRPC error of ``call``."""
    code = error.code() if hasattr(error, "code") else None
    details = error.details() if hasattr(error, "details") else str(error)
    kind = _BY_CODE.get(code, ChromosphereError)
    name = code.name if code is not None else None
    if code == grpc.StatusCode.UNAVAILABLE and not details:
        details = "the daemon cannot be reached"
    return kind(details or str(error), call=call, code=name)
