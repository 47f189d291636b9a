#!/usr/bin/env bash
# Builds the fuzz targets with clang in build-fuzz/ and runs them side by
# side, each for a bounded time from its seed corpus
# (tests/fuzz/corpus/<target>/) and its regression inputs
# (tests/fuzz/regressions/<target>/, every input a crash once found, run
# first). Exits non-zero on a crash, a leak, a timeout or
# an out-of-memory; the input is kept as build-fuzz/artifacts/<target>-*.
#   bash tests/fuzz/run.sh                    # every target, 60 s each
#   MM_FUZZ_SECONDS=600 bash tests/fuzz/run.sh rest_request
# New inputs the fuzzer finds go to a scratch folder, never into the
# committed corpus.
set -euo pipefail
cd "$(dirname "$0")/../.."

seconds=${MM_FUZZ_SECONDS:-60}
targets=("$@")
((${#targets[@]})) || targets=(rest_request grpc_request)

# The model runs uninstrumented: where the ordinary build tree (build/, GCC)
# is configured, its mm_model is brought up to date and linked instead of
# compiling the LibTorch files again with clang (minutes on two cores).
prebuilt=()
if [ -f build/CMakeCache.txt ]; then
  cmake --build build -j "$(nproc)" --target mm_model
  prebuilt=(-DMM_PREBUILT_MODEL_LIBRARY="$PWD/build/model/libmm_model.a")
else
  prebuilt=(-DMM_PREBUILT_MODEL_LIBRARY=)
fi
# -O1, as fuzzing builds usually are: the core's LibTorch-including files
# compiled with the sanitizers in 107 s of CPU at -O1 against 198 s at -O3.
cmake -S . -B build-fuzz -DCMAKE_BUILD_TYPE=Release -DCMAKE_CXX_FLAGS_RELEASE="-O1 -DNDEBUG" -DCMAKE_CXX_COMPILER=clang++ \
  -DMM_BUILD_TESTS=OFF -DMM_BUILD_FUZZERS=ON "${prebuilt[@]}" > /dev/null
cmake --build build-fuzz -j "$(nproc)" --target "${targets[@]/%/_fuzzer}"

mkdir -p build-fuzz/artifacts
# Each target runs on one core; the targets run side by side, each writing
# its log to build-fuzz/<target>.log, shown when all have ended.
fuzz() {
  local target=$1
  local found scratch regressions=()
  found=$(mktemp -d)
  scratch=$(mktemp -d)  # the service's data root and job records (fuzz_service.h)
  [ -d "tests/fuzz/regressions/$target" ] && regressions=("tests/fuzz/regressions/$target")
  echo "fuzzing $target for ${seconds} s"
  # -timeout: one request taking longer is a bug (the slowest valid one
  # takes well under a second); so is one allocation over 256 MiB (a
  # request's own data is a few MiB at most) and a process grown past 2 GiB
  # (it starts at about 400 MiB).
  local status=0
  TMPDIR="$scratch" "build-fuzz/tests/fuzz/${target}_fuzzer" -max_total_time="$seconds" -timeout=20 -rss_limit_mb=2048 \
    -malloc_limit_mb=256 -dict="tests/fuzz/$target.dict" -print_final_stats=1 \
    -artifact_prefix="build-fuzz/artifacts/$target-" \
    "$found" "${regressions[@]}" "tests/fuzz/corpus/$target" || status=$?
  rm -rf "$found" "$scratch"
  if [ "$status" -ne 0 ]; then
    echo "fuzzing $target failed (exit $status); the input is in build-fuzz/artifacts/" >&2
  fi
  return "$status"
}
pids=()
for target in "${targets[@]}"; do
  fuzz "$target" > "build-fuzz/$target.log" 2>&1 &
  pids+=($!)
done
failed=0
for i in "${!targets[@]}"; do
  status=0
  wait "${pids[$i]}" || status=$?
  echo "== ${targets[$i]} (exit $status)"
  cat "build-fuzz/${targets[$i]}.log"
  ((status == 0)) || failed=$status
done
exit "$failed"
