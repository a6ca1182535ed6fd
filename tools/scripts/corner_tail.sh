#!/usr/bin/env bash
# What limits MESE's range error in its tail on the simulated corner (issue 17, part 2): the
# file-based sequence (docs/measuring.md) with physical noise at m = 3 for more takes, a longer
# calibration, finer arccos sub-exposures (n_phi), m = 4, and the scene's noise-free moments;
# then the pixels of the 4-take run's 95th percentile characterised (tools/scripts/corner_tail.py).
# Takes about a minute. Results: docs/eval.md, "The tail on the noisy corner".
#   usage: tools/scripts/corner_tail.sh BUILD_DIR [OUT_DIR]
set -euo pipefail
build=${1:?usage: corner_tail.sh BUILD_DIR [OUT_DIR]}
out=${2:-$(mktemp -d)}
mkdir -p "$out"
root=$(cd "$(dirname "$0")/../.." && pwd)
T="$build/tools/transient/transient"
compare() {  # the MESE line of compare_with_truth.py
  local lines
  lines=$(/usr/bin/python3 "$root/tools/scripts/compare_with_truth.py" "$@")
  echo "${lines%%$'\n'*}"
}

# name, sim options, calibration source, calibration takes
run() {
  local name=$1 options=$2 calibration_source=$3 calibration_takes=$4
  local calibration="$out/calibration-$calibration_takes-${calibration_source//[^a-z0-9]/_}.h5"
  [[ -f $calibration ]] || "$T" calibrate --source "$calibration_source" \
    --takes "$calibration_takes" --out "$calibration" > /dev/null
  # shellcheck disable=SC2086 # options are words
  "$T" sim corner --frames 4 $options --out "$out/$name-capture.h5" > /dev/null
  "$T" moments "$out/$name-capture.h5" --calibration "$calibration" \
    --out "$out/$name-moments.h5" > /dev/null
  "$T" reconstruct "$out/$name-moments.h5" "$out/$name-reconstruction.h5" --bins 64 > /dev/null
  printf '%-44s %s\n' "$name:" "$(compare "$out/$name-capture.h5" "$out/$name-reconstruction.h5")"
}

run "takes 1, calibration 20 takes" "--takes 1" sim:calibration 20
run "takes 4, calibration 20 takes" "--takes 4" sim:calibration 20
run "takes 16, calibration 20 takes" "--takes 16" sim:calibration 20
run "takes 4, calibration 200 takes" "--takes 4" sim:calibration 200
run "takes 16, calibration 200 takes" "--takes 16" sim:calibration 200
run "takes 16, calibration 200, n_phi = 32" "--takes 16 --set nphi=32" \
  "sim:calibration?nphi=32" 200
run "m = 4, takes 4, calibration 20 takes" "--takes 4 --set m=4" "sim:calibration?m=4" 20
/usr/bin/python3 "$root/tools/scripts/corner_tail.py" "$T" "$out" \
  "takes 4, calibration 20 takes" "takes 16, calibration 200 takes" \
  "takes 16, calibration 200, n_phi = 32"
