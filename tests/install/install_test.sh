#!/usr/bin/env bash
# The installed copy works for a user: installs the build's development component into a
# temporary prefix, checks that nothing installed points back into the build or source tree,
# builds tests/install/consumer against it with find_package(transient) (same compiler and
# flags as the build), starts the built transientd on a free loopback port and runs the
# consumer, which streams DEPTH and checks it. Prints the seconds each step took.
#   usage: install_test.sh BUILD_DIR SOURCE_DIR TRANSIENTD CXX BUILD_TYPE CXX_FLAGS
#          CXX_FLAGS_OF_BUILD_TYPE LINKER_FLAGS [LAUNCHER]
set -euo pipefail
build_dir=$1 source_dir=$2 transientd=$3 cxx=$4 build_type=$5 cxx_flags=$6
cxx_flags_config=$7 linker_flags=$8 launcher=${9:-}

work=$(mktemp -d "${TMPDIR:-/tmp}/transient-install-test.XXXXXX")
daemon_pid=
cleanup() {
  if [[ -n $daemon_pid ]]; then
    kill -TERM "$daemon_pid" 2>/dev/null || true
    wait "$daemon_pid" 2>/dev/null || true
  fi
  rm -rf "$work"
}
trap cleanup EXIT

step_start=$(date +%s)
step() {
  local now
  now=$(date +%s)
  echo "install_test: $1 ($((now - step_start)) s)"
  step_start=$now
}

prefix=$work/prefix
cmake --install "$build_dir" --prefix "$prefix" --component development >"$work/install.log"
for header in client/client.h client/frame_stream.h client/decoded_image.h \
              wire/product_registry.h v1/transient.pb.h v1/transient.grpc.pb.h \
              reconstruct/units.h; do
  [[ -f $prefix/include/transient/$header ]] || { echo "not installed: $header"; exit 1; }
done
# A package that refers to the build or the source tree works here and nowhere else (the
# libraries' debug information may name them; the package files and headers may not).
if grep -rlF --include='*.cmake' --include='*.h' --include='*.proto' \
     -e "$(realpath "$build_dir")" -e "$(realpath "$source_dir")" "$prefix"; then
  echo "install_test: the installed files above name the build or source directory"
  exit 1
fi
step "installed into $prefix"

launcher_flag=()
[[ -n $launcher ]] && launcher_flag=("-DCMAKE_CXX_COMPILER_LAUNCHER=$launcher")
upper_type=$(echo "$build_type" | tr '[:lower:]' '[:upper:]')
cmake -S "$source_dir/tests/install/consumer" -B "$work/consumer" -G Ninja \
  -DCMAKE_CXX_COMPILER="$cxx" -DCMAKE_BUILD_TYPE="$build_type" \
  -DCMAKE_CXX_FLAGS="$cxx_flags" "-DCMAKE_CXX_FLAGS_${upper_type}=$cxx_flags_config" \
  -DCMAKE_EXE_LINKER_FLAGS="$linker_flags" -DCMAKE_PREFIX_PATH="$prefix" \
  "${launcher_flag[@]}" >"$work/configure.log" || { cat "$work/configure.log"; exit 1; }
step "configured the consumer with find_package(transient)"
cmake --build "$work/consumer" >"$work/build.log" || { cat "$work/build.log"; exit 1; }
step "built the consumer"

port_file=$work/port
"$transientd" --listen 127.0.0.1:0 --port-file "$port_file" \
  --source 'sim:mirrors?width=48&height=36&pace=fast' 2>"$work/transientd.log" &
daemon_pid=$!
for _ in $(seq 300); do
  [[ -s $port_file ]] && break
  kill -0 "$daemon_pid" 2>/dev/null || { cat "$work/transientd.log"; exit 1; }
  sleep 0.1
done
[[ -s $port_file ]] || { echo "transientd wrote no port file in 30 s"; exit 1; }
step "transientd listens on port $(cat "$port_file")"
"$work/consumer/depth_check" "127.0.0.1:$(cat "$port_file")"
step "the consumer streamed and checked depth"
