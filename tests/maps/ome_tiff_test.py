#!/usr/bin/python3
"""maps.ome.tiff and the frames stack read by a library no one here wrote
(Debian's python3-tifffile): OME, channel names, units, flag meanings, pixel
size, tiling, Deflate without predictor, values equal to maps.exr's (through
the exr_dump helper), frames equal to the session's frame files with each
plane's exposure and illumination; `chromo export`'s bad input refused
(exit 2) with nothing written.

usage: ome_tiff_test.py CHROMO EXR_DUMP SOURCE_DIR WORK_DIR
"""
import json
import shutil
import subprocess
import sys
import unittest
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import tifffile

CHROMO, EXR_DUMP, SOURCE, WORK = (Path(a) for a in sys.argv[1:5])
OME = "{http://www.openmicroscopy.org/Schemas/OME/2016-06}"


def run(*args):
    return subprocess.run([str(a) for a in args], capture_output=True, text=True, timeout=600)


def exr_channels(exr, out):
    r = run(EXR_DUMP, exr, out)
    assert r.returncode == 0, r.stderr
    header = json.loads(Path(str(out) + ".json").read_text())
    raw = np.fromfile(str(out) + ".f32", dtype="<f4")
    return header["channels"], raw.reshape(len(header["channels"]), header["height"], header["width"])


ORDER = ["Cm", "Ch", "Bm", "Che", "residual", "order", "flags"]


def in_ome_order(names, values):
    """maps.exr's channels (sorted by name on read) in the OME-TIFF's order: the known ones first."""
    def rank(name):
        if name in ORDER:
            return ORDER.index(name)
        if name.startswith("sigma_") and name[6:] in ORDER:
            return 100 + ORDER.index(name[6:])
        return 200
    order = sorted(range(len(names)), key=lambda i: (rank(names[i]), i))
    return [names[i] for i in order], values[order]


def ome_annotation(root):
    return {m.get("K"): m.text or "" for m in root.iter(OME + "M")}


class OmeTiffTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        shutil.rmtree(WORK, ignore_errors=True)
        cls.session = WORK / "session"
        shutil.copytree(SOURCE / "data/test/session-format-1", cls.session)
        r = run(CHROMO, "estimate", cls.session, "--out", cls.session / "results", "--cache-dir", WORK / "cache")
        assert r.returncode == 0, r.stdout + r.stderr

    def test_estimate_writes_ome_tiff_beside_maps_exr(self):
        results = self.session / "results"
        names, values = in_ome_order(*exr_channels(results / "maps.exr", WORK / "estimate_dump"))
        self.assertEqual(names[:7], ORDER)
        with tifffile.TiffFile(results / "maps.ome.tiff") as tif:
            self.assertTrue(tif.is_ome)
            root = ET.fromstring(tif.ome_metadata)
            self.assertEqual([c.get("Name") for c in root.iter(OME + "Channel")], names)
            data = tif.asarray()
        self.assertEqual(data.dtype, np.float32)
        self.assertEqual(data.shape, values.shape)
        np.testing.assert_array_equal(data, values)  # NaN where NaN, every value bit for bit

    def test_export_with_units_pixel_size_and_frames(self):
        out = WORK / "export"
        r = run(CHROMO, "export", self.session, "--frames", "--pixel-size-um", "42.5", "--out", out)
        self.assertEqual(r.returncode, 0, r.stderr)
        names, values = in_ome_order(*exr_channels(self.session / "results/maps.exr", WORK / "export_dump"))
        with tifffile.TiffFile(out / "maps.ome.tiff") as tif:
            self.assertTrue(tif.is_ome)
            self.assertEqual(len(tif.pages), len(names))
            page = tif.pages[0]
            self.assertTrue(page.is_tiled)
            self.assertEqual((page.tilewidth, page.tilelength), (256, 256))
            self.assertEqual(int(page.compression), 8)  # ADOBE_DEFLATE
            self.assertEqual(int(page.predictor), 1)    # none
            root = ET.fromstring(tif.ome_metadata)
            pixels = next(root.iter(OME + "Pixels"))
            self.assertEqual(pixels.get("Type"), "float")
            self.assertEqual(int(pixels.get("SizeC")), len(names))
            self.assertAlmostEqual(float(pixels.get("PhysicalSizeX")), 42.5)
            self.assertEqual([c.get("Name") for c in root.iter(OME + "Channel")], names)
            notes = ome_annotation(root)
            self.assertEqual(notes["unit:Cm"], "volume fraction")
            self.assertEqual(notes["unit:Ch"], "volume fraction")
            self.assertEqual(notes["unit:Bm"], "fraction")
            self.assertEqual(notes["unit:residual"], "albedo RMS")
            self.assertEqual(notes["flag:0"], "explained")
            self.assertEqual(notes["flag:4"], "specular")
            self.assertEqual(notes["flag:8"], "no_reference")
            self.assertEqual(notes["flag:9"], "white_target")
            data = tif.asarray()
        np.testing.assert_array_equal(data, values)
        flags = data[names.index("flags")]
        self.assertTrue(set(np.unique(flags)).issubset(set(range(10))))  # codes 0-9, 9 the white target

        # The frames: one stack, each plane equal to its frame file, with its exposure and illumination.
        journal = [json.loads(line) for line in (self.session / "journal.jsonl").read_text().splitlines() if line.strip()]
        frames = [j for j in journal if j.get("type") == "frame"]
        with tifffile.TiffFile(out / "frames-cam0.ome.tiff") as tif:
            self.assertTrue(tif.is_ome)
            stack = tif.asarray()
            root = ET.fromstring(tif.ome_metadata)
        self.assertEqual(stack.shape[0], len(frames))
        planes = list(root.iter(OME + "Plane"))
        notes = ome_annotation(root)
        self.assertEqual(len(planes), len(frames))
        for t, frame in enumerate(frames):
            original = tifffile.imread(self.session / frame["file"])
            np.testing.assert_array_equal(stack[t], original)
            self.assertAlmostEqual(float(planes[t].get("ExposureTime")), frame["exposure_us"] * 1e-6, places=9)
            self.assertEqual(notes[f"plane:{t}:step"], frame["step"])
            self.assertIn("W57=", notes[f"plane:{t}:illumination"])
        self.assertEqual(float(planes[0].get("DeltaT")), 0.0)

    def test_export_of_several_cameras_writes_each_cameras_file(self):
        several = WORK / "several"
        shutil.rmtree(several, ignore_errors=True)
        for camera in ("left", "right"):
            (several / "results" / camera).mkdir(parents=True)
            shutil.copy(self.session / "results/maps.exr", several / "results" / camera / "maps.exr")
        r = run(CHROMO, "export", several)
        self.assertEqual(r.returncode, 0, r.stderr)
        r = run(CHROMO, "export", several, "--out", WORK / "several_out")
        self.assertEqual(r.returncode, 0, r.stderr)
        names, values = in_ome_order(*exr_channels(self.session / "results/maps.exr", WORK / "several_dump"))
        for file in (several / "results/left/maps.ome.tiff", several / "results/right/maps.ome.tiff",
                     WORK / "several_out/left/maps.ome.tiff", WORK / "several_out/right/maps.ome.tiff"):
            with tifffile.TiffFile(file) as tif:
                self.assertTrue(tif.is_ome, file)
                np.testing.assert_array_equal(tif.asarray(), values)
        self.assertFalse((several / "results/maps.ome.tiff").exists())

    def test_bad_input_is_refused_and_changes_nothing(self):
        bad = WORK / "bad"
        shutil.rmtree(bad, ignore_errors=True)
        bad.mkdir()
        r = run(CHROMO, "export", bad / "missing")
        self.assertEqual(r.returncode, 2)
        self.assertIn("not a directory", r.stderr)
        r = run(CHROMO, "export", self.session, "--format", "png")
        self.assertEqual(r.returncode, 2)
        self.assertIn("--format", r.stderr)
        r = run(CHROMO, "export", bad)
        self.assertEqual(r.returncode, 2)
        self.assertIn("no maps.exr", r.stderr)
        for size in ("-1", "nan", "inf"):
            r = run(CHROMO, "export", self.session, "--pixel-size-um", size, "--out", bad / "never")
            self.assertEqual(r.returncode, 2, size)
            self.assertIn("--pixel-size-um", r.stderr)
        self.assertFalse((bad / "never").exists())
        r = run(CHROMO, "export", self.session, "--format", "exr")
        self.assertEqual(r.returncode, 2)
        self.assertIn("--out", r.stderr)
        # A torn maps.exr: refused, the OME-TIFF beside it untouched.
        (bad / "maps.exr").write_bytes((self.session / "results/maps.exr").read_bytes()[:300])
        (bad / "maps.ome.tiff").write_bytes(b"earlier")
        r = run(CHROMO, "export", bad)
        self.assertEqual(r.returncode, 2)
        self.assertIn("maps.exr", r.stderr)
        self.assertEqual((bad / "maps.ome.tiff").read_bytes(), b"earlier")
        # --frames on a folder that is not a session.
        shutil.copy(self.session / "results/maps.exr", bad / "maps.exr")
        r = run(CHROMO, "export", bad, "--frames")
        self.assertEqual(r.returncode, 2)
        self.assertIn("session.json", r.stderr)
        self.assertEqual((bad / "maps.ome.tiff").read_bytes(), b"earlier")
        self.assertEqual(sorted(p.name for p in bad.iterdir()), ["maps.exr", "maps.ome.tiff"])


if __name__ == "__main__":
    unittest.main(argv=sys.argv[:1], verbosity=2)
