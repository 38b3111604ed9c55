#!/usr/bin/env python3
"""Sphere tracing (`st`) against path tracing (`pt`) over the sphere threshold tau.

For each case (a scene file with its medium or boundary overridden) this renders a converged
PT reference once (cached), then PT and ST at the same samples per pixel for every tau, and
records for each render the time, the complexity (ordinary events and sphere steps per path)
and its error against the reference:

* ``rmse_srgb``: RMSE of the sRGB-tonemapped images (clip to [0, 1], sRGB curve), noise and
  bias together (bench/README.md);
* ``bias``: the relative difference of the image means per channel, with its one-sigma
  ``bias_sigma`` from the renders' variances (model error shows up here, noise averages out).

tau decides where a collision takes a learned step (sigma_t * r >= tau) instead of an HG event:
small tau means more, smaller steps (faster, but the models are least accurate at small optical
radii and a small step replaces few events), large tau means fewer steps (closer to PT).

    python -m bench.st_threshold --models DIR            # the default sweep, with other models
    python -m bench.st_threshold --quick                                # 32x32, few spp
    python -m bench.st_threshold --taus 2 4 8 --spp 64 --cases sphere_s100

Writes bench/results/st_threshold.json (settings, machine, one row per render).
"""

from __future__ import annotations

import argparse
import datetime
import json
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
REPO = HERE.parent

import sssphere  # noqa: E402
from bench.machine import machine  # noqa: E402

# name -> (scene file, overrides of shapes[0]: medium keys, or "boundary")
CASES = {
    "sphere_s10": ("scenes/sphere.json", {}),
    "sphere_s100": ("scenes/sphere.json", {"sigma_t": [100, 100, 100]}),
    "bunny_s100_im": ("scenes/bunny.json", {"sigma_t": [100, 100, 100], "boundary": "index_matched"}),
    "bunny_s500_diel": ("scenes/bunny.json", {}),
}
TAUS = (1.0, 2.0, 3.0, 4.0, 6.0, 8.0, 12.0, 16.0)


def scene_dict(case: str, res: int) -> dict:
    path, overrides = CASES[case]
    d = json.loads((REPO / path).read_text())
    d["camera"]["width"] = d["camera"]["height"] = res
    shape = d["shapes"][0]
    for key, value in overrides.items():
        if key == "boundary":
            shape["boundary"] = {"type": value}
        else:
            shape["medium"][key] = value
    return d


def srgb(image: np.ndarray) -> np.ndarray:
    x = np.clip(image, 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)


def rmse_srgb(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.sqrt(np.mean((srgb(a) - srgb(b)) ** 2)))


def errors(result, ref) -> dict:
    n = result.image.shape[0] * result.image.shape[1]
    mean, mean_ref = result.image.mean(axis=(0, 1)), ref.image.mean(axis=(0, 1))
    sigma = np.sqrt(result.variance.sum(axis=(0, 1)) + ref.variance.sum(axis=(0, 1))) / n
    return {
        "rmse_srgb": rmse_srgb(result.image, ref.image),
        "bias": ((mean - mean_ref) / mean_ref).tolist(),
        "bias_sigma": (sigma / mean_ref).tolist(),
    }


def reference(case: str, res: int, spp: int, threads: int, cache: Path):
    """PT at `spp` (seed 1000), cached as .npz keyed by the scene and settings."""
    key = f"{case}_{res}px_{spp}spp"
    file = cache / f"{key}.npz"
    scene = sssphere.load_scene(scene_dict(case, res), base_dir=str(REPO / "scenes"))
    if file.exists():
        z = np.load(file)
        return scene, argparse.Namespace(image=z["image"], variance=z["variance"], seconds=float(z["seconds"]))
    print(f"  reference {key} ...", file=sys.stderr, flush=True)
    r = sssphere.render_full(scene, integrator="pt", spp=spp, seed=1000, threads=threads)
    cache.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(file, image=r.image, variance=r.variance, seconds=r.seconds)
    return scene, r


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cases", nargs="+", default=list(CASES), choices=list(CASES))
    ap.add_argument("--taus", nargs="+", type=float, default=list(TAUS))
    ap.add_argument("--resolution", type=int, default=64)
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--ref-spp", type=int, default=1024)
    ap.add_argument("--seeds", type=int, default=1, help="renders per setting (seeds 1..n; times and errors averaged)")
    ap.add_argument("--threads", type=int, default=0)
    ap.add_argument("--models", default=None, help="model directory (default: the repository's models/)")
    ap.add_argument("--quick", action="store_true", help="32x32, 8 spp, reference 128 spp")
    ap.add_argument("--cache", default=str(HERE / "results" / "cache"))
    ap.add_argument("--output", default=str(HERE / "results" / "st_threshold.json"))
    args = ap.parse_args()
    if args.quick:
        args.resolution, args.spp, args.ref_spp = 32, 8, 128

    rows = []
    for case in args.cases:
        scene, ref = reference(case, args.resolution, args.ref_spp, args.threads, Path(args.cache))
        sssphere.render_full(scene, integrator="st", spp=1, models=args.models, threads=args.threads)  # warm-up
        settings = [("pt", None)] + [("st", tau) for tau in args.taus]
        for integrator, tau in settings:
            acc = []
            for seed in range(1, args.seeds + 1):
                kw = {} if integrator == "pt" else {"sphere_threshold": tau, "models": args.models}
                r = sssphere.render_full(scene, integrator=integrator, spp=args.spp, seed=seed,
                                         threads=args.threads, **kw)
                acc.append({"seconds": r.seconds, "events": r.mean_events_per_path,
                            "steps": r.mean_sphere_steps_per_path, **errors(r, ref)})
            row = {"case": case, "integrator": integrator, "tau": tau, "spp": args.spp,
                   "resolution": args.resolution,
                   "seconds": float(np.mean([a["seconds"] for a in acc])),
                   "events_per_path": float(np.mean([a["events"] for a in acc])),
                   "sphere_steps_per_path": float(np.mean([a["steps"] for a in acc])),
                   "rmse_srgb": float(np.mean([a["rmse_srgb"] for a in acc])),
                   "bias": np.mean([a["bias"] for a in acc], axis=0).tolist(),
                   "bias_sigma": (np.mean([a["bias_sigma"] for a in acc], axis=0) / np.sqrt(len(acc))).tolist()}
            rows.append(row)
            pt_row = next(x for x in rows if x["case"] == case and x["integrator"] == "pt")
            speedup = pt_row["seconds"] / row["seconds"]
            print(f"{case:16s} {integrator} tau={'-' if tau is None else f'{tau:g}':>4} "
                  f"{row['seconds']:7.2f}s x{speedup:5.2f}  events {row['events_per_path']:7.1f} "
                  f"steps {row['sphere_steps_per_path']:5.2f}  rmse_srgb {row['rmse_srgb']:.4f}  "
                  f"bias {np.round(np.array(row['bias']) * 100, 2)} % "
                  f"(+- {np.round(np.array(row['bias_sigma']) * 100, 2)})", flush=True)

    out = {
        "date": datetime.datetime.now().isoformat(timespec="seconds"),
        "machine": machine(),
        "settings": {k: v for k, v in vars(args).items() if k not in ("output", "cache")},
        "models": str(args.models) if args.models else "models/ (repository default)",
        "rows": rows,
    }
    Path(args.output).parent.mkdir(parents=True, exist_ok=True)
    Path(args.output).write_text(json.dumps(out, indent=1))
    print(f"wrote {args.output}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
