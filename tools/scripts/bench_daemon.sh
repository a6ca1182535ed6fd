#!/usr/bin/env bash
# End-to-end speed of transientd (the issue's targets): the simulated camera as fast as it can
# produce, the daemon reconstructing, `transient client` receiving over loopback gRPC. Prints
# one line per case from the client's summary.json: frames/s received, latency percentiles
# (last raw frame of a cycle -> client), frames missed by the client, cycles the daemon dropped.
#   usage: tools/scripts/bench_daemon.sh BUILD_DIR [SECONDS]
set -euo pipefail
build=${1:?usage: bench_daemon.sh BUILD_DIR [SECONDS]}
seconds=${2:-10}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

daemon_args=()  # more transientd options for the next case
run_case() {  # name source products [client options...]
  local name=$1 source=$2 products=$3
  shift 3
  rm -f "$work/port"
  "$build/service/transientd" --source "$source" --listen 127.0.0.1:0 --port-file "$work/port" \
    --stats-interval 1000 "${daemon_args[@]}" 2> "$work/$name.log" &
  local daemon=$!
  for _ in $(seq 600); do [[ -s "$work/port" ]] && break; sleep 0.1; done
  "$build/tools/transient/transient" client --connect "127.0.0.1:$(cat "$work/port")" \
    --products "$products" --seconds "$seconds" --out "$work/$name" "$@" > /dev/null
  kill -TERM "$daemon"
  wait "$daemon"
  /usr/bin/python3 - "$name" "$source" "$products" "$work/$name/summary.json" <<'PY'
import json, sys
name, source, products, path = sys.argv[1:]
s = json.load(open(path))
lat = s["latency_ms"]
print(f"{name:28s} {s['rate_hz']:7.1f} frames/s  latency p50 {lat['p50']:6.1f} ms  "
      f"p99 {lat['p99']:6.1f} ms  missed {s['frames_missed']}  ({source}; {products})")
PY
}

echo "transientd end to end, $(nproc) cores, ${seconds} s per case"
run_case "163x120 m=3 realtime" "sim:mirrors" "range,slices" --bins 64
run_case "163x120 m=3 fast camera" "sim:mirrors?pace=fast" "range,slices" --bins 64
run_case "640x480 m=4 fast camera" "sim:mirrors?width=640&height=480&m=4&pace=fast" \
  "range,amplitude"
# The same camera at a real camera's rate, paced: exposure 0.5 ms + readout 1.3 ms a raw frame,
# 18 raw frames in 32.4 ms (30.9 frames/s). The fast camera above makes frames as fast as the
# simulator can, on the cores the daemon needs, and the daemon drops those it has no time for.
run_case "640x480 m=4 camera 30 Hz" \
  "sim:mirrors?width=640&height=480&m=4&exposure=0.5e-3&readout=1.3e-3" "range,amplitude"
# The daemon alone at the resolutions of real cameras: a recorded capture replayed as fast as
# the daemon takes it (the simulator is not on the cores while the daemon runs).
"$build/tools/transient/transient" sim mirrors --out "$work/vga.h5" --frames 30 --width 640 \
  --height 480 --m 4 --deflate 0 > /dev/null
run_case "640x480 m=4 fast replay" "replay:$work/vga.h5?loop=1&pace=fast" "range"
# The same capture corrected by a calibration, as a real camera's would be: the corrected moments
# of a sparse scene lie on the boundary of the moment set, and most pixels need biasing.
"$build/tools/transient/transient" calibrate --out "$work/vga-calibration.h5" \
  --source "sim:calibration?width=640&height=480&m=4&pace=fast" > /dev/null
daemon_args=(--calibration "$work/vga-calibration.h5")
run_case "640x480 m=4 calibrated replay" "replay:$work/vga.h5?loop=1&pace=fast" "range"
daemon_args=()
"$build/tools/transient/transient" sim mirrors --out "$work/kinect.h5" --frames 30 \
  --set camera=kinect2 --deflate 0 > /dev/null
run_case "512x424 Kinect v2 fast replay" "replay:$work/kinect.h5?loop=1&pace=fast" "depth"
# Pisarenko's first return as the range (range_method = pisarenko) at VGA, m = 3.
"$build/tools/transient/transient" sim mirrors --out "$work/vga3.h5" --frames 30 --width 640 \
  --height 480 --m 3 --deflate 0 > /dev/null
echo "range_method = pisarenko" > "$work/pisarenko.conf"
daemon_args=(--config "$work/pisarenko.conf")
run_case "640x480 m=3 Pisarenko replay" "replay:$work/vga3.h5?loop=1&pace=fast" "range"
daemon_args=()
