#!/usr/bin/env python3
"""Distance grids of optically small media (issue: load time of small scenes): what 16, 32
and 64 cells cost to build and what they save in the render, on scenes/sphere.json (a unit
ball) at a few densities. Since 2026-11-30 a medium at most 16 (32) mean free paths across
gets 16 (32) cells by default (render/scene.h, auto_grid_resolution); this measures why.

Per density and grid: the load time, and the median render time of three interleaved
renders (`pt` and `st`, 2 threads, 32 spp, 128 x 128) with the steps `st` takes per path.

    python -m bench.small_media              # sigma_t 10 and 30 (~2 min on 2 cores)

Writes bench/results/small_media.json.
"""

from __future__ import annotations

import argparse
import datetime
import json
import time
from pathlib import Path

import numpy as np

import sssphere
from bench.machine import machine

HERE = Path(__file__).resolve().parent
CELLS = (16, 32, 64)


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--sigma-t", type=float, nargs="+", default=[10.0, 30.0])
    p.add_argument("--spp", type=int, default=32)
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--output", type=Path, default=HERE / "results" / "small_media.json")
    a = p.parse_args(argv)
    base = json.loads((HERE.parent / "scenes" / "sphere.json").read_text())
    rows = []
    for sigma in a.sigma_t:
        scene = json.loads(json.dumps(base))
        scene["shapes"][0]["medium"]["sigma_t"] = sigma
        scenes, loads = {}, {}
        for cells in CELLS:
            scene.setdefault("render", {})["grid_resolution"] = cells
            t = time.monotonic()
            scenes[cells] = sssphere.load_scene(scene, threads=2)
            loads[cells] = time.monotonic() - t
        times, steps = {}, {}
        for rep in range(a.repeats):  # interleaved: the host's drift hits all alike
            for integrator in ("pt", "st"):
                for cells in CELLS:
                    r = sssphere.render_full(scenes[cells], integrator=integrator, spp=a.spp,
                                             seed=rep, threads=2)
                    times.setdefault((integrator, cells), []).append(r.seconds)
                    steps[(integrator, cells)] = r.mean_sphere_steps_per_path
        for cells in CELLS:
            row = {"sigma_t": sigma, "mean_free_paths_across": 2 * sigma, "cells": cells,
                   "load_seconds": loads[cells],
                   **{f"{i}_seconds": float(np.median(times[(i, cells)])) for i in ("pt", "st")},
                   "st_steps_per_path": steps[("st", cells)]}
            rows.append(row)
            print(f"sigma_t {sigma:g} ({2 * sigma:g} mfp across), {cells:3d} cells: load "
                  f"{row['load_seconds']:.2f} s, pt {row['pt_seconds']:.3f} s, st "
                  f"{row['st_seconds']:.3f} s ({row['st_steps_per_path']:.3f} steps/path)",
                  flush=True)
    a.output.parent.mkdir(parents=True, exist_ok=True)
    a.output.write_text(json.dumps({"date": datetime.date.today().isoformat(),
                                    "machine": machine(), "spp": a.spp, "rows": rows},
                                   indent=1) + "\n")
    print(f"wrote {a.output}")


if __name__ == "__main__":
    main()
