#!/usr/bin/env bash
# Installs every Debian 12 package that building, testing and the demo need (openssl makes the
# security tests' certificates; util-linux's unshare gives the full-disk test its own tmpfs;
# Boost.Beast serves the web viewer, Chromium with Node.js runs its browser tests, nats-server
# and cnats carry frames between machines and test that), then the
# browser tests' npm packages from tests/web/package-lock.json (npm ci: playwright-core, which
# drives Debian's Chromium and downloads no browser).
# lld links the programs (faster than GNU ld: docs/tests.md).
# Idempotent: apt-get skips what is already there. Uses sudo when not root.
set -euo pipefail

packages=(
  cmake ninja-build g++ pkg-config
  clang-15 libomp-15-dev llvm-15 lld
  libhdf5-dev hdf5-tools
  libeigen3-dev libabsl-dev libcli11-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  libgrpc++-dev protobuf-compiler-grpc libprotobuf-dev protobuf-compiler
  libzstd-dev libpng-dev libtiff-dev ffmpeg
  libglpk-dev
  libumockdev-dev umockdev libusb-1.0-0-dev libopenni2-dev
  libopencv-core-dev libopencv-imgproc-dev libopencv-imgcodecs-dev libopencv-videoio-dev
  libegl-dev libgles-dev libegl-mesa0 libgl1-mesa-dri
  python3 python3-numpy python3-h5py python3-grpcio python3-protobuf python3-zstandard
  openssl util-linux libfuzzer-15-dev
  libboost-dev chromium
  nats-server libnats-dev
)
# Node.js and npm: Debian's, unless the machine has its own (NodeSource's nodejs carries npm and
# conflicts with Debian's npm package).
command -v node > /dev/null || packages+=(nodejs)
command -v npm > /dev/null || packages+=(npm)

sudo_cmd=()
if [[ $(id -u) -ne 0 ]]; then
  sudo_cmd=(sudo)
fi

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [[ ${#missing[@]} -eq 0 ]]; then
  echo "deps: all ${#packages[@]} packages already installed"
else
  echo "deps: installing ${missing[*]}"
  "${sudo_cmd[@]}" apt-get update -qq
  DEBIAN_FRONTEND=noninteractive "${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi

# The browser tests' packages, pinned by the lock file; again only when it changed.
web=$(cd "$(dirname "$0")/../tests/web" && pwd)
if [[ ! -f $web/node_modules/.package-lock.json || $web/package-lock.json -nt $web/node_modules/.package-lock.json ]]; then
  echo "deps: npm ci in tests/web (playwright-core)"
  npm ci --prefix "$web" --no-audit --no-fund --ignore-scripts --loglevel=error
else
  echo "deps: tests/web/node_modules is up to date"
fi
