#!/usr/bin/env bash
# The README's second quick-start command: set up, build, run every test.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
scripts/build.sh
# A failed test runs once more before the suite fails: the GigE Vision camera
# tests on loopback depend on the kernel delivering datagrams on a loaded
# machine (the device side answers resends, but a test's timeouts are
# finite). A test that fails twice fails the suite; ctest's log keeps both runs.
ctest --preset release -j2 --repeat until-pass:2 "$@"
# The fuzz smoke (tests/fuzz/README.md): the libFuzzer harnesses, built with
# clang into build/fuzz (only the libraries they need), each run for 6 s on
# its committed corpus, two at a time. scripts/fuzz.sh [SECONDS] is the longer run.
if [[ ! -f build/fuzz/build.ninja ]]; then
  launcher=()
  if command -v ccache >/dev/null; then launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache); fi
  cmake --preset fuzz "${launcher[@]}" >/dev/null
fi
cmake --build --preset fuzz -j2
ctest --preset fuzz -j2
