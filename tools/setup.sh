#!/usr/bin/env bash
# Installs vslam's build dependencies from Debian's archive (idempotent,
# non-interactive), then configures and builds into ./build, and trains the
# default vocabulary where its training images are (tools/build_vocab.sh).
#   tools/setup.sh [--build-dir DIR] [--skip-install] [--sanitize address|thread] [--target NAME]...
# --sanitize configures a sanitizer build (no benchmarks); --target (repeatable)
# builds only the named CMake targets instead of everything.
set -euo pipefail
cd "$(dirname "$0")/.."

build_dir=build
skip_install=0
sanitize=
targets=()
while [ $# -gt 0 ]; do
  case "$1" in
    --build-dir) build_dir="$2"; shift 2 ;;
    --skip-install) skip_install=1; shift ;;
    --sanitize) sanitize="$2"; shift 2 ;;
    --target) targets+=("$2"); shift 2 ;;
    -h|--help) sed -n '2,6p' "$0"; exit 0 ;;
    *) echo "setup.sh: unknown option '$1'" >&2; exit 2 ;;
  esac
done

packages=(build-essential cmake pkg-config curl
          libopencv-dev libeigen3-dev libceres-dev libyaml-cpp-dev libcli11-dev
          libspdlog-dev nlohmann-json3-dev libgtest-dev libbenchmark-dev libosmesa6-dev
          libsqlite3-dev sqlite3 libdeflate-dev jq curl ca-certificates parallel
          time                          # tools/bench_alternate.sh: /usr/bin/time for wall and CPU
          clang-14 libclang-rt-14-dev   # tools/fuzz.sh: clang and libFuzzer
          python3-numpy python3-opencv) # tools/depth_scale_check.py and its test

if [ "$skip_install" = 0 ]; then
  missing=()
  for p in "${packages[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  if [ ${#missing[@]} -gt 0 ]; then
    echo "setup.sh: installing ${missing[*]}" >&2
    sudo_cmd=()
    [ "$(id -u)" = 0 ] || sudo_cmd=(sudo)
    "${sudo_cmd[@]}" apt-get update -q
    DEBIAN_FRONTEND=noninteractive "${sudo_cmd[@]}" apt-get install -y -q --no-install-recommends "${missing[@]}"
  fi
fi

jobs=$(nproc 2>/dev/null || echo 2)
benchmarks=ON
[ -z "$sanitize" ] || benchmarks=OFF
cmake -S . -B "$build_dir" -DCMAKE_BUILD_TYPE=Release -DVSLAM_SANITIZE="$sanitize" \
      -DVSLAM_BUILD_BENCHMARKS="$benchmarks" >/dev/null
if [ ${#targets[@]} -gt 0 ]; then
  cmake --build "$build_dir" -j "$jobs" --target "${targets[@]}"
else
  cmake --build "$build_dir" -j "$jobs"
fi

# Data and models are found at run time ($VSLAM_DATA / $VSLAM_MODELS, ./data,
# ./models, ../shared); say where they were found so a user knows what runs.
for d in "${VSLAM_DATA:-}" data ../shared/data; do
  if [ -n "$d" ] && [ -d "$d/tum" -o -d "$d/kitti" ]; then echo "setup.sh: datasets found in $d" >&2; break; fi
done
for d in "${VSLAM_MODELS:-}" models ../shared/models; do
  if [ -n "$d" ] && ls "$d"/*/*.weights >/dev/null 2>&1; then echo "setup.sh: detector models found in $d" >&2; break; fi
done
if [ ${#targets[@]} -gt 0 ]; then
  echo "setup.sh: built ${targets[*]} in $build_dir" >&2
else
  echo "setup.sh: built $build_dir/vslam" >&2
  # The default vocabulary (k = 10, L = 6) is over 5 MB and not committed: train
  # it where its images are (vocab/README.md); elsewhere vocab/orbvoc.bin serves.
  [ -n "$sanitize" ] || tools/build_vocab.sh --build-dir "$build_dir"
fi
