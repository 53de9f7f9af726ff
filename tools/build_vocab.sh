#!/usr/bin/env bash
# Trains the default vocabulary, vocab/orbvoc_k10_L6.bin (k = 10, L = 6, as
# ORB-SLAM's), with vocab/README.md's command, where its training images are
# found; tools/setup.sh runs it after the build. The file is over 5 MB, so it
# is made here and never committed. Without the images, or when the result is
# not the documented file, nothing is installed and `vslam run` uses the
# committed L = 5 vocab/orbvoc.bin (it says so in its log and report.json).
#   tools/build_vocab.sh [--build-dir DIR]
# Exit status: 0 when the file is in place or cannot be made here, 1 on a
# failed training run.
set -euo pipefail
cd "$(dirname "$0")/.."

build_dir=build
while [ $# -gt 0 ]; do
  case "$1" in
    --build-dir) build_dir="$2"; shift 2 ;;
    -h|--help) sed -n '2,10p' "$0"; exit 0 ;;
    *) echo "build_vocab.sh: unknown option '$1'" >&2; exit 2 ;;
  esac
done

out=vocab/orbvoc_k10_L6.bin
expected_md5=814a679a77cf7df08c051032b2f31a57
# The training set of vocab/README.md, relative to a data folder.
sources=(tum/rgbd_dataset_freiburg3_teddy tum/rgbd_dataset_freiburg3_long_office_household
         kitti/sequences/00 bonn/rgbd_bonn_crowd images)

md5_of() { md5sum "$1" | cut -d' ' -f1; }

if [ -f "$out" ]; then
  if [ "$(md5_of "$out")" = "$expected_md5" ]; then
    echo "build_vocab.sh: $out is in place (md5 $expected_md5)" >&2
    exit 0
  fi
  echo "build_vocab.sh: $out is not the documented file (md5 $(md5_of "$out"), expected $expected_md5): training it again" >&2
  rm -f "$out"
fi

data=
for d in "${VSLAM_DATA:-}" data ../shared/data; do
  [ -n "$d" ] || continue
  complete=1
  for s in "${sources[@]}"; do [ -d "$d/$s" ] || complete=0; done
  if [ "$complete" = 1 ]; then data=$d; break; fi
done
if [ -z "$data" ]; then
  echo "build_vocab.sh: the training images (${sources[*]}) are not all in \$VSLAM_DATA, ./data or ../shared/data;" \
       "vslam uses the committed vocab/orbvoc.bin (k = 10, L = 5)" >&2
  exit 0
fi

images=()
for s in "${sources[@]}"; do images+=("$data/$s"); done
tmp="$out.tmp.$$"
trap 'rm -f "$tmp"' EXIT
echo "build_vocab.sh: training $out on the images in $data (vocab/README.md; 40-90 s on 2 cores)" >&2
start=$SECONDS
"$build_dir/vslam" vocab build --images "${images[@]}" --out "$tmp" \
  --branching 10 --depth 6 --seed 42
md5=$(md5_of "$tmp")
if [ "$md5" != "$expected_md5" ]; then
  # Another OpenCV or a changed training set gives other descriptors: the file
  # would be a good vocabulary, but not the one the documented figures were made with.
  echo "build_vocab.sh: the trained file's md5 is $md5, not the documented $expected_md5" \
       "(other images or another OpenCV?); not installed, vslam uses vocab/orbvoc.bin (k = 10, L = 5)" >&2
  exit 0
fi
mv "$tmp" "$out"
echo "build_vocab.sh: built $out in $((SECONDS - start)) s (md5 $md5)" >&2
