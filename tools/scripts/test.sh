#!/usr/bin/env bash
# make test: every test once under AddressSanitizer + UndefinedBehaviorSanitizer, built with
# Clang (its thread-safety analysis checks the ABSL_GUARDED_BY annotations; warnings are errors;
# Debug at -O0 except the code whose tests compute, which is -O1: the top CMakeLists.txt), and
# the tests that need an optimised build (ctest label `release`: the optimized kernels as users
# run them, the daemon's memory bound measured on resident pages, the soak run) built with GCC in
# Release. The GCC build comes first, so that its tests run beside the sanitizer build (below).
# Prints the wall time of each phase and, at the end, all of them together.
#   usage: tools/scripts/test.sh [ASAN_DIR] [RELEASE_DIR]
#   environment: JOBS (parallel compiles and release tests; default: the cores), TEST_JOBS (the
#   sanitizer tests at a time; default JOBS + 1), CMAKE_FLAGS (both configures)
set -euo pipefail
cd "$(dirname "$0")/../.."
asan_dir=${1:-build-asan}
release_dir=${2:-build}
jobs=${JOBS:-$(nproc)}
cmake_flags=${CMAKE_FLAGS:-}

phases=()
total_start=$(date +%s)
phase() {
  local name=$1
  shift
  local start
  start=$(date +%s)
  echo "== make test: $name"
  "$@"
  local seconds=$(($(date +%s) - start))
  phases+=("$(printf '%-44s %4d s' "$name" "$seconds")")
  echo "== make test: $name took ${seconds} s"
}

# The release build comes first, so that its tests run beside the sanitizer build instead of
# after everything: most of their time is the soak run (service.soak_short: 45 s of a daemon and
# its subscribers, about 0.4 of a core). The build runs at idle priority (chrt --idle: it takes
# only what the tests leave, so the soak and the memory test, RUN_SERIAL, still have the cores
# they need) and in this session (a session of its own would be an autogroup of its own, which
# the kernel gives an equal share whatever its tasks' policy). docs/tests.md has the figures.
#
# The sanitizer build's configure (one core for 7-15 s, most of it the compilers' checks) runs in
# the background from the start, beside the GCC configure and build, instead of on its own
# between the GCC build and the sanitizer build, where it left a core idle.

# A phase in the background: start_background KEY LOG COMMAND... runs COMMAND with its output in
# LOG, in a process group of its own, so that a phase that fails stops it (with a word on where
# its output is); wait_for_background KEY waits for it, prints LOG and returns its status.
declare -A background_pids background_logs
start_background() {
  local name=$1 log=$2
  shift 2
  echo "== make test: $name starts in the background: $log"
  set -m
  "$@" </dev/null >"$log" 2>&1 &
  background_pids[$name]=$!
  background_logs[$name]=$log
  set +m
}
wait_for_background() {
  local name=$1 status=0
  wait "${background_pids[$name]}" || status=$?
  unset "background_pids[$name]"
  cat "${background_logs[$name]}"
  return "$status"
}
stop_background() {
  local name
  for name in "${!background_pids[@]}"; do
    kill -- "-${background_pids[$name]}" 2>/dev/null || true
    echo "== make test: stopped $name; what it printed until then: ${background_logs[$name]}"
  done
}
trap stop_background EXIT

# -g1: line tables only, so sanitizer reports keep file:line and the build stays fast.
mkdir -p "$asan_dir"
# shellcheck disable=SC2086
start_background sanitizer-configure "$asan_dir/configure.log" \
  cmake -S . -B "$asan_dir" -G Ninja -DCMAKE_C_COMPILER=clang-15 -DCMAKE_CXX_COMPILER=clang++-15 \
    -DCMAKE_BUILD_TYPE=Debug -DCMAKE_CXX_FLAGS_DEBUG=-g1 -DCMAKE_C_FLAGS_DEBUG=-g1 \
    -DTRANSIENT_BUILD_TESTS=ON -DTRANSIENT_SANITIZE=ON -DTRANSIENT_WERROR=ON $cmake_flags

# shellcheck disable=SC2086
phase "configure (GCC, Release)" \
  cmake -S . -B "$release_dir" -G Ninja -DCMAKE_BUILD_TYPE=Release -DTRANSIENT_BUILD_TESTS=ON \
    $cmake_flags
phase "build the release tests (GCC, Release)" \
  cmake --build "$release_dir" -j "$jobs" --target transient_release_tests

start_background release-tests "$release_dir/release-tests.log" \
  ctest --test-dir "$release_dir" --output-on-failure -j "$jobs" -L release --timeout 600

phase "configure (Clang, ASan + UBSan): the rest" \
  wait_for_background sanitizer-configure
phase "build (Clang, ASan + UBSan), idle priority" \
  chrt --idle 0 cmake --build "$asan_dir" -j "$jobs"
phase "release tests (label release): the rest" \
  wait_for_background release-tests
# OpenMP threads that wait for work sleep instead of spinning (OMP_WAIT_POLICY=passive): several
# tests run at a time, and a test's spinning team took CPU from the others (docs/tests.md). The
# release tests keep the default, as users run them. One test more than there are cores: with
# as many as cores the phase kept them 76-80 % busy (its tests wait on child processes, sockets
# and timers), with one more 88 %, and took 161-168 s instead of 186 s (docs/tests.md).
test_jobs=${TEST_JOBS:-$((jobs + 1))}
phase "all tests (ASan + UBSan)" \
  env OMP_WAIT_POLICY=passive \
  ctest --test-dir "$asan_dir" --output-on-failure -j "$test_jobs" --timeout 600

echo "== make test: phases"
for line in "${phases[@]}"; do echo "   $line"; done
printf '   %-44s %4d s\n' "make test" "$(($(date +%s) - total_start))"
