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

# Until the daemon exists: reconstruct the example moment file and say where the result is.
demo: build
	mkdir -p out
	$(BUILD_DIR)/tools/transient/transient reconstruct tests/data/example_moments.h5 out/example_reconstruction.h5
	@echo "demo: wrote out/example_reconstruction.h5 (open it with h5py, MATLAB h5read or h5dump)"

bench: deps
	cmake -S . -B $(BUILD_DIR) -G Ninja -DCMAKE_BUILD_TYPE=Release -DTRANSIENT_BUILD_BENCHMARKS=ON $(CMAKE_FLAGS)
	cmake --build $(BUILD_DIR) -j $(JOBS) --target transient_bench
	$(BUILD_DIR)/tests/bench/transient_bench $(BENCH_ARGS)

clean:
	rm -rf $(BUILD_DIR) $(ASAN_DIR) out
