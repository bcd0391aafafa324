"""Chromosphere's Python client: chromod over its socket API (blocking
:class:`Client`, asyncio :class:`AsyncClient`), the maps at full resolution
as numpy, and stored session folders read from disk with no daemon
(:func:`open_session`). API reference: docs/python.md."""
from .aio import AsyncClient
from .client import Client
from ._convert import default_target
from .errors import (ChromosphereError, FailedPrecondition, InvalidArgument, NotFound, PermissionDenied,
                     ResourceExhausted, StoredSessionError, Unavailable)
from .model import (CameraResults, MapChannel, Maps, Photograph, Photographs, PlanAdvice, PreviewFrame, Progress, Relit,
                    Results, SessionRun)
from .stored import StoredSession, open_session, read_ome_maps

__all__ = [
    "AsyncClient", "CameraResults", "ChromosphereError", "Client", "FailedPrecondition", "InvalidArgument",
    "MapChannel", "Maps", "NotFound", "PermissionDenied", "Photograph", "Photographs", "PlanAdvice", "PreviewFrame",
    "Progress", "Relit", "ResourceExhausted",
    "Results", "SessionRun", "StoredSession", "StoredSessionError", "Unavailable", "default_target",
    "open_session", "read_ome_maps",
]
__version__ = "0.1.0"
