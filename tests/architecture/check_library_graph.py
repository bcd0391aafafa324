#!/usr/bin/env python3
"""Checks that docs/architecture.md's library table matches CMake's graph.

The project's own libraries and programs are read from `cmake --graphviz`
(configured afresh in a temporary folder, without tests and benchmarks); each
one's direct links to the project's other libraries (public or private) must
be exactly the ones its row of the table lists under "may depend on". Exit 0
when they agree; 1 with every difference named otherwise; 2 on bad usage.

usage: check_library_graph.py SOURCE_DIR [ARCHITECTURE_MD]
"""
import os
import re
import subprocess
import sys
import tempfile


def cmake_graph(source_dir):
    """{target: set(direct project-library dependencies)} from cmake --graphviz."""
    with tempfile.TemporaryDirectory(prefix="chromo-graph-") as build:
        dot = os.path.join(build, "graph.dot")
        subprocess.run(["cmake", "-S", source_dir, "-B", build, "-G", "Ninja", "-DCHROMO_BUILD_TESTS=OFF",
                        "-DCHROMO_BUILD_BENCH=OFF", f"--graphviz={dot}"],
                       check=True, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        text = open(dot).read()
    names = {}
    for node, label in re.findall(r'"(node\d+)" \[ label = "([^"]+)"', text):
        match = re.fullmatch(r"(\S+)\\n\(chromo::(\S+)\)", label)
        if match:
            names[node] = match.group(2)          # a library with its chromo:: alias
        elif label in ("chromo", "chromod", "chromo-sim"):
            names[node] = label                    # the programs
    graph = {name: set() for name in names.values()}
    for source, target in re.findall(r'"(node\d+)" -> "(node\d+)"', text):
        if source in names and target in names and names[target] not in ("chromo", "chromod", "chromo-sim"):
            graph[names[source]].add(names[target])
    return graph


def documented_graph(markdown):
    """{target: set(dependencies)} from the table whose header has 'may depend on'."""
    graph = {}
    in_table = False
    for line in markdown.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")] if line.startswith("|") else None
        if cells is None:
            in_table = False
            continue
        if "may depend on" in cells:
            in_table, column = True, cells.index("may depend on")
            target_column = cells.index("target")
            continue
        if not in_table or set(line) <= set("|-: "):
            continue
        targets = re.findall(r"`([\w-]+)`", cells[target_column])
        deps = set(re.findall(r"`([\w-]+)`", cells[column]))
        for target in targets:
            graph[target] = deps - {"—"}
    return graph


def main():
    if len(sys.argv) not in (2, 3):
        print(__doc__, file=sys.stderr)
        return 2
    source_dir = sys.argv[1]
    doc_path = sys.argv[2] if len(sys.argv) == 3 else os.path.join(source_dir, "docs", "architecture.md")
    actual = cmake_graph(source_dir)
    documented = documented_graph(open(doc_path, encoding="utf-8").read())
    problems = []
    for target in sorted(set(actual) | set(documented)):
        if target not in documented:
            problems.append(f"{target}: in CMake, not in {doc_path}'s table")
        elif target not in actual:
            problems.append(f"{target}: in {doc_path}'s table, not a CMake target")
        else:
            for dep in sorted(actual[target] - documented[target]):
                problems.append(f"{target} -> {dep}: linked in CMake, not in the table")
            for dep in sorted(documented[target] - actual[target]):
                problems.append(f"{target} -> {dep}: in the table, not linked in CMake")
    for problem in problems:
        print(problem)
    print(f"library graph: {len(actual)} targets, {sum(map(len, actual.values()))} arrows, "
          f"{len(problems)} difference(s) from {os.path.basename(doc_path)}")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
