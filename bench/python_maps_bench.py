#!/usr/bin/env python3
"""How long a camera's maps take to reach numpy over the socket API
(issue 43's target: a 5-MP camera's in <= 3 s on this machine).

Makes real maps of the given size (chromo make-maps-test-data, then chromo
estimate: maps.exr with Cm, Ch, Bm, Che, residual, order, flags), starts
chromod with them in its maps_dir, and times Client.maps() (MapsService.ReadMaps:
the daemon reads maps.exr, streams rows in chunks, the client fills one numpy
array) from the call to the last row in numpy, --runs times; checks the
arrays equal maps.exr's values (exr_dump). Run it with a Python that has the
chromosphere package installed (pip install --no-build-isolation ./clients/python).

    python3 bench/python_maps_bench.py --chromod build/release/bin/chromod \\
        --chromo build/release/bin/chromo --exr-dump build/release/bin/exr_dump [--width 2448 --height 2048]
"""
import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import chromosphere


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--chromod", required=True)
    parser.add_argument("--chromo", required=True)
    parser.add_argument("--exr-dump", required=True)
    parser.add_argument("--width", type=int, default=2448)
    parser.add_argument("--height", type=int, default=2048)
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--work", type=Path, default=None, help="working folder (default: a temporary one)")
    args = parser.parse_args()
    if args.width < 16 or args.height < 16 or args.runs < 1:
        print("python_maps_bench: --width and --height must be >= 16, --runs >= 1", file=sys.stderr)
        return 2
    work = args.work or Path(tempfile.mkdtemp(prefix="chromo-maps-bench-"))
    work.mkdir(parents=True, exist_ok=True)
    maps_dir = work / "maps"
    exr = maps_dir / "bench" / "maps.exr"
    if not exr.is_file():
        started = time.perf_counter()
        subprocess.run([args.chromo, "make-maps-test-data", "--out", str(work / "scene"), "--width", str(args.width),
                        "--height", str(args.height)], check=True, stdout=subprocess.DEVNULL)
        subprocess.run([args.chromo, "estimate", str(work / "scene" / "MEASUREMENT.json"), "--out",
                        str(exr.parent), "--cache-dir", str(work / "cache")], check=True, stdout=subprocess.DEVNULL)
        print(f"maps made in {time.perf_counter() - started:.1f} s: {exr}")
    config = work / "chromod.json"
    config.write_text(json.dumps({"maps_dir": str(maps_dir)}))
    socket = work / "s.sock"
    if socket.exists():
        socket.unlink()
    daemon = subprocess.Popen([args.chromod, "--config", str(config), "--socket", str(socket), "--sessions-dir",
                               str(work / "sessions")], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        for _ in range(300):
            if socket.exists():
                break
            time.sleep(0.1)
        with chromosphere.Client("unix:" + str(socket)) as client:
            seconds = []
            for _ in range(args.runs):
                started = time.perf_counter()
                maps = client.maps("", maps_file="bench/maps.exr")
                seconds.append(time.perf_counter() - started)
        dump = work / "dump"
        subprocess.run([args.exr_dump, str(exr), str(dump)], check=True)
        header = json.loads(Path(str(dump) + ".json").read_text())
        raw = np.fromfile(str(dump) + ".f32", dtype="<f4").reshape(len(header["channels"]), header["height"],
                                                                   header["width"])
        equal = all(np.array_equal(maps[name], raw[i], equal_nan=True) for i, name in enumerate(header["channels"]))
    finally:
        daemon.kill()
        daemon.wait()
        if args.work is None:
            shutil.rmtree(work, ignore_errors=True)
    megapixels = maps.width * maps.height / 1e6
    megabytes = maps.data.nbytes / 1e6
    print(f"{maps.width}x{maps.height} ({megapixels:.1f} MP), {len(maps)} channels, {megabytes:.0f} MB float32: "
          f"maps to numpy over the API in {', '.join(f'{s:.2f}' for s in seconds)} s "
          f"(median {statistics.median(seconds):.2f} s, {megabytes / statistics.median(seconds):.0f} MB/s; "
          f"target <= 3 s at 5 MP); equal to maps.exr: {'yes' if equal else 'NO'}")
    print(f"cores: {os.cpu_count()}")
    return 0 if equal else 1


if __name__ == "__main__":
    sys.exit(main())
