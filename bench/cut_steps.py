#!/usr/bin/env python3
"""Cut sphere steps in the renderer (issue 26): `st` with and without `cut_models`, and `pt`.

The dielectric bunny of bench/st_vs_pt.py (64x64, g = 0.9, albedo (0.999, 0.99995, 0.999))
at each σt of ``--sigmas``: per integrator the render time (the best of ``--repeats``
renders, interleaved), the ordinary scattering events and the steps (sphere and cut) per
path, the image mean, and, where bench/error_time.py's converged `pt` reference is cached
(bench/results/cache/), the sRGB RMSE against it with both renders' noise removed (what is
left estimates the systematic error: the models' bias). The cut steps' set-up (loading the
cut models, building the plane certificates) is timed apart: the wall time of a 1-spp render
with `cut_models` less one without.

    python -m bench.cut_steps                       # ~3 min on 2 cores
    python -m bench.cut_steps --sigmas 1000 4000 --spp 64 --repeats 3

Writes bench/results/cut_steps.json.
"""

from __future__ import annotations

import argparse
import datetime
import json
import time
from pathlib import Path

import numpy as np

import sssphere
from bench.st_vs_pt import errors, reference_error, scene_dict
from bench.machine import machine

HERE = Path(__file__).resolve().parent
REPO = HERE.parent


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--sigmas", nargs="+", type=float, default=[1000.0, 4000.0])
    p.add_argument("--spp", type=int, default=64)
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--threads", type=int, default=0)
    p.add_argument("--models", default=str(REPO / "models"))
    p.add_argument("--cut-models", default=str(REPO / "models" / "cut"))
    p.add_argument("--cache", default=str(HERE / "results" / "cache"))
    p.add_argument("--out", default=str(HERE / "results" / "cut_steps.json"))
    args = p.parse_args()

    configs = {"pt": dict(integrator="pt"),
               "st": dict(integrator="st", models=args.models),
               "st+cut": dict(integrator="st", models=args.models, cut_models=args.cut_models)}
    rows = []
    for sigma in args.sigmas:
        scene = sssphere.load_scene(scene_dict("bunny", "dielectric", sigma, 64),
                                    threads=args.threads)
        setup = {}
        for name in ("st", "st+cut"):
            t0 = time.perf_counter()
            sssphere.render_full(scene, spp=1, seed=1, threads=args.threads, **configs[name])
            setup[name] = time.perf_counter() - t0
        results = {name: None for name in configs}
        seconds = {name: [] for name in configs}
        for _ in range(args.repeats):
            for name, kw in configs.items():
                r = sssphere.render_full(scene, spp=args.spp, seed=7, threads=args.threads, **kw)
                seconds[name].append(r.seconds)
                results[name] = r
        ref_file = Path(args.cache) / f"error_time_bunny_dielectric_{int(sigma)}_64_1024.npz"
        ref = None
        if ref_file.exists():
            z = np.load(ref_file)
            ref = argparse.Namespace(image=z["image"], variance=z["variance"])
        row = {"sigma_t": sigma, "cut_setup_seconds": setup["st+cut"] - setup["st"],
               "reference": ref_file.name if ref is not None else None, "integrators": {}}
        for name, r in results.items():
            entry = {"seconds": min(seconds[name]), "all_seconds": seconds[name],
                     "events_per_path": r.mean_events_per_path,
                     "steps_per_path": r.mean_sphere_steps_per_path,
                     "image_mean": np.nanmean(r.image, axis=(0, 1)).tolist(),
                     "non_finite_pixels": int((~np.isfinite(r.image).all(axis=2)).sum())}
            if ref is not None:
                e = errors(r, ref, reference_error(ref))
                entry["rmse_srgb_ref_corrected"] = e["rmse_srgb_ref_corrected"]
                entry["rmse_srgb_noise_removed"] = e["rmse_srgb_noise_removed"]
            row["integrators"][name] = entry
        it = row["integrators"]
        row["st_over_pt_speedup"] = it["pt"]["seconds"] / it["st"]["seconds"]
        row["st_cut_over_pt_speedup"] = it["pt"]["seconds"] / it["st+cut"]["seconds"]
        row["cut_time_ratio"] = it["st+cut"]["seconds"] / it["st"]["seconds"]
        rows.append(row)
        print(f"sigma_t {sigma:g}: " + "; ".join(
            f"{n} {v['seconds']:.2f}s, {v['events_per_path']:.1f} events + "
            f"{v['steps_per_path']:.2f} steps/path"
            + (f", systematic {v['rmse_srgb_noise_removed']:.4f}"
               if "rmse_srgb_noise_removed" in v else "")
            for n, v in it.items())
            + f"; cut set-up {row['cut_setup_seconds']:.2f}s", flush=True)
    out = {"date": datetime.datetime.now().isoformat(timespec="seconds"),
           "machine": machine(),
           "spp": args.spp, "repeats": args.repeats, "threads": args.threads, "rows": rows}
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps(out, indent=1) + "\n", encoding="utf-8")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
