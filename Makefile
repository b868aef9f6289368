# SPDX-License-Identifier: Apache-2.0
# The README's two commands: `make train` and `make test`.
# Both install missing Debian packages, configure (Release unless BUILD_TYPE says otherwise)
# and build; `train` then runs the nightly pipeline, `test` the ctest suite.

BUILD_DIR  ?= build
BUILD_TYPE ?= Release
JOBS       ?= $(shell nproc)
NIGHTLY    ?= configs/nightly.toml
# The sanitizer and fuzzing build: Clang when present (libFuzzer), else GCC with the replay driver.
SANITIZE_DIR ?= build-sanitize
SANITIZERS   ?= address,undefined
SECONDS      ?= 60

.PHONY: all deps configure build train test bench format clean sanitize-build test-sanitize fuzz

all: build

deps:
	@scripts/install-deps.sh

configure: deps
	@cmake -S . -B $(BUILD_DIR) -DCMAKE_BUILD_TYPE=$(BUILD_TYPE) > $(BUILD_DIR).configure.log 2>&1 \
	  || { cat $(BUILD_DIR).configure.log; exit 1; }
	@echo "configured $(BUILD_DIR) ($(BUILD_TYPE))"

build: configure
	cmake --build $(BUILD_DIR) -j $(JOBS)

train: build
	$(BUILD_DIR)/bin/imm-train all --config $(NIGHTLY)

test: build
	ctest --test-dir $(BUILD_DIR) --output-on-failure -j $(JOBS)

# ASan + UBSan (+ LeakSanitizer) build of the whole suite, fuzz targets included. Without MPI:
# LeakSanitizer reports what OpenMPI itself keeps until exit, so the sanitized suite checks the
# single-process path (the MPI tests skip there; they run in `make test`).
sanitize-build: deps
	@if command -v clang++ >/dev/null; then compilers="-DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ -DIMM_FUZZERS=ON"; \
	 else compilers="-DIMM_FUZZERS=OFF"; fi; \
	 cmake -S . -B $(SANITIZE_DIR) -DCMAKE_BUILD_TYPE=Sanitize -DIMM_SANITIZERS=$(SANITIZERS) \
	   -DIMM_BUILD_BENCHMARKS=OFF -DIMM_WITH_MPI=OFF $$compilers > $(SANITIZE_DIR).configure.log 2>&1 \
	   || { cat $(SANITIZE_DIR).configure.log; exit 1; }
	cmake --build $(SANITIZE_DIR) -j $(JOBS)

# Every test but the three config drills of the evaluations (ConfigDrill/*_evaluation): each runs
# a whole evaluation with baseline tuning for every numeric key at six values, minutes apiece under
# the sanitizers; the evaluations themselves run sanitized in the tools tests.
SANITIZE_EXCLUDE ?= ConfigDrill.*_evaluation
test-sanitize: sanitize-build
	ASAN_OPTIONS=detect_leaks=1:abort_on_error=1:strict_string_checks=1:detect_stack_use_after_return=1 \
	UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
	LSAN_OPTIONS=suppressions=$(CURDIR)/tests/lsan.supp:print_suppressions=0 \
	  ctest --test-dir $(SANITIZE_DIR) --output-on-failure -j $(JOBS) -E '$(SANITIZE_EXCLUDE)'

# Runs every fuzz target for SECONDS seconds (make fuzz SECONDS=600 for a longer campaign).
fuzz: sanitize-build
	scripts/fuzz.sh $(SANITIZE_DIR) $(SECONDS)

# Medians of 5 repetitions into reports/bench/latest.json, slowdowns > 10 % flagged.
bench: build
	scripts/bench.sh $(BUILD_DIR)

format:
	git ls-files '*.cpp' '*.hpp' | xargs clang-format -i

clean:
	rm -rf $(BUILD_DIR) $(BUILD_DIR).configure.log $(SANITIZE_DIR) $(SANITIZE_DIR).configure.log
