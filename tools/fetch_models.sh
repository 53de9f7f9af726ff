#!/usr/bin/env bash
# Downloads detector models listed in models/manifest.tsv from their official
# releases, checking size (and md5 where the manifest knows it).
#   tools/fetch_models.sh NAME...      e.g. tools/fetch_models.sh yolov4 yolov4-tiny
#   tools/fetch_models.sh --list
# Files go to $VSLAM_MODELS when set, else ./models (where vslam looks first).
set -euo pipefail
cd "$(dirname "$0")/.."
manifest=models/manifest.tsv
dest="${VSLAM_MODELS:-models}"

usage() { sed -n '2,6p' "$0" | sed 's/^# \{0,1\}//'; }
[ $# -gt 0 ] || { usage >&2; exit 2; }
case "$1" in
  -h|--help) usage; exit 0 ;;
  --list) grep -v '^#' "$manifest" | cut -f1,3,6; exit 0 ;;
esac
command -v curl >/dev/null || { echo "fetch_models.sh: needs curl (apt-get install curl)" >&2; exit 1; }
mkdir -p "$dest"

file_size() { stat -c %s "$1"; }

# download URL FILE [BYTES MD5]: into $dest/FILE via a .part file, verified before it is kept.
download() {
  local url="$1" file="$2" bytes="${3:--}" md5="${4:-unknown}"
  local target="$dest/$file"
  if [ -f "$target" ] && { [ "$bytes" = - ] || [ "$(file_size "$target")" = "$bytes" ]; }; then
    echo "fetch_models.sh: $target already present"
    return 0
  fi
  echo "fetch_models.sh: downloading $url"
  if ! curl --fail --location --connect-timeout 15 --retry 2 --progress-bar -o "$target.part" "$url"; then
    rm -f "$target.part"
    echo "fetch_models.sh: cannot download $url (no internet on this machine?)" >&2
    return 1
  fi
  if [ "$bytes" != - ] && [ "$(file_size "$target.part")" != "$bytes" ]; then
    echo "fetch_models.sh: $url gave $(file_size "$target.part") bytes, expected $bytes; not kept" >&2
    rm -f "$target.part"
    return 1
  fi
  if [ "$md5" != unknown ] && [ "$md5" != - ]; then
    local actual
    actual=$(md5sum "$target.part" | cut -d' ' -f1)
    if [ "$actual" != "$md5" ]; then
      echo "fetch_models.sh: $url has md5 $actual, expected $md5; not kept" >&2
      rm -f "$target.part"
      return 1
    fi
  fi
  mv "$target.part" "$target"
  echo "fetch_models.sh: wrote $target"
}

status=0
for name in "$@"; do
  row=$(awk -F'\t' -v n="$name" '$1 == n' "$manifest")
  if [ -z "$row" ]; then
    echo "fetch_models.sh: unknown model '$name'; known: $(grep -v '^#' "$manifest" | cut -f1 | tr '\n' ' ')" >&2
    status=2
    continue
  fi
  IFS=$'\t' read -r _ cfg weights names weights_url weights_bytes weights_md5 cfg_url names_url <<<"$row"
  download "$cfg_url" "$cfg" || status=1
  download "$names_url" "$names" || status=1
  download "$weights_url" "$weights" "$weights_bytes" "$weights_md5" || status=1
done
exit $status
