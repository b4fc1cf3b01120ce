# crop4d — the two commands a newcomer needs are `make demo` and `make test`.
# Both install missing Debian packages first (scripts/install-deps.sh), then build.

PRESET ?= release
BUILD_DIR := build/$(PRESET)
CROP4D := $(BUILD_DIR)/crop4d
DEMO_DIR ?= demo
JOBS ?= $(shell nproc)
FUZZ_SECONDS ?= 60

.PHONY: all deps configure build test demo bench fuzz asan asan-unit format clean

all: build

deps:
	@bash scripts/install-deps.sh

$(BUILD_DIR)/build.ninja:
	cmake --preset $(PRESET)

configure: deps $(BUILD_DIR)/build.ninja

build: configure
	cmake --build --preset $(PRESET) -j $(JOBS)

test: build
	ctest --preset $(PRESET) -j $(JOBS)

# The main job on the embedded demo field: everything that exists so far.
demo: build
	bash scripts/demo.sh $(CROP4D) $(DEMO_DIR)

bench: build
	bash bench/run_all.sh $(BUILD_DIR)

# The whole suite under AddressSanitizer + UndefinedBehaviorSanitizer (build/asan).
asan:
	$(MAKE) test PRESET=asan

# Only the unit tests (ctest label `unit`) under the sanitizers, as .ci/run does.
asan-unit: deps
	bash scripts/sanitize-unit-tests.sh $(JOBS)

fuzz: deps
	cmake --preset fuzz && cmake --build --preset fuzz -j $(JOBS) --target crop4d_csv_fuzzer crop4d_yaml_fuzzer
	bash scripts/run-fuzzers.sh build/fuzz $(FUZZ_SECONDS)

format:
	find src bench -name '*.cc' -o -name '*.h' | xargs clang-format -i

clean:
	rm -rf build
