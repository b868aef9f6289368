# The README's two commands: `make train` and `make test`.
# Both install missing Debian packages, configure (Release unless BUILD_TYPE says otherwise)
# and build; `train` then runs the nightly pipeline, `test` the ctest suite.

BUILD_DIR  ?= build
BUILD_TYPE ?= Release
JOBS       ?= $(shell nproc)
NIGHTLY    ?= configs/nightly.toml

.PHONY: all deps configure build train test bench format clean

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

bench: build
	$(BUILD_DIR)/bin/imm-bench --benchmark_min_time=1
	$(BUILD_DIR)/bin/imm-train-bench

format:
	git ls-files '*.cpp' '*.hpp' | xargs clang-format -i

clean:
	rm -rf $(BUILD_DIR) $(BUILD_DIR).configure.log
