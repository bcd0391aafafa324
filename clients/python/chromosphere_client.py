"""A small Python client of chromod (the Chromosphere daemon).

The gRPC stubs are generated at build time (protoc + Debian's
grpc_python_plugin) into build/<preset>/clients/python/gen; this module finds
them there, or wherever CHROMO_PY_STUBS points. Needs Debian's python3-grpcio
and python3-protobuf.

    client = Client(default_target())                      # or ("host:7443", token="...")
    op = client.start_standard_session(subject="forearm")
    final = client.wait(op.id, on_update=print)           # streams progress
    print(client.results(op.id).folder)
"""
import os
import pathlib
import sys

_here = pathlib.Path(__file__).resolve().parent
_stubs = os.environ.get("CHROMO_PY_STUBS")
_candidates = [pathlib.Path(_stubs)] if _stubs else []
_candidates += [_here.parents[1] / "build" / preset / "clients" / "python" / "gen" for preset in ("release", "debug")]
for _candidate in _candidates:
    if (_candidate / "chromosphere" / "v1" / "sessions_pb2.py").exists():
        sys.path.insert(0, str(_candidate))
        break

import grpc  # noqa: E402
from chromosphere.v1 import (cameras_pb2, cameras_pb2_grpc, common_pb2,  # noqa: E402
                             devices_pb2, devices_pb2_grpc, estimation_pb2, estimation_pb2_grpc,
                             leds_pb2, leds_pb2_grpc, maps_pb2, maps_pb2_grpc, operations_pb2,
                             operations_pb2_grpc, planning_pb2, planning_pb2_grpc, sessions_pb2,
                             sessions_pb2_grpc)

FINAL_STATES = {
    operations_pb2.OPERATION_STATE_SUCCEEDED,
    operations_pb2.OPERATION_STATE_FAILED,
    operations_pb2.OPERATION_STATE_CANCELLED,
    operations_pb2.OPERATION_STATE_INTERRUPTED,
}


def default_target():
    """chromod's default socket, by the daemon's rule (files/runtime_dir.hpp):
    $CHROMO_RUNTIME_DIR, else $XDG_RUNTIME_DIR/chromosphere, else
    ~/.local/state/chromosphere/run; then /chromod.sock."""
    if os.environ.get("CHROMO_RUNTIME_DIR"):
        folder = pathlib.Path(os.environ["CHROMO_RUNTIME_DIR"])
    elif os.environ.get("XDG_RUNTIME_DIR"):
        folder = pathlib.Path(os.environ["XDG_RUNTIME_DIR"]) / "chromosphere"
    else:
        folder = pathlib.Path.home() / ".local" / "state" / "chromosphere" / "run"
    return "unix:" + str(folder / "chromod.sock")


def state_name(state):
    return operations_pb2.OperationState.Name(state).replace("OPERATION_STATE_", "").lower()


class Client:
    """One connection to chromod. target: "unix:/path" or "host:port" (TCP needs the token)."""

    def __init__(self, target, token=None, root_certificates=None):
        if token is not None:
            call_credentials = grpc.access_token_call_credentials(token)
            if root_certificates is not None:
                channel_credentials = grpc.ssl_channel_credentials(root_certificates)
            else:
                channel_credentials = grpc.local_channel_credentials()
            credentials = grpc.composite_channel_credentials(channel_credentials, call_credentials)
            self.channel = grpc.secure_channel(target, credentials)
        else:
            self.channel = grpc.insecure_channel(target)
        self.devices = devices_pb2_grpc.DeviceServiceStub(self.channel)
        self.leds = leds_pb2_grpc.LedServiceStub(self.channel)
        self.operations = operations_pb2_grpc.OperationServiceStub(self.channel)
        self.sessions = sessions_pb2_grpc.SessionServiceStub(self.channel)
        self.results_service = estimation_pb2_grpc.ResultsServiceStub(self.channel)
        # Relight, Flush, ImportMaps, ExportProfiles (docs/maps.md); synchronous calls.
        self.maps = maps_pb2_grpc.MapsServiceStub(self.channel)
        # The plan advisor (docs/plan-advisor.md); synchronous.
        self.planning = planning_pb2_grpc.PlanServiceStub(self.channel)
        self.cameras = cameras_pb2_grpc.CameraServiceStub(self.channel)

    def list_devices(self):
        return self.devices.ListDevices(devices_pb2.ListDevicesRequest()).devices

    def list_cameras(self):
        """Every camera: name, model, sensor size, pixel formats, the live view's exposure and pixel
        format, and the driver's error when unreachable (CameraDescription)."""
        return self.cameras.ListCameras(cameras_pb2.ListCamerasRequest()).cameras

    def set_camera_settings(self, camera="", exposure_us=None, pixel_format=""):
        """Sets the live view's exposure (µs) and/or pixel format of one camera ("" = the only one);
        returns its CameraDescription. Refused (FAILED_PRECONDITION, saying why) during a session or
        calibration."""
        request = cameras_pb2.SetCameraSettingsRequest(camera=camera, pixel_format=pixel_format)
        if exposure_us is not None:
            request.exposure_us = exposure_us
        return self.cameras.SetCameraSettings(request)

    def preview(self, camera="", rate_hz=10.0, width=480, count=None, timeout=None):
        """Yields PreviewFrame messages (JPEG, clipped-pixel mask, 64-bin histogram, exposure, source:
        "free_run" or "session:<id>") at up to rate_hz; stops after `count` frames when given."""
        request = cameras_pb2.StreamPreviewRequest(camera=camera, rate_hz=rate_hz, width=width)
        stream = self.cameras.StreamPreview(request, timeout=timeout)
        try:
            for number, frame in enumerate(stream, 1):
                yield frame
                if count is not None and number >= count:
                    break
        finally:
            stream.cancel()

    def set_leds(self, output_enabled=None, controller="", **drive):
        """Sets the LED drive levels (w57, w40, w27, red, green, blue, each 0-1; others 0) and, when
        given, the output enable; returns the LedStatus once applied. Refused during a session."""
        request = leds_pb2.SetLedStateRequest(controller=controller,
                                              state=leds_pb2.LedState(drive=common_pb2.DriveLevels(**drive)))
        if output_enabled is not None:
            request.output_enabled = output_enabled
        return self.leds.SetLedState(request)

    def start_standard_session(self, subject="", exposure_us=0.0, frames_per_camera=0, reference_frames=0,
                               subject_fill=0.0):
        """Starts the standard plan. 0 leaves a count to the daemon's configuration
        (capture.frames_per_capture for each subject step, capture.reference_frames
        for each dark and white step, capture.subject_fill for metering each subject)."""
        request = sessions_pb2.StartSessionRequest(standard=True, subject=subject, exposure_us=exposure_us,
                                                   frames_per_camera=frames_per_camera,
                                                   reference_frames=reference_frames,
                                                   subject_fill=subject_fill)
        return self.sessions.StartSession(request)

    def wait(self, operation_id, on_update=None):
        """Streams the operation's updates until it ends; returns the final Operation."""
        last = None
        for operation in self.operations.WatchOperation(operations_pb2.WatchOperationRequest(id=operation_id)):
            last = operation
            if on_update:
                on_update(operation)
            if operation.state in FINAL_STATES:
                return operation
        # The stream ended early (daemon stopping): ask once more.
        return self.operations.GetOperation(operations_pb2.GetOperationRequest(id=operation_id)) if last else None

    def session(self, session_id, include_frames=False):
        """The session's SessionDetail: plan, steps, frames (with include_frames) and its timeline,
        the seconds each phase took (capture, subject, derived data, maps; -1 for a phase not reached)."""
        return self.sessions.GetSession(sessions_pb2.GetSessionRequest(id=session_id, include_frames=include_frames))

    def results(self, session_id):
        return self.results_service.GetResults(estimation_pb2.GetResultsRequest(session_id=session_id))

    def camera_results(self, session_id):
        """Every camera's results of a session as a dict by camera name: state ("available" or
        "unavailable"), reason, maps_file, report_file, camera_sensitivity, shared_with (the camera
        whose tables it shared, or "") and summary (ResultsSummary). A one-camera session has one."""
        results = self.results(session_id)
        cameras = {}
        for camera in results.cameras:
            cameras[camera.camera] = {
                "state": estimation_pb2.ResultsState.Name(camera.state).replace("RESULTS_STATE_", "").lower(),
                "reason": camera.reason,
                "maps_file": camera.maps_file,
                "report_file": camera.report_file,
                "camera_sensitivity": camera.camera_sensitivity,
                "shared_with": camera.shared_with,
                "summary": camera.summary,
            }
        return cameras

    def relight(self, maps_file, illuminant, label="", photograph_file="", session_id="", timeout=120,
                model_only=False):
        """Relit albedo (and a panel against the photograph) in a new folder of the daemon's; returns
        RelightResponse, whose out_dir and files are relative to the session folder (or the daemon's
        maps_dir without session_id). maps_file and photograph_file are relative to the same folder.
        The maps' posterior discrepancy (their relit layer) is added unless model_only."""
        request = maps_pb2.RelightRequest(session_id=session_id, maps_file=maps_file, illuminant=illuminant,
                                          label=label, photograph_file=photograph_file, model_only=model_only)
        return self.maps.Relight(request, timeout=timeout)

    def compare_plans(self, plans, skins=0, seed=0, interior_population=False, monte_carlo_draws=0, timeout=120):
        """The plan advisor on the daemon's LED library and camera (docs/plan-advisor.md): for each plan
        (a built-in name such as "standard", "multispectral@4", or a planning_pb2.PlanDescription) its
        capture time, σ per parameter, predicted relit ΔE94 per illuminant and, with monte_carlo_draws,
        the Monte Carlo check. Returns ComparePlansResponse; a bad plan raises grpc.RpcError
        INVALID_ARGUMENT naming the field."""
        choices = []
        for plan in plans:
            if isinstance(plan, str):
                choices.append(planning_pb2.PlanChoice(builtin=plan))
            else:
                choices.append(planning_pb2.PlanChoice(description=plan))
        request = planning_pb2.ComparePlansRequest(plans=choices, skins=skins, seed=seed,
                                                   interior_population=interior_population,
                                                   monte_carlo_draws=monte_carlo_draws)
        return self.planning.ComparePlans(request, timeout=timeout)

    def delete_session(self, session_id):
        """Deletes a finished session's folder and the table-cache entries only it used; returns
        DeleteSessionResponse. Refused (FAILED_PRECONDITION) while the session runs."""
        return self.sessions.DeleteSession(sessions_pb2.DeleteSessionRequest(id=session_id))

    def close(self):
        self.channel.close()
