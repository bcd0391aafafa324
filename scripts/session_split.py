#!/usr/bin/env python3
"""Where a session's time went, from its own records (docs/formats/session.md).

    scripts/session_split.py SESSION_DIR [--lab-preparation-s SECONDS]

From journal.jsonl: the capture (the first step's start, just before its
first trigger, to the last stored frame), split into the steps' own settle
and exposure, the white steps' exposure metering (a metered step's start to
its last `exposure_metered` record, less its settle) and the rest: rendering
the frames in the lab's camera simulators, sending and storing them. Then,
after the last frame: the derived data (last `derived` record) and each
`results` record (the maps published: one record when every camera's are,
with each camera's own timings from its summary),
with results/summary.json's (or results/<camera>/summary.json's) timings.
The total runs from the first step's start to the last maps.

The lab's preparation at its start (scene, simulators, drivers: chromod's
start until its socket answers) is not in the session's records; a caller
that measured it passes --lab-preparation-s and it is printed apart, outside
the total (scripts/timed-lab-session.sh does).
"""
import argparse
import datetime
import json
import pathlib
import sys


def seconds(record):
    return datetime.datetime.fromisoformat(record["t"].replace("Z", "+00:00")).timestamp()


def read_journal(path):
    records = []
    with open(path, encoding="utf-8") as journal:
        for number, line in enumerate(journal, 1):
            if not line.strip():
                continue
            try:
                records.append(json.loads(line))
            except json.JSONDecodeError as error:
                raise SystemExit(f"session_split: {path}:{number}: not a JSON record ({error.msg})")
    return records


def summary_timings(session_dir, camera):
    for candidate in ([session_dir / "results" / camera / "summary.json"] if camera else []) + [
            session_dir / "results" / "summary.json"]:
        if candidate.is_file():
            return json.loads(candidate.read_text(encoding="utf-8")).get("timings_s")
    return None


def line(label, value_s, note=""):
    print(f"{label:<56}{value_s:7.1f} s{note}")


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("session_dir", type=pathlib.Path, help="a session folder (with journal.jsonl)")
    parser.add_argument("--lab-preparation-s", type=float, help="the lab's preparation at its start, measured by the caller")
    args = parser.parse_args()
    journal_path = args.session_dir / "journal.jsonl"
    if not journal_path.is_file():
        raise SystemExit(f"session_split: {journal_path}: no such file (not a session folder?)")
    records = read_journal(journal_path)
    for number, record in enumerate(records, 1):
        if "type" not in record or "t" not in record:
            raise SystemExit(f"session_split: {journal_path}: record {number} has no 'type' or 't'")

    steps, frames, metered = {}, {}, {}
    for r in records:
        kind = r["type"]
        if kind == "step_started":
            steps.setdefault(r.get("step"), r)  # a retried step keeps its first start
        elif kind == "frame":
            frames.setdefault(r["step"], []).append(r)
        elif kind == "exposure_metered":
            metered[r["step"]] = max(metered.get(r["step"], 0.0), seconds(r))
    if not steps or not frames:
        raise SystemExit(f"session_split: {journal_path}: no step with stored frames (the session captured nothing)")

    if args.lab_preparation_s is not None:
        print(f"lab preparation at its start (not part of the session): {args.lab_preparation_s:.1f} s")
    first = min(seconds(r) for r in steps.values())
    last_frame = max(seconds(f) for fs in frames.values() for f in fs)
    own = metering = 0.0
    for name, start in steps.items():
        if name not in frames:
            continue
        settle = start.get("settle_ms", 0) / 1e3
        own += settle + max(f.get("exposure_us", 0) for f in frames[name]) / 1e6
        if name in metered:
            metering += max(metered[name] - seconds(start) - settle, 0.0)
    capture = last_frame - first
    cameras = sorted({f.get("camera", "?") for fs in frames.values() for f in fs})
    stored = sum(len(fs) for fs in frames.values())
    print(f"session {args.session_dir.name}: {len(steps)} steps, {stored} frames, cameras {', '.join(cameras)}")
    line("  capture (first step's start to the last frame)", capture)
    line("    steps' own settle + exposure", own)
    line("    exposure metering of the white steps", metering)
    line("    rendering, sending and storing the frames", capture - own - metering)
    derived = [seconds(r) for r in records if r["type"] == "derived"]
    if derived:
        line(f"  derived data ({len(derived)} files), after the last frame", max(derived) - last_frame)
    end = last_frame
    results = [r for r in records if r["type"] == "results"]
    for r in results:
        # One record when every camera's maps are published; "camera" names
        # the headline camera, "cameras" lists them all (several cameras).
        names = [c.get("name") for c in r.get("cameras", []) if c.get("name")]
        label = f"maps of all {len(names)} cameras" if len(names) > 1 else "maps"
        if r.get("state") != "available":
            print(f"  {label}: unavailable ({r.get('reason', 'no reason given')})")
            continue
        end = max(end, seconds(r))
        line(f"  {label} published, after the last frame", seconds(r) - last_frame,
             f" (estimate of {r.get('camera', 'the camera')} {r.get('estimate_seconds', float('nan')):.1f} s, "
             f"{r.get('pixels', 0)} cells)")
        for camera in names if len(names) > 1 else [None]:
            timings = summary_timings(args.session_dir, camera)
            if timings:
                prefix = f"{camera}: " if camera else ""
                print("    " + prefix + ", ".join(f"{name} {value:.2f} s" for name, value in timings.items()))
    if not results:
        print("  no results record (the session did not succeed, or no maps were made)")
    line("  total, first step's start to the last maps", end - first)


if __name__ == "__main__":
    sys.exit(main())
