#!/usr/bin/env bash
# Builds and runs the benches (bench/README.md says what each measures). Each
# writes its figures and charts into bench/results/ and this script keeps its
# printout in bench/results/ (<name>_output.txt; pipeline_sweep.txt and
# mix_solver.txt). pipeline_bench's sweep raises net.core.rmem_max when run
# as root and writes it back itself (also on SIGINT/SIGTERM). Speeds are CPU and wall-clock
# figures: run on an otherwise idle machine. pipeline_bench's camera
# simulators bind loopback addresses of their own (no lock). All of them:
# about 15 minutes on 2 cores (pipeline_bench's sweep ~4) once the lab session is cached (the first run
# renders it, ~35 s).
#
#   scripts/bench.sh [NAME...]   (default: every bench; NAME as in bench/CMakeLists.txt)
set -euo pipefail
cd "$(dirname "$0")/.."
all=(forward_model_bench mix_solver_bench estimation_bench fast_budget_bench spatial_flags_bench estimate_stages_bench camera_frame_bench pipeline_bench plan_advisor_bench)
benches=("$@")
[[ ${#benches[@]} -eq 0 ]] && benches=("${all[@]}")
for name in "${benches[@]}"; do
  if [[ ! " ${all[*]} " =~ " ${name} " ]]; then
    echo "scripts/bench.sh: unknown bench '${name}' (one of: ${all[*]})" >&2
    exit 2
  fi
done
scripts/build.sh --target "${benches[@]}"
mkdir -p bench/results
for name in "${benches[@]}"; do
  echo "== ${name}"
  case "${name}" in
    estimation_bench) args=(--diagnose) ;;
    pipeline_bench) args=(--seconds 8) ;;
    mix_solver_bench) args=(bench/results) ;;
    *) args=() ;;
  esac
  case "${name}" in
    pipeline_bench) printout=bench/results/pipeline_sweep.txt ;;
    mix_solver_bench) printout=bench/results/mix_solver.txt ;;
    plan_advisor_bench) printout=bench/results/plan_advisor/plan_advisor_bench_output.txt ;;
    *) printout="bench/results/${name}_output.txt" ;;
  esac
  "build/release/bin/${name}" "${args[@]}" | tee "${printout}"
done
