#!/usr/bin/env bash
# Hardening checks, run by CI after the test suite:
#   1. a clang build with AddressSanitizer + UndefinedBehaviorSanitizer (any report fails)
#      running the unit tests, a reduced set of registration tests and the OpenCL parity
#      tests;
#   2. bounded libFuzzer runs of the readers (with the formats' dictionary), of align() and
#      of API call sequences, from the seed corpus in fuzz/;
#   3. a soak run on the release build of scripts/test.sh (memory flat, no silent failure)
#      and a short one under the sanitizers (memory errors, leaks).
# Longer runs: FUZZ_SECONDS=3600 FUZZ_SEED=0 SOAK_ALIGNMENTS=20000 bash scripts/hardening.sh
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build="${PCL_MI_HARDENING_DIR:-$root/build-hardening}"
fuzz_seconds="${FUZZ_SECONDS:-60}"
# A fixed seed makes the CI run reproducible (same inputs in the same order); FUZZ_SEED=0
# lets libFuzzer pick a random one, as longer local runs should.
fuzz_seed="${FUZZ_SEED:-1}"
soak_alignments="${SOAK_ALIGNMENTS:-2000}"
release_build="${PCL_MI_BUILD_DIR:-$root/build}"
bash "$root/scripts/setup_debian.sh"

CC=clang CXX=clang++ cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DPCL_MI_SANITIZE=ON -DPCL_MI_BUILD_FUZZERS=ON -DPCL_MI_BUILD_APPS=OFF -DPCL_MI_WITH_PYTHON=OFF
cmake --build "$build" -j "$(nproc)" --target pcl_mi_unit_tests pcl_mi_registration_tests \
  pcl_mi_opencl_tests pcl_mi_soak fuzz_readers fuzz_align fuzz_api

# LeakSanitizer: the OpenCL ICD loader and PoCL keep process-lifetime allocations.
export LSAN_OPTIONS="suppressions=$root/fuzz/lsan.supp:print_suppressions=0"
export ASAN_OPTIONS="detect_leaks=1:abort_on_error=1"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
export PCL_MI_REQUIRE_OPENCL=1

echo "== sanitizers: unit tests"
"$build/test/pcl_mi_unit_tests"
echo "== sanitizers: registration tests (reduced set)"
"$build/test/pcl_mi_registration_tests" \
  --gtest_filter='Kitti/BundledPair.FromIdentityGuess/*VarianceZ:BadInput.*:Hardening*:BadParameters.*:CloudIo.*:Kitti.*:Registration.SameResult*:Registration.Independent*:Registration.FitnessScore*:Registration.Planar*:Registration.CloudsReadInPlace*:Registration.ACloudGrown*:Registration.ATargetGrown*'
echo "== sanitizers: OpenCL parity"
"$build/test/pcl_mi_opencl_tests" --gtest_filter='Backends/OpenClParity.*/0:OpenClAlignment.*'

echo "== fuzzing, ${fuzz_seconds} s per target"
for target in readers align api; do
  corpus="$build/fuzz/corpus_$target"
  mkdir -p "$corpus"
  cp -n "$root/fuzz/corpus/$target/"* "$corpus/" 2>/dev/null || true
  dict=()
  [ "$target" = readers ] && dict=(-dict="$root/fuzz/pcd_ply.dict")
  "$build/fuzz/fuzz_$target" "$corpus" "${dict[@]}" -seed="$fuzz_seed" \
    -max_total_time="$fuzz_seconds" -timeout=30 -rss_limit_mb=4096 -max_len=65536 \
    -print_final_stats=1 2>&1 | tail -n 25
done

echo "== soak under the sanitizers, 20 alignments"
"$build/test/pcl_mi_soak" 20 cpu --no-memory-check
echo "== soak, ${soak_alignments} alignments (release build)"
cmake --build "$release_build" -j "$(nproc)" --target pcl_mi_soak
"$release_build/test/pcl_mi_soak" "$soak_alignments"
