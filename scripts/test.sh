#!/usr/bin/env bash
# The README's second quick-start command: set up, build, run every test.
set -euo pipefail
cd "$(dirname "$0")/.."
# Each phase's wall time on one line at the end (CI's budget: tests/README.md "CI time").
phases=()
phase_start=$SECONDS
phase_done() { phases+=("$1=$((SECONDS - phase_start))s"); phase_start=$SECONDS; }
trap 'echo "test.sh phases: ${phases[*]:-none} total=${SECONDS}s"' EXIT
scripts/setup.sh
phase_done setup
scripts/build.sh
phase_done build
# No retries: a test that fails once fails the suite (a retry would hide a
# flaky test; fix its cause instead: tests/README.md, "Flaky tests").
# Three at a time on CI's two cores: a third of the suite's time is tests
# waiting on labs' clocks and sockets (tests/README.md "CI time").
ctest --preset release -j3 "$@"
phase_done suite
# The fuzz smoke (tests/fuzz/README.md): the libFuzzer harnesses, built with
# clang into build/fuzz (only the libraries they need), each run for 6 s on
# its committed corpus, two at a time. scripts/fuzz.sh [SECONDS] is the longer run.
if [[ ! -f build/fuzz/build.ninja ]]; then
  launcher=()
  if command -v ccache >/dev/null; then launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache); fi
  cmake --preset fuzz "${launcher[@]}" >/dev/null
fi
cmake --build --preset fuzz -j2
phase_done fuzz-build
ctest --preset fuzz -j2
phase_done fuzz-smoke
