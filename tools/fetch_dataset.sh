#!/usr/bin/env bash
# Downloads a TUM RGB-D sequence from the benchmark's official archive, checks
# it and unpacks it where `vslam run --seq tum/<name>` looks for it.
#   tools/fetch_dataset.sh [--data-root DIR] tum/<name>     e.g. tum/fr1_xyz
#   tools/fetch_dataset.sh --list                           every known name
# DIR defaults to $VSLAM_DATA, else ./data; the sequence lands in DIR/tum/.
# KITTI odometry needs a registration and cannot be fetched: see the message.
# $VSLAM_TUM_BASE_URL replaces https://cvg.cit.tum.de/rgbd/dataset (mirrors, tests).
set -euo pipefail

# Keep in step with src/io/sequence_catalog.cpp (a test compares the two).
fr1="360 desk desk2 floor plant room rpy teddy xyz"
fr2="360_hemisphere 360_kidnap coke desk desk_with_person dishes flowerbouquet flowerbouquet_brownbackground
     large_no_loop large_with_loop metallic_sphere metallic_sphere2 pioneer_360 pioneer_slam pioneer_slam2
     pioneer_slam3 rpy teddy xyz"
fr3="cabinet large_cabinet long_office_household nostructure_notexture_far nostructure_notexture_near_withloop
     nostructure_texture_far nostructure_texture_near_withloop sitting_halfsphere sitting_rpy sitting_static
     sitting_xyz structure_notexture_far structure_notexture_near structure_texture_far structure_texture_near
     teddy walking_halfsphere walking_rpy walking_static walking_xyz"

die() { echo "fetch_dataset.sh: $*" >&2; exit 1; }

data_root="${VSLAM_DATA:-./data}"
spec=""
while [ $# -gt 0 ]; do
  case "$1" in
    --data-root) [ $# -ge 2 ] || die "--data-root needs a folder"; data_root="$2"; shift 2 ;;
    --list)
      for n in $fr1; do echo "tum/fr1_$n"; done
      for n in $fr2; do echo "tum/fr2_$n"; done
      for n in $fr3; do echo "tum/fr3_$n"; done
      exit 0 ;;
    -h|--help) sed -n '2,9p' "$0"; exit 0 ;;
    -*) die "unknown option '$1' (see --help)" ;;
    *) [ -z "$spec" ] || die "one sequence at a time ('$spec' and '$1' given)"; spec="$1"; shift ;;
  esac
done
[ -n "$spec" ] || die "no sequence given; usage: tools/fetch_dataset.sh [--data-root DIR] tum/<name>"

case "$spec" in
  kitti/*)
    die "$spec: KITTI odometry needs a registration at cvlibs.net and cannot be fetched; download the grey images" \
        "(data_odometry_gray.zip) and poses (data_odometry_poses.zip) and unpack them so that" \
        "$data_root/kitti/sequences/NN/image_0/ and $data_root/kitti/poses/NN.txt exist" ;;
  tum/*) ;;
  *) die "$spec: not a sequence name (tum/<name>, e.g. tum/fr1_xyz; --list prints all)" ;;
esac

short="${spec#tum/}"
freiburg="" name=""
if [[ "$short" =~ ^fr([123])_(.+)$ ]]; then
  freiburg="${BASH_REMATCH[1]}" name="${BASH_REMATCH[2]}"
  eval "known=\$fr$freiburg"
  # shellcheck disable=SC2154
  [[ " $(echo $known) " == *" $name "* ]] || freiburg=""
fi
[ -n "$freiburg" ] || die "$spec: unknown TUM RGB-D sequence (e.g. tum/fr1_xyz, tum/fr3_long_office_household; --list prints all)"

archive="rgbd_dataset_freiburg${freiburg}_${name}"
base_url="${VSLAM_TUM_BASE_URL:-https://cvg.cit.tum.de/rgbd/dataset}"
url="$base_url/freiburg$freiburg/$archive.tgz"
dest="$data_root/tum"

if [ -f "$dest/$archive/rgb.txt" ]; then
  echo "fetch_dataset.sh: $dest/$archive already holds the sequence" >&2
  exit 0
fi
[ ! -e "$dest/$archive" ] || die "$dest/$archive exists but has no rgb.txt; remove it (or complete it) first"

created_root=0; [ -d "$data_root" ] || created_root=1
mkdir -p "$dest" || die "cannot create $dest"
part="$dest/$archive.tgz.part"
staging="$dest/.$archive.unpacking"
# Leave no partial download or unpacking, nor folders this run created for nothing.
cleanup() {
  rm -f "$part"
  rm -rf "$staging"
  rmdir "$dest" 2>/dev/null || true
  [ "$created_root" = 0 ] || rmdir "$data_root" 2>/dev/null || true
}
trap cleanup EXIT

by_hand="download $url on a machine with internet and unpack it into $dest/ (so that $dest/$archive/rgb.txt exists), or pass --data-root / set VSLAM_DATA to where it already is"
echo "fetch_dataset.sh: downloading $url" >&2
# Fail fast without internet (no DNS, no route), but allow a slow download.
if ! curl --fail --location --connect-timeout 15 --progress-bar --output "$part" "$url"; then
  die "$spec: download of $url failed (no internet?); $by_hand"
fi

echo "fetch_dataset.sh: checking the archive" >&2
gzip -t "$part" 2>/dev/null || die "$spec: $url is not a valid gzip archive (truncated or corrupted download); $by_hand"
tar -tzf "$part" | grep -qx "$archive/rgb.txt" ||
  die "$spec: the archive from $url has no $archive/rgb.txt; $by_hand"

echo "fetch_dataset.sh: unpacking into $dest" >&2
# Unpack beside the target and move it in whole, so an interrupted run never
# leaves a folder that looks complete.
mkdir -p "$staging"
tar -xzf "$part" -C "$staging" || die "$spec: unpacking into $dest failed (disk full?)"
mv "$staging/$archive" "$dest/$archive" || die "$spec: cannot move the unpacked sequence to $dest/$archive"
rm -f "$part"
echo "fetch_dataset.sh: $spec is in $dest/$archive" >&2
