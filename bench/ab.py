#!/usr/bin/env python3
"""A/B timing of two `sssphere-render` builds on the bunny density sweep, interleaved.

A refactoring must not cost speed. This runs two builds of the C++ command line, e.g. the
commit before a change and the change itself, on the scenes of bench/st_vs_pt.py's bunny
sweep (scenes/bunny.json, sigma_t = 500 x {0.25, 0.5, 1, 2} per unit) with both integrators,
and compares the render time each prints (the time of the samples, without loading the scene,
building the distance grid or loading the models), the process's wall time and its CPU time
(user + system, which other load on a shared machine disturbs less than wall time). The runs
alternate A B B A ... so that a drift of the machine's speed falls on both builds alike; the
ratio of the medians is reported per scene and integrator, and their geometric mean per
integrator. Both builds must render the
same image from the same seed: the largest per-pixel difference is reported beside the times
(0 where the change kept the arithmetic).

    git worktree add ../before <commit> && cmake -S ../before -B ../before/build \\
        -DCMAKE_BUILD_TYPE=Release && cmake --build ../before/build --target sssphere-render
    python -m bench.ab ../before/build/cpp/sssphere-render build/dev/cpp/sssphere-render

Writes bench/results/ab.json. Run it on an otherwise idle machine: other load is noise.
"""

from __future__ import annotations

import argparse
import datetime
import json
import math
import os
import re
import statistics
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np
from bench.machine import machine

REPO = Path(__file__).resolve().parent.parent
SCALES = (0.25, 0.5, 1.0, 2.0)
# The summary line's render time: "rendered in 3.65s" since 2026-11-28, "wrote x.exr: 3.65 s,"
# before (a build of an older commit prints that).
TIME_RE = re.compile(r"rendered in ([0-9.]+) ?s\b|wrote .*: ([0-9.]+) s, ")


def render_seconds(output: str) -> float | None:
    """The render time in a `sssphere-render` summary line (either form), or None."""
    found = TIME_RE.search(output)
    return float(found.group(1) or found.group(2)) if found else None


def sweep_scenes(directory: Path, size: int, boundary: str | None = None) -> dict[str, Path]:
    """Writes the bunny sweep's scene files into `directory` (with `boundary`'s type instead of
    the scene's dielectric, if given); returns them by name."""
    base = json.loads((REPO / "scenes" / "bunny.json").read_text())
    scenes = {}
    for scale in SCALES:
        scene = json.loads(json.dumps(base))
        scene["camera"]["width"] = scene["camera"]["height"] = size
        mesh = Path(scene["shapes"][0]["mesh"])
        if not mesh.is_absolute():
            scene["shapes"][0]["mesh"] = str((REPO / "scenes" / mesh).resolve())
        scene["shapes"][0]["medium"]["sigma_t"] = [500 * scale] * 3
        if boundary:
            scene["shapes"][0]["boundary"] = {"type": boundary}
        name = f"bunny_sigma{500 * scale:g}"
        path = directory / f"{name}.json"
        path.write_text(json.dumps(scene))
        scenes[name] = path
    return scenes


def render(binary: str, scene: Path, output: Path, integrator: str, args) -> tuple[float, float, float]:
    """Renders once; returns the render time the command line prints, the process's wall
    time (which adds reading the scene, the distance grid and the models) and its CPU time
    (user + system: less sensitive than wall time to other load on the machine)."""
    cmd = [binary, str(scene), "-o", str(output), "--integrator", integrator,
           "--spp", str(args.spp), "--threads", str(args.threads), "--seed", "1", "--quiet"]
    start = time.perf_counter()
    with subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True) as proc:
        output_text = proc.stdout.read()
        _, status, usage = os.wait4(proc.pid, 0)
        proc.returncode = os.waitstatus_to_exitcode(status)
    wall = time.perf_counter() - start
    cpu = usage.ru_utime + usage.ru_stime
    if proc.returncode != 0:
        raise SystemExit(f"ab: {' '.join(cmd)} failed ({proc.returncode}):\n{output_text}")
    seconds = render_seconds(output_text)
    if seconds is None:
        raise SystemExit(f"ab: no render time in the output of {' '.join(cmd)}:\n{output_text}")
    return seconds, wall, cpu


def geomean(values: list[float]) -> float:
    return math.exp(sum(map(math.log, values)) / len(values))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("a", help="sssphere-render of the first build (before)")
    parser.add_argument("b", help="sssphere-render of the second build (after)")
    parser.add_argument("--spp", type=int, default=64)
    parser.add_argument("--size", type=int, default=128, help="image width and height")
    parser.add_argument("--repeats", type=int, default=4, help="renders per build, scene and integrator")
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--boundary", choices=["dielectric", "index_matched"],
                        help="the bunny's boundary (default: the scene's, dielectric); index_matched "
                        "makes every scattering event of pt sample the lights (NEE)")
    parser.add_argument("--out", type=Path, default=REPO / "bench" / "results" / "ab.json")
    args = parser.parse_args()

    from sssphere.rendering import read_image  # after argparse: --help needs no build

    rows = []
    with tempfile.TemporaryDirectory(prefix="sssphere-ab-") as tmp:
        tmp = Path(tmp)
        for name, scene in sweep_scenes(tmp, args.size, args.boundary).items():
            for integrator in ("pt", "st"):
                times = {"a": [], "b": []}
                walls = {"a": [], "b": []}
                cpus = {"a": [], "b": []}
                for r in range(args.repeats):
                    order = ("a", "b") if r % 2 == 0 else ("b", "a")
                    for which in order:
                        binary = getattr(args, which)
                        out = tmp / f"{which}.exr"
                        seconds, wall, cpu = render(binary, scene, out, integrator, args)
                        times[which].append(seconds)
                        walls[which].append(wall)
                        cpus[which].append(cpu)
                diff = float(np.max(np.abs(read_image(tmp / "a.exr") - read_image(tmp / "b.exr"))))
                a, b = statistics.median(times["a"]), statistics.median(times["b"])
                wall_ratio = statistics.median(walls["b"]) / statistics.median(walls["a"])
                cpu_ratio = statistics.median(cpus["b"]) / statistics.median(cpus["a"])
                rows.append({"scene": name, "integrator": integrator, "a_s": times["a"],
                             "b_s": times["b"], "ratio": b / a, "a_wall_s": walls["a"],
                             "b_wall_s": walls["b"], "wall_ratio": wall_ratio,
                             "a_cpu_s": cpus["a"], "b_cpu_s": cpus["b"], "cpu_ratio": cpu_ratio,
                             "max_pixel_diff": diff})
                print(f"{name:16s} {integrator}  render a {a:7.2f} s  b {b:7.2f} s  b/a {b / a:6.3f}"
                      f"   wall b/a {wall_ratio:6.3f}   CPU b/a {cpu_ratio:6.3f}   max |a-b| {diff:.3g}", flush=True)
    summary = {}
    for integrator in ("pt", "st"):
        mine = [row for row in rows if row["integrator"] == integrator]
        summary[integrator] = {key: geomean([row[key] for row in mine])
                               for key in ("ratio", "wall_ratio", "cpu_ratio")}
        print(f"{integrator}: b/a geometric mean over {len(mine)} scenes: render"
              f" {summary[integrator]['ratio']:.3f}, wall {summary[integrator]['wall_ratio']:.3f},"
              f" CPU {summary[integrator]['cpu_ratio']:.3f}")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({
        "date": datetime.datetime.now().isoformat(timespec="seconds"),
        "machine": machine(), "a": args.a, "b": args.b, "spp": args.spp,
        "size": args.size, "threads": args.threads, "repeats": args.repeats,
        "boundary": args.boundary or "dielectric (the scene's)",
        "geomean_ratio": summary, "rows": rows}, indent=1) + "\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
