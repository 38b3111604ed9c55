"""The `sssphere` command's entry point: imports the command line, which loads NumPy and
the C++ module (a second or more), so that Ctrl-C or SIGTERM meanwhile ends the command as an
interrupt does later (a line, status 130 or 143), not with a traceback of the import."""

from __future__ import annotations

import signal
import sys


class _Terminated(BaseException):
    pass


def _on_sigterm(signum, frame):
    raise _Terminated(signum)


def main() -> int:
    # SIGTERM and SIGHUP too (cli.main installs its own handlers, which do the same later on)
    for s in (signal.SIGTERM, signal.SIGHUP):
        if signal.getsignal(s) == signal.SIG_DFL:
            signal.signal(s, _on_sigterm)
    try:
        from sssphere import cli
    except KeyboardInterrupt:
        print("sssphere: interrupted", file=sys.stderr)
        return 130
    except _Terminated as e:
        if e.args[0] != signal.SIGHUP:  # no terminal to say it to
            print("sssphere: interrupted", file=sys.stderr)
        return 128 + e.args[0]
    return cli.main()
