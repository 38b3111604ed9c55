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
* gaps: two media a gap apart, from 1.5e-7 of the scene (refused) to 1e-4, against 1e-3.
* contact: a cube resting on a floor, lifted off it and cut by it: pixels lit under the
  floor (must be 0), and resting against lifted seen from above (image and time).

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


def rotation(axis, angle: float) -> np.ndarray:
    """The rotation by `angle` (radians) about `axis` (Rodrigues' formula)."""
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    k = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + math.sin(angle) * k + (1 - math.cos(angle)) * k @ k


def two_slabs(gap: float) -> dict:
    """Two index-matched slabs side by side, `gap` apart, turned about an oblique axis; a
    black floor makes the scene 2 across with the gap near its edge (coordinates ~0.8,
    where the rays' offsets are largest). The light reaches the camera only through the
    gap: it lights the first slab, the camera sees the second."""
    turn = rotation([1.0, 2.0, 0.5], 0.7)

    def box(lo, hi, name):
        corners = [[(lo, hi)[(c >> i) & 1][i] for i in range(3)] for c in range(8)]
        return {"name": name, "vertices": [(turn @ c).tolist() for c in corners],
                "faces": [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3],
                          [1, 3, 7, 5], [0, 4, 6, 2]],
                "medium": {"sigma_t": 30, "albedo": 0.995}, "boundary": {"type": "index_matched"}}

    x0 = 0.69
    floor = [(turn @ [x, -1.0, z]).tolist() for x, z in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
    return {"camera": {"origin": (turn @ [3.0, 0, 0]).tolist(),
                       "target": (turn @ [x0 + 0.1, 0, 0]).tolist(),
                       "up": (turn @ [0, 1.0, 0]).tolist(), "fov": 20, "width": 32, "height": 32},
            "shapes": [box([x0 - 0.1, -0.5, -0.5], [x0, 0.5, 0.5], "first"),
                       box([x0 + gap, -0.5, -0.5], [x0 + 0.1 + gap, 0.5, 0.5], "second"),
                       {"vertices": floor, "faces": [[0, 1, 2, 3]],
                        "surface": {"type": "diffuse", "reflectance": 0}}],
            "lights": [{"type": "point", "position": (turn @ [-1.0, 0, 0]).tolist(),
                        "intensity": 50}]}


def cube_on_floor(lift: float, turn=None, floor_y: float = 0.0, floor_x=(-2.0, 2.0),
                  boundary: str | None = None) -> dict:
    """A unit cube of medium `lift` above a diffuse floor (x from floor_x[0] to floor_x[1], z
    from -2 to 2), all turned by `turn`; a point light above, the camera below the floor
    looking up at the cube."""
    turn = np.eye(3) if turn is None else turn
    h = 0.5
    cube = [[x, floor_y + lift + y + h, z] for x in (-h, h) for y in (-h, h) for z in (-h, h)]
    x0, x1 = floor_x
    floor = [[x0, floor_y, -2], [x1, floor_y, -2], [x1, floor_y, 2], [x0, floor_y, 2]]
    t = lambda points: [(turn @ p).tolist() for p in points]  # noqa: E731
    medium = {"sigma_t": 5, "albedo": 0.99}
    return {"camera": {"origin": (turn @ [0.3, floor_y - 3, 0.4]).tolist(),
                       "target": (turn @ [0, floor_y + 0.5, 0]).tolist(),
                       "up": (turn @ [0, 0, 1.0]).tolist(), "fov": 40, "width": 32, "height": 32},
            "shapes": [{"name": "cube", "vertices": t(cube),
                        "faces": [[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6],
                                  [0, 2, 6, 4], [1, 5, 7, 3]],
                        "medium": medium, **({"boundary": {"type": boundary}} if boundary else {})},
                       {"name": "floor", "vertices": t(floor), "faces": [[0, 2, 1], [0, 3, 2]],
                        "surface": {"type": "diffuse", "reflectance": 0.8}}],
            "lights": [{"type": "point", "position": (turn @ [1.0, floor_y + 4, 2]).tolist(),
                        "intensity": 10}]}


def _lit(image) -> int:
    return int(np.count_nonzero(image))


def gaps(spp: int) -> list[dict]:
    """Two index-matched slabs `gap` apart, the light crossing the gap: refused below the gap
    the rays' offsets need (the error names it), and at the gaps allowed, the same light as
    across a wide one (image means, z-scores)."""
    wide = sssphere.render_full(two_slabs(1e-3), integrator="pt", spp=spp, seed=3)
    rows = []
    for gap in (1.5e-7, 3e-7, 1e-6, 3e-6, 1e-5, 1e-4):
        try:
            scene = sssphere.load_scene(two_slabs(gap))
        except sssphere.SceneError as e:
            rows.append({"gap": gap, "refused": str(e)})
            print(f"gaps {gap:g}: refused", flush=True)
            continue
        r = sssphere.render_full(scene, integrator="pt", spp=spp, seed=3)
        rows.append({"gap": gap, "refused": None, "mean": float(r.image.mean()), **compare(wide, r)})
        print(f"gaps {gap:g}: mean {r.image.mean():.4f} (wide {wide.image.mean():.4f}), z "
              + ", ".join(f"{x:+.1f}" for x in rows[-1]["z"]), flush=True)
    return rows


def contact(spp: int, repeats: int, backend: str) -> dict:
    """A unit cube on a floor: resting on it, lifted by 1e-5 of the scene, and with the floor
    through its middle. Lit pixels seen from under the floor, all light above (must be 0);
    from above, resting against lifted (index-matched, where a gap changes nothing: image
    means and z-scores) and their times (medians of interleaved renders at 96 x 96, 4 spp
    times spp), which price the extra ray a hit on a face touching the floor traces."""
    under = []
    for name, lift in (("resting", 0.0), ("lifted", 4e-5), ("through", -0.5)):
        for sigma_t in (5, 50):
            scene = cube_on_floor(lift)
            scene["shapes"][0]["medium"]["sigma_t"] = sigma_t
            for integrator in ("pt", "st"):
                image = sssphere.render(scene, integrator=integrator, spp=spp, seed=1, backend=backend)
                under.append({"case": name, "sigma_t": sigma_t, "integrator": integrator,
                              "lit_pixels": _lit(image), "pixels": image.shape[0] * image.shape[1]})
                print(f"contact under the floor: {name} sigma_t {sigma_t} {integrator}: "
                      f"{under[-1]['lit_pixels']} pixels lit", flush=True)
    above = []
    for sigma_t in (5, 100):
        scenes = {}
        for name, lift in (("resting", 0.0), ("lifted", 4e-5)):
            s = cube_on_floor(lift, boundary="index_matched")
            s["shapes"][0]["medium"]["sigma_t"] = sigma_t
            s["camera"].update(origin=[2.5, 3, 3.5], width=96, height=96)
            scenes[name] = sssphere.load_scene(s)
        for integrator in ("pt", "st"):
            times = {"resting": [], "lifted": []}
            renders = {}
            for _ in range(repeats):
                for name, scene in scenes.items():
                    r = sssphere.render_full(scene, integrator=integrator, spp=4 * spp, seed=1,
                                             backend=backend)
                    times[name].append(r.seconds)
                    renders[name] = r
            med = {k: float(np.median(v)) for k, v in times.items()}
            row = {"sigma_t": sigma_t, "integrator": integrator, "times": times,
                   "median_seconds": med, "ratio_resting_over_lifted": med["resting"] / med["lifted"],
                   **compare(renders["lifted"], renders["resting"])}
            above.append(row)
            print(f"contact from above: sigma_t {sigma_t} {integrator}: resting / lifted time "
                  f"{row['ratio_resting_over_lifted']:.3f}, z "
                  + ", ".join(f"{x:+.1f}" for x in row["z"]), flush=True)
    return {"under_the_floor": under, "from_above": above}


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
        "gaps": gaps(spp),
        "contact": contact(spp, 2 if args.quick else 5, args.backend),
    }
    args.output.parent.mkdir(parents=True, exist_ok=True)
    args.output.write_text(json.dumps(result, indent=1) + "\n")
    print(f"wrote {args.output}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
