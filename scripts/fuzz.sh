#!/usr/bin/env bash
# Builds the libFuzzer targets (cpp/fuzz/) with clang, ASan and UBSan in build/fuzz and runs
# each for a while (docs/fuzzing.md):
#   bash scripts/fuzz.sh [seconds per target, default 60] [target...]
# Targets: scene mesh_obj mesh_ply mesh_off mesh_stl model image_exr image_png (default all).
# Each starts from its seeds (tests/fuzz/corpus/<target>) and regression inputs
# (tests/fuzz/regressions/<target>); what it finds new goes to build/fuzz/work/corpus/
# <target> (kept between runs, never into the repository), and any input that crashes,
# trips a sanitizer, hangs past the timeout or runs out of memory goes to
# build/fuzz/findings/<target>/. Exit status 1 if any target found something: the
# summary prints the command that reproduces each finding.
# Environment: FUZZ_CXX (default clang++-14), FUZZ_JOBS (targets run at once, default 1),
# FUZZ_TIMEOUT (seconds one input may take, default 20), FUZZ_RSS_MB (default 2048),
# FUZZ_KEEP_GOING=1 (do not stop at the first finding: for long runs).
set -euo pipefail
cd "$(dirname "$0")/.."
repo=$PWD
all_targets=(scene mesh_obj mesh_ply mesh_off mesh_stl model image_exr image_png)
seconds=${1:-60}
shift || true
targets=("$@")
[ ${#targets[@]} -gt 0 ] || targets=("${all_targets[@]}")
if ! [[ "$seconds" =~ ^[0-9]+$ ]] || [ "$seconds" -lt 1 ]; then
  echo "usage: bash scripts/fuzz.sh [seconds per target] [target...]" >&2
  exit 2
fi
for t in "${targets[@]}"; do
  if [[ ! " ${all_targets[*]} " =~ " $t " ]]; then
    echo "fuzz.sh: unknown target '$t' (known: ${all_targets[*]})" >&2
    exit 2
  fi
done
cxx=${FUZZ_CXX:-clang++-14}
jobs=${FUZZ_JOBS:-1}
timeout=${FUZZ_TIMEOUT:-20}
rss_mb=${FUZZ_RSS_MB:-2048}

# clang and its libFuzzer runtime: say what to install rather than install it.
missing="fuzz.sh: needs clang with libFuzzer; on Debian 12: sudo apt-get install clang-14 libclang-rt-14-dev (or set FUZZ_CXX)"
if ! command -v "$cxx" > /dev/null; then
  echo "$missing ('$cxx' not found)" >&2
  exit 2
fi
probe=$(mktemp -d)
trap 'rm -rf "$probe"' EXIT
printf '%s\n' '#include <cstddef>' '#include <cstdint>' \
  'extern "C" int LLVMFuzzerTestOneInput(const uint8_t*, size_t) { return 0; }' \
  > "$probe/probe.cpp"
if ! "$cxx" -fsanitize=fuzzer,address,undefined "$probe/probe.cpp" -o "$probe/probe" \
    2> "$probe/log"; then
  cat "$probe/log" >&2
  echo "$missing ('$cxx' cannot link -fsanitize=fuzzer,address,undefined)" >&2
  exit 2
fi

# The build: only the fuzz targets and the libraries they link (no Python module, no
# Vulkan, no tests). The dev environment's cmake and ninja where present.
cmake=cmake
[ -x .venv/bin/cmake ] && cmake=.venv/bin/cmake
generator=()
if [ -x .venv/bin/ninja ] || command -v ninja > /dev/null; then
  generator=(-G Ninja)
  [ -x .venv/bin/ninja ] && generator+=(-DCMAKE_MAKE_PROGRAM="$repo/.venv/bin/ninja")
fi
dir=build/fuzz
if [ ! -f "$dir/CMakeCache.txt" ]; then
  "$cmake" -S . -B "$dir" "${generator[@]}" -DCMAKE_CXX_COMPILER="$cxx" \
    -DCMAKE_BUILD_TYPE=RelWithDebInfo -DSSSPHERE_FUZZ=ON -DSSSPHERE_SANITIZE=address \
    -DSSSPHERE_VULKAN=OFF -DSSSPHERE_TESTS=OFF -DSSSPHERE_PYTHON=OFF
fi
"$cmake" --build "$dir" -j "${BUILD_JOBS:-$(nproc)}" --target sssphere-fuzz

work=$dir/work
findings=$dir/findings
mkdir -p "$work"
# UBSan aborts on its first report (so libFuzzer saves the input); ASan's defaults, with
# leak checking, hold.
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
export ASAN_OPTIONS=${ASAN_OPTIONS:-}

run_target() {
  local t=$1
  local exe=$dir/cpp/fuzz_$t log=$work/$t.log
  local corpus=$work/corpus/$t
  rm -rf "${findings:?}/$t"
  mkdir -p "$corpus" "$findings/$t"
  local inputs=("$corpus" "tests/fuzz/corpus/$t")
  [ -d "tests/fuzz/regressions/$t" ] && inputs+=("tests/fuzz/regressions/$t")
  local extra=()
  [ -f "tests/fuzz/$t.dict" ] && extra+=(-dict="tests/fuzz/$t.dict")
  # No leak checks for the image targets: OpenImageIO (not instrumented) leaks its error
  # string when libpng longjmps out of a corrupt file (PNGInput::PngReadCallback), and
  # our wrapper holds OpenImageIO's objects in unique_ptr only.
  # LeakSanitizer's check at exit is turned off for them too (ASAN_OPTIONS below).
  local asan_options=$ASAN_OPTIONS
  [[ "$t" == image_* ]] && extra+=(-detect_leaks=0) && asan_options=$ASAN_OPTIONS:detect_leaks=0
  # FUZZ_KEEP_GOING=1: carry on past findings (libFuzzer's fork mode; each one is saved)
  [ "${FUZZ_KEEP_GOING:-0}" = 1 ] &&
    extra+=(-fork=1 -ignore_crashes=1 -ignore_ooms=1 -ignore_timeouts=1)
  local rc=0
  # bash's time: wall, user and system seconds of libFuzzer and its children
  { TIMEFORMAT='%R %U %S'
    time ASAN_OPTIONS=$asan_options "$exe" -max_total_time="$seconds" -timeout="$timeout" -rss_limit_mb="$rss_mb" \
      -max_len=16384 -print_final_stats=1 -artifact_prefix="$findings/$t/" "${extra[@]}" \
      "${inputs[@]}" > "$log" 2>&1 || rc=$?
  } 2> "$work/$t.time"
  echo "$rc" > "$work/$t.rc"
}

echo "fuzz.sh: ${targets[*]}: $seconds s each, $jobs at a time; logs in $work/<target>.log"
running=0
for t in "${targets[@]}"; do
  if [ "$running" -ge "$jobs" ]; then
    wait -n
    running=$((running - 1))
  fi
  run_target "$t" &
  running=$((running + 1))
done
wait

status=0
printf '%-10s %8s %8s %10s %8s %8s %7s  %s\n' target wall_s cpu_s execs cov ft corpus result
for t in "${targets[@]}"; do
  log=$work/$t.log
  read -r wall user sys < "$work/$t.time"
  cpu=$(awk -v u="$user" -v s="$sys" 'BEGIN { printf "%.0f", u + s }')
  # The last status line: "#N <event> cov: C ft: F corp: K/..." (fork mode: "#N: cov: ...")
  last=$(grep -E '^#[0-9]+' "$log" | tail -1 || true)
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
  [ -n "$execs" ] || execs=$(sed -n 's/^#\([0-9]*\).*/\1/p' <<< "$last")
  cov=$(sed -n 's/.* cov: \([0-9]*\).*/\1/p' <<< "$last")
  ft=$(sed -n 's/.* ft: \([0-9]*\).*/\1/p' <<< "$last")
  corp=$(find "$work/corpus/$t" -type f | wc -l)
  result=ok
  if [ "$(cat "$work/$t.rc")" != 0 ] || [ -n "$(ls -A "$findings/$t")" ]; then
    result="FINDING (exit $(cat "$work/$t.rc"); $log)"
    status=1
  fi
  printf '%-10s %8.0f %8s %10s %8s %8s %7s  %s\n' "$t" "$wall" "$cpu" "${execs:-?}" \
    "${cov:-?}" "${ft:-?}" "$corp" "$result"
done
for t in "${targets[@]}"; do
  for f in "$findings/$t"/*; do
    [ -e "$f" ] || continue
    echo "finding: $f"
    echo "  reproduce: $dir/cpp/fuzz_$t $f"
    echo "  once fixed: cp $f tests/fuzz/regressions/$t/ (ctest then replays it)"
  done
done
exit "$status"
