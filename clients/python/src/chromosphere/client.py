"""The blocking client of chromod (the Chromosphere daemon)."""
from __future__ import annotations

from typing import Callable, Iterable, Iterator, List, Optional, Sequence

import grpc

from . import _convert
from .errors import from_rpc_error
from .model import Maps, Photographs, PlanAdvice, PreviewFrame, Progress, Relit, Results, SessionRun
from .v1 import (cameras_pb2_grpc, devices_pb2, devices_pb2_grpc, estimation_pb2, estimation_pb2_grpc, maps_pb2_grpc,
                 maps_pb2, operations_pb2, operations_pb2_grpc, planning_pb2_grpc, sessions_pb2,
                 sessions_pb2_grpc)

ProgressCallback = Callable[[Progress], None]


def channel_credentials(token: Optional[str], root_certificates: Optional[bytes]) -> Optional[grpc.ChannelCredentials]:
    """Credentials for TCP with a bearer token (TLS with root_certificates); None for a Unix socket."""
    if token is None:
        return None
    call = grpc.access_token_call_credentials(token)
    base = grpc.ssl_channel_credentials(root_certificates) if root_certificates else grpc.local_channel_credentials()
    return grpc.composite_channel_credentials(base, call)


class Client:
    """One connection to chromod.

    target: "unix:/path/chromod.sock" (default: the daemon's default socket) or
    "host:port" (TCP needs ``token``; ``root_certificates`` for TLS). Every
    method raises a :class:`chromosphere.ChromosphereError` subclass naming
    what was wrong. Use as a context manager, or call :meth:`close`.
    """

    def __init__(self, target: Optional[str] = None, token: Optional[str] = None,
                 root_certificates: Optional[bytes] = None, timeout: float = 120.0) -> None:
        self.target = target or _convert.default_target()
        self.timeout = timeout
        credentials = channel_credentials(token, root_certificates)
        self.channel = (grpc.secure_channel(self.target, credentials) if credentials
                        else grpc.insecure_channel(self.target))
        self._devices = devices_pb2_grpc.DeviceServiceStub(self.channel)
        self._cameras = cameras_pb2_grpc.CameraServiceStub(self.channel)
        self._operations = operations_pb2_grpc.OperationServiceStub(self.channel)
        self._sessions = sessions_pb2_grpc.SessionServiceStub(self.channel)
        self._results = estimation_pb2_grpc.ResultsServiceStub(self.channel)
        self._maps = maps_pb2_grpc.MapsServiceStub(self.channel)
        self._planning = planning_pb2_grpc.PlanServiceStub(self.channel)

    def __enter__(self) -> "Client":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        self.channel.close()

    def _call(self, name: str, method, request, timeout: Optional[float] = None):
        try:
            return method(request, timeout=timeout if timeout is not None else self.timeout)
        except grpc.RpcError as error:
            raise from_rpc_error(error, name) from None

    def devices(self) -> List[devices_pb2.Device]:
        """Every device: name, backend, address, health."""
        return list(self._call("DeviceService.ListDevices", self._devices.ListDevices,
                               devices_pb2.ListDevicesRequest()).devices)

    def start_session(self, subject: str = "", *, exposure_us: float = 0.0, frames_per_camera: int = 0,
                      reference_frames: int = 0, subject_fill: float = 0.0) -> str:
        """Starts the standard plan and returns the session id. 0 leaves a setting to the daemon's
        configuration; subject_fill in (0, 1) meters each subject (docs/daemon.md)."""
        request = _convert.start_request(subject, exposure_us, frames_per_camera, reference_frames, subject_fill)
        return self._call("SessionService.StartSession", self._sessions.StartSession, request).id

    def wait(self, operation_id: str, on_progress: Optional[ProgressCallback] = None,
             timeout: Optional[float] = None) -> Progress:
        """Streams the operation's progress (each update to on_progress) until it ends; returns the last."""
        last: Optional[Progress] = None
        try:
            stream = self._operations.WatchOperation(operations_pb2.WatchOperationRequest(id=operation_id),
                                                     timeout=timeout)
            for operation in stream:
                last = _convert.progress(operation)
                if on_progress:
                    on_progress(last)
                if last.finished:
                    return last
        except grpc.RpcError as error:
            raise from_rpc_error(error, "OperationService.WatchOperation") from None
        operation = self._call("OperationService.GetOperation", self._operations.GetOperation,
                               operations_pb2.GetOperationRequest(id=operation_id))
        return _convert.progress(operation)

    def run_session(self, subject: str = "", *, on_progress: Optional[ProgressCallback] = None,
                    exposure_us: float = 0.0, frames_per_camera: int = 0, reference_frames: int = 0,
                    subject_fill: float = 0.0, timeout: Optional[float] = None) -> SessionRun:
        """Runs the standard session to its end (progress to on_progress) and returns how it ended."""
        session_id = self.start_session(subject, exposure_us=exposure_us, frames_per_camera=frames_per_camera,
                                        reference_frames=reference_frames, subject_fill=subject_fill)
        final = self.wait(session_id, on_progress, timeout=timeout)
        return SessionRun(id=session_id, state=final.state, message=final.error or final.message,
                          frames_stored=final.frames_stored, folder=final.folder)

    def results(self, session_id: str) -> Results:
        """The session's results: state, each camera's maps and report (paths relative to its folder)."""
        return _convert.results(self._call("ResultsService.GetResults", self._results.GetResults,
                                           estimation_pb2.GetResultsRequest(session_id=session_id)))

    def maps(self, session_id: str, camera: Optional[str] = None, channels: Optional[Sequence[str]] = None,
             *, maps_file: str = "", chunk_bytes: int = 0) -> Maps:
        """A session's maps at full resolution as numpy (streamed in chunks of rows).

        camera: which camera's maps (None: the only one, or the first with maps); maps_file: a maps
        file relative to the session folder instead (with session_id "": relative to the daemon's
        maps_dir); channels: a subset (None: all). Channels come as Cm, Ch, Bm, Che, residual,
        order, flags, then the others; one call sends at most the daemon's max_read_maps_bytes."""
        if not maps_file:
            maps_file = _convert.maps_file_of(self.results(session_id), session_id, camera)
        assembler = _convert.MapsAssembler(f"session {session_id}: {maps_file}")
        request = _convert.read_maps_request(session_id, maps_file, channels, chunk_bytes)
        try:
            for chunk in self._maps.ReadMaps(request, timeout=self.timeout):
                assembler.add(chunk)
        except grpc.RpcError as error:
            raise from_rpc_error(error, "MapsService.ReadMaps") from None
        return assembler.result()

    def relight(self, session_id: str, illuminant: str, *, maps_file: str = "results/maps.exr",
                label: str = "", photograph_file: str = "", model_only: bool = False) -> Relit:
        """The maps relit under an illuminant (W57..B, D65, D50, A, "4000K", or a CSV in the session
        folder); files in a new folder of the session's products/. The maps' posterior discrepancy
        (their relit layer, where they carry one) is added unless model_only; the summary's
        "discrepancy_layer" says which."""
        request = _convert.relight_request(session_id, maps_file, illuminant, label, photograph_file, model_only)
        return _convert.relit(self._call("MapsService.Relight", self._maps.Relight, request))

    def photographs(self, session_id: str, maps_file: str = "results/maps.exr") -> Photographs:
        """The session folder's RGB OpenEXR files a relight of maps_file can compare against (the
        web view's picker): each with its size and whether it is the maps' (then usable)."""
        request = maps_pb2.ListPhotographsRequest(session_id=session_id, maps_file=maps_file)
        return _convert.photographs(self._call("MapsService.ListPhotographs", self._maps.ListPhotographs, request))

    def preview(self, camera: str = "", *, rate_hz: float = 10.0, width: int = 480, white_balance: bool = False,
                region: Optional[_convert.Region] = None, count: Optional[int] = None) -> Iterator[PreviewFrame]:
        """Yields live preview frames of a camera ("": the only one) at up to rate_hz (0-30), width
        64-1280 pixels; stops after ``count`` frames when given. white_balance: the picture balanced
        for a white target under the LEDs as driven now, from chromod's LED library (the frame says
        which, or "none: raw" and why); region: (x, y, width, height) as fractions of the frame that
        the histogram and region_mean come from (None: the whole frame; outside [0, 1]:
        InvalidArgument naming it). During a session the frames are the session's own."""
        request = _convert.preview_request(camera, rate_hz, width, white_balance, region)
        stream = self._cameras.StreamPreview(request, timeout=self.timeout)
        try:
            for number, frame in enumerate(stream, 1):
                yield _convert.preview_frame(frame)
                if count is not None and number >= count:
                    break
        except grpc.RpcError as error:
            raise from_rpc_error(error, "CameraService.StreamPreview") from None
        finally:
            stream.cancel()

    def compare_plans(self, plans: Iterable[_convert.PlanLike], *, skins: int = 0, seed: int = 0,
                      interior_population: bool = False, monte_carlo_draws: int = 0) -> List[PlanAdvice]:
        """The plan advisor on the daemon's LED library and camera (docs/plan-advisor.md)."""
        request = _convert.compare_request(plans, skins, seed, interior_population, monte_carlo_draws)
        return _convert.plan_advice(self._call("PlanService.ComparePlans", self._planning.ComparePlans, request))

    def delete_session(self, session_id: str) -> None:
        """Deletes a finished session's folder (refused while it runs)."""
        self._call("SessionService.DeleteSession", self._sessions.DeleteSession,
                   sessions_pb2.DeleteSessionRequest(id=session_id))
