#!/usr/bin/env bash
# Issue 15's moving-object check on the synthetic room, for several texture
# seeds: the three runs of SlamMovingObject.RoomWithAWalkingPerson... (which
# runs seed 1 only) through the command line. Per seed it renders the room
# without and with the billboard of the person cropped from ../shared's
# person.jpg (260 frames, 0.35 m wide, as the test), runs them monocular and
# threaded with Yolo-Fastest, and prints the keyframe ATE (Sim(3)) of
#   static     the room without the billboard, --moving-classes coco-movable
#   checked    the billboard, --moving-classes coco-movable (the motion check)
#   unchecked  the billboard, the paper's filter alone
# and whether the issue's two conditions hold: checked <= 1.2 x static, and
# unchecked > 1.2 x static.
#   tools/bench_moving_room.sh [--seeds "1 2 ... 8"] [--out DIR] [-- extra vslam run options]
set -euo pipefail
cd "$(dirname "$0")/.."
seeds="1 2 3 4 5 6 7 8"
out=runs/bench-moving-room-$(date +%Y%m%d-%H%M%S)
while [ $# -gt 0 ]; do
  case "$1" in
    --seeds) seeds="$2"; shift 2 ;;
    --out) out="$2"; shift 2 ;;
    --) shift; break ;;
    -h|--help) sed -n '2,13p' "$0"; exit 0 ;;
    *) echo "bench_moving_room.sh: unknown option '$1'" >&2; exit 2 ;;
  esac
done
photo=""
for dir in "${VSLAM_DATA:-}" ./data ../shared/data; do
  if [ -n "$dir" ] && [ -f "$dir/images/person.jpg" ]; then photo="$dir/images/person.jpg"; break; fi
done
[ -n "$photo" ] || { echo "bench_moving_room.sh: images/person.jpg not found in \$VSLAM_DATA, ./data or ../shared/data" >&2; exit 2; }
mkdir -p "$out"
# The person alone (x 165-305, y 80-390 of the 640x424 photo), as the test crops it.
/usr/bin/python3 - "$photo" "$out/person.png" <<'PY'
import sys, cv2
photo = cv2.imread(sys.argv[1], cv2.IMREAD_COLOR)
if photo is None:
    sys.exit("bench_moving_room.sh: cannot read " + sys.argv[1])
cv2.imwrite(sys.argv[2], photo[80:390, 165:305])
PY
printf '%-5s %-10s %-10s %-12s %-12s %s\n' seed static_cm checked_cm unchecked_cm "moving/parked/undecided" "conditions"
extra=("$@")  # the caller's vslam run options, for every run
# Renders the room of seed $seed into $1 (`vslam synth` options after it); false when it fails.
render() {
  local room="$1"
  shift
  build/vslam synth --out "$room" --seed "$seed" --frames 260 --turns 0.624 "$@" >"$room.synth.log" 2>&1 ||
    { echo "seed $seed: vslam synth failed, see $room.synth.log" >&2; return 1; }
}
# Runs room $2 monocular into run-$1-$seed (`vslam run` options after them); its failure shows as a missing ATE.
run() {
  local kind="$1" room="$2"
  shift 2
  build/vslam run --seq "$room" --config "$room/camera.yaml" --mode mono --no-render "$@" \
    --out "$out/run-$kind-$seed" "${extra[@]}" >/dev/null 2>"$out/run-$kind-$seed.log" || true
}
for seed in $seeds; do
  static="$out/static-$seed"
  moving="$out/moving-$seed"
  render "$static" || continue
  render "$moving" --moving-object "$out/person.png" --moving-object-width 0.35 || continue
  run static "$static" --moving-classes coco-movable
  run checked "$moving" --moving-classes coco-movable
  run unchecked "$moving"
  python3 - "$out" "$seed" <<'PY'
import json, sys
out, seed = sys.argv[1], sys.argv[2]
def run(kind):
    try:
        return json.load(open(f"{out}/run-{kind}-{seed}/report.json"))
    except (OSError, ValueError):
        return None
def ate_cm(report):
    try:
        return 100 * report["ate"]["keyframes"]["rmse_m"]
    except (TypeError, KeyError):
        return None
static, checked, unchecked = run("static"), run("checked"), run("unchecked")
s, c, u = ate_cm(static), ate_cm(checked), ate_cm(unchecked)
fmt = lambda v: "-" if v is None else "%.2f" % v
verdicts = (checked or {}).get("moving_objects") or {}
counts = "%s/%s/%s" % (verdicts.get("moving", "-"), verdicts.get("parked", "-"), verdicts.get("undecided", "-"))
if None in (s, c, u):
    conditions = "no ATE (see the run logs)"
else:
    conditions = "checked %.2fx %s, unchecked %.2fx %s" % (c / s, "ok" if c <= 1.2 * s else "FAILS",
                                                           u / s, "ok" if u > 1.2 * s else "FAILS")
print("%-5s %-10s %-10s %-12s %-12s %s" % (seed, fmt(s), fmt(c), fmt(u), counts, conditions))
PY
done
echo "runs in $out"
