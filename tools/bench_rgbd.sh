#!/usr/bin/env bash
# RGB-D against monocular (issue 13), threaded, with tools/bench.sh:
#   tools/bench_rgbd.sh [--runs N]      (default 5 runs each)
# fr1_xyz and fr3_teddy (200 frames) with the detector off; Bonn crowd
# (config/bonn.yaml) with the detector off, on (labels only) and on with
# person as a dynamic class. Prints bench.sh's per-run lines and medians.
set -euo pipefail
cd "$(dirname "$0")/.."
runs=5
while [ $# -gt 0 ]; do
  case "$1" in
    --runs) runs="$2"; shift 2 ;;
    -h|--help) sed -n '2,6p' "$0"; exit 0 ;;
    *) echo "bench_rgbd.sh: unknown option '$1'" >&2; exit 2 ;;
  esac
done
out=runs/bench-rgbd-$(date +%Y%m%d-%H%M%S)
bonn=(--seq ../shared/data/bonn/rgbd_bonn_crowd --config config/bonn.yaml)
bench() {
  local name="$1"; shift
  echo "== $name (load average $(cut -d' ' -f1 /proc/loadavg))"
  tools/bench.sh --runs "$runs" --out "$out/$name" -- "$@" --no-render
}
for mode in rgbd mono; do
  bench "fr1_xyz-$mode" --seq tum/fr1_xyz --mode "$mode" --detector none
  bench "fr3_teddy-$mode" --seq tum/fr3_teddy --mode "$mode" --detector none
  bench "bonn_crowd-$mode-off" "${bonn[@]}" --mode "$mode" --detector none
  bench "bonn_crowd-$mode-on" "${bonn[@]}" --mode "$mode"
  bench "bonn_crowd-$mode-on-person-dynamic" "${bonn[@]}" --mode "$mode" --dynamic-classes person
done
echo "runs in $out"
