# The two README commands are `make demo` and `make test`; both install what they need first.
BUILD_DIR ?= build
ASAN_DIR ?= build-asan
JOBS ?= $(shell nproc)
PREFIX ?= /usr/local
CMAKE_FLAGS ?=
BENCH_ARGS ?=

.PHONY: deps build install test demo demo-files pictures eval bench fuzz clean

deps:
	bash tools/install_deps.sh

build: deps
	cmake -S . -B $(BUILD_DIR) -G Ninja -DCMAKE_BUILD_TYPE=Release -DTRANSIENT_BUILD_TESTS=OFF \
	  -DCMAKE_INSTALL_PREFIX=$(PREFIX) $(CMAKE_FLAGS)
	cmake --build $(BUILD_DIR) -j $(JOBS)

# transientd and transient into PREFIX/bin, the generated protocol's shared library into
# PREFIX/lib, the C++ client library with its headers and CMake package (find_package(transient),
# target transient::client; client/README.md), and the OpenNI2 driver into the Drivers folder of
# Debian's libOpenNI2 (openni2/README.md).
install: build
	cmake --install $(BUILD_DIR) --prefix $(PREFIX)

# All tests: those that need an optimised build in GCC Release (in the background while the next
# build runs) and the whole suite once under ASan + UBSan (Clang, thread-safety analysis,
# warnings as errors); prints each phase's time.
test: deps
	JOBS=$(JOBS) CMAKE_FLAGS="$(CMAKE_FLAGS)" bash tools/scripts/test.sh $(ASAN_DIR) $(BUILD_DIR)

TRANSIENT = $(BUILD_DIR)/tools/transient/transient
# The product's main job: transientd on the simulated mirrors scene (thesis fig. 8.7), its live
# viewer in a browser (the URL is printed) and `transient client` for DEMO_SECONDS; out/ gets
# depth, range, slices, the light sweep as MP4 and the client's summary.
DEMO_SECONDS ?= 10
demo: build
	bash tools/scripts/demo.sh $(BUILD_DIR) $(DEMO_SECONDS)

# The file-based measurement sequence of the README (sim -> calibrate -> moments ->
# reconstruct), compared with the scene's truth, into out/files/.
demo-files: build
	rm -rf out/files && mkdir -p out/files
	$(TRANSIENT) sim mirrors --frames 4 --out out/files/capture.h5
	$(TRANSIENT) calibrate --source sim:calibration --takes 20 --out out/files/calibration.h5
	$(TRANSIENT) moments out/files/capture.h5 --calibration out/files/calibration.h5 --out out/files/moments.h5
	$(TRANSIENT) reconstruct out/files/moments.h5 out/files/reconstruction.h5 --bins 64
	/usr/bin/python3 tools/scripts/compare_with_truth.py out/files/capture.h5 out/files/reconstruction.h5
	@echo "demo-files: wrote out/files/{capture,calibration,moments,reconstruction}.h5 (transient info FILE describes each)"

# Every picture kind of `transient view` for the mirrors, corner and video scenes into out/view/.
pictures: build
	bash tools/scripts/view_scenes.sh $(BUILD_DIR) out/view

# The quality benchmark against related methods (thesis fig. 8.12, 8.13) into out/eval/.
eval: build
	$(TRANSIENT) eval --out out/eval

# The libFuzzer harnesses (tests/fuzz, docs/fuzzing.md), each for FUZZ_SECONDS (FUZZ_RUNS caps
# the executions; FUZZ_HARNESSES picks some), in build-fuzz/ (Clang, ASan + UBSan).
FUZZ_SECONDS ?= 60
FUZZ_HARNESSES ?=
fuzz: deps
	RUNS=$(FUZZ_RUNS) bash tools/scripts/fuzz.sh build-fuzz $(FUZZ_SECONDS) $(FUZZ_HARNESSES)

bench: deps
	cmake -S . -B $(BUILD_DIR) -G Ninja -DCMAKE_BUILD_TYPE=Release -DTRANSIENT_BUILD_BENCHMARKS=ON $(CMAKE_FLAGS)
	cmake --build $(BUILD_DIR) -j $(JOBS) --target transient_bench
	$(BUILD_DIR)/tests/bench/transient_bench $(BENCH_ARGS)

clean:
	rm -rf $(BUILD_DIR) $(ASAN_DIR) build-fuzz out
