#!/usr/bin/env bash
# The pictures of thesis §8.5 for three simulated scenes: the file-based sequence (sim ->
# calibrate -> moments -> reconstruct, as `make demo-files`) for `mirrors` (fig. 8.7-8.10),
# `corner` (fig. 8.11, 8.13) and `video` (fig. 8.15, 8.16; enough frames for the person to
# move), then `transient view` drawing every picture kind into OUT_DIR/<scene>/, and for
# `mirrors` and `video` the moment-depth pictures (thesis ch. 4: virtual objects occluded by
# the real scene and its shadow on a virtual backdrop, from filtered moment maps of the depth).
#   usage: tools/scripts/view_scenes.sh BUILD_DIR OUT_DIR
# OUT_DIR/<scene>/data/ holds capture.h5, moments.h5 and reconstruction.h5; OUT_DIR/<scene>/
# light.mp4 and frame_NNN/ (slices, cumulative, streak, range, amplitude, flags, direct,
# indirect, points.ply, per-pixel plots, moment_depth/), and for video moment_plane.mp4.
set -euo pipefail
build=${1:?usage: view_scenes.sh BUILD_DIR OUT_DIR}
out=${2:?usage: view_scenes.sh BUILD_DIR OUT_DIR}
transient="$build/tools/transient/transient"
[[ -x "$transient" ]] || { echo "view_scenes: no $transient (build it first)" >&2; exit 1; }
start=$(date +%s.%N)
mkdir -p "$out"

# One calibration of the default camera (163x120, m = 3) serves every scene.
calibration="$out/calibration.h5"
rm -f "$calibration"
"$transient" calibrate --source sim:calibration --takes 20 --out "$calibration"

# scene, frames, extra moments options
for spec in "mirrors 2" "corner 2" "video 10 --video"; do
  read -r scene frames moments_options <<< "$spec"
  dir="$out/$scene"
  rm -rf "$dir" && mkdir -p "$dir/data"
  "$transient" sim "$scene" --frames "$frames" --out "$dir/data/capture.h5"
  # shellcheck disable=SC2086  # moments_options is a list of options
  "$transient" moments "$dir/data/capture.h5" --calibration "$calibration" \
    --out "$dir/data/moments.h5" $moments_options
  "$transient" reconstruct "$dir/data/moments.h5" "$dir/data/reconstruction.h5" --bins 64 \
    --bounds-r 0.5
  # Every picture kind: slices and cumulative frames at every bin, the video over all frames
  # and bins, the streak image of the middle row, range/amplitude/flags/direct/indirect, the
  # point cloud with the capture's intrinsics, and plots of the centre pixel and one at the
  # left edge; for mirrors and video also the moment-depth pictures, with the default range
  # and placement except the video's sphere, put where the person's torso passes in front of
  # it in the last frames (pixel 60,45).
  moment_options=()
  case "$scene" in
    mirrors) moment_options=(--moment-depth) ;;
    video) moment_options=(--moment-depth --moment-video --sphere 3.2,0.3,60,45) ;;
  esac
  "$transient" view "$dir/data/reconstruction.h5" --out "$dir" --slices --cumulative --video \
    --images --point-cloud --camera "$dir/data/capture.h5" --streak 60 --pixel 81,60 \
    --pixel 20,60 --ply-format binary "${moment_options[@]}"
done

end=$(date +%s.%N)
echo "view_scenes: wrote $(find "$out" -type f | wc -l) files into $out in" \
  "$(awk -v a="$start" -v b="$end" 'BEGIN { printf "%.1f", b - a }') s"
