#!/usr/bin/env python3
"""Where st's index-matched bias came from, and how the two step-NEE estimators compare.

The index-matched bunny of bench/st_vs_pt.py at sigma_t = 1000 (64x64, lights of
scenes/bunny.json): `pt` without NEE (an independent unbiased estimate), `st` with
step_nee "event" and "hits", and `st` without NEE, each with its image mean and the one-sigma
of that mean. Then the same scene with the area light shrunk to each of --light-sizes (same
power): `pt` (NEE) against `st` with either estimator. Seeds are fixed, so the numbers in
docs/sphere-tracing.md ("NEE for a sphere step") come out again.

    python -m bench.step_nee          # ~4 min on 2 cores

Writes bench/results/step_nee.json.
"""

from __future__ import annotations

import argparse
import datetime
import json
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent

import sssphere  # noqa: E402
from bench.st_vs_pt import scene_dict  # noqa: E402


def stats(r) -> dict:
    img = r.image.astype(np.float64)
    n = img.shape[0] * img.shape[1]
    return {"seconds": r.seconds, "image_mean": img.mean(axis=(0, 1)).tolist(),
            "sigma_of_mean": (np.sqrt(r.variance.astype(np.float64).sum(axis=(0, 1))) / n).tolist()}


def shrink_light(d: dict, size: float) -> dict:
    """The area light as a size x size square about its centre, radiance scaled for equal power."""
    light = d["lights"][0]
    c, e1, e2 = (np.array(light[k], dtype=float) for k in ("corner", "edge1", "edge2"))
    side = np.linalg.norm(e1)
    mid = c + 0.5 * e1 + 0.5 * e2
    e1, e2 = e1 * size / side, e2 * size / side
    light.update(corner=(mid - 0.5 * e1 - 0.5 * e2).tolist(), edge1=e1.tolist(), edge2=e2.tolist(),
                 radiance=[x * (side / size) ** 2 for x in light["radiance"]])
    return d


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--sigma", type=float, default=1000.0)
    p.add_argument("--st-spp", type=int, default=4096)
    p.add_argument("--pt-spp", type=int, default=2048)
    p.add_argument("--light-sizes", type=float, nargs="*", default=[0.5, 0.1])
    p.add_argument("--threads", type=int, default=0, help="0 = all cores")
    p.add_argument("--output", type=Path, default=HERE / "results" / "step_nee.json")
    args = p.parse_args(argv)
    kw = dict(threads=args.threads)
    scene = sssphere.load_scene(scene_dict("bunny", "index_matched", args.sigma, 64), **kw)
    out = {"date": datetime.datetime.now().isoformat(timespec="seconds"), "settings": vars(args) | {
        "output": str(args.output)}, "decomposition": {}, "small_lights": []}
    runs = {"pt_no_nee": dict(integrator="pt", spp=args.pt_spp, seed=2000, nee=False),
            "st_event": dict(integrator="st", spp=args.st_spp, seed=7, step_nee="event"),
            "st_hits": dict(integrator="st", spp=args.st_spp, seed=7, step_nee="hits"),
            "st_no_nee": dict(integrator="st", spp=args.st_spp, seed=7, nee=False)}
    for name, r_kw in runs.items():
        out["decomposition"][name] = s = stats(sssphere.render_full(scene, **r_kw, **kw))
        print(f"{name:10} {s['seconds']:6.1f} s  mean {np.round(s['image_mean'], 5)}  "
              f"sigma {np.array(s['sigma_of_mean'])}", flush=True)
    for size in args.light_sizes:
        sc = sssphere.load_scene(shrink_light(scene_dict("bunny", "index_matched", args.sigma, 64), size), **kw)
        row = {"light_size": size,
               "pt": stats(sssphere.render_full(sc, integrator="pt", spp=512 if size >= 0.5 else 256,
                                                seed=1000, **kw))}
        for mode in ("hits", "event"):
            row[f"st_{mode}"] = stats(sssphere.render_full(sc, integrator="st", spp=1024 if size >= 0.5 else 512,
                                                            seed=7, step_nee=mode, **kw))
        out["small_lights"].append(row)
        print(f"light {size}: " + ", ".join(f"{k} G {v['image_mean'][1]:.5f} ± {v['sigma_of_mean'][1]:.1e}"
                                            for k, v in row.items() if k != "light_size"), flush=True)
    args.output.parent.mkdir(parents=True, exist_ok=True)
    args.output.write_text(json.dumps(out, indent=1))
    print(f"wrote {args.output}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
