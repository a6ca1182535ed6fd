#!/usr/bin/env bash
# The daemon's soak and fault run (issue 18; docs/daemon.md "Soak run"): transientd on a
# simulated camera that is unplugged every UNPLUG_EVERY seconds for UNPLUG_FOR, 20 subscribers
# (14 keeping up, 3 stalling, 3 reconnecting), recordings, calibrations, SetConfig changes, bad
# requests and raw garbage mixed in, for MINUTES. Prints resident memory, descriptors and
# threads as it goes and a table per subscriber at the end; exits 1 if a subscriber that kept
# up lost a frame, if memory or descriptors grew, or if a call did not end as it should
# (tools/scripts/soak.py says exactly what is checked). The report (soak.json, samples.csv,
# soak.svg) goes to OUT_DIR.
#   usage: tools/scripts/soak.sh MINUTES [BUILD_DIR] [OUT_DIR]
#   e.g.:  tools/scripts/soak.sh 60 build out/soak
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
minutes=${1:?usage: soak.sh MINUTES [BUILD_DIR] [OUT_DIR]}
build=$(cd "${2:-$root/build}" && pwd)
out=${3:-$root/out/soak}
transientd=$build/service/transientd
if [[ ! -x $transientd ]]; then
  echo "soak.sh: $transientd is missing; build it first (make build, or cmake --build $build)" >&2
  exit 2
fi
rm -rf "$out"
mkdir -p "$out"
export PYTHONPATH="$root/tools/python:$build/proto/python:$root/tests/python${PYTHONPATH:+:$PYTHONPATH}"
exec /usr/bin/python3 "$root/tools/scripts/soak.py" --minutes "$minutes" --transientd "$transientd" \
  --out "$out" --unplug-every "${UNPLUG_EVERY:-60}" --unplug-for "${UNPLUG_FOR:-5}" \
  --sample-interval "${SAMPLE_INTERVAL:-1}" --print-every "${PRINT_EVERY:-60}"
