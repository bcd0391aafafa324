"""Requests built and responses turned into the package's types: shared by
the blocking and the asyncio client."""
from __future__ import annotations

import json
import os
from typing import Dict, Iterable, List, Optional, Sequence, Union

import numpy as np
from google.protobuf.json_format import MessageToDict

from .errors import ChromosphereError, FailedPrecondition, InvalidArgument
from .model import (CameraResults, MapChannel, Maps, Photograph, Photographs, PlanAdvice, PreviewFrame, Progress, Relit,
                    Results)
from .v1 import cameras_pb2, estimation_pb2, maps_pb2, operations_pb2, planning_pb2, sessions_pb2

FINAL_STATES = {"succeeded", "failed", "cancelled", "interrupted"}


def default_target() -> str:
    """chromod's default socket, by the daemon's rule (files/runtime_dir.hpp):
    $CHROMO_RUNTIME_DIR, else $XDG_RUNTIME_DIR/chromosphere, else
    ~/.local/state/chromosphere/run; then /chromod.sock."""
    if os.environ.get("CHROMO_RUNTIME_DIR"):
        folder = os.environ["CHROMO_RUNTIME_DIR"]
    elif os.environ.get("XDG_RUNTIME_DIR"):
        folder = os.path.join(os.environ["XDG_RUNTIME_DIR"], "chromosphere")
    else:
        folder = os.path.join(os.path.expanduser("~"), ".local", "state", "chromosphere", "run")
    return "unix:" + os.path.join(folder, "chromod.sock")


def state_name(state: int) -> str:
    return operations_pb2.OperationState.Name(state).replace("OPERATION_STATE_", "").lower()


def progress(op: operations_pb2.Operation) -> Progress:
    c = op.counters
    return Progress(id=op.id, state=state_name(op.state), progress=op.progress, eta_seconds=op.eta_seconds,
                    message=op.message, error=op.error, frames_stored=c.stored, frames_expected=c.expected,
                    frames_lost=c.lost, folder=op.folder)


def start_request(subject: str, exposure_us: float, frames_per_camera: int, reference_frames: int,
                  subject_fill: float) -> sessions_pb2.StartSessionRequest:
    if not 0 <= subject_fill < 1:
        raise InvalidArgument(f"subject_fill: {subject_fill} is outside [0, 1) (0: the daemon's configuration)")
    return sessions_pb2.StartSessionRequest(standard=True, subject=subject, exposure_us=exposure_us,
                                            frames_per_camera=frames_per_camera, reference_frames=reference_frames,
                                            subject_fill=subject_fill)


def _relative(path: str, folder: str) -> str:
    if folder and path.startswith(folder.rstrip("/") + "/"):
        return path[len(folder.rstrip("/")) + 1:]
    return path


def _json(text: str) -> Dict[str, object]:
    try:
        value = json.loads(text) if text else {}
    except ValueError:
        return {}
    return value if isinstance(value, dict) else {}


def results(r: estimation_pb2.Results) -> Results:
    available = r.state == estimation_pb2.RESULTS_STATE_AVAILABLE
    cameras = [CameraResults(camera=c.camera, available=c.state == estimation_pb2.RESULTS_STATE_AVAILABLE,
                             reason=c.reason, maps_file=_relative(c.maps_file, r.folder),
                             report_file=_relative(c.report_file, r.folder),
                             summary=MessageToDict(c.summary, preserving_proto_field_name=True))
               for c in r.cameras]
    if not cameras and available:
        cameras = [CameraResults(camera="", available=True, reason="", maps_file=_relative(r.maps_file, r.folder),
                                 report_file=_relative(r.report_file, r.folder),
                                 summary=MessageToDict(r.summary, preserving_proto_field_name=True))]
    return Results(session_id=r.session_id, available=available, reason=r.reason, folder=r.folder, cameras=cameras,
                   summary=_json(r.summary_json))


def maps_file_of(found: Results, session_id: str, camera: Optional[str]) -> str:
    """The maps file of `camera` in GetResults' answer `found`; FailedPrecondition when the session has no
    maps yet, ChromosphereError naming the camera when it has none (both the blocking and the async client)."""
    if not found.available:
        raise FailedPrecondition(f"session {session_id} has no maps ({found.reason or 'not yet'})",
                                 call="ResultsService.GetResults")
    try:
        return found.camera(camera).maps_file
    except KeyError as error:
        raise ChromosphereError(str(error.args[0]), call="ResultsService.GetResults") from None


def relight_request(session_id: str, maps_file: str, illuminant: str, label: str,
                    photograph_file: str, model_only: bool = False) -> maps_pb2.RelightRequest:
    return maps_pb2.RelightRequest(session_id=session_id, maps_file=maps_file, illuminant=illuminant, label=label,
                                   photograph_file=photograph_file, model_only=model_only)


def read_maps_request(session_id: str, maps_file: str, channels: Optional[Sequence[str]],
                      chunk_bytes: int) -> maps_pb2.ReadMapsRequest:
    return maps_pb2.ReadMapsRequest(session_id=session_id, maps_file=maps_file, channels=list(channels or []),
                                    chunk_bytes=chunk_bytes)


class MapsAssembler:
    """Fills one (channels, height, width) float32 array from ReadMaps' chunks."""

    def __init__(self, source: str) -> None:
        self.source = source
        self.maps: Optional[Maps] = None
        self.rows_received = 0

    def add(self, chunk: maps_pb2.ReadMapsResponse) -> None:
        if self.maps is None:
            channels = [MapChannel(c.name, c.unit, c.meaning) for c in chunk.channels]
            data = np.empty((len(channels), chunk.height, chunk.width), dtype=np.float32)
            self.maps = Maps(width=chunk.width, height=chunk.height, channels=channels,
                             flag_names=list(chunk.flag_names), data=data, source=self.source)
        maps = self.maps
        rows, begin = chunk.rows, chunk.row_begin
        if begin + rows > maps.height or len(chunk.data) != len(maps.channels):
            raise InvalidArgument(f"{self.source}: a chunk of rows {begin}-{begin + rows} with {len(chunk.data)} "
                                  f"channels does not fit {maps.width}x{maps.height}x{len(maps.channels)} maps")
        for index, payload in enumerate(chunk.data):
            maps.data[index, begin:begin + rows, :] = np.frombuffer(payload, dtype="<f4").reshape(rows, maps.width)
        self.rows_received += rows

    def result(self) -> Maps:
        if self.maps is None or self.rows_received != self.maps.height:
            got = self.rows_received
            raise InvalidArgument(f"{self.source}: the stream ended after {got} rows"
                                  + (f" of {self.maps.height}" if self.maps else ""))
        return self.maps


def relit(r: maps_pb2.RelightResponse) -> Relit:
    return Relit(illuminant=r.illuminant, width=r.width, height=r.height, relit_pixels=r.relit_pixels,
                 out_dir=r.out_dir, files=list(r.files), summary=_json(r.summary_json))


PlanLike = Union[str, planning_pb2.PlanDescription]


def compare_request(plans: Iterable[PlanLike], skins: int, seed: int, interior_population: bool,
                    monte_carlo_draws: int) -> planning_pb2.ComparePlansRequest:
    choices = []
    for plan in plans:
        if isinstance(plan, str):
            choices.append(planning_pb2.PlanChoice(builtin=plan))
        elif isinstance(plan, planning_pb2.PlanDescription):
            choices.append(planning_pb2.PlanChoice(description=plan))
        else:
            raise InvalidArgument(f"plans: {plan!r} is neither a built-in plan name nor a PlanDescription")
    return planning_pb2.ComparePlansRequest(plans=choices, skins=skins, seed=seed,
                                            interior_population=interior_population,
                                            monte_carlo_draws=monte_carlo_draws)


def plan_advice(response: planning_pb2.ComparePlansResponse) -> List[PlanAdvice]:
    out = []
    for a in response.plans:
        out.append(PlanAdvice(plan=a.plan, channels=list(a.channels), subject_s=a.subject_s,
                              reference_s=a.reference_s,
                              sigma={"cm": a.sigma.cm, "ch": a.sigma.ch, "bm": a.sigma.bm, "che": a.sigma.che},
                              predicted_delta_e94=dict(zip(a.illuminants, a.predicted_delta_e94)),
                              predicted_delta_e94_mean=a.predicted_delta_e94_mean,
                              monte_carlo_delta_e94_mean=a.monte_carlo_delta_e94_mean if a.checked else None))
    return out


def photographs(r: maps_pb2.ListPhotographsResponse) -> Photographs:
    return Photographs(maps_width=r.maps_width, maps_height=r.maps_height,
                       photographs=[Photograph(file=p.file, width=p.width, height=p.height, same_size=p.same_size)
                                    for p in r.photographs])


Region = Sequence[float]  # x, y, width, height as fractions of the frame (0-1)


def preview_request(camera: str, rate_hz: float, width: int, white_balance: bool,
                    region: Optional[Region]) -> cameras_pb2.StreamPreviewRequest:
    request = cameras_pb2.StreamPreviewRequest(camera=camera, rate_hz=rate_hz, width=width, white_balance=white_balance)
    if region is not None:
        values = list(region)
        if len(values) != 4:
            raise InvalidArgument(f"region: {values!r} is not four numbers (x, y, width, height as fractions of the frame)")
        request.region.x, request.region.y, request.region.width, request.region.height = (float(v) for v in values)
    return request


def preview_frame(f: cameras_pb2.PreviewFrame) -> PreviewFrame:
    return PreviewFrame(camera=f.camera, width=f.width, height=f.height, jpeg=bytes(f.jpeg), clipped_pixels=f.clipped_pixels,
                        histogram=list(f.histogram), full_scale=f.full_scale, pixel_format=f.pixel_format,
                        exposure_us=f.exposure_us, source=f.source, sequence=f.sequence,
                        region_mean=list(f.region_mean), region_cells=f.region_cells,
                        region_px=(f.region_x, f.region_y, f.region_width, f.region_height),
                        white_balance=f.white_balance, white_balance_gains=list(f.white_balance_gains))
