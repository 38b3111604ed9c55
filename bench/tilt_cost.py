#!/usr/bin/env python3
"""What the forward-memory tilt (models/tilt.json; docs/sphere-tracing.md, "The forward-memory
tilt") costs and what it changes behind a rough dielectric, the two checks of 2026-12-01 that
bench/forward_memory.py does not make.

1. Cost: `st` on the bunny (bench/st_vs_pt.py's scenes, σt = 1000, dielectric and
   index-matched, 64×64, 64 spp, one thread) with the shipped models and with their decoders
   alone (no tilt.json), alternated; render time and time per step, medians.
2. A thin backlit layer (0.1 thick, g 0.95) behind a rough dielectric (η 1.33, α 0.3) at
   σt = 500, 1000, 2000: image means of `st` with and without the tilt against `pt`,
   16 seeds × 64 spp each.
3. The issue's headline case, the dielectric bunny at σt = 1000 (64×64): image means of `st`
   with and without the tilt against `pt`, 16 seeds × 512 spp each (8192 spp per
   integrator), standard errors from the spread of the seeds' means. Does the tilt's
   +0.3 % shift of this image (bench/README.md, "The forward-memory tilt") move it towards
   `pt` or away?

    python -m bench.tilt_cost                  # all three, ~14 min on 2 cores
    python -m bench.tilt_cost --parts bunny    # the third alone, ~8 min

Writes bench/results/tilt_cost.json (the parts run replace theirs, the others are kept).
"""

from __future__ import annotations

import argparse
import datetime
import json
import math
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

import sssphere
from bench.forward_memory import slab_scene, untilted_copy
from bench.st_vs_pt import scene_dict

RESULTS = Path(__file__).resolve().parent / "results" / "tilt_cost.json"


def cost(plain: str, runs: int) -> dict:
    out = {}
    for boundary in ("dielectric", "index_matched"):
        scene = sssphere.load_scene(scene_dict("bunny", boundary, 1000.0, 64))
        rows = {"untilted": [], "tilted": []}
        for k in range(runs):
            order = ("untilted", "tilted") if k % 2 == 0 else ("tilted", "untilted")
            for name in order:
                kw = {"models": plain} if name == "untilted" else {}
                t = time.perf_counter()
                r = sssphere.render_full(scene, integrator="st", spp=64, seed=k + 1, threads=1,
                                         **kw)
                seconds = time.perf_counter() - t
                steps = r.mean_sphere_steps_per_path * 64 ** 3
                rows[name].append({"seconds": seconds, "step_ns": 1e9 * r.step_seconds / steps})
        med = {n: {k: statistics.median(x[k] for x in v) for k in ("seconds", "step_ns")}
               for n, v in rows.items()}
        out[boundary] = {"runs": rows, "medians": med,
                         "time_ratio": med["tilted"]["seconds"] / med["untilted"]["seconds"],
                         "step_ratio": med["tilted"]["step_ns"] / med["untilted"]["step_ns"]}
        print(f"bunny {boundary}: render x{out[boundary]['time_ratio']:.3f}, step "
              f"{med['untilted']['step_ns']:.0f} -> {med['tilted']['step_ns']:.0f} ns", flush=True)
    return out


def rough_layer(plain: str, seeds: int) -> list[dict]:
    cells = []
    for sigma_t in (500.0, 1000.0, 2000.0):
        d = slab_scene(0.95, sigma_t, 0.1)
        d["shapes"][0]["boundary"] = {"type": "dielectric", "ior": 1.33, "roughness": 0.3}
        scene = sssphere.load_scene(d)
        cell = {"sigma_t": sigma_t}
        for name, kw in (("pt", {"integrator": "pt"}),
                         ("st_untilted", {"integrator": "st", "models": plain}),
                         ("st", {"integrator": "st"})):
            means = [float(sssphere.render_full(scene, spp=64, seed=1000 * k + 3, **kw).image.mean())
                     for k in range(seeds)]
            cell[name] = {"mean": float(np.mean(means)),
                          "standard_error": float(np.std(means, ddof=1) / math.sqrt(seeds))}
        line = f"rough layer sigma_t {sigma_t:g}:"
        for name in ("st_untilted", "st"):
            diff = cell[name]["mean"] - cell["pt"]["mean"]
            cell[name]["relative_to_pt"] = diff / cell["pt"]["mean"]
            cell[name]["z"] = diff / math.hypot(cell[name]["standard_error"],
                                                cell["pt"]["standard_error"])
            line += f" {name} {100 * cell[name]['relative_to_pt']:+.1f} % (z {cell[name]['z']:+.1f})"
        print(line, flush=True)
        cells.append(cell)
    return cells


def bunny_mean(plain: str, seeds: int, spp: int) -> dict:
    scene = sssphere.load_scene(scene_dict("bunny", "dielectric", 1000.0, 64))
    out = {"sigma_t": 1000.0, "boundary": "dielectric", "seeds": seeds, "spp": spp}
    for name, kw in (("pt", {"integrator": "pt"}),
                     ("st_untilted", {"integrator": "st", "models": plain}),
                     ("st", {"integrator": "st"})):
        # One image mean per seed and channel; the seeds are independent renders.
        means = np.array([sssphere.render_full(scene, spp=spp, seed=7919 * k + 5, **kw)
                          .image.astype(np.float64).mean(axis=(0, 1)) for k in range(seeds)])
        out[name] = {"mean": means.mean(axis=0).tolist(),
                     "standard_error": (means.std(axis=0, ddof=1) / math.sqrt(seeds)).tolist(),
                     "seed_means": means.tolist()}
    pt_mean, pt_se = np.array(out["pt"]["mean"]), np.array(out["pt"]["standard_error"])
    for name in ("st_untilted", "st"):
        mean, se = np.array(out[name]["mean"]), np.array(out[name]["standard_error"])
        out[name]["relative_to_pt"] = ((mean - pt_mean) / pt_mean).tolist()
        out[name]["relative_standard_error"] = (np.hypot(se, pt_se) / pt_mean).tolist()
        print(f"bunny dielectric sigma_t 1000, {seeds} x {spp} spp, {name} vs pt (R, G, B): "
              + ", ".join(f"{100 * d:+.2f} ± {100 * e:.2f} %" for d, e in
                          zip(out[name]["relative_to_pt"], out[name]["relative_standard_error"])),
              flush=True)
    return out


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--runs", type=int, default=4, help="renders per model set for the cost")
    p.add_argument("--seeds", type=int, default=16,
                   help="renders per integrator, rough layer and bunny")
    p.add_argument("--bunny-spp", type=int, default=512, help="spp of each bunny render")
    p.add_argument("--parts", nargs="+", choices=("cost", "rough_layer", "bunny"),
                   default=["cost", "rough_layer", "bunny"], help="which checks to run")
    args = p.parse_args()
    result = json.loads(RESULTS.read_text()) if RESULTS.exists() else {}
    with tempfile.TemporaryDirectory() as d:
        plain = untilted_copy(None, Path(d))
        parts = {"cost": lambda: cost(plain, args.runs),
                 "rough_layer": lambda: rough_layer(plain, args.seeds),
                 "bunny": lambda: bunny_mean(plain, args.seeds, args.bunny_spp)}
        for name in args.parts:
            result[name] = parts[name]()
            result.setdefault("dates", {})[name] = datetime.date.today().isoformat()
    RESULTS.write_text(json.dumps(result, indent=1) + "\n")
    print(f"wrote {RESULTS}")


if __name__ == "__main__":
    main()
