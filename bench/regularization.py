#!/usr/bin/env python3
"""Smooth dielectric under the sun: how path regularization (a smooth boundary's
`regularization` alpha, docs/notation.md "Regularization") approaches the rough interface's
alpha -> 0 limit, and what it costs in noise.

The scene: the bunny (largest side 1) of a dense, nearly white medium (g = 0.9) behind a
dielectric boundary (eta = 1.5), lit by a directional light and a dim constant environment.
Rendered with `pt` at equal spp: the smooth boundary with regularization 0 (the sun cannot
reach the medium: what Mitsuba 3 renders), with several regularization alphas, and rough
boundaries of alpha 0.08, 0.02 and 0.01 (`st` too at the default regularization: its speed,
and its difference to `pt`). Every render has a seed of its own.

Per render: the mean over the bunny's pixels with its standard error (from the renders'
own per-pixel variances), the mean relative per-pixel variance (noise), the render time;
against the rough render of the same alpha, the difference of the means in standard errors;
and the sRGB RMSE between each pair, with the RMSE that noise alone would give.

    python -m bench.regularization                 # 48 x 48, 1024 spp, sigma_t 250 (~3 min)
    python -m bench.regularization --quick         # 16 x 16, 16 spp: a smoke run

Writes bench/results/regularization.json.
"""

from __future__ import annotations

import argparse
import datetime
import json
from pathlib import Path

import numpy as np

import sssphere
from bench.machine import machine

HERE = Path(__file__).resolve().parent
BUNNY = "/usr/share/glmark2/models/bunny.obj"
REGULARIZATIONS = [0.0, 0.16, 0.08, 0.05, 0.02, 0.01]
ROUGHNESSES = [0.08, 0.02, 0.01]
DEFAULT = 0.05  # render/boundaries/dielectric.h kDefaultRegularization


def scene_dict(res: int, sigma_t: float, boundary: dict) -> dict:
    return {
        "camera": {"origin": [0, 0.1, 2.6], "target": [0, 0, 0], "up": [0, 1, 0], "fov": 30,
                   "width": res, "height": res},
        "shapes": [{"name": "bunny", "mesh": BUNNY, "normalize": True,
                    "medium": {"sigma_t": sigma_t, "albedo": [0.999, 0.9995, 0.999], "g": 0.9},
                    "boundary": {"type": "dielectric", "ior": 1.5, **boundary}}],
        "lights": [
            {"type": "directional", "direction": [-0.4, -1, -0.5], "irradiance": [3, 3, 3]},
            {"type": "environment", "radiance": [0.05, 0.05, 0.05]},
        ],
    }


def srgb(x: np.ndarray) -> np.ndarray:
    x = np.clip(x, 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--res", type=int, default=48)
    p.add_argument("--spp", type=int, default=1024)
    p.add_argument("--sigma-t", type=float, default=250.0)
    p.add_argument("--quick", action="store_true", help="16 x 16, 16 spp")
    p.add_argument("--output", type=Path, default=HERE / "results" / "regularization.json")
    a = p.parse_args(argv)
    if a.quick:
        a.res, a.spp = 16, 16

    variants = [(f"smooth, regularization {r:g}", "pt", {"regularization": r})
                for r in REGULARIZATIONS]
    # regularization 0: the rough interface's own lobe for the sun too (since 2026-11-30 a
    # rough interface below the regularization takes its lobe for point and directional
    # lights, which would make these rows the regularized ones)
    variants += [(f"rough {r:g}", "pt", {"roughness": r, "regularization": 0})
                 for r in ROUGHNESSES]
    variants += [(f"smooth, regularization {DEFAULT:g}, st", "st", {"regularization": DEFAULT})]
    renders, rows = {}, {}
    mask = None
    for seed, (name, integrator, boundary) in enumerate(variants, 1):
        scene = sssphere.load_scene(scene_dict(a.res, a.sigma_t, boundary))
        r = sssphere.render_full(scene, integrator=integrator, spp=a.spp, seed=seed)
        if mask is None:  # the bunny's pixels: not the environment's exact 0.05
            mask = np.any(np.abs(r.image - 0.05) > 1e-6, axis=2)
        img, var = r.image[mask].astype(np.float64), r.variance[mask].astype(np.float64)
        n = img.size
        rows[name] = {"integrator": integrator, "boundary": boundary, "seconds": r.seconds,
                      "mean": float(img.mean()), "standard_error": float(np.sqrt(var.sum()) / n),
                      "relative_pixel_variance": float(var.mean() / max(img.mean(), 1e-12) ** 2)}
        renders[name] = r
        print(f"{name:34s} mean {img.mean():.4f} +- {rows[name]['standard_error']:.4f}  "
              f"rel. pixel var {rows[name]['relative_pixel_variance']:.3g}  {r.seconds:.1f} s",
              flush=True)

    def compare(x: str, y: str) -> dict:
        a_, b_ = renders[x], renders[y]
        d = rows[x]["mean"] - rows[y]["mean"]
        se = np.hypot(rows[x]["standard_error"], rows[y]["standard_error"])
        diff = srgb(a_.image[mask]) - srgb(b_.image[mask])
        # noise alone: the sRGB slope times the pixels' standard deviations, added
        slope = lambda img: np.gradient(srgb(np.linspace(0, 1, 4097)))[  # noqa: E731
            np.clip((img * 4096).astype(int), 0, 4096)] * 4096
        noise = np.sqrt(np.mean(slope(a_.image[mask]) ** 2 * a_.variance[mask]
                                + slope(b_.image[mask]) ** 2 * b_.variance[mask]))
        return {"mean_difference": float(d), "z": float(d / se),
                "relative_difference": float(d / rows[y]["mean"]),
                "srgb_rmse": float(np.sqrt(np.mean(diff ** 2))), "srgb_rmse_noise": float(noise)}

    comparisons = {}
    for r in ROUGHNESSES:
        for reg in REGULARIZATIONS[1:]:
            comparisons[f"regularization {reg:g} vs rough {r:g}"] = compare(
                f"smooth, regularization {reg:g}", f"rough {r:g}")
    comparisons["rough 0.02 vs rough 0.01"] = compare("rough 0.02", "rough 0.01")
    comparisons[f"st vs pt, regularization {DEFAULT:g}"] = compare(
        f"smooth, regularization {DEFAULT:g}, st", f"smooth, regularization {DEFAULT:g}")
    for k, c in comparisons.items():
        print(f"{k:40s} mean diff {c['relative_difference']:+.3%} (z {c['z']:+.1f})  "
              f"sRGB RMSE {c['srgb_rmse']:.4f} (noise alone {c['srgb_rmse_noise']:.4f})")
    st = rows[f"smooth, regularization {DEFAULT:g}, st"]
    pt = rows[f"smooth, regularization {DEFAULT:g}"]
    out = {"date": datetime.date.today().isoformat(), "machine": machine(),
           "res": a.res, "spp": a.spp,
           "sigma_t": a.sigma_t, "pixels": int(mask.sum()), "renders": rows,
           "comparisons": comparisons, "st_speedup": pt["seconds"] / st["seconds"]}
    a.output.parent.mkdir(parents=True, exist_ok=True)
    a.output.write_text(json.dumps(out, indent=1) + "\n")
    print(f"st / pt speed-up at regularization {DEFAULT:g}: {out['st_speedup']:.2f}; "
          f"wrote {a.output}")


if __name__ == "__main__":
    main()
