#!/usr/bin/env bash
# Side-by-side timing: runs several `vslam run` variants in alternated rounds,
# so that a machine whose speed drifts (this one: 5.7-8.6 s for one command in
# half an hour, docs/BENCHMARKS.md) slows every variant alike.
#   tools/bench_alternate.sh [--rounds N] [--out DIR] \
#       --variant NAME [--bin PATH] -- RUN_ARGS... [--variant NAME [--bin PATH] -- RUN_ARGS...]...
# e.g. tools/bench_alternate.sh --rounds 5 \
#        --variant mono -- --seq tum/fr1_xyz --detector none --no-render \
#        --variant rgbd -- --seq tum/fr1_xyz --mode rgbd --detector none --no-render
# Each round runs every variant once, starting one variant later each round.
# --bin runs another vslam binary (a scratch build) instead of build/vslam.
# Each run goes through tools/bench.sh --runs 1, under OUT/NAME/roundR.
# Prints a row per run (wall and CPU from /usr/bin/time, the rest from
# report.json), then per variant the medians, and the median over rounds of
# each variant's wall time divided by the first variant's in the same round.
set -euo pipefail
cd "$(dirname "$0")/.."

usage() { sed -n '2,15p' "$0"; }
rounds=5
out=runs/alternate-$(date +%Y%m%d-%H%M%S)
names=() bins=()
while [ $# -gt 0 ]; do
  case "$1" in
    --rounds) rounds="$2"; shift 2 ;;
    --out) out="$2"; shift 2 ;;
    --variant) break ;;
    -h|--help) usage; exit 0 ;;
    *) echo "bench_alternate.sh: unknown option '$1'" >&2; exit 2 ;;
  esac
done
[[ "$rounds" =~ ^[1-9][0-9]*$ ]] || { echo "bench_alternate.sh: --rounds takes a positive integer, not '$rounds'" >&2; exit 2; }
mkdir -p "$out"

# Each variant's run arguments go to $out/NAME.args, one a line.
while [ $# -gt 0 ]; do
  [ "$1" = --variant ] && [ $# -ge 2 ] || { echo "bench_alternate.sh: expected '--variant NAME', got '$1'" >&2; exit 2; }
  name="$2"; shift 2
  [[ "$name" =~ ^[A-Za-z0-9_.-]+$ ]] || { echo "bench_alternate.sh: variant name '$name' must be letters, digits, . _ -" >&2; exit 2; }
  for known in "${names[@]}"; do
    [ "$known" != "$name" ] || { echo "bench_alternate.sh: variant '$name' given twice" >&2; exit 2; }
  done
  bin=build/vslam
  if [ "${1:-}" = --bin ]; then bin="$2"; shift 2; fi
  [ -x "$bin" ] || { echo "bench_alternate.sh: variant '$name': $bin is not an executable (run tools/setup.sh?)" >&2; exit 2; }
  [ "${1:-}" = -- ] || { echo "bench_alternate.sh: variant '$name': give its run arguments after --" >&2; exit 2; }
  shift
  : > "$out/$name.args"
  while [ $# -gt 0 ] && [ "$1" != --variant ]; do printf '%s\n' "$1" >> "$out/$name.args"; shift; done
  [ -s "$out/$name.args" ] || { echo "bench_alternate.sh: variant '$name' has no run arguments" >&2; exit 2; }
  names+=("$name"); bins+=("$bin")
done
[ ${#names[@]} -gt 0 ] || { usage >&2; exit 2; }

rows="$out/runs.tsv"
printf 'round\tvariant\tframes_tracked\tate_kf_m\tate_frames_m\tsim3_scale_frames\twall_s\tcpu_s\n' > "$rows"
n=${#names[@]}
for round in $(seq 1 "$rounds"); do
  for k in $(seq 0 $((n - 1))); do
    v=$(( (k + round - 1) % n ))
    name=${names[$v]}
    mapfile -t args < "$out/$name.args"
    # One run through tools/bench.sh, so that both read report.json alike.
    dir="$out/$name/round$round"
    mkdir -p "$out/$name"
    if ! tools/bench.sh --runs 1 --bin "${bins[$v]}" --out "$dir" -- "${args[@]}" \
         > "$dir.stdout" 2> "$dir.stderr"; then
      echo "bench_alternate.sh: variant '$name', round $round failed: $(tail -n 1 "$dir.stderr")" >&2
      exit 1
    fi
    # Its columns by name; wall_s is the process's elapsed time.
    awk -F'\t' -v r="$round" -v v="$name" \
      'NR == 1 {for (c = 1; c <= NF; c++) col[$c] = c}
       NR == 2 {print r "\t" v "\t" $col["frames_tracked"] "\t" $col["ate_kf_m"] "\t" $col["ate_frames_m"] "\t" \
                      $col["sim3_scale_frames"] "\t" $col["elapsed_s"] "\t" $col["cpu_s"]}' "$dir/runs.tsv" >> "$rows"
    tail -n 1 "$rows"
  done
done

median() { sort -g | awk -f tools/median.awk; }
echo "# medians over $rounds rounds (load average at the end $(cut -d' ' -f1-3 /proc/loadavg)); rows in $rows"
printf 'variant\tframes_tracked\tate_kf_m\tate_frames_m\tsim3_scale_frames\twall_s\tcpu_s\twall_vs_%s\n' "${names[0]}"
for name in "${names[@]}"; do
  line="$name"
  for col in 3 4 5 6 7 8; do
    line+=$'\t'$(awk -F'\t' -v v="$name" -v c="$col" 'NR > 1 && $2 == v {print $c}' "$rows" | median)
  done
  # The wall time against the first variant's, round by round, then the median.
  ratio=$(awk -F'\t' -v v="$name" -v first="${names[0]}" \
            'NR > 1 && $2 == first {f[$1] = $7} NR > 1 && $2 == v {w[$1] = $7}
             END {for (r in w) if (r in f && f[r] > 0) print w[r] / f[r]}' "$rows" | median)
  printf '%s\t%s\n' "$line" "$ratio"
done
