# The two README commands are `make demo` and `make test`; both install what they need first.
BUILD_DIR ?= build
ASAN_DIR ?= build-asan
JOBS ?= $(shell nproc)
CMAKE_FLAGS ?=
BENCH_ARGS ?=

.PHONY: deps build test test-release test-sanitize demo bench clean

deps:
	bash tools/install_deps.sh

build: deps
	cmake -S . -B $(BUILD_DIR) -G Ninja -DCMAKE_BUILD_TYPE=Release -DTRANSIENT_BUILD_TESTS=OFF $(CMAKE_FLAGS)
	cmake --build $(BUILD_DIR) -j $(JOBS)

# All tests: the Release build, then the same suite under AddressSanitizer + UBSan.
test: deps test-release test-sanitize

test-release:
	cmake -S . -B $(BUILD_DIR) -G Ninja -DCMAKE_BUILD_TYPE=Release -DTRANSIENT_BUILD_TESTS=ON $(CMAKE_FLAGS)
	cmake --build $(BUILD_DIR) -j $(JOBS)
	ctest --test-dir $(BUILD_DIR) --output-on-failure -j $(JOBS)

test-sanitize:
	cmake -S . -B $(ASAN_DIR) -G Ninja -DCMAKE_BUILD_TYPE=Debug -DTRANSIENT_BUILD_TESTS=ON -DTRANSIENT_SANITIZE=ON $(CMAKE_FLAGS)
	cmake --build $(ASAN_DIR) -j $(JOBS)
	ctest --test-dir $(ASAN_DIR) --output-on-failure -j $(JOBS)

# Until the daemon exists: the measurement sequence of the README on the simulated camera
# (mirrors scene, thesis fig. 8.7), then the reconstruction compared with the scene's truth.
TRANSIENT = $(BUILD_DIR)/tools/transient/transient
demo: build
	rm -rf out && mkdir -p out
	$(TRANSIENT) sim mirrors --frames 4 --out out/capture.h5
	$(TRANSIENT) calibrate --source sim:calibration --takes 20 --out out/calibration.h5
	$(TRANSIENT) moments out/capture.h5 --calibration out/calibration.h5 --out out/moments.h5
	$(TRANSIENT) reconstruct out/moments.h5 out/reconstruction.h5 --bins 64
	/usr/bin/python3 tools/scripts/compare_with_truth.py out/capture.h5 out/reconstruction.h5
	@echo "demo: wrote out/capture.h5, out/calibration.h5, out/moments.h5 and out/reconstruction.h5 (transient info FILE describes each; h5py, MATLAB h5read and h5dump open them)"

bench: deps
	cmake -S . -B $(BUILD_DIR) -G Ninja -DCMAKE_BUILD_TYPE=Release -DTRANSIENT_BUILD_BENCHMARKS=ON $(CMAKE_FLAGS)
	cmake --build $(BUILD_DIR) -j $(JOBS) --target transient_bench
	$(BUILD_DIR)/tests/bench/transient_bench $(BENCH_ARGS)

clean:
	rm -rf $(BUILD_DIR) $(ASAN_DIR) out
