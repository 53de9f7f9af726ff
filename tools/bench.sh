#!/usr/bin/env bash
# Repeats an end-to-end `vslam run` and prints the median of each figure.
#   tools/bench.sh [--runs N] [--out DIR] -- RUN_ARGS...
# e.g. tools/bench.sh --runs 5 -- --seq tum/fr1_xyz --detector none
# Prints one line per run and a final "median" line: frames tracked, keyframe
# and frame ATE RMSE (m; SE(3) for rgbd, Sim(3) for mono), the keyframes'
# Sim(3) scale, tracking median and p95 (ms per frame, extraction included),
# wall seconds, fps, peak RSS (MB), and the frames' Sim(3) scale. For rgbd the
# scales check the metric scale; where the keyframes span only centimetres
# (Bonn crowd) the frames' scale is the meaningful one.
set -euo pipefail
cd "$(dirname "$0")/.."

runs=5
out=runs/bench-$(date +%Y%m%d-%H%M%S)
while [ $# -gt 0 ]; do
  case "$1" in
    --runs) runs="$2"; shift 2 ;;
    --out) out="$2"; shift 2 ;;
    --) shift; break ;;
    -h|--help) sed -n '2,10p' "$0"; exit 0 ;;
    *) echo "bench.sh: unknown option '$1' (run arguments go after --)" >&2; exit 2 ;;
  esac
done
[ $# -gt 0 ] || { echo "bench.sh: give the vslam run arguments after --" >&2; exit 2; }
command -v jq >/dev/null || { echo "bench.sh: needs jq (tools/setup.sh installs it)" >&2; exit 2; }
[ -x build/vslam ] || { echo "bench.sh: build/vslam missing: run tools/setup.sh first" >&2; exit 2; }

mkdir -p "$out"
rows="$out/runs.tsv"
printf 'run\tframes_tracked\tate_kf_m\tate_frames_m\tsim3_scale_kf\ttrack_median_ms\ttrack_p95_ms\twall_s\tfps\tpeak_mb\tsim3_scale_frames\n' > "$rows"
for i in $(seq 1 "$runs"); do
  build/vslam run "$@" --out "$out/run$i" > "$out/run$i.stdout" 2> "$out/run$i.log"
  jq -r --arg i "$i" '[ $i, .frames_tracked,
      (if .ate then .ate.keyframes.rmse_m else "nan" end),
      (if .ate then .ate.frames.rmse_m else "nan" end),
      (if .ate then (.ate.keyframes.sim3_scale // .ate.keyframes.scale) else "nan" end),
      .stage_ms.frame.median, .stage_ms.frame.p95, .wall_s, .fps, .peak_rss_mb,
      (if .ate then (.ate.frames.sim3_scale // .ate.frames.scale) else "nan" end) ] | @tsv' \
      "$out/run$i/report.json" >> "$rows"
  tail -n 1 "$rows"
done
# Median of every column over the runs.
{
  printf 'median'
  columns=$(head -n 1 "$rows" | awk -F'\t' '{print NF}')
  for c in $(seq 2 "$columns"); do
    tail -n +2 "$rows" | cut -f "$c" | sort -g |
      awk '{ v[NR] = $1 } END { m = (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2; printf "\t%.4g", m }'
  done
  printf '\n'
} | tee "$out/median.tsv"
echo "bench.sh: rows in $rows" >&2
