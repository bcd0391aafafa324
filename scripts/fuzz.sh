#!/usr/bin/env bash
# The one command for a longer fuzzing run (tests/fuzz/README.md):
#   scripts/fuzz.sh [SECONDS] [HARNESS...]
# builds the `fuzz` preset (clang, libFuzzer + ASan + UBSan) and runs each
# harness for SECONDS (default 600) on a scratch copy of its committed corpus,
# one at a time (-jobs=1). A crash leaves crash-*/leak-*/timeout-* files in
# build/fuzz/findings/HARNESS/ and makes the script exit 1; new corpus
# entries stay in build/fuzz/work/HARNESS/ (copy the interesting ones into
# tests/fuzz/corpus/HARNESS/ by hand).
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-600}
shift || true
cmake --preset fuzz >/dev/null
cmake --build --preset fuzz -j2
harnesses=("$@")
if ((${#harnesses[@]} == 0)); then
  mapfile -t harnesses < <(cd tests/fuzz/corpus && ls)
fi
failed=()
for name in "${harnesses[@]}"; do
  work=build/fuzz/work/$name findings=build/fuzz/findings/$name
  mkdir -p "$work" "$findings"
  echo "fuzz: $name for ${seconds}s"
  if ! ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1 \
      "build/fuzz/bin/$name" -max_total_time="$seconds" -max_len=65536 -rss_limit_mb=2048 -timeout=10 -jobs=1 \
      -print_final_stats=1 -artifact_prefix="$findings/" "$work" "tests/fuzz/corpus/$name" \
      >"$findings/log.txt" 2>&1; then
    failed+=("$name")
    echo "fuzz: $name FOUND something: $findings (log.txt)"
  fi
  grep -E "^stat::(number_of_executed_units|new_units_added)|^#[0-9]+.*DONE" "$findings/log.txt" || true
done
if ((${#failed[@]} > 0)); then
  echo "fuzz: findings in ${failed[*]}" >&2
  exit 1
fi
echo "fuzz: ${#harnesses[@]} harness(es), ${seconds}s each, nothing found"
