#!/usr/bin/env bash
# One sequence run from several start frames, to see the spread of a figure
# that a single run gives as one sample. KITTI 00's 200 frames repeat to the
# digit from one start frame, yet small changes move that figure by 0.1-0.2 m:
# the spread over start frames is the yardstick for such a change
# (docs/BENCHMARKS.md, "KITTI 00 across start frames").
#   tools/bench_start_frames.sh [--starts "0 1 ... 19"] [--bin PATH] [--out DIR] -- RUN_ARGS...
# e.g. tools/bench_start_frames.sh -- --seq kitti/00 --detector none --no-render
# Runs `vslam run RUN_ARGS --start-frame S --out DIR/start-S` for each S and
# prints per start the frames tracked, keyframes and the keyframe and frame
# ATE (report.json's ate.*.rmse_m, metres), then their medians.
set -euo pipefail
cd "$(dirname "$0")/.."
starts="$(seq -s ' ' 0 19)"
bin=build/vslam
out=runs/bench-start-frames-$(date +%Y%m%d-%H%M%S)
while [ $# -gt 0 ]; do
  case "$1" in
    --starts) starts="$2"; shift 2 ;;
    --bin) bin="$2"; shift 2 ;;
    --out) out="$2"; shift 2 ;;
    --) shift; break ;;
    -h|--help) sed -n '2,11p' "$0"; exit 0 ;;
    *) echo "bench_start_frames.sh: unknown option '$1'" >&2; exit 2 ;;
  esac
done
[ $# -gt 0 ] || { echo "bench_start_frames.sh: give the vslam run options after --" >&2; exit 2; }
[ -x "$bin" ] || { echo "bench_start_frames.sh: $bin is not an executable (build first)" >&2; exit 2; }
command -v jq >/dev/null || { echo "bench_start_frames.sh: needs jq" >&2; exit 2; }
mkdir -p "$out"
table="$out/starts.tsv"
printf 'start\tframes_tracked\tkeyframes\tate_kf_m\tate_frames_m\n' >"$table"
for start in $starts; do
  dir="$out/start-$start"
  if ! "$bin" run "$@" --start-frame "$start" --out "$dir" >"$dir.log" 2>&1; then
    echo "start $start: vslam run failed, see $dir.log" >&2
  fi
  if [ -f "$dir/report.json" ]; then
    jq -r --arg s "$start" '[$s, .frames_tracked, .keyframes, (.ate.keyframes.rmse_m // "nan"), (.ate.frames.rmse_m // "nan")] | @tsv' \
      "$dir/report.json" >>"$table"
  else
    printf '%s\tnan\tnan\tnan\tnan\n' "$start" >>"$table"
  fi
done
cat "$table"
median() { tail -n +2 "$table" | cut -f "$1" | sort -g | awk -f tools/median.awk; }
printf '# medians over %d starts: keyframe ATE %s m, frame ATE %s m; rows in %s\n' \
  "$(($(wc -l <"$table") - 1))" "$(median 4)" "$(median 5)" "$table"
