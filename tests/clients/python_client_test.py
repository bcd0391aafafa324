"""The installed chromosphere package against a live chromod (run by
python_package_test.sh with the venv's interpreter): maps at full resolution
equal to maps.exr's values (exr_dump), blocking and asyncio clients alike,
open_session through maps.ome.tiff with no daemon, typed results, and
errors as exceptions naming what was wrong.

usage: python_client_test.py SOCKET SESSION_ID EXR_DUMP CHROMOD WORK
"""
import asyncio
import json
import shutil
import subprocess
import time
import sys
import unittest
from pathlib import Path

import numpy as np

import chromosphere
from chromosphere.v1 import maps_pb2

SOCKET, SESSION, EXR_DUMP, CHROMOD, WORK = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4], Path(sys.argv[5])
TARGET = "unix:" + SOCKET


def exr(path):
    out = WORK / "dump"
    subprocess.run([EXR_DUMP, str(path), str(out)], check=True)
    header = json.loads(Path(str(out) + ".json").read_text())
    raw = np.fromfile(str(out) + ".f32", dtype="<f4").reshape(len(header["channels"]), header["height"],
                                                               header["width"])
    return dict(zip(header["channels"], raw))


class PackageTest(unittest.TestCase):
    def setUp(self):
        self.client = chromosphere.Client(TARGET)

    def tearDown(self):
        self.client.close()

    def test_stubs_come_from_the_package_with_pyi(self):
        module = Path(maps_pb2.__file__)
        self.assertEqual(module.parent.parent, Path(chromosphere.__file__).parent)
        self.assertTrue(str(module).startswith(str(Path(sys.prefix) / "lib")), module)  # the venv's site-packages
        self.assertIn("site-packages", module.parts)
        self.assertTrue(module.with_suffix(".pyi").is_file())
        self.assertTrue((Path(chromosphere.__file__).parent / "py.typed").is_file())

    def test_maps_at_full_resolution_equal_maps_exr(self):
        results = self.client.results(SESSION)
        self.assertTrue(results.available, results.reason)
        camera = results.camera()
        self.assertEqual(camera.maps_file, "results/maps.exr")
        self.assertEqual(camera.summary["method"], "fast")
        self.assertGreater(int(camera.summary["flag_counts"]["explained"]), 0)
        self.assertIn("flag_counts", results.summary)
        maps = self.client.maps(SESSION)
        values = exr(Path(results.folder) / camera.maps_file)
        self.assertEqual(sorted(maps.names), sorted(values))
        for name, expected in values.items():
            self.assertEqual(maps[name].shape, expected.shape)
            self.assertEqual(maps[name].dtype, np.float32)
            np.testing.assert_array_equal(maps[name], expected, err_msg=name)
        self.assertEqual(maps.unit("Cm"), "volume fraction")
        self.assertEqual(maps.flag_names[0], "explained")
        self.assertEqual(len(maps.flag_names), 10)
        self.assertEqual(maps.flag_names[9], "white_target")
        self.assertGreater(int(maps.explained().sum()), 0)
        # A subset, and small chunks: the same values.
        few = self.client.maps(SESSION, channels=["Ch", "flags"], chunk_bytes=65536)
        self.assertEqual(few.names, ["Ch", "flags"])
        np.testing.assert_array_equal(few["Ch"], values["Ch"])

    def test_asyncio_client_gives_the_same_maps(self):
        async def read():
            async with chromosphere.AsyncClient(TARGET) as client:
                return await client.results(SESSION), await client.maps(SESSION)

        results, maps = asyncio.run(read())
        self.assertTrue(results.available)
        blocking = self.client.maps(SESSION)
        for name in blocking.names:
            np.testing.assert_array_equal(maps[name], blocking[name])

    def test_open_session_reads_the_folder_without_a_daemon(self):
        results = self.client.results(SESSION)
        stored = chromosphere.open_session(results.folder)
        self.assertEqual(stored.id, SESSION)
        self.assertEqual(len(stored.frames), 19)
        self.assertIn("flag_counts", stored.report())
        from_disk = stored.maps()
        over_api = self.client.maps(SESSION)
        self.assertEqual(from_disk.names, over_api.names)
        for name in over_api.names:
            np.testing.assert_array_equal(from_disk[name], over_api[name])
        self.assertEqual(from_disk.unit("Ch"), "volume fraction")
        self.assertEqual(from_disk.flag_names, over_api.flag_names)
        with self.assertRaisesRegex(chromosphere.StoredSessionError, "no session.json"):
            chromosphere.open_session(WORK)

    def test_open_session_of_several_cameras(self):
        results = self.client.results(SESSION)
        copy = WORK / "several"
        shutil.rmtree(copy, ignore_errors=True)
        copy.mkdir()
        shutil.copy(Path(results.folder) / "session.json", copy / "session.json")
        for camera in ("side", "top"):
            (copy / "results" / camera).mkdir(parents=True)
            for name in ("maps.ome.tiff", "summary.json"):
                shutil.copy(Path(results.folder) / "results" / name, copy / "results" / camera / name)
        stored = chromosphere.open_session(copy)
        self.assertEqual(stored.cameras(), ["side", "top"])
        np.testing.assert_array_equal(stored.maps("top")["Cm"], stored.maps()["Cm"])
        self.assertIn("flag_counts", stored.report("side"))
        with self.assertRaisesRegex(chromosphere.StoredSessionError, r"no maps of camera 'front' \(cameras: side, top\)"):
            stored.maps("front")

    def test_errors_name_what_was_wrong(self):
        with self.assertRaisesRegex(chromosphere.NotFound, "session_id: no session \"20990101T000000Z-none-000000\""):
            self.client.maps("20990101T000000Z-none-000000")
        with self.assertRaisesRegex(chromosphere.InvalidArgument, "MapsService.ReadMaps: channels: \"nope\" is not in"):
            self.client.maps(SESSION, channels=["nope"])
        with self.assertRaisesRegex(chromosphere.InvalidArgument, "chunk_bytes: must be"):
            self.client.maps(SESSION, chunk_bytes=100)
        with self.assertRaisesRegex(chromosphere.InvalidArgument, "maps_file: must not contain"):
            self.client.maps(SESSION, maps_file="../x/maps.exr")
        with self.assertRaisesRegex(chromosphere.InvalidArgument, "maps_file: "):
            self.client.maps(SESSION, maps_file="session.json")  # not an EXR
        unknown_camera = "ResultsService.GetResults: session .* has no camera 'cam9'"
        with self.assertRaisesRegex(chromosphere.ChromosphereError, unknown_camera):
            self.client.maps(SESSION, camera="cam9")

        async def unknown_camera_async():
            async with chromosphere.AsyncClient(TARGET) as client:
                await client.maps(SESSION, camera="cam9")
        with self.assertRaisesRegex(chromosphere.ChromosphereError, unknown_camera):
            asyncio.run(unknown_camera_async())
        with self.assertRaisesRegex(chromosphere.InvalidArgument, "subject_fill"):
            self.client.start_session("bad", subject_fill=1.5)
        with self.assertRaisesRegex(chromosphere.InvalidArgument, "illuminant"):
            self.client.relight(SESSION, "")
        missing = chromosphere.Client("unix:" + str(WORK / "no.sock"), timeout=2)
        with self.assertRaises(chromosphere.Unavailable):
            missing.results(SESSION)
        missing.close()

    def test_a_read_past_the_bound_is_refused_naming_it(self):
        # A daemon of its own whose bound lets two channels of these maps through, not all seven.
        results = self.client.results(SESSION)
        maps = self.client.maps(SESSION, channels=["Cm"])
        bound = max(maps.width * maps.height * 4 * 2, 1 << 20)  # the key's floor is 1 MiB
        self.assertGreater(maps.width * maps.height * 4 * 7, bound)
        folder = WORK / "bounded"
        shutil.rmtree(folder, ignore_errors=True)
        (folder / "maps" / "s").mkdir(parents=True)
        shutil.copy(Path(results.folder) / results.camera().maps_file, folder / "maps" / "s" / "maps.exr")
        (folder / "chromod.json").write_text(json.dumps({"maps_dir": str(folder / "maps"),
                                                         "max_read_maps_bytes": bound}))
        daemon = subprocess.Popen([CHROMOD, "--config", str(folder / "chromod.json"), "--socket",
                                   str(folder / "s.sock"), "--sessions-dir", str(folder / "sessions")],
                                  stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        try:
            for _ in range(300):
                if (folder / "s.sock").exists():
                    break
                time.sleep(0.1)
            with chromosphere.Client("unix:" + str(folder / "s.sock")) as bounded:
                with self.assertRaisesRegex(chromosphere.ResourceExhausted,
                                            r"channels: \d+ channels of s/maps.exr \(\d+x\d+\) are \d+ bytes, .*\(max_read_maps_bytes\)"):
                    bounded.maps("", maps_file="s/maps.exr")
                two = bounded.maps("", maps_file="s/maps.exr", channels=["Cm", "Ch"])
                np.testing.assert_array_equal(two["Cm"], maps["Cm"])
        finally:
            daemon.kill()
            daemon.wait()

    def test_typed_relight_results_and_plans(self):
        relit = self.client.relight(SESSION, "A", label="typed")
        self.assertIsInstance(relit, chromosphere.Relit)
        self.assertGreater(relit.relit_pixels, 0)
        self.assertTrue(relit.out_dir.startswith("products/relight-"))
        advice = self.client.compare_plans(["standard"], skins=4)
        self.assertEqual(advice[0].plan, "standard")
        self.assertGreater(advice[0].predicted_delta_e94_mean, 0)
        self.assertIn("D65", advice[0].predicted_delta_e94)

    def test_photographs_list_a_relights_own_picture(self):
        before = self.client.photographs(SESSION)
        self.assertIsInstance(before, chromosphere.Photographs)
        maps = self.client.maps(SESSION, channels=["Cm"])
        self.assertEqual((before.maps_width, before.maps_height), (maps.width, maps.height))
        relit = self.client.relight(SESSION, "D65", label="photograph")
        picture = next(f for f in relit.files if f.endswith("relit.exr"))
        after = self.client.photographs(SESSION)
        listed = {p.file: p for p in after.photographs}
        self.assertEqual(listed[picture], chromosphere.Photograph(picture, maps.width, maps.height, True))
        self.assertIn(picture, [p.file for p in after.usable])
        self.assertEqual(len(after.photographs), len(before.photographs) + 1)
        self.assertEqual([p.file for p in after.photographs], sorted(listed))

        async def listed_async():
            async with chromosphere.AsyncClient(TARGET) as client:
                return await client.photographs(SESSION)
        self.assertEqual(asyncio.run(listed_async()), after)
        with self.assertRaisesRegex(chromosphere.InvalidArgument, "MapsService.ListPhotographs: maps_file: must not contain"):
            self.client.photographs(SESSION, "../maps.exr")

    def test_preview_with_white_balance_and_a_region(self):
        whole = next(self.client.preview(width=160, count=1))
        self.assertIsInstance(whole, chromosphere.PreviewFrame)
        self.assertEqual(whole.jpeg[:2], b"\xff\xd8")  # a JPEG
        self.assertEqual((whole.width, whole.source), (160, "free_run"))
        self.assertEqual(len(whole.histogram), 64)
        self.assertEqual(whole.region_px, (0, 0, whole.width, whole.height))
        self.assertTrue(whole.white_balance.startswith("none: raw"), whole.white_balance)  # not asked
        frames = list(self.client.preview(width=160, white_balance=True, region=(0.25, 0.5, 0.5, 0.25), count=2))
        self.assertEqual(len(frames), 2)
        part = frames[-1]
        self.assertEqual(part.region_px, (40, whole.height // 2, 80, whole.height // 4))
        self.assertEqual(part.region_cells, 80 * (whole.height // 4))
        self.assertEqual(sum(part.histogram), 4 * part.region_cells)  # a Bayer cell: four samples
        self.assertEqual(sum(whole.histogram), 4 * whole.region_cells)
        self.assertEqual(len(part.region_mean), 3)
        # This daemon has no LED calibration: the picture stays raw, and says why.
        self.assertRegex(part.white_balance, r"^none: raw \(.*calibration")
        self.assertEqual(part.white_balance_gains, [1.0, 1.0, 1.0])

        async def first_async():
            async with chromosphere.AsyncClient(TARGET) as client:
                async for frame in client.preview(width=160, region=(0.25, 0.5, 0.5, 0.25), count=1):
                    return frame
        self.assertEqual(asyncio.run(first_async()).region_px, part.region_px)
        with self.assertRaisesRegex(chromosphere.InvalidArgument, "CameraService.StreamPreview: region"):
            next(self.client.preview(width=160, region=(0.5, 0.5, 0.8, 0.2), count=1))
        with self.assertRaisesRegex(chromosphere.InvalidArgument, "region: .* is not four numbers"):
            next(self.client.preview(region=(0.1, 0.2, 0.3)))


if __name__ == "__main__":
    unittest.main(argv=sys.argv[:1], verbosity=2)
