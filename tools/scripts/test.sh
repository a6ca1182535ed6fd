#!/usr/bin/env bash
# make test: every test once under AddressSanitizer + UndefinedBehaviorSanitizer, built with
# Clang (its thread-safety analysis checks the ABSL_GUARDED_BY annotations; warnings are errors;
# Debug at -O0 except the code whose tests compute, which is -O1: the top CMakeLists.txt),
# then the tests that need an optimised build (ctest label `release`: the optimized kernels as
# users run them, and the daemon's memory bound measured on resident pages) built with GCC in
# Release. Prints the wall time of each phase and, at the end, all of them together.
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

# -g1: line tables only, so sanitizer reports keep file:line and the build stays fast.
# shellcheck disable=SC2086
phase "configure (Clang, ASan + UBSan)" \
  cmake -S . -B "$asan_dir" -G Ninja -DCMAKE_C_COMPILER=clang-15 -DCMAKE_CXX_COMPILER=clang++-15 \
    -DCMAKE_BUILD_TYPE=Debug -DCMAKE_CXX_FLAGS_DEBUG=-g1 -DCMAKE_C_FLAGS_DEBUG=-g1 \
    -DTRANSIENT_BUILD_TESTS=ON -DTRANSIENT_SANITIZE=ON -DTRANSIENT_WERROR=ON $cmake_flags
phase "build (Clang, ASan + UBSan)" cmake --build "$asan_dir" -j "$jobs"
# OpenMP threads that wait for work sleep instead of spinning (OMP_WAIT_POLICY=passive): two
# tests run at a time on two cores, and a test's spinning team took CPU from the other test
# (docs/tests.md). The release tests keep the default, as users run them.
phase "all tests (ASan + UBSan)" \
  env OMP_WAIT_POLICY=passive \
  ctest --test-dir "$asan_dir" --output-on-failure -j "$jobs" --timeout 600

# shellcheck disable=SC2086
phase "configure (GCC, Release)" \
  cmake -S . -B "$release_dir" -G Ninja -DCMAKE_BUILD_TYPE=Release -DTRANSIENT_BUILD_TESTS=ON \
    $cmake_flags
phase "build the release tests (GCC, Release)" \
  cmake --build "$release_dir" -j "$jobs" --target transient_release_tests
phase "release tests (label release)" \
  ctest --test-dir "$release_dir" --output-on-failure -j "$jobs" -L release --timeout 600

echo "== make test: phases"
for line in "${phases[@]}"; do echo "   $line"; done
printf '   %-44s %4d s\n' "make test" "$(($(date +%s) - total_start))"
