#!/usr/bin/env bash
# Builds the libFuzzer targets of tests/fuzz/ (clang, ASan + UBSan) into
# build-fuzz/ and runs each for SECONDS (default 60), from its seed corpus.
#   tools/fuzz.sh [SECONDS] [TARGET...]     (TARGET: tum_list, ply, ...; default all)
# Fails when any target crashes, hangs (one input over 10 s), leaks, runs out
# of memory (one allocation over 1 GB) or gets a sanitizer report. The input is
# saved in build-fuzz/fuzz/findings/<target>/ and the log in build-fuzz/fuzz/logs/.
# New inputs the fuzzer finds go to build-fuzz/fuzz/corpus/<target>/, never
# into the seed corpus in the repository (docs/FUZZING.md).
set -euo pipefail
cd "$(dirname "$0")/.."

seconds=${1:-60}
[[ "$seconds" =~ ^[0-9]+$ && "$seconds" -gt 0 ]] || { echo "fuzz.sh: SECONDS must be a positive integer, not '$seconds'" >&2; exit 2; }
[ $# -gt 0 ] && shift
targets=("$@")
if [ ${#targets[@]} = 0 ]; then
  for dir in tests/fuzz/corpus/*/; do targets+=("$(basename "$dir")"); done
fi

compiler=clang++-14
if ! command -v "$compiler" >/dev/null ||
   ! ls /usr/lib/llvm-14/lib/clang/*/lib/linux/libclang_rt.fuzzer-x86_64.a >/dev/null 2>&1; then
  echo "fuzz.sh: needs clang-14 and libFuzzer (libclang-rt-14-dev); tools/setup.sh installs them" >&2
  exit 2
fi

build_dir=build-fuzz
start=$SECONDS
cmake -S . -B "$build_dir" -DCMAKE_BUILD_TYPE=Release -DCMAKE_CXX_COMPILER="$compiler" -DVSLAM_FUZZ=ON \
      -DVSLAM_BUILD_TESTS=OFF -DVSLAM_BUILD_BENCHMARKS=OFF >/dev/null
cmake --build "$build_dir" -j "$(nproc 2>/dev/null || echo 2)" --target "${targets[@]/#/fuzz_}"
echo "fuzz.sh: built ${#targets[@]} targets in $((SECONDS - start)) s" >&2

# halt_on_error: the first report ends the run (UBSan is built with
# -fno-sanitize-recover, so it aborts too).
export ASAN_OPTIONS="halt_on_error=1:detect_leaks=1:allocator_may_return_null=0"
export UBSAN_OPTIONS="halt_on_error=1:print_stacktrace=1"
out="$build_dir/fuzz"
status=0
for target in "${targets[@]}"; do
  mkdir -p "$out/corpus/$target" "$out/findings/$target" "$out/logs"
  log="$out/logs/$target.log"
  # The first corpus folder receives new inputs; the seeds are only read.
  if "$out/fuzz_$target" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 -malloc_limit_mb=1024 \
       -print_final_stats=1 -artifact_prefix="$out/findings/$target/" \
       "$out/corpus/$target" "tests/fuzz/corpus/$target" >"$log" 2>&1; then
    runs=$(sed -nE 's/^stat::number_of_executed_units: *([0-9]+)/\1/p' "$log")
    echo "fuzz.sh: $target: no finding in ${runs:-?} runs (${seconds} s)" >&2
  else
    status=1
    echo "fuzz.sh: $target: FAILED; input in $out/findings/$target/, log $log:" >&2
    grep -E "ERROR|runtime error|SUMMARY|Test unit written|ALARM|deadly signal|==[0-9]+==|^Base64:" "$log" | head -20 >&2 || tail -20 "$log" >&2
    # The stack and the input itself: CI keeps only what is printed.
    grep -E "^ +#[0-9]+ " "$log" | grep -v -E "in (fuzzer::|__sanitizer|__libc|_start|main )" | head -12 >&2 || true
  fi
done
exit "$status"
