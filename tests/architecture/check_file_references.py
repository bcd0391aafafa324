#!/usr/bin/env python3
"""Finds comments and docs that name a project file which does not exist.

Scans the project's C++ sources, CMake files, scripts and Markdown for paths
such as `estimation/inverter.hpp`, `daemon/src/api/server.cpp` or
`docs/formats/session.md` and resolves each the ways a reader would: from the
repository root, from the naming file's folder, as a library's public header
(`<lib>/include/chromo/<lib>/...`) or source (`<lib>/src/...`), or as an
`#include` path. A name that resolves nowhere is stale (a file moved or
renamed) and is printed with where it appears. Exit 0 when none is stale,
1 otherwise, 2 on bad usage.

usage: check_file_references.py SOURCE_DIR
"""
import os
import re
import sys

LIBRARIES = ["files", "spectral", "estimation", "drivers", "calibration", "session", "maps", "simulators",
             "proto", "daemon", "cli", "bench", "tests", "docs", "scripts", "data", "clients", "cmake", "web"]
SCANNED = (".cpp", ".hpp", ".h", ".md", ".txt", ".cmake", ".sh", ".py", ".proto")
REFERENCE = re.compile(r"(?<![\w./-])((?:%s)/[\w./-]*?[\w-]+\.(?:hpp|cpp|h|md|proto|sh|py|cmake))\b" % "|".join(
    LIBRARIES + ["chromo"]))


def project_files(root):
    for folder, dirs, names in os.walk(root):
        dirs[:] = [d for d in dirs if not d.startswith(".") and d not in ("build", "node_modules")]
        for name in names:
            yield os.path.relpath(os.path.join(folder, name), root)


def resolves(root, naming_file, reference, all_files):
    candidates = [reference, os.path.join(os.path.dirname(naming_file), reference)]
    parts = reference.split("/")
    if parts[0] == "chromo" and len(parts) > 2:
        candidates.append(os.path.join(parts[1], "include", reference))
    elif parts[0] in LIBRARIES and len(parts) > 1:
        rest = "/".join(parts[1:])
        candidates += [os.path.join(parts[0], "include", "chromo", parts[0], rest), os.path.join(parts[0], "src", rest),
                       os.path.join(parts[0], "include", "chromo", parts[0], *parts[1:])]
    if any(os.path.exists(os.path.join(root, c)) for c in candidates):
        return True
    # a sub-folder path inside a library (simulators/scene/..., drivers/camera/...)
    return any(f.endswith("/" + reference) or f == reference for f in all_files)


def main():
    if len(sys.argv) != 2:
        print(__doc__, file=sys.stderr)
        return 2
    root = sys.argv[1]
    all_files = list(project_files(root))
    stale = []
    for path in all_files:
        if not path.endswith(SCANNED) or path.startswith(("data/", "tests/architecture/")):
            continue
        with open(os.path.join(root, path), encoding="utf-8", errors="replace") as handle:
            for number, line in enumerate(handle, 1):
                for reference in REFERENCE.findall(line):
                    if "chromosphere/v1" in reference or "<" in reference:
                        continue
                    if not resolves(root, path, reference, all_files):
                        stale.append(f"{path}:{number}: {reference}")
    for entry in stale:
        print(entry)
    print(f"file references: {len(stale)} stale")
    return 1 if stale else 0


if __name__ == "__main__":
    sys.exit(main())
