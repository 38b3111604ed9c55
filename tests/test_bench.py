"""The benchmarks stay runnable: every bench/ module imports as part of the `bench` package
(no sys.path edits) and parses its command line (``python -m bench.NAME --help`` from the
repository's root, as bench/README.md runs them)."""

import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
MODULES = sorted(p.stem for p in (REPO / "bench").glob("*.py") if p.stem != "__init__")


@pytest.mark.parametrize("module", MODULES)
def test_bench_module_runs_as_part_of_the_package(module):
    r = subprocess.run([sys.executable, "-m", f"bench.{module}", "--help"], cwd=REPO,
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    assert "usage:" in r.stdout


def test_bench_holds_no_machine_paths():
    for path in (REPO / "bench").glob("*.py"):
        text = path.read_text()
        for prefix in ("/work/", "/root/", "/home/", "/tmp/"):
            assert prefix not in text, f"{path.name} names a path of one machine ({prefix}...)"
