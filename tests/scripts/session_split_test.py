#!/usr/bin/env python3
"""scripts/session_split.py on a session folder written here: a two-camera
session's journal (steps, frames, metering, derived data, the results record)
and each camera's summary. Asserts the split's figures and labels, and that
a journal line that is not JSON is refused naming its line."""
import json
import pathlib
import subprocess
import sys
import tempfile
import unittest

SCRIPT = pathlib.Path(__file__).resolve().parents[2] / "scripts" / "session_split.py"


def at(seconds):
    return f"2026-12-05T10:00:{seconds:06.3f}Z"


class SessionSplit(unittest.TestCase):
    def write_session(self, folder, journal_lines):
        (folder / "journal.jsonl").write_text("\n".join(journal_lines) + "\n", encoding="utf-8")
        for camera, total in (("cam0", 10.5), ("cam1", 9.5)):
            (folder / "results" / camera).mkdir(parents=True)
            (folder / "results" / camera / "summary.json").write_text(
                json.dumps({"timings_s": {"estimate": 2.0, "total_before_writing": total}}), encoding="utf-8")

    def run_split(self, folder):
        return subprocess.run([sys.executable, str(SCRIPT), str(folder)], capture_output=True, text=True)

    def test_two_cameras_one_results_record_with_each_cameras_timings(self):
        records = [
            {"type": "step_started", "step": "white D65'", "settle_ms": 50, "t": at(0.0)},
            {"type": "exposure_metered", "step": "white D65'", "t": at(2.05)},
            {"type": "frame", "step": "white D65'", "camera": "cam0", "exposure_us": 8000, "t": at(2.5)},
            {"type": "frame", "step": "white D65'", "camera": "cam1", "exposure_us": 8000, "t": at(2.6)},
            {"type": "step_started", "step": "subject D65'", "settle_ms": 50, "t": at(3.0)},
            {"type": "frame", "step": "subject D65'", "camera": "cam0", "exposure_us": 8000, "t": at(4.0)},
            {"type": "derived", "t": at(6.0)},
            {"type": "results", "state": "available", "camera": "cam0", "estimate_seconds": 2.0, "pixels": 100,
             "cameras": [{"name": "cam0"}, {"name": "cam1"}], "t": at(14.0)},
        ]
        with tempfile.TemporaryDirectory() as directory:
            folder = pathlib.Path(directory)
            self.write_session(folder, [json.dumps(r) for r in records])
            done = self.run_split(folder)
        self.assertEqual(done.returncode, 0, done.stderr)
        out = done.stdout
        self.assertIn("2 steps, 3 frames, cameras cam0, cam1", out)
        self.assertRegex(out, r"capture \(first step's start to the last frame\)\s+4\.0 s")
        self.assertRegex(out, r"exposure metering of the white steps\s+2\.0 s")  # 2.05 - 0.0 - 0.05 settle
        self.assertRegex(out, r"derived data \(1 files\), after the last frame\s+2\.0 s")
        self.assertRegex(out, r"maps of all 2 cameras published, after the last frame\s+10\.0 s")
        self.assertNotIn("maps of cam0 published", out)
        self.assertIn("cam0: estimate 2.00 s, total_before_writing 10.50 s", out)
        self.assertIn("cam1: estimate 2.00 s, total_before_writing 9.50 s", out)
        self.assertRegex(out, r"total, first step's start to the last maps\s+14\.0 s")

    def test_a_line_that_is_not_json_is_refused_naming_it(self):
        with tempfile.TemporaryDirectory() as directory:
            folder = pathlib.Path(directory)
            self.write_session(folder, [json.dumps({"type": "step_started", "step": "a", "t": at(0)}), "{torn"])
            done = self.run_split(folder)
        self.assertNotEqual(done.returncode, 0)
        self.assertIn("journal.jsonl:2: not a JSON record", done.stderr)


if __name__ == "__main__":
    unittest.main()
