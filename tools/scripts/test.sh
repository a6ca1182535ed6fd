#!/usr/bin/env bash
# make test: every test once under AddressSanitizer + UndefinedBehaviorSanitizer, built with
# Clang (its thread-safety analysis checks the ABSL_GUARDED_BY annotations; warnings are errors;
# Debug at -O0 except the code whose tests compute, which is -O1: the top CMakeLists.txt),
# then the tests that need an optimised build (ctest label `release`: the optimized kernels as
# users run them, and the daemon's memory bound measured on resident pages) built with GCC in
# Release. Prints the wall time of each phase and, at the end, all of them together.
# The GCC build runs beside the sanitizer phases at idle priority (SCHED_IDLE): it takes only the
# CPU that the sanitizer build and tests leave unused (the tests wait on daemons, sockets and
# browsers), and the sanitizer phases run as fast as they would alone (docs/tests.md).
#   usage: tools/scripts/test.sh [ASAN_DIR] [RELEASE_DIR]
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

# The GCC Release build of the release tests, in the background at idle priority, its output in
# RELEASE_DIR/make_test_build.log (its end printed if it fails). A process group of its own (set -m)
# so that an early exit stops all of it, but not a session of its own: the kernel's autogroups
# share the CPU between sessions, and a build in a session of its own took half of it.
mkdir -p "$release_dir"
release_log="$release_dir/make_test_build.log"
idle=(chrt --idle 0)
"${idle[@]}" true 2>/dev/null || idle=(nice -n 19)
release_start=$(date +%s)
set -m
# shellcheck disable=SC2016  # the inner script's arguments, expanded by the inner shell
"${idle[@]}" bash -c '
  set -e
  cmake -S . -B "$1" -G Ninja -DCMAKE_BUILD_TYPE=Release -DTRANSIENT_BUILD_TESTS=ON $3
  cmake --build "$1" -j "$2" --target transient_release_tests
  echo "== make test: the GCC build of the release tests took $(($(date +%s) - $4)) s"' \
  release-build "$release_dir" "$jobs" "$cmake_flags" "$release_start" < /dev/null \
  > "$release_log" 2>&1 &
release_pid=$!
set +m
trap 'kill -- -"$release_pid" 2>/dev/null || true' EXIT
echo "== make test: the GCC build of the release tests started at idle priority (log: $release_log)"

# -g1: line tables only, so sanitizer reports keep file:line and the build stays fast.
# shellcheck disable=SC2086
phase "configure (Clang, ASan + UBSan)" \
  cmake -S . -B "$asan_dir" -G Ninja -DCMAKE_C_COMPILER=clang-15 -DCMAKE_CXX_COMPILER=clang++-15 \
    -DCMAKE_BUILD_TYPE=Debug -DCMAKE_CXX_FLAGS_DEBUG=-g1 -DCMAKE_C_FLAGS_DEBUG=-g1 \
    -DTRANSIENT_BUILD_TESTS=ON -DTRANSIENT_SANITIZE=ON -DTRANSIENT_WERROR=ON $cmake_flags
phase "build (Clang, ASan + UBSan)" cmake --build "$asan_dir" -j "$jobs"
# OpenMP threads that wait for work sleep instead of spinning (OMP_WAIT_POLICY=passive): two
# tests run at a time on two cores, and a spinning team took CPU from the other test (about a
# fifth of the phase's CPU, docs/tests.md). The release tests keep the default, as users run.
phase "all tests (ASan + UBSan)" \
  env OMP_WAIT_POLICY=passive \
  ctest --test-dir "$asan_dir" --output-on-failure -j "$jobs" --timeout 600

wait_release_build() {
  local status=0
  wait "$release_pid" || status=$?
  trap - EXIT
  if ((status == 0)); then
    tail -n 1 "$release_log"
  else
    tail -n 60 "$release_log"
    echo "== make test: the GCC build of the release tests failed (exit $status): $release_log"
    return "$status"
  fi
}
phase "the rest of the GCC build (Release)" wait_release_build
phase "release tests (label release)" \
  ctest --test-dir "$release_dir" --output-on-failure -j "$jobs" -L release --timeout 600

echo "== make test: phases"
for line in "${phases[@]}"; do echo "   $line"; done
printf '   %-44s %4d s\n' "make test" "$(($(date +%s) - total_start))"
