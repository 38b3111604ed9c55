#!/usr/bin/env python3
"""Sphere steps in chromatic media: `st` against `pt` where the channels' extinctions differ.

With spectral MIS `st` goes on in one channel where a step fits spectral_switch_extinction
(docs/notation.md, "Colour"). This bench renders media whose channels lie close together
(marble, whole milk: the rule is the smallest extinction there) and far apart (cream, an
index-matched rock of sigma_t (2000, 1000, 500), a bunny of (5000, 500, 20)) with both
integrators, same scene loaded once, `--seeds` renders each (alternated), and reports per
channel the variance of the pooled image mean times the total render time, `pt`'s over
`st`'s (`st`'s efficiency at equal error), besides time, events and steps per path and the
pooled image means' z-scores of st against pt.

    python -m bench.chromatic_steps            # ~1 min on 2 cores
    python -m bench.chromatic_steps --seeds 1 --spp 16   # quicker

Writes bench/results/chromatic_steps.json. To compare two builds (as for the change of
2026-12-02), run it on each.
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
LIGHTS = [{"type": "area", "corner": [-1.5, 2.5, 1.5], "edge1": [0, 0, -3.0],
           "edge2": [3.0, 0, 0], "radiance": [1.5, 1.5, 1.5]},
          {"type": "environment", "radiance": [0.3, 0.3, 0.3]}]


def _scene(shape: dict, res: int) -> dict:
    return {"camera": {"origin": [0.3, 0.4, 2.6], "target": [0, 0, 0], "fov": 30,
                       "width": res, "height": res},
            "shapes": [shape], "lights": LIGHTS}


def _rock() -> dict:
    """A lumpy closed mesh (an icosphere with radial bumps), inline."""
    t = (1 + 5 ** 0.5) / 2
    v = [[-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0], [0, -1, t], [0, 1, t], [0, -1, -t],
         [0, 1, -t], [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1]]
    f = [[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4],
         [11, 10, 2], [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8],
         [3, 8, 9], [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]]
    for _ in range(3):  # subdivide
        mid, nf = {}, []
        for a, b, c in f:
            m = []
            for i, j in ((a, b), (b, c), (c, a)):
                key = (min(i, j), max(i, j))
                if key not in mid:
                    mid[key] = len(v)
                    v.append([(v[i][k] + v[j][k]) / 2 for k in range(3)])
                m.append(mid[key])
            nf += [[a, m[0], m[2]], [b, m[1], m[0]], [c, m[2], m[1]], [m[0], m[1], m[2]]]
        f = nf
    out = []
    for x, y, z in v:
        n = (x * x + y * y + z * z) ** 0.5
        bump = 0.5 * (1 + 0.12 * np.sin(3 * x / n) * np.cos(2 * y / n) + 0.08 * np.sin(5 * z / n))
        out.append([x / n * bump, y / n * bump, z / n * bump])
    return {"vertices": out, "faces": f}


def cases(res: int) -> dict[str, dict]:
    diel = {"type": "dielectric", "ior": 1.5}
    return {
        "marble (preset, scale 300)": _scene(
            {"mesh": BUNNY, "normalize": True, "medium": {"preset": "marble", "scale": 300},
             "boundary": diel}, res),
        "wholemilk (preset, scale 300), index-matched": _scene(
            {"mesh": BUNNY, "normalize": True, "medium": {"preset": "wholemilk", "scale": 300},
             "boundary": {"type": "index_matched"}}, res),
        "cream (preset, scale 200)": _scene(
            {"mesh": BUNNY, "normalize": True, "medium": {"preset": "cream", "scale": 200},
             "boundary": {"type": "dielectric", "ior": 1.3}}, res),
        "rock (2000, 1000, 500), index-matched": _scene(
            {**_rock(), "medium": {"sigma_t": [2000, 1000, 500], "albedo": [0.995, 0.98, 0.9],
                                   "g": 0.5},
             "boundary": {"type": "index_matched"}}, res),
        "bunny (5000, 500, 20)": _scene(
            {"mesh": BUNNY, "normalize": True,
             "medium": {"sigma_t": [5000, 500, 20], "albedo": [0.9999, 0.99, 0.8], "g": 0.3},
             "boundary": {"type": "dielectric", "ior": 1.4}}, res),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--res", type=int, default=64)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--seeds", type=int, default=3,
                    help="renders per integrator and case, each with its own seed")
    ap.add_argument("--output", default=str(HERE / "results" / "chromatic_steps.json"))
    args = ap.parse_args()
    rows = []
    for name, d in cases(args.res).items():
        scene = sssphere.load_scene(d)
        runs = {"pt": [], "st": []}
        for k in range(args.seeds):  # pt and st alternate, so that drifts hit both alike
            for integrator in ("pt", "st"):
                seed = 2 * k + (integrator == "st")
                res = sssphere.render_full(scene, integrator=integrator, spp=args.spp,
                                           seed=seed, threads=args.threads)
                npix = res.image.shape[0] * res.image.shape[1]
                runs[integrator].append({
                    "seed": seed, "seconds": res.seconds, "events": res.mean_events_per_path,
                    "steps": res.mean_sphere_steps_per_path,
                    "mean": res.image.reshape(-1, 3).astype(np.float64).mean(0),
                    "var_of_mean": res.variance.reshape(-1, 3).astype(np.float64).sum(0)
                    / npix ** 2})
        r = {}
        for integrator, rs in runs.items():
            # The seeds' renders pooled: their mean, and the variance of that mean.
            n = len(rs)
            var = sum(x["var_of_mean"] for x in rs) / n ** 2
            seconds = sum(x["seconds"] for x in rs)
            r[integrator] = {"seconds": seconds, "events": float(np.mean([x["events"] for x in rs])),
                             "steps": float(np.mean([x["steps"] for x in rs])),
                             "mean": (sum(x["mean"] for x in rs) / n).tolist(),
                             "var_of_mean": var.tolist(),
                             "var_x_time": (var * seconds).tolist(),
                             "seconds_each": [x["seconds"] for x in rs]}
        z = [(a - b) / np.sqrt(va + vb) for a, b, va, vb in
             zip(r["st"]["mean"], r["pt"]["mean"], r["st"]["var_of_mean"], r["pt"]["var_of_mean"])]
        gain = [p / s for p, s in zip(r["pt"]["var_x_time"], r["st"]["var_x_time"])]
        rows.append({"case": name, **r, "z_st_vs_pt": z, "efficiency_st_over_pt": gain})
        print(f"{name:45s} pt {r['pt']['seconds']:.2f} s ({r['pt']['events']:.0f} ev)  "
              f"st {r['st']['seconds']:.2f} s ({r['st']['events']:.1f} ev + "
              f"{r['st']['steps']:.2f} steps)  efficiency st/pt "
              f"{' '.join(f'{g:.2f}' for g in gain)}  z {' '.join(f'{x:+.1f}' for x in z)}",
              flush=True)
    out = {"date": datetime.date.today().isoformat(), "machine": machine(),
           "spp": args.spp, "res": args.res, "threads": args.threads, "seeds": args.seeds,
           "cases": rows}
    Path(args.output).parent.mkdir(parents=True, exist_ok=True)
    Path(args.output).write_text(json.dumps(out, indent=1) + "\n")
    print("wrote", args.output)


if __name__ == "__main__":
    main()
