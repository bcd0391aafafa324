"""A stored session folder read from disk with no daemon: its maps (through
maps.ome.tiff, written beside every maps.exr), its report (summary.json) and
its frame records (the journal). Needs tifffile (Debian's python3-tifffile)."""
from __future__ import annotations

import json
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path
from typing import Dict, List, Optional, Union

import numpy as np

from .errors import StoredSessionError
from .model import MapChannel, Maps

_OME = "{http://www.openmicroscopy.org/Schemas/OME/2016-06}"


def read_ome_maps(path: Union[str, Path]) -> Maps:
    """A maps.ome.tiff (`chromo export`, or beside maps.exr) as Maps: channel names from the OME-XML,
    units, meanings and flag names from its MapAnnotation."""
    import tifffile  # only open_session needs it

    path = Path(path)
    if not path.is_file():
        raise StoredSessionError(f"{path}: no such file (write it with: chromo export SESSION_DIR)")
    try:
        with tifffile.TiffFile(path) as tif:
            if not tif.is_ome:
                raise StoredSessionError(f"{path}: not an OME-TIFF")
            root = ET.fromstring(tif.ome_metadata)
            data = tif.asarray()
    except (tifffile.TiffFileError, ET.ParseError, ValueError) as error:
        raise StoredSessionError(f"{path}: unreadable OME-TIFF ({error})") from None
    notes = {m.get("K"): m.text or "" for m in root.iter(_OME + "M")}
    names = [c.get("Name") or f"channel {i}" for i, c in enumerate(root.iter(_OME + "Channel"))]
    data = np.asarray(data, dtype=np.float32)
    if data.ndim == 2:
        data = data[np.newaxis]
    if data.shape[0] != len(names):
        raise StoredSessionError(f"{path}: {data.shape[0]} planes for {len(names)} named channels")
    channels = [MapChannel(n, notes.get(f"unit:{n}", ""), notes.get(f"meaning:{n}", "")) for n in names]
    flags = []
    while f"flag:{len(flags)}" in notes:
        flags.append(notes[f"flag:{len(flags)}"])
    return Maps(width=data.shape[2], height=data.shape[1], channels=channels, flag_names=flags, data=data,
                source=str(path))


@dataclass
class StoredSession:
    """A session folder on disk: ``maps(camera)``, ``report(camera)``, ``frames`` (journal records)."""

    folder: Path
    session: Dict[str, object]
    frames: List[Dict[str, object]] = field(default_factory=list)

    @property
    def id(self) -> str:
        return str(self.session.get("id", self.folder.name))

    def cameras(self) -> List[str]:
        """The cameras with maps: "" for a one-camera session (results/), else each results/<camera>/."""
        results = self.folder / "results"
        if (results / "maps.ome.tiff").is_file() or (results / "maps.exr").is_file():
            return [""]
        return sorted(p.name for p in results.iterdir() if p.is_dir() and
                      ((p / "maps.ome.tiff").is_file() or (p / "maps.exr").is_file())) if results.is_dir() else []

    def _results_folder(self, camera: Optional[str]) -> Path:
        cameras = self.cameras()
        if not cameras:
            raise StoredSessionError(f"{self.folder}: no maps in results/ (estimate them: chromo estimate "
                                     f"{self.folder} --out {self.folder / 'results'})")
        if camera is None:
            camera = cameras[0]
        if camera not in cameras:
            raise StoredSessionError(f"{self.folder}: no maps of camera {camera!r} (cameras: {', '.join(cameras)})")
        return self.folder / "results" / camera if camera else self.folder / "results"

    def maps(self, camera: Optional[str] = None) -> Maps:
        """The camera's maps (None: the only or first camera) from its maps.ome.tiff."""
        folder = self._results_folder(camera)
        if not (folder / "maps.ome.tiff").is_file():
            raise StoredSessionError(f"{folder}: maps.exr but no maps.ome.tiff (write it: chromo export {self.folder})")
        return read_ome_maps(folder / "maps.ome.tiff")

    def report(self, camera: Optional[str] = None) -> Dict[str, object]:
        """The camera's summary.json as a dict."""
        path = self._results_folder(camera) / "summary.json"
        try:
            return json.loads(path.read_text())
        except (OSError, ValueError) as error:
            raise StoredSessionError(f"{path}: {error}") from None


def open_session(folder: Union[str, Path]) -> StoredSession:
    """A stored session folder (docs/formats/session.md) read with no daemon."""
    folder = Path(folder)
    session_file = folder / "session.json"
    if not session_file.is_file():
        raise StoredSessionError(f"{folder}: not a session folder (no session.json)")
    try:
        session = json.loads(session_file.read_text())
    except (OSError, ValueError) as error:
        raise StoredSessionError(f"{session_file}: {error}") from None
    frames = []
    journal = folder / "journal.jsonl"
    if journal.is_file():
        for line in journal.read_text().splitlines():
            try:
                record = json.loads(line)
            except ValueError:
                continue  # a torn last line after a crash
            if isinstance(record, dict) and record.get("type") == "frame":
                frames.append(record)
    return StoredSession(folder=folder, session=session if isinstance(session, dict) else {}, frames=frames)
