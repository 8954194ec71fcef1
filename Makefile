# Two commands on a fresh Debian machine:
#   make demo   installs dependencies, builds, runs the main job
#   make test   installs dependencies, builds, runs the test suite
# Hardening (docs/robustness.md):
#   make test-sanitize   the suite again under ASan + UBSan (build-asan)
#   make test-tsan       every threaded test under TSan, against an instrumented oneTBB (build-tsan)
#   make fuzz            each libFuzzer target for FUZZ_SECONDS (build-fuzz, clang)
BUILD ?= build
JOBS ?= $(shell nproc)
CMAKE_FLAGS ?= -DCMAKE_BUILD_TYPE=Release -DHBP_WERROR=ON

.PHONY: all deps configure build demo test clean test-sanitize test-tsan fuzz

all: build

deps:
	@bash scripts/install-deps

$(BUILD)/build.ninja:
	cmake -S . -B $(BUILD) -G Ninja $(CMAKE_FLAGS)

configure: deps $(BUILD)/build.ninja

build: configure
	cmake --build $(BUILD) -j $(JOBS)

demo: build
	@bash scripts/demo $(BUILD)

test: build
	cd $(BUILD) && ctest --output-on-failure -j $(JOBS) --timeout 900

clean:
	rm -rf $(BUILD)

# ---- Hardening ----------------------------------------------------------------
# Separate build directories; RTL and benchmarks are left out (not what the
# sanitizers are for; the Verilated model dominates build time). The CUDA
# room is built for ASan only: its CPU launcher runs the kernels' bodies as
# plain C++, instrumented (nvcc's objects are not).
ASAN_BUILD ?= build-asan
TSAN_BUILD ?= build-tsan
FUZZ_BUILD ?= build-fuzz
FUZZ_SECONDS ?= 60
FUZZ_TARGETS = scene_native scene_broadmark cli broadphase
HARDEN_FLAGS = -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g1" \
  -DHBP_WERROR=OFF -DHBP_BUILD_RTL=OFF -DHBP_BUILD_BENCH=OFF -DHBP_CUDA=OFF
# The installed-package consumer tests build uninstrumented projects
# against the instrumented library, and gpu_check_dry_run builds its own:
# not meaningful here.
SANITIZE_EXCLUDE = ^(bullet_consumer_package|core_only_package|gpu_check_dry_run)$$

test-sanitize: deps
	cmake -S . -B $(ASAN_BUILD) -G Ninja $(HARDEN_FLAGS) -DHBP_CUDA=AUTO -DHBP_SANITIZE=ON
	cmake --build $(ASAN_BUILD) -j $(JOBS)
	cd $(ASAN_BUILD) && ASAN_OPTIONS=detect_leaks=1:abort_on_error=1:strict_string_checks=1 \
	  UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
	  LSAN_OPTIONS=suppressions=$(CURDIR)/tests/lsan-thirdparty.supp:print_suppressions=0 \
	  ctest --output-on-failure -j $(JOBS) --timeout 1800 -E '$(SANITIZE_EXCLUDE)'

# TSan on the suites that run threads (ctest label "threaded", listed in
# tests/CMakeLists.txt: the hybrid system, the collision pipeline, the Bullet
# drop-in, the ray tracer's hierarchy, the scenario's parallel steps), in CI.
# TSan only sees the scheduler's synchronisation when libtbb is instrumented
# too: scripts/build-tsan-tbb builds Debian's oneTBB source package with
# -fsanitize=thread into $(TSAN_BUILD)/tbb (once, cached) and the project is
# configured against it. No suppressions. Each case runs in its own process
# (ctest), which TSan handles several times faster than one long process.
# Left out: three single-threaded memory measurements of test_limits whose
# 10^7-pair frames cost a minute of CPU each under TSan and add no threads.
# Two long runs take fewer steps under TSan (tests/sanitizers.hpp).
TSAN_TESTS = test_hybrid_broadphase test_adversarial test_bullet_broadphase test_raytrace_traversal \
  test_two_level_hierarchy test_scenario test_software_engine test_limits test_raytrace_colliding_objects \
  test_broad_phase test_pair_events test_parallel_pair_sort test_task_system \
  test_broad_phase_sleep test_broad_phase_snapshot test_broad_phase_large_world
TSAN_EXCLUDE = ^Limits\.(MemoryPerObjectAndPerPair|MaxPairsIsExactAndTheInstanceSurvives|UnlimitedExplosionIsExact)$$
TSAN_TBB = $(abspath $(TSAN_BUILD))/tbb
test-tsan: deps
	JOBS=$(JOBS) bash scripts/build-tsan-tbb $(TSAN_TBB)
	cmake -S . -B $(TSAN_BUILD) -G Ninja $(HARDEN_FLAGS) $(CMAKE_ARGS) -DTBB_DIR=$(TSAN_TBB)/install/lib/cmake/TBB \
	  -DCMAKE_CXX_FLAGS="-fsanitize=thread" -DCMAKE_EXE_LINKER_FLAGS="-fsanitize=thread" \
	  -DCMAKE_BUILD_RPATH=$(TSAN_TBB)/install/lib
	cmake --build $(TSAN_BUILD) -j $(JOBS) --target $(TSAN_TESTS)
	cd $(TSAN_BUILD) && TSAN_OPTIONS="halt_on_error=1 abort_on_error=1 second_deadlock_stack=1" \
	  ctest --output-on-failure -j $(JOBS) --timeout 1800 -L threaded -E '$(TSAN_EXCLUDE)'

# libFuzzer needs clang: the library and the targets are instrumented for
# coverage, ASan and UBSan. Each target runs FUZZ_SECONDS from the committed
# seeds (fuzz/corpus/<target>, read-only) plus its own growing corpus in
# $(FUZZ_BUILD)/corpus/<target>; crashes land in $(FUZZ_BUILD)/artifacts.
fuzz: deps
	cmake -S . -B $(FUZZ_BUILD) -G Ninja -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ \
	  -DCMAKE_BUILD_TYPE=RelWithDebInfo -DHBP_BUILD_RTL=OFF -DHBP_BUILD_BENCH=OFF -DHBP_CUDA=OFF -DHBP_FUZZ=ON \
	  -DCMAKE_CXX_FLAGS="-fsanitize=fuzzer-no-link,address,undefined -fno-sanitize-recover=undefined"
	cmake --build $(FUZZ_BUILD) -j $(JOBS) --target fuzzers
	@set -e; for t in $(FUZZ_TARGETS); do \
	  mkdir -p $(FUZZ_BUILD)/corpus/$$t $(FUZZ_BUILD)/artifacts/$$t; \
	  echo "fuzz_$$t: $(FUZZ_SECONDS) s"; \
	  $(FUZZ_BUILD)/fuzz/fuzz_$$t -max_total_time=$(FUZZ_SECONDS) -print_final_stats=1 \
	    -artifact_prefix=$(FUZZ_BUILD)/artifacts/$$t/ $(FUZZ_BUILD)/corpus/$$t fuzz/corpus/$$t \
	    > $(FUZZ_BUILD)/fuzz_$$t.log 2>&1 || { tail -60 $(FUZZ_BUILD)/fuzz_$$t.log; exit 1; }; \
	  grep -E "stat::(number_of_executed_units|average_exec_per_sec|new_units_added)" $(FUZZ_BUILD)/fuzz_$$t.log; \
	done
