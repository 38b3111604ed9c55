#!/usr/bin/env bash
# Installs everything sssphere needs on Debian 12 and then the package itself.
#   bash scripts/install.sh         Debian libraries + `pip install .` (the `sssphere` command)
#   bash scripts/install.sh --dev   the same, editable, with the C++ tests and test peers
#                                   (Mitsuba 3, embreex, scipy, pytest) into build/dev
set -euo pipefail
cd "$(dirname "$0")/.."

dev=0
for arg in "$@"; do
  case "$arg" in
    --dev) dev=1 ;;
    *) echo "install.sh: unknown option '$arg' (allowed: --dev)" >&2; exit 2 ;;
  esac
done

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi

# C++ libraries (Embree, TBB, CGAL + GMP/MPFR/Boost, OpenImageIO, JSON, Highway for the SIMD
# decoders, GoogleTest), the compilers, and glmark2-data for the Stanford bunny used by
# scenes/bunny.json.
packages=(build-essential libembree-dev libtbb-dev libcgal-dev libgmp-dev libmpfr-dev
          libboost-dev libopenimageio-dev nlohmann-json3-dev libhwy-dev libgtest-dev glmark2-data
          python3-dev python3-pip)
# The GPU path (cpp/gpu/): the Vulkan loader and headers, glslc for the compute shaders, and
# Mesa's drivers, whose lavapipe runs those shaders on CPU-only machines and in CI.
packages+=(libvulkan-dev glslc mesa-vulkan-drivers)
# --dev: clang-format for the C++ format check in scripts/test.sh.
if [ "$dev" -eq 1 ]; then packages+=(clang-format); fi
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "install.sh: installing Debian packages: ${missing[*]}"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi

PY=${PYTHON:-python3}
$PY -m pip install -q --upgrade "pip>=23" 2>/dev/null || true
if [ "$dev" -eq 1 ]; then
  $PY -m pip install -q "scikit-build-core>=0.10" "pybind11>=2.12" cmake ninja
  $PY -m pip install -q --no-build-isolation -e ".[test]" \
      -Cbuild-dir=build/dev -Ccmake.define.SSSPHERE_TESTS=ON
else
  $PY -m pip install -q .
fi
echo "install.sh: done ($(command -v sssphere))"
