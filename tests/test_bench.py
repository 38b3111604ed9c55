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


@pytest.mark.parametrize("script", sorted(p.name for p in (REPO / "scenes").glob("*.py")))
def test_scene_scripts_answer_help_without_writing(script):
    """scenes/make_thin_torus.py had no argument parser: --help rewrote the tracked mesh."""
    before = {p: p.stat().st_mtime_ns for p in (REPO / "scenes").rglob("*") if p.is_file()}
    r = subprocess.run([sys.executable, f"scenes/{script}", "--help"], cwd=REPO,
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    assert "usage:" in r.stdout
    after = {p: p.stat().st_mtime_ns for p in (REPO / "scenes").rglob("*") if p.is_file()}
    assert after == before


def test_bench_holds_no_machine_paths():
    for path in (REPO / "bench").glob("*.py"):
        text = path.read_text()
        for prefix in ("/work/", "/root/", "/home/", "/tmp/"):
            assert prefix not in text, f"{path.name} names a path of one machine ({prefix}...)"


def test_ab_reads_the_render_time_the_command_line_prints(tmp_path, small_scene):
    """bench/ab.py times two builds by the render time their summary lines print; the line
    changed (2026-11-28) and ab stopped with "no render time". It reads today's line, from
    this build, and the older one an older build prints (bench/spectral_mis.py reads it too)."""
    import json

    from bench import ab
    from test_cli import _cpp_cli

    small_scene["render"]["spp"] = 1
    (tmp_path / "s.json").write_text(json.dumps(small_scene))
    r = subprocess.run([_cpp_cli(), str(tmp_path / "s.json"), "-o", str(tmp_path / "x.exr"),
                        "--quiet"], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    seconds = ab.render_seconds(r.stdout + r.stderr)
    assert seconds is not None and seconds >= 0, r.stdout + r.stderr
    assert ab.render_seconds("wrote x.exr: 0.06 s, 9.7 scattering events per path") == 0.06
