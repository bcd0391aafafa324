"""Typed results of the client: plain dataclasses and numpy arrays, never
protobuf messages or daemon-side paths the caller has to interpret."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Dict, Iterator, List, Mapping, Optional, Tuple

import numpy as np


@dataclass(frozen=True)
class MapChannel:
    """One channel of a maps file: its name, unit ("" when unknown) and meaning."""

    name: str
    unit: str
    meaning: str


@dataclass(eq=False)
class Maps(Mapping[str, np.ndarray]):
    """Chromophore maps at full resolution: ``maps["Cm"]`` is a float32 array
    of shape (height, width), NaN where the map has no value. ``channels``
    gives each channel's unit and meaning, ``flag_names[code]`` what a value
    of the "flags" channel means (0: explained)."""

    width: int
    height: int
    channels: List[MapChannel]
    flag_names: List[str]
    data: np.ndarray  # (channels, height, width) float32
    source: str = ""  # where they came from: "session <id>: results/maps.exr" or a file

    def __getitem__(self, name: str) -> np.ndarray:
        for index, channel in enumerate(self.channels):
            if channel.name == name:
                return self.data[index]
        raise KeyError(f"channel {name!r} is not in the maps (they have {', '.join(self.names)})")

    def __iter__(self) -> Iterator[str]:
        return iter(self.names)

    def __len__(self) -> int:
        return len(self.channels)

    @property
    def names(self) -> List[str]:
        return [c.name for c in self.channels]

    def unit(self, name: str) -> str:
        """The unit of channel ``name`` ("" when unknown)."""
        return self.channel(name).unit

    def channel(self, name: str) -> MapChannel:
        for channel in self.channels:
            if channel.name == name:
                return channel
        raise KeyError(f"channel {name!r} is not in the maps (they have {', '.join(self.names)})")

    def explained(self) -> np.ndarray:
        """Boolean mask of the pixels the model explains (flags == 0)."""
        return self["flags"] == 0


@dataclass(frozen=True)
class Progress:
    """One update of a running operation (a session, a calibration)."""

    id: str
    state: str  # "pending", "running", "paused", "succeeded", "failed", "cancelled", "interrupted"
    progress: float  # 0-1
    eta_seconds: float  # negative when unknown
    message: str
    error: str
    frames_stored: int
    frames_expected: int
    frames_lost: int
    folder: str

    @property
    def finished(self) -> bool:
        return self.state in ("succeeded", "failed", "cancelled", "interrupted")


@dataclass(frozen=True)
class CameraResults:
    """One camera's results of a session."""

    camera: str
    available: bool
    reason: str
    maps_file: str  # relative to the session folder, e.g. "results/maps.exr"
    report_file: str  # relative to the session folder
    summary: Dict[str, object]  # headline numbers: method, model, pixels, pixels_per_second, flag_counts, relit_delta_e94, ...


@dataclass(frozen=True)
class Results:
    """A session's results: whether maps exist, and each camera's."""

    session_id: str
    available: bool
    reason: str
    folder: str  # the session folder on the daemon's host
    cameras: List[CameraResults]
    summary: Dict[str, object] = field(default_factory=dict)  # results/summary.json

    def camera(self, name: Optional[str] = None) -> CameraResults:
        """The camera called ``name``; None: the only camera, or the first with maps."""
        if name is None:
            for camera in self.cameras:
                if camera.available:
                    return camera
            if self.cameras:
                return self.cameras[0]
            raise KeyError(f"session {self.session_id} has no camera results ({self.reason or 'none yet'})")
        for camera in self.cameras:
            if camera.camera == name:
                return camera
        raise KeyError(f"session {self.session_id} has no camera {name!r} "
                       f"(its cameras: {', '.join(c.camera for c in self.cameras)})")


@dataclass(frozen=True)
class SessionRun:
    """A finished session run: its final state, results and frames."""

    id: str
    state: str
    message: str
    frames_stored: int
    folder: str

    @property
    def succeeded(self) -> bool:
        return self.state == "succeeded"


@dataclass(frozen=True)
class Relit:
    """A relighting done by the daemon: files relative to the session folder."""

    illuminant: str
    width: int
    height: int
    relit_pixels: int
    out_dir: str
    files: List[str]
    summary: Dict[str, object]


@dataclass(frozen=True)
class PlanAdvice:
    """The plan advisor's figures for one plan (docs/plan-advisor.md)."""

    plan: str
    channels: List[str]
    subject_s: float
    reference_s: float
    sigma: Dict[str, float]  # Cramér-Rao σ per parameter: cm, ch, bm, che
    predicted_delta_e94: Dict[str, float]  # per illuminant
    predicted_delta_e94_mean: float
    monte_carlo_delta_e94_mean: Optional[float]  # None unless checked


@dataclass(frozen=True)
class Photograph:
    """An RGB OpenEXR file of a session folder that a relight can compare against
    (:meth:`Client.relight`'s photograph_file): usable when same_size (the maps' size)."""

    file: str  # relative to the session folder
    width: int
    height: int
    same_size: bool


@dataclass(frozen=True)
class Photographs:
    """The photographs of a session folder for one maps file (MapsService.ListPhotographs)."""

    maps_width: int
    maps_height: int
    photographs: List[Photograph]

    @property
    def usable(self) -> List[Photograph]:
        """Those of the maps' size."""
        return [p for p in self.photographs if p.same_size]


@dataclass(frozen=True)
class PreviewFrame:
    """One live preview frame (CameraService.StreamPreview, docs/web.md "Cameras in the API").

    jpeg: the picture (sRGB; white-balanced when asked and possible); histogram: 64 bins of the
    region's raw values over [0, full_scale]; region_mean: the region's raw mean per channel
    (R, G, B; mono: one); region_px: the region in preview pixels (x, y, width, height);
    white_balance: what the picture's balance came from, or "none: raw" and why;
    white_balance_gains: the R, G, B gains applied (1, 1, 1 when none)."""

    camera: str
    width: int
    height: int
    jpeg: bytes
    clipped_pixels: int
    histogram: List[int]
    full_scale: int
    pixel_format: str
    exposure_us: float
    source: str  # "free_run" or "session:<id>"
    sequence: int
    region_mean: List[float]
    region_cells: int
    region_px: Tuple[int, int, int, int]
    white_balance: str
    white_balance_gains: List[float]
