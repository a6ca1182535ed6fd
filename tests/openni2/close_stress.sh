#!/usr/bin/env bash
# Closing OpenNI2 recordings again and again on a busy machine, to count the crashes of OpenNI2's
# file player that openni2/include/transient/openni2/close_device.h keeps clear of (openni2/
# README.md has the rates). Not part of `make test`: each run is a few hundred processes.
#
#   tests/openni2/close_stress.sh BUILD_DIR play|daemon RUNS [BUSY]
#
# Records a 5-frame .oni of transientd's simulated camera with OpenNI2's Recorder
# (openni_only_reader record), then RUNS times:
#   play    openni_only_reader plays it in manual mode to its end and closes it;
#   daemon  transientd --source openni2:FILE?pace=fast serves it to `transient client` until the
#           recording ends, where the pipeline closes the source, then stops on SIGTERM.
# BUSY (default 2) busy loops run beside it. Prints each failed run's exit status (139: SIGSEGV in
# a build without the sanitizers, 1 under them) and the count; exits 1 when any run failed.
set -euo pipefail
usage="usage: close_stress.sh BUILD_DIR play|daemon RUNS [BUSY]"
build=$(realpath "${1:?$usage}")
mode=${2:?$usage}
runs=${3:?$usage}
busy=${4:-2}
[[ $mode == play || $mode == daemon ]] || { echo "close_stress.sh: play or daemon, not $mode" >&2; exit 2; }
[[ $runs =~ ^[1-9][0-9]*$ && $busy =~ ^[0-9]+$ ]] || { echo "$usage" >&2; exit 2; }
reader=$build/tests/openni2/openni_only_reader
transientd=$build/service/transientd
transient=$build/tools/transient/transient
openni_env=(env -u TRANSIENT_OPENNI2_DISABLE "LD_LIBRARY_PATH=$build/openni2-runtime")

work=$(mktemp -d)
pids=()
daemon_pid=
cleanup() {
  for pid in "${pids[@]}" $daemon_pid; do kill -KILL "$pid" 2>/dev/null || true; done
  rm -rf "$work"
}
trap cleanup EXIT

# transientd on port 0, in the background (daemon_pid), once its port file names the port.
start_daemon() {
  local source=$1 port_file=$2 log=$3
  rm -f "$port_file"
  "${openni_env[@]}" "$transientd" --source "$source" --listen 127.0.0.1:0 \
    --port-file "$port_file" --data-dir "$work/data" 2>"$log" &
  daemon_pid=$!
  for _ in $(seq 200); do
    [[ -s $port_file ]] && return 0
    kill -0 "$daemon_pid" 2>/dev/null || break
    sleep 0.05
  done
  echo "close_stress.sh: transientd did not start: $(cat "$log")" >&2
  exit 1
}

# SIGTERM to the daemon, SIGKILL after 10 s (a daemon hung while closing counts as failed);
# returns its exit status.
stop_daemon() {
  local status=0
  kill "$daemon_pid" 2>/dev/null || true
  for _ in $(seq 200); do
    kill -0 "$daemon_pid" 2>/dev/null || break
    sleep 0.05
  done
  if kill -0 "$daemon_pid" 2>/dev/null; then
    echo "close_stress.sh: transientd did not stop within 10 s of SIGTERM" >&2
    kill -KILL "$daemon_pid" 2>/dev/null || true
  fi
  wait "$daemon_pid" || status=$?
  daemon_pid=
  return "$status"
}

start_daemon "sim:mirrors?width=80&height=60" "$work/sim.port" "$work/sim.log"
"${openni_env[@]}" "$reader" record "transient://127.0.0.1:$(cat "$work/sim.port")" 5 \
  "$work/x.oni" >/dev/null
stop_daemon || true

for _ in $(seq "$busy"); do
  (while :; do :; done) &
  pids+=($!)
  disown  # no job message when cleanup kills it
done

failed=0
for run in $(seq "$runs"); do
  status=0
  if [[ $mode == play ]]; then
    "${openni_env[@]}" "$reader" play "$work/x.oni" "$work/played.bin" >/dev/null \
      2>"$work/run.log" || status=$?
  else
    start_daemon "openni2:$work/x.oni?pace=fast" "$work/replay.port" "$work/run.log"
    "$transient" client --connect "127.0.0.1:$(cat "$work/replay.port")" --products depth \
      --frames 5 --out "$work/client" >/dev/null 2>&1 || true
    for _ in $(seq 100); do grep -q "ended" "$work/run.log" && break; sleep 0.02; done
    stop_daemon || status=$?
  fi
  if ((status != 0)); then
    failed=$((failed + 1))
    echo "run $run: exit status $status; $(tail -n 2 "$work/run.log" | tr '\n' ' ')"
  fi
done
echo "close_stress.sh $mode: $failed of $runs runs failed ($busy busy loops beside)"
((failed == 0))
