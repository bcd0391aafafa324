#!/usr/bin/env python3
"""Checks the daemon's sub-rooms and its public/internal split.

daemon/ holds four rooms (daemon/README.md): devices/, operations/,
capture/ and api/, lowest first. A room's sources
(daemon/src/<room>/) and internal headers
(daemon/include/chromo/daemon/internal/<room>/) may include the internal
headers of the rooms below it, never of a room above. The public headers
(daemon/include/chromo/daemon/*.hpp) are what chromod and other programs
include; outside daemon/, only tests/ and bench/ may include an internal
header, and cli/ includes nothing of the daemon. Only the devices/ room
(where the virtual lab is one more backend) includes a simulator: no public
header, no other room, not chromod.

usage: check_daemon_rooms.py SOURCE_DIR      exit 0 clean, 1 violations, 2 usage
       check_daemon_rooms.py --self-test     plants one upward include, expects it caught
"""
import os
import re
import shutil
import sys
import tempfile

ROOMS = ["devices", "operations", "capture", "api"]  # lowest first
MAY_USE = {room: set(ROOMS[:i]) for i, room in enumerate(ROOMS)}
INCLUDE = re.compile(r'#include\s+"chromo/daemon/(internal/(\w+)/)?[\w/]+\.hpp"')
SIMULATOR = re.compile(r'#include\s+"chromo/simulators/')
SOURCES = (".cpp", ".hpp", ".h")


def room_of(path):
    parts = path.split(os.sep)
    if parts[:2] == ["daemon", "src"] and len(parts) > 3 and parts[2] in ROOMS:
        return parts[2]
    if parts[:5] == ["daemon", "include", "chromo", "daemon", "internal"] and len(parts) > 6:
        return parts[5]
    return None


def violations(root):
    found = []
    for folder, dirs, names in os.walk(root):
        dirs[:] = [d for d in dirs if not d.startswith(".") and d not in ("build", "node_modules")]
        for name in names:
            if not name.endswith(SOURCES):
                continue
            path = os.path.relpath(os.path.join(folder, name), root)
            top = path.split(os.sep)[0]
            room = room_of(path)
            with open(os.path.join(root, path), encoding="utf-8", errors="replace") as handle:
                for number, line in enumerate(handle, 1):
                    if top == "daemon" and room != "devices" and SIMULATOR.search(line):
                        found.append(f"{path}:{number}: only daemon's devices/ room may include a simulator ({line.strip()})")
                        continue
                    match = INCLUDE.search(line)
                    if not match:
                        continue
                    where = f"{path}:{number}"
                    target = match.group(2)
                    if top == "cli":
                        found.append(f"{where}: cli/ includes the daemon ({line.strip()})")
                    elif target is None:
                        continue
                    elif target not in ROOMS:
                        found.append(f"{where}: internal room '{target}' is not one of {ROOMS}")
                    elif top not in ("daemon", "tests", "bench"):
                        found.append(f"{where}: {top}/ includes the daemon's internal header ({line.strip()})")
                    elif path == os.path.join("daemon", "chromod.cpp"):
                        found.append(f"{where}: chromod includes an internal header ({line.strip()})")
                    elif room is not None and target != room and target not in MAY_USE[room]:
                        found.append(f"{where}: room {room}/ includes {target}/, a room above it ({line.strip()})")
    return found


def self_test():
    tree = tempfile.mkdtemp()
    try:
        os.makedirs(os.path.join(tree, "daemon", "src", "devices"))
        with open(os.path.join(tree, "daemon", "src", "devices", "planted.cpp"), "w") as handle:
            handle.write('#include "chromo/daemon/internal/capture/sequencer.hpp"\n')
            handle.write('#include "chromo/simulators/camera/lab_cameras.hpp"\n')  # allowed in devices/
        public = os.path.join(tree, "daemon", "include", "chromo", "daemon")
        os.makedirs(public)
        with open(os.path.join(public, "planted.hpp"), "w") as handle:
            handle.write('#include "chromo/simulators/camera/lab_cameras.hpp"\n')
        found = violations(tree)
        if (len(found) == 2 and any("room devices/ includes capture/" in f for f in found)
                and any("planted.hpp:1: only daemon's devices/ room may include a simulator" in f for f in found)):
            print("self-test: the planted upward include and simulator include were caught:", found)
            return 0
        print("self-test FAILED: expected one upward include and one simulator include, got", found)
        return 1
    finally:
        shutil.rmtree(tree)


def main():
    if len(sys.argv) != 2:
        print(__doc__, file=sys.stderr)
        return 2
    if sys.argv[1] == "--self-test":
        return self_test()
    found = violations(sys.argv[1])
    for line in found:
        print(line)
    print(f"daemon rooms: {len(found)} violation(s)")
    return 1 if found else 0


if __name__ == "__main__":
    sys.exit(main())
