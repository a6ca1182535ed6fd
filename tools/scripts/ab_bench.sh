#!/usr/bin/env bash
# Before/after timing of Google Benchmark binaries on a noisy machine: runs each binary in turn,
# ROUNDS times, each run REPETITIONS repetitions of every benchmark the filter selects, and
# prints per benchmark and binary the least and the median of all its repetitions (ms or the
# benchmark's own time unit). On the 2-core VMs a round's speed swung by up to 25 %; the
# alternation shares that between the binaries and the least is what rounds agree on
# (docs/speed.md, the tenth session). Build the "before" binary first and copy it aside, e.g.
#   cp build/tests/bench/transient_bench /tmp/bench_before   (then change, rebuild)
#   tools/scripts/ab_bench.sh 'BM_MeseRange/m:[348]/optimized:1' 6 /tmp/bench_before \
#     build/tests/bench/transient_bench
#   usage: tools/scripts/ab_bench.sh FILTER ROUNDS BINARY...
#   environment: REPETITIONS (default 5), MIN_TIME (seconds a repetition, default 0.1)
set -euo pipefail

if [[ $# -lt 3 ]]; then
  echo "usage: $0 FILTER ROUNDS BINARY... (Google Benchmark binaries, timed alternately)" >&2
  exit 2
fi
filter=$1
rounds=$2
shift 2
if ! [[ $rounds =~ ^[1-9][0-9]*$ ]]; then
  echo "$0: ROUNDS must be a positive integer, not '$rounds'" >&2
  exit 2
fi
for binary in "$@"; do
  if [[ ! -x $binary ]]; then
    echo "$0: '$binary' is not an executable file" >&2
    exit 2
  fi
done
repetitions=${REPETITIONS:-5}
min_time=${MIN_TIME:-0.1}

results=$(mktemp)
run=$(mktemp)
errors=$(mktemp)
trap 'rm -f "$results" "$run" "$errors"' EXIT
for round in $(seq "$rounds"); do
  for binary in "$@"; do
    echo "round $round/$rounds: $binary" >&2
    if ! "$binary" --benchmark_filter="$filter" --benchmark_min_time="$min_time" \
      --benchmark_repetitions="$repetitions" --benchmark_format=json >"$run" 2>"$errors" ||
      [[ ! -s $run ]]; then
      echo "$0: $binary ran no benchmark for the filter '$filter':" >&2
      cat "$errors" >&2
      exit 1
    fi
    /usr/bin/python3 -c '
import json, sys
for b in json.load(open(sys.argv[2]))["benchmarks"]:
    if b.get("run_type") == "iteration":
        print(sys.argv[1], b["run_name"], b["real_time"], b["time_unit"], sep="\t")
' "$binary" "$run" >>"$results"
  done
done

/usr/bin/python3 - "$results" "$@" <<'PY'
import statistics, sys
path, binaries = sys.argv[1], sys.argv[2:]
times, units = {}, {}
for line in open(path):
    binary, name, time, unit = line.rstrip("\n").split("\t")
    times.setdefault((name, binary), []).append(float(time))
    units[name] = unit
if not times:
    sys.exit("ab_bench.sh: the filter selected no benchmark")
names = sorted({name for name, _ in times})
print("least (median) per binary, " + " | ".join(binaries))
for name in names:
    cells = []
    for binary in binaries:
        t = times.get((name, binary))
        cells.append("-" if not t else f"{min(t):.4g} ({statistics.median(t):.4g}) {units[name]}")
    print(f"{name}: " + " | ".join(cells))
PY
