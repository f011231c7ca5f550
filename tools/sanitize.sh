#!/usr/bin/env bash
# The test suite under sanitizers; exits non-zero on any report or failing test.
#   ASan + UBSan (g++): the whole suite (tests/CMakeLists.txt leaves out test_no_allocation,
#     which replaces malloc as ASan does), the install test's consumers included.
#   TSan (clang + LLVM's libomp): test_batch, the OpenMP batches and the batch command, and
#     test_chain_threads, one chain's step split over threads, and test_thread_team, the
#     worker pool that runs it (std::thread and atomics, which TSan sees itself). gcc's
#     libgomp is not instrumented, so TSan cannot see its barriers and reports races that are
#     none; libomp's Archer tool tells TSan about them, so nothing needs suppressing.
# Builds in build-asan and build-tsan (or NONHOLO_ASAN_BUILD, NONHOLO_TSAN_BUILD).
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/setup.sh"
nonholo_require clang-14 libomp-14-dev libclang-rt-14-dev

asan_build="${NONHOLO_ASAN_BUILD:-$NONHOLO_ROOT/build-asan}"
tsan_build="${NONHOLO_TSAN_BUILD:-$NONHOLO_ROOT/build-tsan}"
jobs="$(nproc)"

echo "== ASan + UBSan: the test suite" >&2
cmake -S "$NONHOLO_ROOT" -B "$asan_build" -DCMAKE_BUILD_TYPE=Release \
  -DNONHOLO_SANITIZE=address,undefined >/dev/null
cmake --build "$asan_build" -j "$jobs"
UBSAN_OPTIONS=print_stacktrace=1 ctest --test-dir "$asan_build" --output-on-failure -j "$jobs"

echo "== TSan: test_batch, test_chain_threads, test_thread_team" >&2
cmake -S "$NONHOLO_ROOT" -B "$tsan_build" -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_CXX_COMPILER=clang++-14 -DNONHOLO_SANITIZE=thread >/dev/null
cmake --build "$tsan_build" -j "$jobs" --target test_batch test_chain_threads test_thread_team nonholo_cli
# Archer is loaded through OMPT. It needs ignore_noninstrumented_modules: libomp's own
# (uninstrumented) locks are otherwise reported; CHOLMOD's accesses go unchecked too. A report
# makes the process exit with 66, so the test fails.
export OMP_TOOL_LIBRARIES=/usr/lib/llvm-14/lib/libarcher.so
TSAN_OPTIONS=ignore_noninstrumented_modules=1 \
  ctest --test-dir "$tsan_build" --output-on-failure -j "$jobs" -L '^(test_batch|test_chain_threads|test_thread_team)$'
