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
# UNITY=ON compiles each target's sources in batches (cmake/ImmBuildSpeed.cmake): a cold build of
# the whole tree in less time, an incremental one in more. .ci/run builds with it.
UNITY        ?= OFF

.PHONY: all deps configure build train test test-long bench format clean sanitize-build test-sanitize fuzz wheel

all: build

deps:
	@scripts/install-deps.sh

configure: deps
	@cmake -S . -B $(BUILD_DIR) -DCMAKE_BUILD_TYPE=$(BUILD_TYPE) -DIMM_UNITY_BUILD=$(UNITY) > $(BUILD_DIR).configure.log 2>&1 \
	  || { cat $(BUILD_DIR).configure.log; exit 1; }
	@echo "configured $(BUILD_DIR) ($(BUILD_TYPE))"

build: configure
	cmake --build $(BUILD_DIR) -j $(JOBS)

train: build
	$(BUILD_DIR)/bin/imm-train all --config $(NIGHTLY)

# The Python package's wheel (both modules and the runtime library) into dist/, built from this
# build's tree: `pip install dist/immtrain-*.whl` in any environment of Debian's Python
# (the interpreter the build is for).
PYTHON ?= /usr/bin/python3
wheel: build
	IMMTRAIN_CMAKE_BUILD_DIR=$(BUILD_DIR) $(PYTHON) -m pip wheel --no-build-isolation --no-deps -w dist .

# $(call ctest_and_summary,BUILD_DIR,CTEST_ARGS): ctest with a JUnit file, then the build's test
# count and ten slowest tests (scripts/test-summary.py); fails when either does.
ctest_and_summary = status=0; ctest --test-dir $(1) --output-on-failure -j $(JOBS) $(2) \
	--output-junit ctest-results.xml || status=$$?; \
	python3 scripts/test-summary.py $(1) || { [ $$status -ne 0 ] || status=1; }; exit $$status

# The default suite: every test but the studies labelled `long` (make test-long). Prints the
# build's test count and its ten slowest tests (scripts/test-summary.py); with CI=true a test that
# skips fails the target unless .ci/skip-allowlist names it.
test: build
	@$(call ctest_and_summary,$(BUILD_DIR),-LE '^long$$')

# The studies and long drills: minutes each, run by hand or by a scheduled job, never by .ci/run.
test-long: build
	ctest --test-dir $(BUILD_DIR) --output-on-failure -j $(JOBS) -L '^long$$'

# ASan + UBSan (+ LeakSanitizer) build of the whole suite, fuzz targets included. Without MPI:
# LeakSanitizer reports what OpenMPI itself keeps until exit, so the sanitized suite checks the
# single-process path (test-sanitize leaves out the MPI tests; they run in `make test`). The banks'
# IMM cycle as its generic kernel alone (IMM_MODE_COUNT_KERNELS=OFF, cmake/ImmBuildSpeed.cmake:
# the same statements; their per-mode-count copies were 5–10× their files' sanitized compile).
sanitize-build: deps
	@if command -v clang++ >/dev/null; then compilers="-DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ -DIMM_FUZZERS=ON"; \
	 else compilers="-DIMM_FUZZERS=OFF"; fi; \
	 cmake -S . -B $(SANITIZE_DIR) -DCMAKE_BUILD_TYPE=Sanitize -DIMM_SANITIZERS=$(SANITIZERS) \
	   -DIMM_BUILD_BENCHMARKS=OFF -DIMM_WITH_MPI=OFF -DIMM_MODE_COUNT_KERNELS=OFF -DIMM_UNITY_BUILD=$(UNITY) $$compilers > $(SANITIZE_DIR).configure.log 2>&1 \
	   || { cat $(SANITIZE_DIR).configure.log; exit 1; }
	cmake --build $(SANITIZE_DIR) -j $(JOBS)

# The unit and property suite and the fuzz replays under the sanitizers. The long end-to-end
# drills run in the Release suite only, where they already run whole: the kill -9 drills (label
# drill), whole nightlies (nightly), the MPI runs (mpi: the sanitized build has no MPI, see
# sanitize-build), the config drills of the evaluations (each a whole evaluation with baseline
# tuning per drilled value), ga-imm's whole Table 3 with every baseline tuned (193 s of the
# sanitized suite's 894 s; the same experiment runs here on a small regime in
# Tools.GaAndInputEstimatorTrainAndEvaluateOnARegimeWrittenInTheTest), the fast-turn regime's
# classical bar end to end (206 s sanitized; its tuner, experiments and rank run here in
# Tools.TheRegimesTrackerIsChosenOnARegimeWrittenInTheTest), the FCM-IMM's training and
# evaluation end to end (232 s sanitized: two trainings, each experiment tuning its classical bar;
# the FCM trainer and filter run sanitized in FcmTraining.* and FcmImm.*, its experiment on
# recorded plots in Tools.RecordingsExported…), the partial-truth recordings (192 s; their import
# and judgement run sanitized in Tools.RecordingsExported… and RecordedTracks.*) and the studies
# (long), and the Python trainer's side and tutorial (test_lab.py passes sanitized but takes 344 s:
# its trainings and tuned experiments, whose C++ runs sanitized in the trainer, evaluation and
# Experiments.* suites; the Release suite runs both). Also left to the Release suite, to keep
# .ci/run near its 30 minutes (each was 20–160 s sanitized): every mutation of every shipped model
# (162 s; the fuzz stage runs model_file_fuzzer from the shipped models under the same sanitizers,
# and its replay runs here), the consumer project's CMake build, the plot-sigma statistics over 30
# tracks (TrainingWithoutTruth runs the same learning here), the envelope on whole regimes
# (Envelope.* here), and the end-to-end tool runs of the wIMM, the TSK/FIMM and the noise schedule,
# whose trainers run here in WimmTraining.*, TskTraining.* and NoiseSchedule.*. The config drills
# of the trainers, the tools and the regime files do run here, each key at one absurd value (two
# in the Release suite): an absurd value must not reach undefined behaviour. Two more checks of
# figures, not of memory, run in Release only (62 s and 27 s sanitized): GA-IMM's result against
# the files its reporters write (the experiment itself runs here in
# Tools.GaAndInputEstimator…) and W2a's 6000 epochs against plain loops (the fused batch
# gradient runs here in Backpropagation.*). The process's glibc memory policy
# (Process.FreedMemory…) is checked in Release only: the sanitizer's allocator replaces glibc's.
SANITIZE_EXCLUDE_LABELS ?= ^(drill|nightly|mpi|long)$$
SANITIZE_EXCLUDE ?= ConfigDrill.*_evaluation|Tools.GaImmEvaluationReportsTable3ForEveryFilter|Tools.AFastTurnRegime.*|Tools.FcmTrainingAndEvaluationEndToEnd|Tools.PartialTruthJudges.*|python.TheTrainersSide.*|python.TheTutorial.*|HostileModelFile.EveryMutationOfEveryShippedModelIsRefusedOrLoads|package.ConsumerProjectBuildsAgainstTheInstalledRuntime|PlotSigma.*|EnvelopeOnRegimes.*|Tools.PolarRecordingsTrainAndEvaluateTheWimmWithoutTruth|Tools.AScheduleThatSwitchesOffIsTheClassicalBarItself|Tools.WimmTrainingAndEvaluationEndToEnd|Tools.TskTrainingFromStoredSamples|Tools.TskTrainingAndFimmEvaluationEndToEnd|Experiments.GaImmResultIsWhatItsReportWrites|Workloads.W2aFullBatchMatchesPlainLoops|Process.FreedMemoryIsKeptForTheNextAllocations
test-sanitize: sanitize-build
	@export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1:strict_string_checks=1:detect_stack_use_after_return=1 \
	  UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
	  LSAN_OPTIONS=suppressions=$(CURDIR)/tests/lsan.supp:print_suppressions=0; \
	  $(call ctest_and_summary,$(SANITIZE_DIR),-LE '$(SANITIZE_EXCLUDE_LABELS)' -E '$(SANITIZE_EXCLUDE)')

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
