#!/usr/bin/env bash
# Fuzzes the scene-file parser: builds tests/fuzz/fuzz_scene_file (clang, libFuzzer, ASan +
# UBSan) in ./build-fuzz and runs it for FUZZ_SECONDS (default 60) from the seed corpus
# tests/fuzz/corpus. Exits non-zero on a finding (a crash, leak, undefined behaviour,
# timeout, or an exception other than std::invalid_argument); the input that caused it is
# left in build-fuzz/findings/. `bash tools/fuzz.sh FILE...` runs the target on given inputs
# only (to reproduce a finding).
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/setup.sh"
# Bookworm's clang 14 has libFuzzer and the sanitizer runtimes in libclang-rt-14-dev, and
# OpenMP for clang in libomp-14-dev.
nonholo_require clang libclang-rt-14-dev libomp-14-dev

build="${NONHOLO_FUZZ_BUILD:-$NONHOLO_ROOT/build-fuzz}"
# Debug keeps Eigen's index assertions; -O1 keeps the fuzzer fast.
CC=clang CXX=clang++ cmake -S "$NONHOLO_ROOT" -B "$build" -DCMAKE_BUILD_TYPE=Debug -DCMAKE_CXX_FLAGS_DEBUG="-O1 -g" \
  -DNONHOLO_BUILD_FUZZERS=ON -DNONHOLO_BUILD_TESTS=OFF -DNONHOLO_BUILD_BENCHMARKS=OFF >/dev/null
cmake --build "$build" --target fuzz_scene_file -j "$(nproc)"
fuzzer="$build/tests/fuzz/fuzz_scene_file"

if (($#)); then
  exec "$fuzzer" "$@"
fi
mkdir -p "$build/corpus" "$build/findings"  # new inputs go to the first directory, not the repository
"$fuzzer" "$build/corpus" "$NONHOLO_ROOT/tests/fuzz/corpus" \
  -dict="$NONHOLO_ROOT/tests/fuzz/scene.dict" -max_total_time="${FUZZ_SECONDS:-60}" -max_len=4096 -timeout=10 \
  -rss_limit_mb=2048 -artifact_prefix="$build/findings/" -print_final_stats=1 || {
  echo "fuzz.sh: the fuzzer found a problem; the input is in $build/findings/ (reproduce: bash tools/fuzz.sh FILE)" >&2
  exit 1
}
