#!/usr/bin/env bash
# Sanitizer runs (docs/fuzzing.md), each in its own build directory, never touching
# build/dev or the virtual environment:
#   bash scripts/sanitize.sh address          build/asan: AddressSanitizer + UBSan (gcc), the
#                                             GoogleTest suite and the fuzz replays (ctest)
#                                             and pytest against the sanitized modules
#   bash scripts/sanitize.sh address --ci     build/asan-ci: the same without the Python
#                                             module, ctest only (CI's share, see below)
#   bash scripts/sanitize.sh thread           build/tsan: ThreadSanitizer, the threaded
#                                             render and walk tests (ctest)
# --ci: ctest only, in full; no Python module and no pytest. CI stops at 90 minutes, and pytest
# under ASan is slow (the three files CI once ran, 146 tests, took more than 13 minutes on
# 2 cores, the whole suite about 3x its plain time): run it here, before a release or after
# changing the bindings.
# Extra arguments after these go to pytest (address only), e.g. -k scene, or test files to
# run instead of the whole suite.
# Needs the dev environment (bash scripts/install.sh --dev): its python, pytest and cmake.
# Environment: JOBS (parallel build and test jobs, default nproc); SKIP_CTEST=1 (address:
# pytest only, e.g. to run one slow test file under ASan); SANITIZE_CGAL=0 (address:
# cpp/geometry/cgal.cpp without sanitizers, ~14x faster distance grids, for
# tests/test_robustness.py's 128^3 grids; CMake's SSSPHERE_SANITIZE_CGAL).
set -euo pipefail
cd "$(dirname "$0")/.."
repo=$PWD
mode=${1:-}
shift || true
ci=0
if [ "${1:-}" = "--ci" ]; then
  ci=1
  shift
fi
case "$mode" in
  address | thread) ;;
  *)
    echo "usage: bash scripts/sanitize.sh address [--ci | pytest args] | thread" >&2
    exit 2
    ;;
esac
if [ "$ci" = 1 ] && [ $# -gt 0 ]; then
  echo "sanitize.sh: --ci runs ctest only and takes no pytest arguments (got: $*)" >&2
  exit 2
fi
if [ "$ci" = 1 ] && [ "${SKIP_CTEST:-0}" = 1 ]; then
  echo "sanitize.sh: --ci runs ctest only, so SKIP_CTEST=1 would leave nothing to run" >&2
  exit 2
fi
py=.venv/bin/python
[ -f build/dev/python ] && py=$(cat build/dev/python)
if [ ! -x "$py" ]; then
  echo "sanitize.sh: no dev environment: run 'bash scripts/install.sh --dev' first" >&2
  exit 2
fi
bin=$(dirname "$py")
cmake=$bin/cmake
ctest=$bin/ctest
[ -x "$cmake" ] || cmake=cmake
[ -x "$ctest" ] || ctest=ctest
jobs=${JOBS:-$(nproc)}
export CXX=${CXX:-g++}

# UBSan: print a stack and fail the test (the build has -fno-sanitize-recover=undefined).
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1

if [ "$mode" = thread ]; then
  dir=build/tsan
  "$cmake" -S . -B "$dir" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DSSSPHERE_SANITIZE=thread -DSSSPHERE_TESTS=ON -DSSSPHERE_PYTHON=OFF
  "$cmake" --build "$dir" -j "$jobs" --target sssphere_tests
  # Embree and oneTBB are not instrumented: TSan cannot see their synchronisation. The
  # suppressions drop reports from inside those libraries, and ignore_noninstrumented_modules
  # drops those where uninstrumented code calls libstdc++ (Embree's TBB workers reading the
  # device's configuration strings that rtcNewDevice wrote on our thread: the hand-over is a
  # TBB task spawn, invisible to TSan). Our own code is instrumented and checked in full.
  export TSAN_OPTIONS="halt_on_error=1 second_deadlock_stack=1 ignore_noninstrumented_modules=1 suppressions=$repo/scripts/tsan.supp"
  # The tests that run work on several threads: the renderer (thread pool, cancel), the
  # sphere tracer's and the walks' thread-count invariance, the batched model, and the
  # scene build (distance grids built on several threads).
  "$ctest" --test-dir "$dir" --output-on-failure -j "$jobs" \
    -R 'Renderer\.|Scheduler\.|ThreadCount|PathsInFlight|DistanceGrid\.|^Scene\.|SceneBuild\.'
  exit 0
fi

dir=build/asan
python=ON
if [ "$ci" = 1 ]; then
  dir=build/asan-ci
  python=OFF
fi
sanitize_cgal=ON
[ "${SANITIZE_CGAL:-1}" = 0 ] && sanitize_cgal=OFF
"$cmake" -S . -B "$dir" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DSSSPHERE_SANITIZE=address -DSSSPHERE_SANITIZE_CGAL="$sanitize_cgal" \
  -DSSSPHERE_TESTS=ON -DSSSPHERE_PYTHON="$python" \
  -DPython_EXECUTABLE="$py"
# CI builds what ctest runs, no command-line programs
targets=()
[ "$ci" = 1 ] && targets=(--target sssphere_tests sssphere_fuzz_replay)
"$cmake" --build "$dir" -j "$jobs" "${targets[@]}"

# Leaks are checked in the C++ tests (LeakSanitizer runs at exit of each test binary),
# except in those that load a Vulkan driver: Mesa's lavapipe, which the Vulkan loader
# loads and unloads again, leaves one 128-byte block of its own behind, which
# LeakSanitizer can only show as "<unknown module>" (the library is gone by then), so no
# suppression can name it. And in the image tests: OpenImageIO (not instrumented) leaks
# its error string when libpng longjmps out of a corrupt PNG (docs/fuzzing.md), and the
# stack LeakSanitizer records ends in libstdc++. Those tests still run under ASan and
# UBSan.
if [ "${SKIP_CTEST:-0}" != 1 ]; then
  export ASAN_OPTIONS=abort_on_error=0:detect_stack_use_after_return=0:strict_string_checks=1
  gpu_tests='Vulkan|Gpu|ImageIo'
  "$ctest" --test-dir "$dir" --output-on-failure -j "$jobs" -E "$gpu_tests"
  ASAN_OPTIONS=$ASAN_OPTIONS:detect_leaks=0 \
    "$ctest" --test-dir "$dir" --output-on-failure -j "$jobs" -R "$gpu_tests"
fi
if [ "$ci" = 1 ]; then exit 0; fi

# pytest against the sanitized extension modules. The editable install's import hook
# (.venv/.../_editable_skbc_sssphere.py) would load build/dev's modules, so pyroot/ holds
# a copy of the package with the ASan-built _core and _image, the shipped models beside
# it (where an installed package finds them, model.py), and a sitecustomize.py that
# removes that hook; PYTHONPATH carries all three to pytest and to the CLI subprocesses
# of the tests.
pyroot=$dir/pyroot
rm -rf "$pyroot"
mkdir -p "$pyroot"
cp -r python/sssphere "$pyroot/sssphere"
find "$pyroot" -name __pycache__ -prune -exec rm -rf {} +
cp "$dir"/cpp/_core.*.so "$dir"/cpp/_image.*.so "$pyroot/sssphere/"
ln -s "$repo/models" "$pyroot/sssphere/models"
cat > "$pyroot/sitecustomize.py" <<'EOF'
# Written by scripts/sanitize.sh: import sssphere from this directory, not the editable
# install's build (its import hook is put first on sys.meta_path by a .pth file).
import sys

sys.meta_path[:] = [f for f in sys.meta_path
                    if type(f).__name__ != "ScikitBuildRedirectingFinder"]
EOF
# The interpreter is not instrumented, so the ASan runtime must be loaded first. Leak
# checking is off in Python: CPython keeps interned objects and module state alive at
# exit on purpose, which LeakSanitizer reports as thousands of leaks that are not ours.
# libstdc++ is preloaded with it: ASan intercepts __cxa_throw, and finds the real one only
# if libstdc++ is loaded when ASan starts (the interpreter does not link it), else the first
# C++ exception aborts with "CHECK failed: ... real___cxa_throw".
preload="$("$CXX" -print-file-name=libasan.so) $("$CXX" -print-file-name=libstdc++.so)"
export ASAN_OPTIONS=detect_leaks=0:detect_stack_use_after_return=0
export PYTHONPATH=$repo/$pyroot
# The memory test of test_load.py measures the resident size, which ASan changes by design
# (freed memory waits in its quarantine, up to 256 MB): it runs in the plain build only.
# The files too large for memory are made so by an address-space limit, which ASan's
# terabytes of reserved shadow memory cannot live under.
pytest_args=(--deselect tests/test_load.py::test_memory_stays_flat_over_a_thousand_load_render_cycles
             --deselect "tests/test_bad_input.py::test_an_input_file_too_large_for_memory_is_named")
# The whole suite, unless the arguments name test files or directories themselves.
named=0
for a in "$@"; do [ -e "$a" ] && named=1; done
[ "$named" = 1 ] || pytest_args+=(tests)
pytest_args+=("$@")
# Check that the sanitized modules are the ones imported, then the tests
LD_PRELOAD=$preload "$py" -c \
  "import sssphere._core as c, sssphere._image as i; print('sanitized:', c.__file__, i.__file__)"
LD_PRELOAD=$preload "$py" -m pytest -p no:cacheprovider "${pytest_args[@]}"
