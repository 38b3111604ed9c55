#!/usr/bin/env bash
# Runs every test: the GoogleTest suite (ctest) and the Python suite (pytest).
# Needs `bash scripts/install.sh --dev` first (it builds build/dev with the C++ tests and
# installs the module; run it again after changing C++: the rebuild is incremental).
set -euo pipefail
cd "$(dirname "$0")/.."
if [ ! -f build/dev/CTestTestfile.cmake ]; then
  echo "test.sh: build/dev is missing: run 'bash scripts/install.sh --dev' first" >&2
  exit 2
fi
ctest --test-dir build/dev --output-on-failure -j "$(nproc)"
python3 -m pytest tests "$@"
