#!/usr/bin/env python3
"""How much of the entering direction a learned sphere step keeps (models/README.md, "Known
weaknesses"; docs/sphere-tracing.md, "The forward-memory tilt"): the mean exit cos θ of the
shipped models, with their tilt (tilt.json) and without it, against exact sphere walks over σ
and g (albedo 0.9999), split by log N into quintiles at the largest σ for g = 0.9 and 0.7,
and the images it makes: backlit index-matched slabs (0.2 thick, albedo 0.9999, eight (g, σt)
from (0.9, 2000) to (−0.5, 500), and one 0.1 thick at g 0.95, σt 1000, lit through by an area
light) rendered by `pt`, by `st` on exact walks, by `st` on the models without the tilt and
with it, image means over independent seeds. Seeds are fixed: a rerun gives the same numbers.

    python -m bench.forward_memory                 # ~15 min on 2 cores
    python -m bench.forward_memory --no-render     # the step statistics alone, ~4 min

Writes bench/results/forward_memory.json.
"""

from __future__ import annotations

import argparse
import datetime
import json
import tempfile
from pathlib import Path

import numpy as np

import sssphere

RESULTS = Path(__file__).resolve().parent / "results" / "forward_memory.json"


def step_statistics(sigmas: list[float], gs: list[float], n: int, models=None) -> list[dict]:
    model = sssphere.ScatteringModel.load(models)
    plain = sssphere.ScatteringModel.load(models, tilt=False)
    rows = []
    # Each cell its own seeds: with the same streams in every cell, one unlucky stretch of
    # draws moved every cell's mean alike. The models' samples are cheap: ten times the walks.
    for cell, (g, sigma) in enumerate((g, sigma) for g in gs for sigma in sigmas):
        a = model.sample(sigma_t=sigma, g=g, albedo=0.9999, n=10 * n, seed=2 * cell + 1)
        b = sssphere.sphere_walks(sigma, g, 0.9999, n, seed=2 * cell + 2)
        u = plain.sample(sigma_t=sigma, g=g, albedo=0.9999, n=10 * n, seed=2 * cell + 1)
        ca, cb = a["cos_theta"].astype(np.float64), b["cos_theta"].astype(np.float64)
        cu = u["cos_theta"].astype(np.float64)
        se = float(np.hypot(ca.std() / np.sqrt(10 * n), cb.std() / np.sqrt(n)))
        row = {"g": g, "sigma": sigma, "tilted": model.tilted,
               "model_mean_cos": float(ca.mean()),
               "walks_mean_cos": float(cb.mean()), "z": float((ca.mean() - cb.mean()) / se),
               "untilted_mean_cos": float(cu.mean()),
               "untilted_z": float((cu.mean() - cb.mean()) / se),
               "model_mean_log_N": float(np.log(a["N"]).mean()),
               "walks_mean_log_N": float(np.log(b["N"]).mean())}
        print(f"g {g:4} sigma {sigma:5}: mean cos {row['model_mean_cos']:+.4f} (model) "
              f"{row['walks_mean_cos']:+.4f} (walks), z {row['z']:+.1f} (untilted "
              f"{row['untilted_mean_cos']:+.4f}, z {row['untilted_z']:+.1f}); mean log N "
              f"{row['model_mean_log_N']:.3f} / {row['walks_mean_log_N']:.3f}", flush=True)
        if sigma == max(sigmas) and g in (0.9, 0.7):  # where the memory goes: by length
            la, lb = np.log(a["N"]), np.log(b["N"])
            edges = np.quantile(lb, np.linspace(0, 1, 6))
            row["by_log_N_quintile"] = [
                {"log_N": [float(lo), float(hi)],
                 "model_mean_cos": float(ca[(la >= lo) & (la <= hi)].mean()),
                 "model_share": float(((la >= lo) & (la <= hi)).mean()),
                 "walks_mean_cos": float(cb[(lb >= lo) & (lb <= hi)].mean()),
                 "walks_share": float(((lb >= lo) & (lb <= hi)).mean())}
                for lo, hi in zip(edges[:-1], edges[1:])]
        rows.append(row)
    return rows


# The step statistics' grid; the quintiles by log N at the largest σ for g = 0.9 and 0.7.
SIGMAS = [5.0, 10.0, 25.0, 50.0, 100.0, 200.0]
GS = [0.95, 0.9, 0.7, 0.0, -0.7]

# Backlit slabs, (g, σt): transmission through 20 to 200 reduced mean free paths, where each
# light path takes many sphere steps (7.5 and 9.4 per camera path on average at g = 0.9 and
# 0.95, the first and third) and a small bias per step adds up.
# The last, 0.1 thick, is a slab that played no part in choosing the shipped PathGen (a
# review found st +4.8 to +6.0 % too bright on it before the tilt).
SLABS = [(0.9, 2000.0, 0.2), (0.9, 1000.0, 0.2), (0.95, 3000.0, 0.2), (0.7, 700.0, 0.2),
         (0.7, 2000.0, 0.2), (0.0, 300.0, 0.2), (0.0, 1000.0, 0.2), (-0.5, 500.0, 0.2),
         (0.95, 1000.0, 0.1)]


def slab_scene(g: float = 0.9, sigma_t: float = 2000.0, thickness: float = 0.2) -> dict:
    # 1.4 wide, centred at the origin; the camera in front, the light behind
    x, y, z = 0.7, 0.7, thickness / 2
    v = [[sx * x, sy * y, sz * z] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    faces = [t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))]
    return {"camera": {"origin": [0, 0, 3], "target": [0, 0, 0], "up": [0, 1, 0], "fov": 20,
                       "width": 16, "height": 16},
            "shapes": [{"vertices": v, "faces": faces,
                        "medium": {"sigma_t": sigma_t, "albedo": 0.9999, "g": g},
                        "boundary": {"type": "index_matched"}}],
            "lights": [{"type": "area", "corner": [-1, -1, -1], "edge1": [2, 0, 0],
                        "edge2": [0, 2, 0], "radiance": 2}]}


def untilted_copy(models, directory: Path) -> str:
    """A model directory with the decoders of `models` (default: the shipped ones) and no
    tilt.json, for renders without the tilt."""
    from sssphere.model import DEFAULT_MODELS

    source = Path(models) if models else DEFAULT_MODELS
    for name in ("lengthgen.json", "pathgen.json", "eventgen.json"):
        (directory / name).symlink_to((source / name).resolve())
    return str(directory)


def slab_images(g: float, sigma_t: float, thickness: float, seeds: int, spp: int,
                models=None) -> dict:
    scene = sssphere.load_scene(slab_scene(g, sigma_t, thickness))
    out = {"g": g, "sigma_t": sigma_t, "thickness": thickness}
    with tempfile.TemporaryDirectory() as plain:
        integrators = (
            ("pt", {"integrator": "pt"}),
            ("st_walks", {"integrator": "st", "sphere_sampler": "walk"}),
            ("st_untilted", {"integrator": "st", "models": untilted_copy(models, Path(plain))}),
            ("st", {"integrator": "st", **({"models": models} if models else {})}))
        for name, options in integrators:
            means = [float(sssphere.render_full(scene, spp=spp, seed=10_000 * k + 7,
                                                **options).image.mean())
                     for k in range(seeds)]
            m, se = float(np.mean(means)), float(np.std(means, ddof=1) / np.sqrt(seeds))
            out[name] = {"mean": m, "standard_error": se}
    line = (f"slab g {g:5} sigma_t {sigma_t:6} thickness {thickness}: pt "
            f"{out['pt']['mean']:.5f}")
    for name in ("st_walks", "st_untilted", "st"):
        d = out[name]["mean"] - out["pt"]["mean"]
        out[name]["relative_to_pt"] = d / out["pt"]["mean"]
        out[name]["z"] = d / float(np.hypot(out[name]["standard_error"],
                                            out["pt"]["standard_error"]))
        line += (f"; {name} {100 * out[name]['relative_to_pt']:+5.1f} % "
                 f"(z {out[name]['z']:+5.1f})")
    print(line, flush=True)
    return out


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--samples", type=int, default=20_000, help="steps per (sigma, g) cell")
    p.add_argument("--seeds", type=int, default=64, help="renders of the slab per integrator")
    p.add_argument("--spp", type=int, default=64, help="samples per pixel of each render")
    p.add_argument("--no-render", action="store_true", help="the step statistics only")
    p.add_argument("--models", help="model directory to measure (default: the shipped models; "
                                    "then the results are not written)")
    args = p.parse_args()
    steps = step_statistics(SIGMAS, GS, args.samples, args.models)
    z = np.array([row["z"] for row in steps])
    zu = np.array([row["untilted_z"] for row in steps])
    summary = {"rms_z": float(np.sqrt(np.mean(z ** 2))), "max_abs_z": float(np.abs(z).max()),
               "untilted_rms_z": float(np.sqrt(np.mean(zu ** 2))),
               "untilted_max_abs_z": float(np.abs(zu).max())}
    print(f"mean cos θ over {len(steps)} cells: rms z {summary['rms_z']:.2f}, "
          f"max |z| {summary['max_abs_z']:.1f} (untilted: {summary['untilted_rms_z']:.2f}, "
          f"{summary['untilted_max_abs_z']:.1f})", flush=True)
    result = {"date": datetime.date.today().isoformat(), "albedo": 0.9999,
              "samples": args.samples, "steps": steps, "steps_summary": summary}
    if not args.no_render:
        result["slabs"] = {"seeds": args.seeds, "spp": args.spp,
                           "cells": [slab_images(g, s, thickness, args.seeds, args.spp,
                                                 args.models)
                                     for g, s, thickness in SLABS]}
    if args.models:
        return
    RESULTS.parent.mkdir(exist_ok=True)
    RESULTS.write_text(json.dumps(result, indent=1) + "\n")
    print(f"wrote {RESULTS}")


if __name__ == "__main__":
    main()
