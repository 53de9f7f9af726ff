#!/usr/bin/env bash
# Loop closing on the synthetic room for several texture seeds: renders the
# room (vslam synth --seed N), runs it (threaded, no detector, no final BA, so
# that loop closing's own correction is what is measured) and prints, per
# seed, the loops closed and how far apart the ground truth puts each loop's
# two keyframes (a true loop joins keyframes < 0.3 m apart).
#   tools/bench_room_seeds.sh [--seeds "1 2 ... 10"] [--out DIR] [-- extra vslam run options]
set -euo pipefail
cd "$(dirname "$0")/.."
seeds="1 2 3 4 5 6 7 8 9 10"
out=runs/bench-room-seeds-$(date +%Y%m%d-%H%M%S)
while [ $# -gt 0 ]; do
  case "$1" in
    --seeds) seeds="$2"; shift 2 ;;
    --out) out="$2"; shift 2 ;;
    --) shift; break ;;
    -h|--help) sed -n '2,7p' "$0"; exit 0 ;;
    *) echo "bench_room_seeds.sh: unknown option '$1'" >&2; exit 2 ;;
  esac
done
mkdir -p "$out"
printf '%-5s %-6s %-9s %-10s %s\n' seed loops kf_ate_cm wall_s "loops (current-matched keyframe: ground-truth distance m, scale, matches)"
for seed in $seeds; do
  room="$out/room-$seed"
  build/vslam synth --out "$room" --seed "$seed" >"$room.synth.log" 2>&1 || { echo "seed $seed: vslam synth failed, see $room.synth.log" >&2; continue; }
  build/vslam run --seq "$room" --config "$room/camera.yaml" --detector none --no-render --no-final-ba \
    --out "$room/run" "$@" >/dev/null 2>"$room/run.log" || true
  python3 - "$room" "$seed" <<'PY'
import json, sys, bisect
room, seed = sys.argv[1], sys.argv[2]
report = json.load(open(f"{room}/run/report.json"))
gt = []
for line in open(f"{room}/groundtruth.txt"):
    if line.startswith("#") or not line.strip():
        continue
    v = [float(x) for x in line.split()]
    gt.append((v[0], v[1:4]))
times = [t for t, _ in gt]
def at(t):
    i = min(range(len(gt)), key=lambda k: abs(times[k] - t))
    return gt[i][1]
loops = []
for loop in report.get("loops", []):
    a, b = loop.get("current_timestamp"), loop.get("matched_timestamp")
    d = "?" if a is None or b is None else "%.3f" % sum((x - y) ** 2 for x, y in zip(at(a), at(b))) ** 0.5
    loops.append("%d-%d: %s m, %.3f, %d" % (loop["current_keyframe"], loop["matched_keyframe"], d, loop["scale"], loop["inliers"]))
ate = report.get("ate") or {}
kf = ate.get("keyframes") if isinstance(ate, dict) else None
print("%-5s %-6d %-9s %-10.1f %s" % (seed, len(report.get("loops", [])), "%.2f" % (100 * kf["rmse_m"]) if kf else "-",
                                     report.get("wall_s", 0), "; ".join(loops)))
PY
done
echo "runs in $out"
