#!/usr/bin/env bash
# The one-command demo (make demo): transientd on the simulated mirrors scene (thesis fig. 8.7),
# the live viewer in a browser (`transient web`, its URL printed) while `transient client`
# receives depth, range, 64 transient slices and the moment depth map for SECONDS, and the
# light sweep over the wall as an MP4. Everything lands in out/.
#   usage: tools/scripts/demo.sh BUILD_DIR [SECONDS]
set -euo pipefail
build=${1:?usage: demo.sh BUILD_DIR [SECONDS]}
seconds=${2:-5}
transientd="$build/service/transientd"
transient="$build/tools/transient/transient"
out=out
rm -rf "$out" && mkdir -p "$out"

port_file="$out/transientd.port"
"$transientd" --source sim:mirrors --listen 127.0.0.1:0 --port-file "$port_file" \
  --data-dir "$out/data" --stats-interval 2 2> "$out/transientd.log" &
daemon=$!
web=""
stop_daemon() {
  if [[ -n $web ]] && kill -0 "$web" 2> /dev/null; then
    kill -TERM "$web"
    wait "$web" || true
  fi
  if kill -0 "$daemon" 2> /dev/null; then
    kill -TERM "$daemon"
    wait "$daemon" || true
  fi
}
trap stop_daemon EXIT

for _ in $(seq 300); do
  [[ -s "$port_file" ]] && break
  if ! kill -0 "$daemon" 2> /dev/null; then
    echo "demo: transientd exited; its log:" >&2
    cat "$out/transientd.log" >&2
    exit 1
  fi
  sleep 0.1
done
[[ -s "$port_file" ]] || { echo "demo: transientd did not start within 30 s" >&2; exit 1; }
address="127.0.0.1:$(cat "$port_file")"
echo "demo: transientd serves sim:mirrors on $address (log: $out/transientd.log)"

# The live viewer (docs/web.md) on port 8080, or another free one when 8080 is taken.
web_port_file="$out/web.port"
for listen in 127.0.0.1:8080 127.0.0.1:0; do
  rm -f "$web_port_file"
  "$transient" web --connect "$address" --listen "$listen" --port-file "$web_port_file" \
    --url-file "$out/web.url" 2> "$out/web.log" &
  web=$!
  for _ in $(seq 100); do
    [[ -s "$web_port_file" ]] && break
    kill -0 "$web" 2> /dev/null || break
    sleep 0.1
  done
  [[ -s "$web_port_file" ]] && break
  web=""
done
if [[ -n $web ]]; then
  for _ in $(seq 50); do [[ -s "$out/web.url" ]] && break; sleep 0.1; done
  echo "demo: the live viewer is at $(cat "$out/web.url") for the next ${seconds} s" \
    "(make demo DEMO_SECONDS=300 keeps it longer)"
else
  echo "demo: the live viewer did not start; its log: $out/web.log" >&2
fi

# Also the moment depth map (docs/moment_depth_maps.md): the client computes from it how much
# of a virtual plane 1.98 m from the camera the real scene (a wall 1.84 to 2.05 m away) hides.
"$transient" client --connect "$address" --products depth,range,amplitude,slices,moment_depth \
  --bins 64 --moment-near 1.5 --moment-far 2.5 --virtual-plane 1.98 --seconds "$seconds" --out "$out"

# The light sweep: the 64 slices of the last frame, one per video frame (fixed colour scale).
ffmpeg -loglevel error -y -framerate 16 -i "$out/slices/slice_%03d.png" \
  -vf "scale=iw*4:ih*4:flags=neighbor,format=yuv420p" -c:v libx264 "$out/light_sweep.mp4"

stop_daemon
trap - EXIT
echo "demo: wrote $out/depth.png (16-bit millimetres), $out/range.tiff (float metres),"
echo "      $out/slices/slice_NNN.png (64 transient slices), $out/light_sweep.mp4 (the light"
echo "      sweeping over the wall and the mirrors), $out/moment_depth/occlusion_plane.png (a"
echo "      virtual plane at 1.98 m occluded by the scene), $out/summary.json (rate, latency, drops)"
