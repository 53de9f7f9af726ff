#!/usr/bin/env bash
# Repeats an end-to-end `vslam run` and prints the median of each figure.
#   tools/bench.sh [--runs N] [--out DIR] [--bin PATH] -- RUN_ARGS...
# e.g. tools/bench.sh --runs 5 -- --seq tum/fr1_xyz --detector none
# Prints one line per run and a final "median" line: frames tracked, keyframe
# and frame ATE RMSE (m; SE(3) for rgbd, Sim(3) for mono), the keyframes'
# Sim(3) scale, tracking median and p95 (ms per frame, extraction included),
# wall seconds (the report's), fps, peak RSS (MB), the frames' Sim(3) scale,
# and the process's elapsed and CPU seconds from /usr/bin/time. For rgbd the
# scales check the metric scale; where the keyframes span only centimetres
# (Bonn crowd) the frames' scale is the meaningful one.
# --bin runs another vslam binary (a scratch build) instead of build/vslam.
set -euo pipefail
cd "$(dirname "$0")/.."

runs=5
bin=build/vslam
out=runs/bench-$(date +%Y%m%d-%H%M%S)
while [ $# -gt 0 ]; do
  case "$1" in
    --runs) runs="$2"; shift 2 ;;
    --out) out="$2"; shift 2 ;;
    --bin) bin="$2"; shift 2 ;;
    --) shift; break ;;
    -h|--help) sed -n '2,12p' "$0"; exit 0 ;;
    *) echo "bench.sh: unknown option '$1' (run arguments go after --)" >&2; exit 2 ;;
  esac
done
[ $# -gt 0 ] || { echo "bench.sh: give the vslam run arguments after --" >&2; exit 2; }
command -v jq >/dev/null || { echo "bench.sh: needs jq (tools/setup.sh installs it)" >&2; exit 2; }
[[ "$runs" =~ ^[1-9][0-9]*$ ]] || { echo "bench.sh: --runs takes a positive integer, not '$runs'" >&2; exit 2; }
[ -x /usr/bin/time ] || { echo "bench.sh: needs /usr/bin/time (Debian package time; tools/setup.sh installs it)" >&2; exit 2; }
[ -x "$bin" ] || { echo "bench.sh: $bin is not an executable (run tools/setup.sh?)" >&2; exit 2; }

mkdir -p "$out"
rows="$out/runs.tsv"
printf 'run\tframes_tracked\tate_kf_m\tate_frames_m\tsim3_scale_kf\ttrack_median_ms\ttrack_p95_ms\twall_s\tfps\tpeak_mb\tsim3_scale_frames\telapsed_s\tcpu_s\n' > "$rows"
for i in $(seq 1 "$runs"); do
  if ! /usr/bin/time -f '%e %U %S' -o "$out/run$i.time" "$bin" run "$@" --out "$out/run$i" \
       > "$out/run$i.stdout" 2> "$out/run$i.log"; then
    echo "bench.sh: run $i failed; see $out/run$i.log" >&2
    exit 1
  fi
  read -r elapsed user sys < "$out/run$i.time"
  jq -r --arg i "$i" --arg elapsed "$elapsed" --arg cpu "$(awk -v u="$user" -v s="$sys" 'BEGIN{print u + s}')" \
      '[ $i, .frames_tracked,
      (.ate.keyframes.rmse_m // "nan"),
      (.ate.frames.rmse_m // "nan"),
      (.ate.keyframes.sim3_scale // .ate.keyframes.scale // "nan"),
      .stage_ms.frame.median, .stage_ms.frame.p95, .wall_s, .fps, .peak_rss_mb,
      (.ate.frames.sim3_scale // .ate.frames.scale // "nan"),
      $elapsed, $cpu ] | @tsv' \
      "$out/run$i/report.json" >> "$rows"
  tail -n 1 "$rows"
done
# Median of every column over the runs.
{
  printf 'median'
  columns=$(head -n 1 "$rows" | awk -F'\t' '{print NF}')
  for c in $(seq 2 "$columns"); do
    printf '\t%s' "$(tail -n +2 "$rows" | cut -f "$c" | sort -g | awk -v format=%.4g -f tools/median.awk)"
  done
  printf '\n'
} | tee "$out/median.tsv"
echo "bench.sh: rows in $rows" >&2
