#!/usr/bin/env bash
# Runs every check: ruff and clang-format, the GoogleTest suite (ctest) and pytest.
# Needs `bash scripts/install.sh --dev` first (it builds build/dev with the C++ tests and
# installs the module; run it again after changing C++: the rebuild is incremental).
# Extra arguments go to pytest (e.g. -m 'not slow', -k gpu).
set -euo pipefail
cd "$(dirname "$0")/.."
if [ ! -f build/dev/CTestTestfile.cmake ] || [ ! -f build/dev/python ]; then
  echo "test.sh: build/dev is missing: run 'bash scripts/install.sh --dev' first" >&2
  exit 2
fi
py=$(cat build/dev/python)   # the interpreter install.sh --dev installed into
# ctest from the same environment (pip's cmake, which built build/dev), else from PATH
ctest=$(dirname "$py")/ctest
[ -x "$ctest" ] || ctest=ctest
# Lint and format checks first (seconds): ruff (pyflakes, pycodestyle and bugbear rules from
# pyproject.toml) and clang-format (.clang-format: Google base, 4-space indent, 90 columns).
"$py" -m ruff check python tests bench scenes
clang-format --dry-run --Werror $(git ls-files 'cpp/*.cpp' 'cpp/*.h')
"$ctest" --test-dir build/dev --output-on-failure -j "$(nproc)"
# --durations: the slowest tests in the log, to see what makes the suite longer.
"$py" -m pytest tests --durations=25 "$@"
