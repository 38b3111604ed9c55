"""The `sssphere` command's entry point: imports the command line, which loads NumPy and
the C++ module (a second or more), so that Ctrl-C meanwhile ends the command as an
interrupt does later (a line, status 130), not with a traceback of the import."""

from __future__ import annotations

import sys


def main() -> int:
    try:
        from sssphere import cli
    except KeyboardInterrupt:
        print("sssphere: interrupted", file=sys.stderr)
        return 130
    return cli.main()
