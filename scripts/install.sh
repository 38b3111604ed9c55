#!/usr/bin/env bash
# Installs sssphere on Debian 12 (or a Debian-based system with the same packages): the
# Debian libraries it links, then the Python package into a virtual environment, with its
# commands (`sssphere`, `sssphere-render`) linked where a shell finds them.
#
#   bash scripts/install.sh         the package, built from this checkout
#   bash scripts/install.sh --dev   the same, editable (C++ rebuilt incrementally in
#                                   build/dev), with the C++ tests and the test peers
#                                   (Mitsuba 3, embreex, scipy, torch, pytest)
#
# Where things go (README.md, "Where the install goes"):
#   Debian packages    apt-get (through sudo when not root)
#   Python package     .venv/ in this checkout, a virtual environment (PEP 668: Debian's
#                      own python3 takes no packages; nothing is installed into it)
#   commands           symbolic links in /usr/local/bin (root or sudo), else ~/.local/bin
#
# Environment:
#   PYTHON=python3.12      make .venv with that interpreter instead of python3
#   PYTHON=env/bin/python  an interpreter of an existing virtual or conda environment:
#                          install into that environment; no .venv, no links
#   SSSPHERE_VENV=dir      the virtual environment to make or reuse (default .venv)
#   SSSPHERE_BIN=dir       where to link the commands (default: see above)
set -euo pipefail
cd "$(dirname "$0")/.."
repo=$(pwd)

say() { echo "install.sh: $*"; }
die() { echo "install.sh: error: $*" >&2; exit 1; }

dev=0
for arg in "$@"; do
  case "$arg" in
    --dev) dev=1 ;;
    -h|--help) sed -n '2,24p' "$0"; exit 0 ;;
    *) echo "install.sh: unknown option '$arg' (allowed: --dev, --help)" >&2; exit 2 ;;
  esac
done

# C++ libraries (Embree, TBB, CGAL + GMP/MPFR/Boost, OpenImageIO, JSON, CLI11, Highway for the
# SIMD decoders, GoogleTest), the compilers, glmark2-data for the Stanford bunny used by
# scenes/bunny.json, and Python's headers and venv module (Debian splits both off python3).
packages=(build-essential libembree-dev libtbb-dev libcgal-dev libgmp-dev libmpfr-dev
          libboost-dev libopenimageio-dev nlohmann-json3-dev libhwy-dev libcli11-dev libgtest-dev
          glmark2-data python3-dev python3-venv)
# The GPU path (cpp/gpu/): the Vulkan loader and headers, glslc for the compute shaders, and
# Mesa's drivers, whose lavapipe runs those shaders on CPU-only machines and in CI.
packages+=(libvulkan-dev glslc mesa-vulkan-drivers)
# --dev: clang-format for the C++ format check in scripts/test.sh, and clang with libFuzzer
# for the fuzz targets (scripts/fuzz.sh, docs/fuzzing.md).
if [ "$dev" -eq 1 ]; then packages+=(clang-format clang-14 libclang-rt-14-dev); fi
apt_command="apt-get update && apt-get install -y --no-install-recommends ${packages[*]}"

# --- The platform: Debian's packages are what we build against -----------------------------
os_id=""; os_like=""; os_version=""
if [ -r /etc/os-release ]; then
  os_id=$(. /etc/os-release; echo "${ID:-}")
  os_like=$(. /etc/os-release; echo "${ID_LIKE:-}")
  os_version=$(. /etc/os-release; echo "${VERSION_ID:-}")
fi
if [ "$(uname -s)" != Linux ] || ! command -v dpkg-query >/dev/null || \
   { [ "$os_id" != debian ] && [[ " $os_like " != *" debian "* ]]; }; then
  cat >&2 <<EOF
install.sh: error: this installer supports Debian 12 (and Debian-based Linux with the same
packages); this system is '${os_id:-$(uname -s)}'. Elsewhere, install these yourself:
  a C++17 compiler, CMake >= 3.24, Embree 3, oneTBB, CGAL >= 5.5 (with GMP, MPFR, Boost),
  OpenImageIO >= 2.4, nlohmann-json 3, Highway >= 1.0, Python >= 3.10 with its headers;
  optionally the Vulkan loader and headers with glslc (the GPU path) and GoogleTest (--dev);
then, in a virtual environment: pip install .   (or pip install -e '.[test]' for development)
EOF
  exit 1
fi
if [ "$os_id" = debian ] && [ -n "$os_version" ] && [ "$os_version" != 12 ]; then
  say "note: tested on Debian 12; this is Debian $os_version (going on)"
fi

# --- Debian packages ------------------------------------------------------------------------
missing_packages() {
  local p
  for p in "${packages[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || echo "$p"
  done
}
cannot_install() {
  cat >&2 <<EOF
install.sh: error: $1
  These Debian packages are missing: $2
  Install them as root, then run this script again:
    $apt_command
EOF
  exit 1
}
sudo_cmd=()
if [ "$(id -u)" -ne 0 ]; then sudo_cmd=(sudo); fi
mapfile -t missing < <(missing_packages)
if [ ${#missing[@]} -gt 0 ]; then
  if [ "$(id -u)" -ne 0 ] && ! command -v sudo >/dev/null; then
    cannot_install "not root and there is no sudo to run apt-get with" "${missing[*]}"
  fi
  say "installing Debian packages: ${missing[*]}"
  "${sudo_cmd[@]}" apt-get update -qq ||
    cannot_install "'apt-get update' failed (no network, or sudo refused?)" "${missing[*]}"
  DEBIAN_FRONTEND=noninteractive "${sudo_cmd[@]}" apt-get install -y -qq \
      --no-install-recommends "${missing[@]}" ||
    cannot_install "'apt-get install' failed (no network, or packages not found?)" "${missing[*]}"
  mapfile -t missing < <(missing_packages)
  [ ${#missing[@]} -eq 0 ] || cannot_install "apt-get did not install everything" "${missing[*]}"
fi

# --- The Python environment -----------------------------------------------------------------
# An interpreter that belongs to a virtual environment (sys.prefix != sys.base_prefix) or to
# a conda environment takes the package directly; any other one (Debian's python3, which
# refuses `pip install` under PEP 668, or a pyenv build) only makes .venv.
base_python=${PYTHON:-python3}
command -v "$base_python" >/dev/null || die "PYTHON='$base_python' is not an interpreter on PATH"
"$base_python" -c 'import sys; sys.exit(sys.version_info < (3, 10))' ||
  die "$base_python is Python $("$base_python" -c 'import sys; print(sys.version.split()[0])'); 3.10 or newer is needed"
in_env=$("$base_python" -c 'import os, sys
print(int(sys.prefix != sys.base_prefix or os.path.isdir(os.path.join(sys.prefix, "conda-meta"))))')
if [ -n "${PYTHON:-}" ] && [ "$in_env" -eq 1 ]; then
  py=$(command -v "$base_python")
  venv=""
  say "installing into the environment of $py"
else
  venv=${SSSPHERE_VENV:-$repo/.venv}
  if [ ! -x "$venv/bin/python" ]; then
    say "making the virtual environment $venv ($base_python)"
    "$base_python" -m venv "$venv" || die "'$base_python -m venv $venv' failed"
  fi
  py=$venv/bin/python
fi

pip=("$py" -m pip --disable-pip-version-check)
if [ "$dev" -eq 1 ]; then
  "${pip[@]}" install -q "scikit-build-core>=0.10" "pybind11>=2.12" cmake ninja
  "${pip[@]}" install -q --no-build-isolation -e ".[test]" \
      --config-settings=build-dir=build/dev --config-settings=cmake.define.SSSPHERE_TESTS=ON
  # scripts/test.sh runs the suites with this interpreter
  echo "$py" > build/dev/python
else
  say "building and installing the package (a few minutes on 2 cores)"
  "${pip[@]}" install -q .
fi

# --- The commands, where a shell finds them -------------------------------------------------
bindir=$(dirname "$py")
if [ -n "$venv" ]; then
  if [ -n "${SSSPHERE_BIN:-}" ]; then
    link_dir=$SSSPHERE_BIN; link_cmd=()
  elif [ "$(id -u)" -eq 0 ]; then
    link_dir=/usr/local/bin; link_cmd=()
  elif command -v sudo >/dev/null && sudo -n true 2>/dev/null; then
    link_dir=/usr/local/bin; link_cmd=(sudo)
  else
    link_dir=$HOME/.local/bin; link_cmd=()
  fi
  "${link_cmd[@]}" mkdir -p "$link_dir"
  for cmd in sssphere sssphere-render; do
    [ -x "$bindir/$cmd" ] && "${link_cmd[@]}" ln -sfn "$bindir/$cmd" "$link_dir/$cmd"
  done
  say "commands linked in $link_dir: sssphere, sssphere-render -> $bindir"
  case ":$PATH:" in
    *":$link_dir:"*) ;;
    *) say "note: $link_dir is not on PATH; add it (export PATH=\"$link_dir:\$PATH\")" ;;
  esac
fi
say "done: $("$bindir/sssphere" --version) ($py)"
