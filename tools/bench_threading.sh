#!/usr/bin/env bash
# Threaded against deterministic, idle and under one competing CPU load
# (stress-ng --cpu 1), with tools/bench.sh on each sequence.
#   tools/bench_threading.sh [--runs N] [SEQ[@CONFIG]...]
# (default: fr1_xyz, fr3_teddy, kitti/00, and Bonn crowd with config/bonn.yaml; 5 runs)
# Prints bench.sh's per-run lines and medians for: deterministic (1 run: it
# repeats to the digit), threaded idle (N runs), threaded loaded (N runs).
set -euo pipefail
cd "$(dirname "$0")/.."
runs=5
while [ $# -gt 0 ]; do
  case "$1" in
    --runs) runs="$2"; shift 2 ;;
    -h|--help) sed -n '2,6p' "$0"; exit 0 ;;
    *) break ;;
  esac
done
sequences=("$@")
[ ${#sequences[@]} -gt 0 ] ||
  sequences=(tum/fr1_xyz tum/fr3_teddy kitti/00 ../shared/data/bonn/rgbd_bonn_crowd@config/bonn.yaml)
command -v stress-ng >/dev/null || { echo "bench_threading.sh: needs stress-ng (apt-get install stress-ng)" >&2; exit 2; }
out=runs/bench-threading-$(date +%Y%m%d-%H%M%S)
for entry in "${sequences[@]}"; do
  seq=${entry%@*}
  args=(--seq "$seq" --detector none --no-render)
  [ "$entry" = "$seq" ] || args+=(--config "${entry#*@}")
  name=$(basename "$seq")
  echo "== $seq: deterministic (load average $(cut -d' ' -f1 /proc/loadavg))"
  tools/bench.sh --runs 1 --out "$out/$name-det" -- "${args[@]}" --deterministic
  echo "== $seq: threaded, idle (load average $(cut -d' ' -f1 /proc/loadavg))"
  tools/bench.sh --runs "$runs" --out "$out/$name-idle" -- "${args[@]}"
  stress-ng --cpu 1 --quiet &
  stress=$!
  sleep 1
  echo "== $seq: threaded, under stress-ng --cpu 1"
  tools/bench.sh --runs "$runs" --out "$out/$name-load" -- "${args[@]}" || true
  kill "$stress"; wait "$stress" 2>/dev/null || true
done
echo "runs in $out"
