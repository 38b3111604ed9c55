#!/usr/bin/env bash
# Runs the README's install-and-render command (the first `sh` block under "## Quick start")
# verbatim on a stock Debian 12 root, as a normal user with sudo (../shared/tools/fresh-debian,
# which needs root), then checks that it left the rendered image and a working
# `sssphere --version`. Fails loudly when such a root cannot be made.
#   bash scripts/check_fresh_install.sh [--root]   (--root: run the command as root instead)
set -euo pipefail
cd "$(dirname "$0")/.."
as=(--user)
[ "${1:-}" = --root ] && as=()

fresh=../shared/tools/fresh-debian
if [ ! -x "$fresh" ]; then
  echo "check_fresh_install.sh: FAILED: $fresh is missing, so the README's install command" \
       "cannot be checked on a stock Debian 12" >&2
  exit 1
fi
if [ "$(id -u)" -ne 0 ]; then
  echo "check_fresh_install.sh: FAILED: fresh-debian needs root (chroot); run as root" >&2
  exit 1
fi
if [ -n "$(git status --porcelain --untracked-files=no)" ]; then
  echo "check_fresh_install.sh: note: uncommitted changes are not checked (the root gets HEAD)" >&2
fi

# The README's first block under "## Quick start", and the image it writes (its -o argument)
command=$(python3 - <<'PY'
import re, sys
text = open("README.md", encoding="utf-8").read()
section = re.search(r"^## Quick start\b.*?(?=^## |\Z)", text, re.M | re.S)
blocks = re.findall(r"^```sh\n(.*?)^```", section.group(0) if section else "", re.M | re.S)
if len(blocks) < 2:
    sys.exit("README.md: '## Quick start' must hold two sh blocks (install and render; install and test)")
print(blocks[0].strip())
PY
)
image=$(sed -nE 's/.* -o ([^ ]+).*/\1/p' <<<"$command")
[ -n "$image" ] || { echo "check_fresh_install.sh: no '-o IMAGE' in: $command" >&2; exit 1; }
echo "check_fresh_install.sh: on a stock Debian 12 (${as[*]:-as root}): $command"

check="$command && test -s '$image' && sssphere --version && echo 'fresh install: OK'"
start=$(date +%s)
if ! "$fresh" "${as[@]}" -- bash -c "$check"; then
  echo "check_fresh_install.sh: FAILED: the README's first command did not install and render" \
       "on a stock Debian 12 (see above)" >&2
  exit 1
fi
echo "check_fresh_install.sh: passed in $(( $(date +%s) - start )) s"
