"""The asyncio client of chromod (grpc.aio): the blocking Client's calls as
coroutines, for notebooks and services that run an event loop.

    async with AsyncClient() as client:
        run = await client.run_session("forearm", on_progress=print)
        maps = await client.maps(run.id)
"""
from __future__ import annotations

from typing import AsyncIterator, Iterable, List, Optional, Sequence

import grpc
from grpc import aio

from . import _convert
from .client import ProgressCallback, channel_credentials
from .errors import from_rpc_error
from .model import Maps, Photographs, PlanAdvice, PreviewFrame, Progress, Relit, Results, SessionRun
from .v1 import (cameras_pb2_grpc, estimation_pb2, estimation_pb2_grpc, maps_pb2, maps_pb2_grpc, operations_pb2,
                 operations_pb2_grpc, planning_pb2_grpc, sessions_pb2_grpc)


class AsyncClient:
    """One asyncio connection to chromod; the same arguments and errors as :class:`Client`."""

    def __init__(self, target: Optional[str] = None, token: Optional[str] = None,
                 root_certificates: Optional[bytes] = None, timeout: float = 120.0) -> None:
        self.target = target or _convert.default_target()
        self.timeout = timeout
        credentials = channel_credentials(token, root_certificates)
        self.channel = aio.secure_channel(self.target, credentials) if credentials else aio.insecure_channel(self.target)
        self._cameras = cameras_pb2_grpc.CameraServiceStub(self.channel)
        self._operations = operations_pb2_grpc.OperationServiceStub(self.channel)
        self._sessions = sessions_pb2_grpc.SessionServiceStub(self.channel)
        self._results = estimation_pb2_grpc.ResultsServiceStub(self.channel)
        self._maps = maps_pb2_grpc.MapsServiceStub(self.channel)
        self._planning = planning_pb2_grpc.PlanServiceStub(self.channel)

    async def __aenter__(self) -> "AsyncClient":
        return self

    async def __aexit__(self, *exc: object) -> None:
        await self.close()

    async def close(self) -> None:
        await self.channel.close()

    async def _call(self, name: str, method, request):
        try:
            return await method(request, timeout=self.timeout)
        except grpc.RpcError as error:
            raise from_rpc_error(error, name) from None

    async def start_session(self, subject: str = "", *, exposure_us: float = 0.0, frames_per_camera: int = 0,
                            reference_frames: int = 0, subject_fill: float = 0.0) -> str:
        request = _convert.start_request(subject, exposure_us, frames_per_camera, reference_frames, subject_fill)
        return (await self._call("SessionService.StartSession", self._sessions.StartSession, request)).id

    async def wait(self, operation_id: str, on_progress: Optional[ProgressCallback] = None) -> Progress:
        last: Optional[Progress] = None
        try:
            async for operation in self._operations.WatchOperation(
                    operations_pb2.WatchOperationRequest(id=operation_id)):
                last = _convert.progress(operation)
                if on_progress:
                    on_progress(last)
                if last.finished:
                    return last
        except grpc.RpcError as error:
            raise from_rpc_error(error, "OperationService.WatchOperation") from None
        operation = await self._call("OperationService.GetOperation", self._operations.GetOperation,
                                     operations_pb2.GetOperationRequest(id=operation_id))
        return _convert.progress(operation)

    async def run_session(self, subject: str = "", *, on_progress: Optional[ProgressCallback] = None,
                          exposure_us: float = 0.0, frames_per_camera: int = 0, reference_frames: int = 0,
                          subject_fill: float = 0.0) -> SessionRun:
        session_id = await self.start_session(subject, exposure_us=exposure_us, frames_per_camera=frames_per_camera,
                                              reference_frames=reference_frames, subject_fill=subject_fill)
        final = await self.wait(session_id, on_progress)
        return SessionRun(id=session_id, state=final.state, message=final.error or final.message,
                          frames_stored=final.frames_stored, folder=final.folder)

    async def results(self, session_id: str) -> Results:
        return _convert.results(await self._call("ResultsService.GetResults", self._results.GetResults,
                                                 estimation_pb2.GetResultsRequest(session_id=session_id)))

    async def maps(self, session_id: str, camera: Optional[str] = None, channels: Optional[Sequence[str]] = None,
                   *, maps_file: str = "", chunk_bytes: int = 0) -> Maps:
        if not maps_file:
            maps_file = _convert.maps_file_of(await self.results(session_id), session_id, camera)
        assembler = _convert.MapsAssembler(f"session {session_id}: {maps_file}")
        request = _convert.read_maps_request(session_id, maps_file, channels, chunk_bytes)
        try:
            async for chunk in self._maps.ReadMaps(request, timeout=self.timeout):
                assembler.add(chunk)
        except grpc.RpcError as error:
            raise from_rpc_error(error, "MapsService.ReadMaps") from None
        return assembler.result()

    async def relight(self, session_id: str, illuminant: str, *, maps_file: str = "results/maps.exr",
                      label: str = "", photograph_file: str = "", model_only: bool = False) -> Relit:
        request = _convert.relight_request(session_id, maps_file, illuminant, label, photograph_file, model_only)
        return _convert.relit(await self._call("MapsService.Relight", self._maps.Relight, request))

    async def photographs(self, session_id: str, maps_file: str = "results/maps.exr") -> Photographs:
        request = maps_pb2.ListPhotographsRequest(session_id=session_id, maps_file=maps_file)
        return _convert.photographs(await self._call("MapsService.ListPhotographs", self._maps.ListPhotographs,
                                                     request))

    async def preview(self, camera: str = "", *, rate_hz: float = 10.0, width: int = 480, white_balance: bool = False,
                      region: Optional[_convert.Region] = None, count: Optional[int] = None) -> AsyncIterator[PreviewFrame]:
        """The blocking :meth:`Client.preview` as an async generator."""
        request = _convert.preview_request(camera, rate_hz, width, white_balance, region)
        call = self._cameras.StreamPreview(request, timeout=self.timeout)
        try:
            number = 0
            async for frame in call:
                number += 1
                yield _convert.preview_frame(frame)
                if count is not None and number >= count:
                    break
        except grpc.RpcError as error:
            raise from_rpc_error(error, "CameraService.StreamPreview") from None
        finally:
            call.cancel()

    async def compare_plans(self, plans: Iterable[_convert.PlanLike], *, skins: int = 0, seed: int = 0,
                            interior_population: bool = False, monte_carlo_draws: int = 0) -> List[PlanAdvice]:
        request = _convert.compare_request(plans, skins, seed, interior_population, monte_carlo_draws)
        return _convert.plan_advice(await self._call("PlanService.ComparePlans", self._planning.ComparePlans,
                                                     request))
