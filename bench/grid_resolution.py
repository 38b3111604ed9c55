#!/usr/bin/env python3
"""The distance grid's resolution against render time (issue 26): `pt` and `st` per grid.

The bunny of bench/st_vs_pt.py (64x64, g = 0.9) with each of ``--boundaries``, at each σt
of ``--sigmas``, with the grid pinned to each of ``--resolutions`` cells
(`render.grid_resolution`): the grid's build time (the scene's load), its size, and per
integrator the render time (the best of ``--repeats`` renders, interleaved over integrators
and grids), the events and steps per path and the image
mean with its standard error. The grid's bound is loosest within a cell of the surface,
where `st` leaves its events: a finer grid lets paths step closer to the surface, but it
is larger (its cache misses slow the queries that remain: `pt`'s at flight ends near the
surface and, in index-matched media, for light sampling at every collision) and slower to
build. `Scene::auto_grid_resolution` follows these numbers.

    python -m bench.grid_resolution                  # ~8 min on 2 cores
    python -m bench.grid_resolution --boundaries dielectric --sigmas 4000 --repeats 2

Writes bench/results/grid_resolution.json.
"""

from __future__ import annotations

import argparse
import datetime
import json
import math
import time
from pathlib import Path

import numpy as np

import sssphere
from bench.machine import machine
from bench.st_vs_pt import scene_dict

HERE = Path(__file__).resolve().parent
REPO = HERE.parent


def grid_megabytes(scene, resolution: int) -> float:
    """What the grid holds: a float distance and a byte of side per node, the nodes
    spanning the mesh's bounds plus a cell of padding on each side
    (geometry/distance_grid.h)."""
    positions = np.asarray(scene.shape_mesh(0)[0], dtype=np.float64)
    extent = positions.max(axis=0) - positions.min(axis=0)
    cell = float(extent.max()) / resolution
    nodes = math.prod(math.ceil(e / cell) + 3 for e in extent)
    return nodes * 5 / 1e6


def image_mean(r) -> tuple[list[float], list[float]]:
    """The image's mean per channel and its standard error (from the per-pixel variance of
    the mean)."""
    n = r.image.shape[0] * r.image.shape[1]
    mean = np.nanmean(r.image.astype(np.float64), axis=(0, 1))
    se = np.sqrt(np.nansum(r.variance.astype(np.float64), axis=(0, 1))) / n
    return mean.tolist(), se.tolist()


def measure(boundary: str, sigma: float, args) -> list[dict]:
    """One row per grid resolution for the bunny with `boundary` at extinction `sigma`. The
    scenes are all loaded first, then rendered in turns (each repeat runs every integrator
    on every grid, the grids' order reversed every other repeat), so that a drift of this
    host's speed falls on all of them alike."""
    scenes, loads = {}, {}
    for res in args.resolutions:
        d = scene_dict("bunny", boundary, sigma, 64)
        d["render"] = {"grid_resolution": res}
        t0 = time.perf_counter()
        scenes[res] = sssphere.load_scene(d, threads=args.threads)
        loads[res] = time.perf_counter() - t0
    seconds = {(res, name): [] for res in scenes for name in ("pt", "st")}
    last = {}
    for repeat in range(args.repeats):
        order = list(scenes) if repeat % 2 == 0 else list(reversed(scenes))
        for name in ("pt", "st"):
            for res in order:
                r = sssphere.render_full(scenes[res], spp=args.spp, seed=7,
                                         threads=args.threads, integrator=name,
                                         models=args.models if name == "st" else None)
                seconds[res, name].append(r.seconds)
                last[res, name] = r
    rows = []
    for res, scene in scenes.items():
        row = {"boundary": boundary, "sigma_t": sigma, "grid_resolution": res,
               "load_seconds": loads[res], "grid_megabytes": grid_megabytes(scene, res),
               "integrators": {}}
        for name in ("pt", "st"):
            r = last[res, name]
            mean, se = image_mean(r)
            row["integrators"][name] = {
                "seconds": min(seconds[res, name]), "all_seconds": seconds[res, name],
                "events_per_path": r.mean_events_per_path,
                "steps_per_path": r.mean_sphere_steps_per_path,
                "image_mean": mean, "image_mean_stderr": se}
        it = row["integrators"]
        row["st_over_pt_speedup"] = it["pt"]["seconds"] / it["st"]["seconds"]
        rows.append(row)
        print(f"{boundary}, sigma_t {sigma:g}, {res} cells: load {loads[res]:.1f}s, "
              f"{row['grid_megabytes']:.0f} MB; " + "; ".join(
                  f"{n} {v['seconds']:.3f}s, {v['events_per_path']:.1f} events + "
                  f"{v['steps_per_path']:.2f} steps/path" for n, v in it.items())
              + f"; x{row['st_over_pt_speedup']:.2f}", flush=True)
    return rows


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--sigmas", nargs="+", type=float, default=[1000.0, 1500.0, 2000.0, 3000.0, 4000.0, 8000.0])
    p.add_argument("--boundaries", nargs="+", default=["dielectric", "index-matched"],
                   choices=["dielectric", "index-matched"])
    p.add_argument("--resolutions", nargs="+", type=int, default=[128, 256])
    p.add_argument("--spp", type=int, default=64)
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--threads", type=int, default=2)
    p.add_argument("--models", default=str(REPO / "models"))
    p.add_argument("--out", default=str(HERE / "results" / "grid_resolution.json"))
    args = p.parse_args()

    rows = []
    for boundary in args.boundaries:
        for sigma in args.sigmas:
            rows += measure(boundary, sigma, args)
    out = {"date": datetime.datetime.now().isoformat(timespec="seconds"),
           "machine": machine(), "spp": args.spp, "repeats": args.repeats,
           "threads": args.threads, "rows": rows}
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps(out, indent=1) + "\n", encoding="utf-8")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
