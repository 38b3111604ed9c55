"""The `sssphere` command's entry point: imports the command line, which loads NumPy and
the C++ module (a second or more), so that Ctrl-C or SIGTERM meanwhile ends the command as an
interrupt does later (a line, status 130 or 143), not with a traceback of the import."""

from __future__ import annotations

import signal
import sys


class _Terminated(BaseException):
    pass


def _on_sigterm(signum, frame):
    raise _Terminated


def main() -> int:
    # SIGTERM too (cli.main installs its own handler, which does the same later on)
    if signal.getsignal(signal.SIGTERM) == signal.SIG_DFL:
        signal.signal(signal.SIGTERM, _on_sigterm)
    try:
        from sssphere import cli
    except KeyboardInterrupt:
        print("sssphere: interrupted", file=sys.stderr)
        return 130
    except _Terminated:
        print("sssphere: interrupted", file=sys.stderr)
        return 128 + signal.SIGTERM
    return cli.main()
