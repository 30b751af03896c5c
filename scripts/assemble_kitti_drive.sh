#!/usr/bin/env bash
# Assembles a KITTI raw drive folder that the package's tools read (kitti_to_bag, run_pipeline,
# evaluate) from the official downloads or from a repository checkout that holds the raw layout,
# with the drive's KITTI tracking labels as its truth. KITTI data is CC BY-NC-SA 3.0: the result
# is for your own use and is never committed to this repository.
#
# Usage: scripts/assemble_kitti_drive.sh --raw DIR --drive YYYY_MM_DD_drive_NNNN
#            --tracking-labels label_02/SSSS.txt --output DIR [--frames FIRST-LAST]
#
#   --raw DIR              a folder holding YYYY_MM_DD/ (calib_*.txt and YYYY_MM_DD_drive_NNNN_sync/
#                          with image_02, velodyne_points and oxts), at any depth: the unzipped
#                          official raw downloads, or e.g. a checkout of
#                          AbdelazizHamadi/3D-scene-reconstruction-using-camera-Lidar-with-KITTI-dataset
#                          (KITTI_SAMPLE/RAW/2011_09_26/2011_09_26_drive_0009_sync)
#   --drive NAME           e.g. 2011_09_26_drive_0009 (the drive of tracking training sequence 0001)
#   --tracking-labels F    the sequence's label file in the KITTI tracking benchmark's format
#                          (data_tracking_label_2/training/label_02/SSSS.txt), whose frame numbers
#                          are the drive's frame numbers
#   --frames A-B           frames to keep, inclusive (default: every frame with a scan and an image)
#   --output DIR           written: DIR/YYYY_MM_DD/calib_*.txt and DIR/YYYY_MM_DD/NAME_sync/ with
#                          image_02, velodyne_points, oxts (frames A..B renumbered from 0, their
#                          time stamps), label_02/SSSS.txt (the tracking labels of those frames,
#                          renumbered: evaluate --tracking-labels) and label_2/NNNNNNNNNN.txt (the
#                          same labels per frame in the object format: oracle boxes for the replay
#                          detector)
#
# Then, for example:
#   rosrun grid_vision_fusion kitti_to_bag DIR/2011_09_26/2011_09_26_drive_0009_sync drive_0009.bag
#   rosrun grid_vision_fusion run_pipeline --bag drive_0009.bag --output run.bag \
#       --replay-directory DIR/2011_09_26/2011_09_26_drive_0009_sync/label_2
#   rosrun grid_vision_fusion evaluate --drive DIR/2011_09_26/2011_09_26_drive_0009_sync \
#       --tracking-labels DIR/2011_09_26/2011_09_26_drive_0009_sync/label_02/0001.txt \
#       --detections run.bag --output evaluation
set -euo pipefail

die() { echo "assemble_kitti_drive: error: $*" >&2; exit 1; }
usage() { sed -n '2,/^set -euo/p' "${BASH_SOURCE[0]}" | sed '$d' | sed 's/^# \{0,1\}//'; exit "${1:-2}"; }

raw="" drive="" labels="" output="" frames=""
while (($#)); do
  case "$1" in
    --raw) raw=${2:?--raw needs a folder}; shift 2 ;;
    --drive) drive=${2:?--drive needs a name}; shift 2 ;;
    --tracking-labels) labels=${2:?--tracking-labels needs a file}; shift 2 ;;
    --output) output=${2:?--output needs a folder}; shift 2 ;;
    --frames) frames=${2:?--frames needs FIRST-LAST}; shift 2 ;;
    -h|--help) usage 0 ;;
    *) echo "assemble_kitti_drive: unknown option '$1'" >&2; usage 2 ;;
  esac
done
[[ -n $raw && -n $drive && -n $labels && -n $output ]] || { echo "assemble_kitti_drive: --raw, --drive, --tracking-labels and --output are required" >&2; usage 2; }
[[ $drive =~ ^([0-9]{4}_[0-9]{2}_[0-9]{2})_drive_[0-9]{4}$ ]] || die "--drive '$drive' is not named like 2011_09_26_drive_0009"
date=${BASH_REMATCH[1]}
[[ -d $raw ]] || die "--raw '$raw' is not a folder"
[[ -f $labels ]] || die "--tracking-labels '$labels' cannot be read"

source_drive=$(find "$raw" -maxdepth 6 -type d -path "*/${date}/${drive}_sync" -print -quit)
[[ -n $source_drive ]] || die "no ${date}/${drive}_sync folder under '$raw'"
source_day=$(dirname "$source_drive")
for f in calib_cam_to_cam.txt calib_velo_to_cam.txt calib_imu_to_velo.txt; do
  [[ -f $source_day/$f ]] || die "$source_day/$f is missing (the day's calibration belongs beside the drive)"
done
for d in image_02 velodyne_points oxts; do
  [[ -f $source_drive/$d/timestamps.txt ]] || die "$source_drive/$d/timestamps.txt is missing"
done

# The frames that have a scan, an image and an OXTS record.
count=0
while [[ -f $source_drive/velodyne_points/data/$(printf %010d "$count").bin &&
         -f $source_drive/image_02/data/$(printf %010d "$count").png &&
         -f $source_drive/oxts/data/$(printf %010d "$count").txt ]]; do
  count=$((count + 1))
done
((count > 0)) || die "$source_drive has no frame 0 with a scan, an image and an OXTS record"
first=0 last=$((count - 1))
if [[ -n $frames ]]; then
  [[ $frames =~ ^([0-9]+)-([0-9]+)$ ]] || die "--frames '$frames' is not FIRST-LAST"
  first=$((10#${BASH_REMATCH[1]})) last=$((10#${BASH_REMATCH[2]}))
  ((first <= last)) || die "--frames $frames: the first frame lies after the last"
  ((last < count)) || die "--frames $frames: $source_drive has frames 0-$((count - 1)) only"
fi

day_out=$output/$date
drive_out=$day_out/${drive}_sync
rm -rf "$drive_out.tmp"
mkdir -p "$drive_out.tmp"
cp "$source_day"/calib_{cam_to_cam,velo_to_cam,imu_to_velo}.txt "$day_out/"
sequence=$(basename "$labels" .txt)
echo "[assemble] $drive frames $first-$last -> $drive_out ($((last - first + 1)) frames, labels of sequence $sequence)"
for d in image_02 velodyne_points oxts; do
  ext=$([[ $d == image_02 ]] && echo png || { [[ $d == oxts ]] && echo txt || echo bin; })
  mkdir -p "$drive_out.tmp/$d/data"
  sed -n "$((first + 1)),$((last + 1))p" "$source_drive/$d/timestamps.txt" > "$drive_out.tmp/$d/timestamps.txt"
  (( $(wc -l < "$drive_out.tmp/$d/timestamps.txt") == last - first + 1 )) ||
    die "$source_drive/$d/timestamps.txt has fewer than $((last + 1)) lines"
  for ((i = first; i <= last; i++)); do
    cp "$source_drive/$d/data/$(printf %010d "$i").$ext" "$drive_out.tmp/$d/data/$(printf %010d $((i - first))).$ext"
  done
done
[[ -f $source_drive/oxts/dataformat.txt ]] && cp "$source_drive/oxts/dataformat.txt" "$drive_out.tmp/oxts/"

# Tracking labels: "frame track_id type truncated occluded alpha left top right bottom h w l x y z
# rotation_y [score]". Renumbered to the kept frames; label_2 drops the first two columns.
mkdir -p "$drive_out.tmp/label_02" "$drive_out.tmp/label_2"
awk -v first="$first" -v last="$last" -v src="$labels" '
  /^[[:space:]]*$/ { next }
  NF < 17 || $1 !~ /^[0-9]+$/ { printf "assemble_kitti_drive: error: %s:%d: not a KITTI tracking label line\n", src, NR > "/dev/stderr"; bad = 1; exit 1 }
  $1 >= first && $1 <= last { $1 = $1 - first; print }
' "$labels" > "$drive_out.tmp/label_02/$sequence.txt" || die "cannot read $labels"
for ((i = 0; i <= last - first; i++)); do
  awk -v f="$i" '$1 == f { $1 = ""; $2 = ""; sub(/^  /, ""); print }' "$drive_out.tmp/label_02/$sequence.txt" \
    > "$drive_out.tmp/label_2/$(printf %010d "$i").txt"
done
cat > "$drive_out.tmp/LICENSE.txt" <<EOF
KITTI raw data and tracking labels, (c) Geiger, Lenz, Stiller, Urtasun (KITTI Vision Benchmark,
IJRR 2013), CC BY-NC-SA 3.0. Assembled by grid_vision_fusion's scripts/assemble_kitti_drive.sh
from $source_drive (frames $first-$last) and $labels. Do not commit or redistribute it
under another license.
EOF
rm -rf "$drive_out"
mv "$drive_out.tmp" "$drive_out"
echo "[assemble] done: $(ls "$drive_out/velodyne_points/data" | wc -l) scans, $(grep -vc DontCare "$drive_out/label_02/$sequence.txt") labelled objects"
