#!/usr/bin/env bash
# Frames through NATS JetStream next to the gRPC path (README, "Many cameras, many machines"):
# a real nats-server on loopback (JetStream on, file store, the default 1 MB max_payload),
# transientd --publish MOMENT_STATE, and two `transient client`s at once for the same seconds:
# one over gRPC, one from NATS (--nats). Prints per case and transport: frames/s received, MB/s
# of MOMENT_STATE (as float32 planes), latency p50 / p99 (end of the frame's capture -> the
# client), frames missed.
#   usage: tools/scripts/bench_nats.sh BUILD_DIR [SECONDS]
set -euo pipefail
build=${1:?usage: bench_nats.sh BUILD_DIR [SECONDS]}
seconds=${2:-10}
work=$(mktemp -d)
nats_pid=
cleanup() {
  [[ -n $nats_pid ]] && kill "$nats_pid" 2> /dev/null && wait "$nats_pid" 2> /dev/null
  rm -rf "$work"
}
trap cleanup EXIT
transient=$build/tools/transient/transient

port=$(/usr/bin/python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])')
nats-server -a 127.0.0.1 -p "$port" -js -sd "$work/store" > "$work/nats.log" 2>&1 &
nats_pid=$!
for _ in $(seq 100); do (exec 3<> "/dev/tcp/127.0.0.1/$port") 2> /dev/null && break; sleep 0.1; done
url=nats://127.0.0.1:$port

report() {  # case transport summary.json
  /usr/bin/python3 - "$@" <<'PY'
import json, sys
name, transport, path = sys.argv[1:]
s = json.load(open(path))
planes = sum(1 for f in s["files"] if f.startswith("moment_state/"))
mb = planes * s["camera"]["width"] * s["camera"]["height"] * 4 / 1e6
lat = s["latency_ms"]
print(f"{name:26s} {transport:5s} {s['rate_hz']:6.1f} frames/s {s['rate_hz'] * mb:7.1f} MB/s "
      f"({mb:.2f} MB a frame)  latency p50 {lat['p50']:6.1f} ms  p99 {lat['p99']:6.1f} ms  "
      f"missed {s['frames_missed']}")
PY
}

run_case() {  # name camera source [more transientd options]
  local name=$1 camera=$2 source=$3
  shift 3
  rm -f "$work/port"
  "$build/service/transientd" --source "$source" --listen 127.0.0.1:0 --port-file "$work/port" \
    --data-dir "$work/data" --stats-interval 1000 --publish "$url" --nats-camera "$camera" "$@" \
    2> "$work/$camera.log" &
  local daemon=$!
  for _ in $(seq 600); do [[ -s "$work/port" ]] && break; sleep 0.1; done
  "$transient" client --connect "127.0.0.1:$(cat "$work/port")" --products moment_state \
    --seconds "$seconds" --out "$work/$camera-grpc" > /dev/null &
  local grpc=$!
  "$transient" client --nats "$url" --nats-camera "$camera" --products moment_state \
    --seconds "$seconds" --out "$work/$camera-nats" > /dev/null
  wait "$grpc"
  kill -TERM "$daemon"
  wait "$daemon"
  report "$name" gRPC "$work/$camera-grpc/summary.json"
  report "$name" NATS "$work/$camera-nats/summary.json"
}

echo "MOMENT_STATE over gRPC and NATS JetStream at once, $(nproc) cores, ${seconds} s per case"
run_case "163x120 m=3 camera rate" small "sim:mirrors"
"$transient" sim mirrors --out "$work/vga.h5" --frames 30 --width 640 --height 480 --m 3 \
  --deflate 0 > /dev/null
run_case "640x480 m=3 fast replay" vga "replay:$work/vga.h5?loop=1&pace=fast"
# The same with the NATS side in half floats (the gRPC client still asks for float32; MB/s
# counts float32 planes for both).
run_case "640x480 NATS float16" vga16 "replay:$work/vga.h5?loop=1&pace=fast" \
  --nats-encoding float16
