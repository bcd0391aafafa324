#!/usr/bin/env bash
# Configures (once) and builds the release preset into build/release.
# Uses ccache as the compiler launcher when it is installed (a rebuild of
# unchanged sources in another checkout then takes seconds).
set -euo pipefail
cd "$(dirname "$0")/.."
if [[ ! -f build/release/build.ninja ]]; then
  launcher=()
  if command -v ccache >/dev/null; then launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache); fi
  cmake --preset release "${launcher[@]}"
fi
cmake --build --preset release "$@"
