#!/usr/bin/env bash
# make fuzz: builds the libFuzzer harnesses of tests/fuzz (Clang 15, ASan + UBSan, coverage of
# the project's code) into BUILD_DIR and runs each for SECONDS (or RUNS executions), on a working
# copy of its committed corpus (BUILD_DIR/corpus/NAME: what libFuzzer finds is kept there, the
# committed seeds stay small). Crashes go to BUILD_DIR/crashes/NAME-*; a crash makes the run fail.
# Prints each harness's executions, rate and coverage (libFuzzer's final stats) and a summary.
#   usage: tools/scripts/fuzz.sh BUILD_DIR SECONDS [HARNESS...]
#   RUNS=1000000 tools/scripts/fuzz.sh build-fuzz 3600 config   # a million executions at most
set -euo pipefail
build=${1:?usage: fuzz.sh BUILD_DIR SECONDS [HARNESS...]}
seconds=${2:?usage: fuzz.sh BUILD_DIR SECONDS [HARNESS...]}
shift 2
harnesses=("$@")
if [[ ${#harnesses[@]} -eq 0 ]]; then
  harnesses=(config source_uri data_dir image_codec v4l2 kinect2 rpc hdf5 page_request)
fi
root=$(cd "$(dirname "$0")/../.." && pwd)

# SKIP_BUILD=1: the harnesses are built already (two runs of this script side by side).
if [[ -z ${SKIP_BUILD:-} ]]; then
mkdir -p "$build"
cmake -S "$root" -B "$build" -G Ninja -DCMAKE_C_COMPILER=clang-15 -DCMAKE_CXX_COMPILER=clang++-15 \
  -DCMAKE_BUILD_TYPE=RelWithDebInfo -DTRANSIENT_BUILD_TESTS=OFF -DTRANSIENT_SANITIZE=ON \
  -DTRANSIENT_FUZZ=ON > "$build/configure.log" 2>&1 || { cat "$build/configure.log"; exit 1; }
cmake --build "$build" -j "${JOBS:-$(nproc)}" --target "${harnesses[@]/#/transient_fuzz_}"
fi

mkdir -p "$build/crashes"
status=0
summary=()
for name in "${harnesses[@]}"; do
  corpus="$build/corpus/$name"
  mkdir -p "$corpus"
  cp -n "$root/tests/fuzz/corpus/$name"/* "$corpus"/ 2>/dev/null || true
  log="$build/$name.log"
  echo "fuzz: $name for ${seconds} s${RUNS:+ or $RUNS runs} (log: $log)"
  args=(-max_total_time="$seconds" -print_final_stats=1 -artifact_prefix="$build/crashes/$name-"
        -rss_limit_mb=4096 -timeout=30)
  [[ -n ${RUNS:-} ]] && args+=(-runs="$RUNS")
  # HDF5 1.10.8 leaks inside itself on corrupt metadata (tests/formats/lsan.supp): not a finding.
  # It also crashes and hangs on corrupt files (docs/fuzzing.md, contained there): the hdf5
  # harness runs in fork mode, which records each crash, hang and out-of-memory in crashes/ and
  # goes on. A hang costs its job the timeout: 3 s, where a file of the corpus takes 13 ms.
  lsan=""
  if [[ $name == hdf5 ]]; then
    lsan="suppressions=$root/tests/formats/lsan.supp"
    args+=(-fork=1 -ignore_crashes=1 -ignore_timeouts=1 -ignore_ooms=1 -timeout=3)
  fi
  if ! LSAN_OPTIONS=$lsan "$build/tests/fuzz/transient_fuzz_$name" "${args[@]}" "$corpus" \
      > "$log" 2>&1; then
    status=1
    echo "fuzz: $name FOUND A CRASH: $(ls "$build/crashes/$name-"* 2>/dev/null | tr '\n' ' ')"
    grep -m3 -E "ERROR|SUMMARY|runtime error" "$log" || true
  fi
  if [[ $name == hdf5 ]]; then
    found=$(grep -aoP 'oom/timeout/crash: \K[0-9]+/[0-9]+/[0-9]+' "$log" | tail -1 || true)
    echo "fuzz: hdf5 out-of-memory/timeout/crash ${found:-0/0/0}, each inside HDF5 so far" \
      "(docs/fuzzing.md; inputs in $build/crashes/hdf5-*): check a new one's stack"
  fi
  execs=$(grep -oP 'stat::number_of_executed_units:\s+\K[0-9]+' "$log" ||
          grep -aoP '^#[0-9]+: cov: .* exec/s: [0-9]+ .*' "$log" | tail -1 | grep -oP '^#\K[0-9]+' ||
          echo "?")
  rate=$(grep -oP 'stat::average_exec_per_sec:\s+\K[0-9]+' "$log" || echo "?")
  cov=$(grep -oP '^#[0-9]+\s+(DONE|INITED).*?cov: \K[0-9]+' "$log" | tail -1 || echo "?")
  ft=$(grep -oP '^#[0-9]+\s+(DONE|INITED).*?ft: \K[0-9]+' "$log" | tail -1 || echo "?")
  units=$(ls "$corpus" | wc -l)
  summary+=("$(printf '%-12s %12s executions %8s/s  coverage %6s edges %7s features  corpus %5s' \
    "$name" "$execs" "$rate" "$cov" "$ft" "$units")")
done
printf '%s\n' "fuzz: summary" "${summary[@]}"
exit $status
