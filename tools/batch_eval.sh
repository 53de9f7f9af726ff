#!/usr/bin/env bash
# Batch evaluation: runs `vslam run` for every sequence x mode x detector and
# writes results.csv and results.md (one row per run), with each run's folder
# (trajectory, map, report.json and the PNG renders) under OUT/runs/.
#
#   tools/batch_eval.sh --seqs tum/fr3_teddy,kitti/00 --out DIR [options] [-- RUN_ARGS...]
#   tools/batch_eval.sh --seqs ... --out DIR --emit-jobs FILE   (job list for a Slurm array)
#   tools/batch_eval.sh --collect DIR                          (tables from finished runs)
#
# Options:
#   --seqs LIST        comma-separated sequences, as `vslam run --seq` takes them
#                      (tum/fr1_xyz, kitti/00, a folder); required unless --collect
#   --out DIR          output folder: DIR/runs/<seq>_<mode>_<detector>/, DIR/jobs.txt,
#                      DIR/jobs.tsv, DIR/results.csv, DIR/results.md; required
#   --modes LIST       comma-separated `vslam run --mode` values: mono, rgbd (default: mono)
#   --detectors LIST   comma-separated: on = the config's detector model, off = --detector none,
#                      anything else = that model name (default: on,off)
#   --jobs N           runs at the same time, through GNU parallel (default: 1). On a 2-core
#                      machine more than 1 job distorts the timing figures (fps, stage times):
#                      use 1 when the timings matter
#   --vslam PATH       the vslam executable (default: build/vslam)
#   --dry-run          print the job list (one shell command a line) and run nothing
#   --emit-jobs FILE   write the job list to FILE (and DIR/jobs.tsv for --collect), run nothing;
#                      see tools/slurm_batch_eval.sbatch and docs/REPORTS.md
#   --collect DIR      build DIR/results.csv and DIR/results.md from the run folders of an
#                      earlier batch (DIR/jobs.tsv), run nothing
#   -h, --help         this text
#   -- RUN_ARGS...     passed on to every `vslam run` (e.g. -- --max-frames 40 --deterministic)
#
# A run that fails (exit status not 0, or killed before it finished) is a row
# with its status, never left out. Exit status: 0 when every run succeeded,
# 1 when some failed, 2 on bad usage.
set -euo pipefail

usage() { sed -n '2,/^set -euo/p' "$0" | sed '$d' | sed 's/^# \{0,1\}//'; }
fail() { echo "batch_eval.sh: $*" >&2; exit 2; }

root=$(cd "$(dirname "$0")/.." && pwd)
seqs="" out="" modes="mono" detectors="on,off" jobs=1 vslam="$root/build/vslam"
dry_run=0 emit_jobs="" collect=""
run_args=()
while [ $# -gt 0 ]; do
  case "$1" in
    --seqs) [ $# -ge 2 ] || fail "--seqs needs a value"; seqs="$2"; shift 2 ;;
    --out) [ $# -ge 2 ] || fail "--out needs a value"; out="$2"; shift 2 ;;
    --modes) [ $# -ge 2 ] || fail "--modes needs a value"; modes="$2"; shift 2 ;;
    --detectors) [ $# -ge 2 ] || fail "--detectors needs a value"; detectors="$2"; shift 2 ;;
    --jobs) [ $# -ge 2 ] || fail "--jobs needs a value"; jobs="$2"; shift 2 ;;
    --vslam) [ $# -ge 2 ] || fail "--vslam needs a value"; vslam="$2"; shift 2 ;;
    --dry-run) dry_run=1; shift ;;
    --emit-jobs) [ $# -ge 2 ] || fail "--emit-jobs needs a file"; emit_jobs="$2"; shift 2 ;;
    --collect) [ $# -ge 2 ] || fail "--collect needs a folder"; collect="$2"; shift 2 ;;
    -h|--help) usage; exit 0 ;;
    --) shift; run_args=("$@"); break ;;
    *) fail "unknown option '$1' (see --help; vslam run arguments go after --)" ;;
  esac
done

command -v jq >/dev/null || fail "needs jq (tools/setup.sh installs it)"

# Shell-quotes one word for the job lines.
quote() { printf "'%s'" "${1//\'/\'\\\'\'}"; }

# A name usable as a folder: '/' and anything unusual become '-'.
safe_name() { printf '%s' "$1" | sed 's#^/*##; s#[^A-Za-z0-9._-]#-#g'; }

# ---- tables ---------------------------------------------------------------
# fmt DECIMALS VALUE: the number rounded, or a dash when there is none.
fmt() { if [ -n "$2" ]; then printf "%.${1}f" "$2"; else printf '–'; fi; }

# One row per line of DIR/jobs.tsv (name, sequence, mode, detector).
collect_tables() {
  local dir="$1"
  [ -f "$dir/jobs.tsv" ] || fail "$dir/jobs.tsv not found (not a batch_eval.sh output folder?)"
  local csv="$dir/results.csv" md="$dir/results.md" failed=0
  local header="sequence,mode,detector,status,ate_rmse_m,rpe_trans_m_per_s,rpe_rot_deg_per_s,frames_tracked,frames_total,fps,peak_mb,run_dir"
  echo "$header" > "$csv"
  {
    echo "| sequence | mode | detector | status | ATE RMSE (m) | RPE (m/s, deg/s) | frames tracked | fps | peak MB | renders |"
    echo "| --- | --- | --- | --- | ---: | ---: | ---: | ---: | ---: | --- |"
  } > "$md"
  local name seq mode det
  while IFS=$'\t' read -r name seq mode det; do
    local run="$dir/runs/$name" status values
    if [ -f "$run/exit_status" ] && [ "$(cat "$run/exit_status")" = 0 ] && [ -f "$run/report.json" ]; then
      status=ok
    elif [ -f "$run/exit_status" ]; then
      status="failed (exit $(cat "$run/exit_status"))"
    elif [ -f "$run/run.log" ]; then
      status="incomplete (no exit status: killed or still running)"
    else
      status="not run"
    fi
    if [ "$status" = ok ]; then
      values=$(jq -r '[
          (if .ate then .ate.frames.rmse_m else "" end),
          (if .rpe then .rpe.frames.trans_rmse else "" end),
          (if .rpe then .rpe.frames.rot_rmse_deg else "" end),
          .frames_tracked, .frames_total, .fps, .peak_rss_mb ] | @tsv' "$run/report.json") ||
        { status="failed (unreadable report.json)"; values=$'\t\t\t\t\t\t'; }
    else
      values=$'\t\t\t\t\t\t'
      failed=1
    fi
    local ate rpe_t rpe_r tracked total fps peak
    IFS=$'\t' read -r ate rpe_t rpe_r tracked total fps peak <<< "$values"
    # CSV: a field with a comma or quote is quoted.
    local field fields=() line=""
    for field in "$seq" "$mode" "$det" "$status" "$ate" "$rpe_t" "$rpe_r" "$tracked" "$total" "$fps" "$peak" "runs/$name"; do
      case "$field" in *[,\"]*) field="\"${field//\"/\"\"}\"" ;; esac
      fields+=("$field")
    done
    line=$(IFS=,; echo "${fields[*]}")
    echo "$line" >> "$csv"
    local renders="–"
    [ -f "$run/trajectory_top.png" ] && renders="[trajectory](runs/$name/trajectory_top.png), [map](runs/$name/map_top.png)"
    local rpe="–"
    [ -n "$rpe_t" ] && rpe="$(fmt 4 "$rpe_t") / $(fmt 2 "$rpe_r")"
    local frames="–"
    [ -n "$tracked" ] && frames="$tracked / $total"
    echo "| $seq | $mode | $det | $status | $(fmt 4 "$ate") | $rpe | $frames | $(fmt 1 "$fps") | $(fmt 0 "$peak") | $renders |" >> "$md"
  done < "$dir/jobs.tsv"
  echo "batch_eval.sh: wrote $csv and $md" >&2
  return "$failed"
}

if [ -n "$collect" ]; then
  [ -d "$collect" ] || fail "--collect: no folder $collect"
  collect_tables "$collect" && exit 0 || exit 1
fi

# ---- job list -------------------------------------------------------------
[ -n "$seqs" ] || fail "--seqs is required (see --help)"
[ -n "$out" ] || fail "--out is required (see --help)"
[[ "$jobs" =~ ^[1-9][0-9]*$ ]] || fail "--jobs must be a positive integer, not '$jobs'"
out=$(realpath -m "$out")  # job lines must work from any folder
IFS=, read -r -a seq_list <<< "$seqs"
IFS=, read -r -a mode_list <<< "$modes"
IFS=, read -r -a detector_list <<< "$detectors"
for mode in "${mode_list[@]}"; do
  case "$mode" in mono|rgbd) ;; *) fail "unknown mode '$mode' (mono, rgbd)" ;; esac
done
[ ${#seq_list[@]} -gt 0 ] && [ ${#detector_list[@]} -gt 0 ] || fail "empty --seqs or --detectors"

extra=""
for arg in "${run_args[@]+"${run_args[@]}"}"; do extra+=" $(quote "$arg")"; done

job_lines=() job_rows=()
for seq in "${seq_list[@]}"; do
  for mode in "${mode_list[@]}"; do
    for det in "${detector_list[@]}"; do
      case "$det" in
        on) det_args="" ;;
        off) det_args=" --detector none" ;;
        *) det_args=" --detector $(quote "$det")" ;;
      esac
      name="$(safe_name "$seq")_${mode}_$(safe_name "$det")"
      run="$out/runs/$name"
      # Each line is self-contained (Slurm runs one line per array task): it
      # runs from the project root and leaves run.log and exit_status in the run folder.
      job_lines+=("mkdir -p $(quote "$run") && rm -f $(quote "$run/exit_status") && cd $(quote "$root") && { $(quote "$vslam") run --seq $(quote "$seq") --mode $mode$det_args --out $(quote "$run")$extra > $(quote "$run/run.log") 2>&1; echo \$? > $(quote "$run/exit_status"); }")
      job_rows+=("$name"$'\t'"$seq"$'\t'"$mode"$'\t'"$det")
    done
  done
done

if [ "$dry_run" = 1 ]; then
  printf '%s\n' "${job_lines[@]}"
  exit 0
fi
mkdir -p "$out"
printf '%s\n' "${job_rows[@]}" > "$out/jobs.tsv"
printf '%s\n' "${job_lines[@]}" > "$out/jobs.txt"
if [ -n "$emit_jobs" ]; then
  printf '%s\n' "${job_lines[@]}" > "$emit_jobs"
  echo "batch_eval.sh: ${#job_lines[@]} jobs in $emit_jobs; e.g. sbatch --array=1-${#job_lines[@]} tools/slurm_batch_eval.sbatch $emit_jobs, then tools/batch_eval.sh --collect $out" >&2
  exit 0
fi

[ -x "$vslam" ] || fail "$vslam not found or not executable: build first (tools/setup.sh) or give --vslam"
echo "batch_eval.sh: ${#job_lines[@]} runs, $jobs at a time, into $out" >&2
if command -v parallel >/dev/null; then
  parallel --will-cite --jobs "$jobs" --joblog "$out/parallel.log" < "$out/jobs.txt" ||
    echo "batch_eval.sh: GNU parallel reported a failure (see $out/parallel.log)" >&2
elif [ "$jobs" = 1 ]; then
  while IFS= read -r line; do bash -c "$line"; done < "$out/jobs.txt"
else
  fail "--jobs $jobs needs GNU parallel (apt-get install parallel, or tools/setup.sh)"
fi
collect_tables "$out" && exit 0 || exit 1
