#!/usr/bin/env python3
"""Geometric robustness: the same picture wherever the scene sits and however big it is.

Three measurements (docs/robustness.md explains what they test):

* framed sphere: a black, optically thick sphere (radius 1, sigma_t 1000, albedo 0) under a
  constant environment of 1, seen from d radii away with fov = 2 asin(1/d) / 0.8, so that it
  fills the same part of the image at every d. Every pixel whose footprint lies inside the
  silhouette must be exactly 0; "leaking" counts those that are not, "partly covered" the
  pixels strictly between 0 and 1.
* scale: a scattering sphere scaled by k (lengths x k, sigma / k, point intensity x k^2):
  the image must not change. Per channel, the relative difference of the image mean to
  k = 1 and its z-score (from the renders' variances).
* translation: a small sphere (radius 0.1) and its camera and lights moved by T.
* scale limits: an opaque diffuse sphere of radius k/2 (extent k) under an environment and a
  point light, at extents up to the parser's limits [1e-8, 1e10] against extent 1, and
  just past them, where the scene must be refused (the message is recorded).

    python -m bench.robustness            # ~2 min on 2 cores
    python -m bench.robustness --quick    # fewer cases and samples

Writes bench/results/robustness.json.
"""

from __future__ import annotations

import argparse
import datetime
import json
import math
from pathlib import Path

import numpy as np

import sssphere
from bench.machine import machine

RESULTS = Path(__file__).resolve().parent / "results"


def framed_sphere_scene(d: float, res: int = 64, shape: str = "sphere") -> dict:
    fov = math.degrees(2 * math.asin(1 / d) / 0.8)
    geometry = ({"sphere": {"center": [0, 0, 0], "radius": 1, "subdivisions": 5}} if shape == "sphere"
                else {"mesh": str(Path(__file__).resolve().parents[1] / "scenes" / "thin_torus.ply")})
    return {
        "camera": {"origin": [0, 0, d], "target": [0, 0, 0], "up": [0, 1, 0], "fov": fov,
                   "width": res, "height": res},
        "shapes": [{"name": "black", **geometry,
                    "medium": {"sigma_t": 1000, "albedo": 0, "g": 0},
                    "boundary": {"type": "index_matched"}}],
        "lights": [{"type": "environment", "radiance": 1}],
        "render": {"spp": 16, "seed": 3},
    }


def silhouette_radius(d: float) -> float:
    """The sphere's silhouette radius in units of the image's half-height: the tangent of
    its angular radius asin(1/d) over that of half the fov (0.8 only as d -> inf)."""
    return math.tan(math.asin(1 / d)) / math.tan(math.asin(1 / d) / 0.8)


def inner_disc(res: int, d: float, fraction: float = 0.95) -> np.ndarray:
    """Pixels whose whole footprint lies within `fraction` of the silhouette's radius."""
    c = (np.arange(res) + 0.5) / res * 2 - 1
    x, y = np.meshgrid(c, c)
    corner = np.hypot(np.abs(x) + 1 / res, np.abs(y) + 1 / res)
    return corner < silhouette_radius(d) * fraction


def framed_sphere(ds, integrators, spp: int, backend: str) -> list[dict]:
    rows = []
    for integrator in integrators:
        for d in ds:
            scene = sssphere.load_scene(framed_sphere_scene(d))
            r = sssphere.render_full(scene, integrator=integrator, spp=spp, seed=3, backend=backend)
            lum = r.image.mean(axis=2)
            inside = inner_disc(lum.shape[0], d)
            rows.append({"integrator": integrator, "d": d, "mean": float(lum.mean()),
                         "partly_covered": int(((lum > 0) & (lum < 1)).sum()),
                         "leaking": int((lum[inside] > 0).sum()), "inner_pixels": int(inside.sum())})
            print(f"framed sphere {integrator} d={d:g}: mean {rows[-1]['mean']:.4f}, "
                  f"partly covered {rows[-1]['partly_covered']}, leaking {rows[-1]['leaking']}",
                  flush=True)
    return rows


def scattering_scene(k: float = 1.0, t: float = 0.0, radius: float = 1.0, res: int = 48) -> dict:
    """A sphere of `radius` (sigma_t 20 / radius) with a point light and an environment,
    every length scaled by k and every position moved by t along (1, 1, 1)."""
    def at(p):
        return [k * c + t for c in p]
    sigma = 20.0 / radius / k
    return {
        "camera": {"origin": at([0, 0, 4 * radius]), "target": at([0, 0, 0]), "up": [0, 1, 0],
                   "fov": 30, "width": res, "height": res},
        "shapes": [{"name": "ball", "sphere": {"center": [0, 0, 0], "radius": radius, "subdivisions": 4},
                    "transform": {"scale": k, "translate": [t, t, t]},
                    "medium": {"sigma_t": sigma, "albedo": [0.95, 0.9, 0.8], "g": 0.3},
                    "boundary": {"type": "index_matched"}}],
        "lights": [{"type": "point", "position": at([3 * radius, 3 * radius, 3 * radius]),
                    "intensity": 10 * (k * radius) ** 2},
                   {"type": "environment", "radiance": 0.1}],
        "render": {"spp": 64, "seed": 1},
    }


def compare(ref, other) -> dict:
    """Per channel: relative difference of the image means and its z-score."""
    n = ref.image.shape[0] * ref.image.shape[1]
    m0, m1 = ref.image.reshape(-1, 3).mean(0), other.image.reshape(-1, 3).mean(0)
    se = np.sqrt(ref.variance.reshape(-1, 3).sum(0) + other.variance.reshape(-1, 3).sum(0)) / n
    return {"rel_diff": [float(x) for x in (m1 - m0) / m0], "z": [float(x) for x in (m1 - m0) / se],
            "identical": bool(np.array_equal(ref.image, other.image))}


def invariance(cases, integrator: str, spp: int, radius: float, label: str, backend: str) -> list[dict]:
    def render(scene):
        return sssphere.render_full(scene, integrator=integrator, spp=spp, seed=1, backend=backend)

    ref = render(scattering_scene(radius=radius))
    rows = []
    for k, t in cases:
        r = render(scattering_scene(k, t, radius))
        row = {"integrator": integrator, "k": k, "t": t, "radius": radius, **compare(ref, r)}
        rows.append(row)
        print(f"{label} {integrator} k={k:g} t={t:g}: rel. diff (r, g, b) "
              + ", ".join(f"{x:+.4f}" for x in row["rel_diff"]) + "  z "
              + ", ".join(f"{x:+.1f}" for x in row["z"]) + ("  (identical)" if row["identical"] else ""),
              flush=True)
    return rows


def lit_ball(extent: float, res: int = 32) -> dict:
    """An opaque diffuse ball `extent` across under an environment and a point light."""
    k = extent / 2
    return {"camera": {"origin": [0.3 * k, 0.2 * k, 4 * k], "target": [0, 0, 0], "fov": 30,
                       "width": res, "height": res},
            "shapes": [{"sphere": {"center": [0, 0, 0], "radius": k},
                        "surface": {"type": "diffuse", "reflectance": 0.5}}],
            "lights": [{"type": "environment", "radiance": 1},
                       {"type": "point", "position": [3 * k, 3 * k, 3 * k], "intensity": 20 * k * k}]}


def scale_limits(spp: int) -> list[dict]:
    def render(extent):
        return sssphere.render_full(lit_ball(extent), integrator="pt", spp=spp, seed=2)

    ref, rows = render(1.0), []
    for extent in (1.01e-8, 1e-4, 1e4, 0.99e10):  # an icosphere is a hair narrower than its sphere
        rows.append({"extent": extent, **compare(ref, render(extent))})
        print(f"scale limits extent={extent:g}: rel. diff " + ", ".join(f"{x:+.2e}" for x in rows[-1]["rel_diff"])
              + "  z " + ", ".join(f"{x:+.1f}" for x in rows[-1]["z"]), flush=True)
    for extent in (5e-9, 2e10):
        try:
            sssphere.load_scene(lit_ball(extent))
            refused = None
        except sssphere.SceneError as e:
            refused = str(e)
        rows.append({"extent": extent, "refused": refused})
        print(f"scale limits extent={extent:g}: " + (f"refused: {refused}" if refused else "NOT refused"), flush=True)
    return rows


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--quick", action="store_true")
    p.add_argument("--backend", default="cpu", choices=["cpu", "vulkan"])
    p.add_argument("--output", type=Path, default=RESULTS / "robustness.json")
    args = p.parse_args(argv)
    spp = 16 if args.quick else 64
    ds = [3, 50, 1000] if args.quick else [2, 3, 10, 50, 200, 1000, 10000]
    integrators = ["pt"] if args.quick else ["pt", "st"]
    scales = [(k, 0.0) for k in ([1e-3, 1e3] if args.quick else [1e-4, 1e-3, 1e-2, 1e2, 1e3, 1e4])]
    moves = [(1.0, t) for t in ([1e3] if args.quick else [1e2, 1e3, 1e4])]
    result = {
        "date": datetime.datetime.now().isoformat(timespec="seconds"),
        "machine": machine(),
        "version": sssphere.__version__,
        "framed_sphere": framed_sphere(ds, integrators, spp, args.backend),
        "scale": [row for i in integrators
                  for row in invariance(scales, i, spp, 1.0, "scale", args.backend)],
        "translation": [row for i in integrators
                        for row in invariance(moves, i, spp, 0.1, "translation", args.backend)],
        "scale_limits": scale_limits(spp),
    }
    args.output.parent.mkdir(parents=True, exist_ok=True)
    args.output.write_text(json.dumps(result, indent=1) + "\n")
    print(f"wrote {args.output}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
