#!/usr/bin/env bash
# One sequence run from several start frames, to see the spread of a figure
# that a single run gives as one sample. KITTI 00's 200 frames repeat to the
# digit from one start frame, yet small changes move that figure by 0.1-0.2 m:
# the spread over start frames is the yardstick for such a change
# (docs/BENCHMARKS.md, "KITTI 00 across start frames").
#   tools/bench_start_frames.sh [--starts "0 1 ... 19"] [--bin PATH] [--out DIR] -- RUN_ARGS...
# e.g. tools/bench_start_frames.sh -- --seq kitti/00 --detector none --no-render
# Runs each start once through tools/bench.sh (`--runs 1 -- RUN_ARGS
# --start-frame S`, into DIR/start-S) and prints per start the frames
# tracked, keyframes and the keyframe and frame ATE (metres), then their medians.
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
mkdir -p "$out"
table="$out/starts.tsv"
printf 'start\tframes_tracked\tkeyframes\tate_kf_m\tate_frames_m\n' >"$table"
for start in $starts; do
  dir="$out/start-$start"
  if tools/bench.sh --runs 1 --bin "$bin" --out "$dir" -- "$@" --start-frame "$start" >"$dir.stdout" 2>"$dir.stderr"; then
    # bench.sh's columns by name, and the keyframes from the run's report.
    keyframes=$(jq -r .keyframes "$dir/run1/report.json")
    awk -F'\t' -v s="$start" -v k="$keyframes" \
      'NR == 1 {for (c = 1; c <= NF; c++) col[$c] = c}
       NR == 2 {print s "\t" $col["frames_tracked"] "\t" k "\t" $col["ate_kf_m"] "\t" $col["ate_frames_m"]}' \
      "$dir/runs.tsv" >>"$table"
  else
    echo "start $start: the run failed: $(tail -n 1 "$dir.stderr")" >&2
    printf '%s\tnan\tnan\tnan\tnan\n' "$start" >>"$table"
  fi
done
cat "$table"
median() { tail -n +2 "$table" | cut -f "$1" | sort -g | awk -f tools/median.awk; }
printf '# medians over %d starts: keyframe ATE %s m, frame ATE %s m; rows in %s\n' \
  "$(($(wc -l <"$table") - 1))" "$(median 4)" "$(median 5)" "$table"
