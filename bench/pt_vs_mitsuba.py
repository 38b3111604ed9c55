#!/usr/bin/env python3
"""Our path tracer against Mitsuba 3 (`volpath`, scalar_rgb) over a density sweep.

Both renderers get the same scene: the same triangle mesh (ours, written to a PLY file), an
index-matched boundary, a grey homogeneous medium (sigma_t per unit length, the object's largest
side being 1), a directional light plus a dim constant environment, the same camera and the
same samples per pixel. Mitsuba runs with max_depth = -1 and rr_depth = 100000 so that it
computes the same unbiased estimate as ours (its defaults, Russian roulette from depth 5, are
4-5x faster in dense media and wrong or very noisy there).

Both trace one shadow ray per scattering event, to one light chosen uniformly (Mitsuba:
one sampled emitter); `--lights directional` or `--lights environment` compares with a single
light. Mitsuba's image is dark in dense media by its
ray-spawn offset at the null interface (sssphere/mitsuba.py; about 1 % at sigma_t = 1000).

Timed: our `render_full` (the scene is loaded and its distance grid built before the clock
starts) and Mitsuba's `mi.render` (after `mi.load_dict`; four renders of spp/4 samples with
different seeds, times summed, whose spread estimates Mitsuba's per-pixel variance).

Two ratios per case: the time ratio at equal spp (Mitsuba / ours), and the equal-error ratio
(Mitsuba time x its mean per-pixel variance) / (our time x ours): how much longer Mitsuba
needs for the same noise. Our estimators (exact transmittance in shadow rays, MIS) carry less
variance per sample than Mitsuba's (0/1 transmittance by free-flight sampling). Both use all cores unless --threads
says otherwise. Each renderer gets one untimed warm-up render at 1 spp on the first case.

    python -m bench.pt_vs_mitsuba                 # 128x128, 64 spp, sigma_t 1, 10, 100, 1000
    python -m bench.pt_vs_mitsuba --quick         # 32x32, 4 spp: a smoke run (seconds)
    python -m bench.pt_vs_mitsuba --spp 16 --resolution 64 --sigma 10 100

Writes bench/results/pt_vs_mitsuba.json and, if matplotlib is installed,
bench/results/pt_vs_mitsuba.png.
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
REPO = HERE.parent

import sssphere  # noqa: E402
from bench.machine import machine  # noqa: E402

BUNNY = "/usr/share/glmark2/models/bunny.obj"
SIGMAS = (1.0, 10.0, 100.0, 1000.0)
MITSUBA_SPLITS = 4  # Mitsuba renders per case (their spread gives its variance)


LIGHTS = {
    "directional": {"type": "directional", "direction": [-0.5, -1, -0.6], "irradiance": [3, 3, 3]},
    "environment": {"type": "environment", "radiance": [0.1, 0.1, 0.1]},
}


def scene_dict(kind: str, sigma: float, albedo: float, g: float, res: int,
               lights: str = "both") -> dict:
    if kind == "sphere":
        # Radius 0.5: largest side 1, like the normalized bunny.
        shape = {"sphere": {"center": [0, 0, 0], "radius": 0.5}}
    elif kind == "bunny":
        shape = {"mesh": BUNNY, "normalize": True}
    else:
        raise ValueError(kind)
    shape.update({
        "medium": {"sigma_t": [sigma] * 3, "albedo": [albedo] * 3, "g": g},
        "boundary": {"type": "index_matched"},
    })
    return {
        "camera": {"origin": [0, 0.1, 2.6], "target": [0, 0, 0], "up": [0, 1, 0], "fov": 30,
                   "width": res, "height": res},
        "shapes": [shape],
        "lights": list(LIGHTS.values()) if lights == "both" else [LIGHTS[lights]],
    }


def run_case(kind, sigma, args, mu, mi, warm):
    sd = scene_dict(kind, sigma, args.albedo, args.g, args.resolution, args.lights)
    t0 = time.perf_counter()
    ours_scene = sssphere.load_scene(sd, threads=args.threads)
    ours_load = time.perf_counter() - t0
    if not warm["ours"]:
        sssphere.render_full(ours_scene, spp=1, seed=1, threads=args.threads)
        warm["ours"] = True
    t0 = time.perf_counter()
    r = sssphere.render_full(ours_scene, spp=args.spp, seed=args.seed, threads=args.threads)
    ours_s = time.perf_counter() - t0

    with tempfile.TemporaryDirectory(prefix="pt_vs_mitsuba-") as tmp:
        t0 = time.perf_counter()
        mi_scene = mi.load_dict(mu.mitsuba_scene_dict(
            sd, ours_scene, tmp, spp=args.spp, seed=args.seed, rr_depth=mu.RR_DEPTH, max_depth=-1))
        mi_load = time.perf_counter() - t0
        if not warm["mitsuba"]:
            mi.render(mi_scene, spp=1, seed=1)
            warm["mitsuba"] = True
        # MITSUBA_SPLITS renders of spp / MITSUBA_SPLITS samples with different seeds: the same
        # total samples (their summed time is Mitsuba's time), and the spread between them
        # estimates Mitsuba's per-pixel variance of the mean, for the equal-error comparison.
        parts, mi_s = [], 0.0
        for k in range(MITSUBA_SPLITS):
            t0 = time.perf_counter()
            img = mi.render(mi_scene, spp=args.spp // MITSUBA_SPLITS, seed=args.seed + 1000 * k)
            mi_s += time.perf_counter() - t0
            parts.append(np.array(img, dtype=np.float64)[:, :, :3])
        del mi_scene, img
        parts = np.stack(parts)
        mi_img = parts.mean(axis=0)
        mi_var = parts.var(axis=0, ddof=1) / MITSUBA_SPLITS

    ours_img = r.image.astype(np.float64)
    n_pix = ours_img.shape[0] * ours_img.shape[1]
    ours_mean = ours_img.mean(axis=(0, 1))
    ours_mean_sigma = np.sqrt(r.variance.astype(np.float64).sum(axis=(0, 1))) / n_pix
    mi_mean = mi_img.mean(axis=(0, 1))
    verts, tris = ours_scene.shape_mesh(0)
    ours_var_mean = float(r.variance.astype(np.float64).mean())
    mi_var_mean = float(mi_var.mean())
    return {
        "scene": kind,
        "triangles": int(len(tris)),
        "sigma_t": sigma,
        "albedo": args.albedo,
        "g": args.g,
        "spp": args.spp,
        "resolution": [args.resolution, args.resolution],
        "our_seconds": ours_s,
        "our_reported_render_seconds": r.seconds,
        "mitsuba_seconds": mi_s,
        "ratio_mitsuba_over_ours": mi_s / ours_s if ours_s > 0 else None,
        # Equal-error comparison: time x mean per-pixel variance of the mean (the time each
        # needs for a given noise level is proportional to it). > 1: we are more efficient.
        "our_mean_pixel_variance": ours_var_mean,
        "mitsuba_mean_pixel_variance": mi_var_mean,
        "efficiency_ratio_mitsuba_over_ours": (mi_s * mi_var_mean) / (ours_s * ours_var_mean)
        if ours_s > 0 and ours_var_mean > 0 else None,
        "our_load_seconds": ours_load,
        "mitsuba_load_seconds": mi_load,
        "our_mean_events_per_path": r.mean_events_per_path,
        "our_image_mean": ours_mean.tolist(),
        "our_image_mean_sigma": ours_mean_sigma.tolist(),
        "mitsuba_image_mean": mi_mean.tolist(),
        "relative_difference_of_means": ((ours_mean - mi_mean) / np.where(mi_mean != 0, mi_mean, 1)).tolist(),
        # One sigma of that difference, assuming Mitsuba's per-sample variance equals ours
        # (we only know ours from a single Mitsuba render): sqrt(2) * ours / mean.
        "relative_difference_sigma_approx": (np.sqrt(2) * ours_mean_sigma
                                             / np.where(mi_mean != 0, mi_mean, 1)).tolist(),
    }


def plot(results, path):
    try:
        import matplotlib
    except ImportError:
        print("matplotlib is not installed: no plot (pip install matplotlib)", file=sys.stderr)
        return False
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(15, 4.2))
    for kind, marker in (("sphere", "o"), ("bunny", "s")):
        rows = [r for r in results["cases"] if r["scene"] == kind]
        if not rows:
            continue
        s = [r["sigma_t"] for r in rows]
        axes[0].loglog(s, [r["our_seconds"] for r in rows], marker + "-", label=f"ours, {kind}")
        axes[0].loglog(s, [r["mitsuba_seconds"] for r in rows], marker + "--", label=f"Mitsuba, {kind}")
        axes[1].semilogx(s, [r["ratio_mitsuba_over_ours"] for r in rows], marker + "-", label=kind)
        axes[2].errorbar(s, [100 * np.mean(r["relative_difference_of_means"]) for r in rows],
                         yerr=[100 * np.mean(r["relative_difference_sigma_approx"]) for r in rows],
                         fmt=marker + "-", capsize=3, label=kind)
        axes[2].set_xscale("log")
    meta = results["settings"]
    axes[0].set(xlabel="sigma_t (per unit; object size 1)", ylabel="render seconds",
                title=f"{meta['resolution']}x{meta['resolution']}, {meta['spp']} spp, "
                      f"{meta['threads_ours']}/{meta['threads_mitsuba']} threads")
    axes[1].set(xlabel="sigma_t", ylabel="Mitsuba seconds / our seconds", title="speed-up")
    axes[1].axhline(1, color="grey", lw=0.5)
    axes[2].set(xlabel="sigma_t", ylabel="(ours - Mitsuba) / Mitsuba, %",
                title="image mean difference (+- 1 sigma, approx.)")
    axes[2].axhline(0, color="grey", lw=0.5)
    for a in axes:
        a.grid(True, which="both", alpha=0.3)
        a.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return True


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--spp", type=int, default=None, help="samples per pixel (default 64; quick 4)")
    p.add_argument("--resolution", type=int, default=None, help="square image side (default 128; quick 32)")
    p.add_argument("--sigma", type=float, nargs="+", default=list(SIGMAS), help="sigma_t values (grey, per unit)")
    p.add_argument("--scenes", nargs="+", default=["sphere", "bunny"], choices=["sphere", "bunny"])
    p.add_argument("--albedo", type=float, default=0.99, help="grey single-scattering albedo (default 0.99)")
    p.add_argument("--g", type=float, default=0.0, help="Henyey-Greenstein g (default 0)")
    p.add_argument("--lights", choices=["both", "directional", "environment"], default="both",
                   help="directional light + constant environment (default), or one of them")
    p.add_argument("--threads", type=int, default=0, help="threads for both renderers (0 = all cores)")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--quick", action="store_true", help="32x32, 4 spp: a smoke run")
    p.add_argument("--output", type=Path, default=HERE / "results" / "pt_vs_mitsuba.json")
    args = p.parse_args(argv)
    if args.spp is None:
        args.spp = 4 if args.quick else 64
    if args.spp % MITSUBA_SPLITS:
        p.error(f"--spp must be a multiple of {MITSUBA_SPLITS} (Mitsuba renders in {MITSUBA_SPLITS} parts)")
    if args.resolution is None:
        args.resolution = 32 if args.quick else 128

    import sssphere.mitsuba as mu

    mi = mu.import_mitsuba("scalar_rgb")
    import drjit as dr

    threads = args.threads if args.threads > 0 else (os.cpu_count() or 1)
    # Mitsuba's scalar variants render on Dr.Jit's thread pool. Keep at least two workers
    # (with one worker thread, Mitsuba 3.9 hung while writing an EXR).
    dr.set_thread_count(max(threads, 2) if args.threads == 0 else args.threads)
    settings = {
        "spp": args.spp, "resolution": args.resolution, "albedo": args.albedo, "g": args.g,
        "seed": args.seed,
        "lights": [LIGHTS[k] for k in (LIGHTS if args.lights == "both" else [args.lights])],
        "boundary": "index_matched",
        "threads_ours": threads, "threads_mitsuba": int(dr.thread_count()),
        "mitsuba": {"version": mi.__version__, "variant": mi.variant(), "integrator": "volpath",
                    "max_depth": -1, "rr_depth": mu.RR_DEPTH, "film": "hdrfilm, box filter",
                    "sampler": "independent"},
        "ours": {"integrator": "pt", "version": sssphere.__version__},
        "machine": machine(),
        "date": datetime.datetime.now().isoformat(timespec="seconds"),
        "timing": "our render_full and Mitsuba's mi.render, wall clock, scene loading excluded",
    }
    print(f"ours: {threads} threads; Mitsuba {mi.__version__} {mi.variant()} volpath "
          f"(max_depth -1, rr_depth {mu.RR_DEPTH}): {dr.thread_count()} threads; "
          f"{args.resolution}x{args.resolution}, {args.spp} spp", flush=True)
    warm = {"ours": False, "mitsuba": False}
    cases = []
    for kind in args.scenes:
        for sigma in args.sigma:
            c = run_case(kind, sigma, args, mu, mi, warm)
            cases.append(c)
            print(f"{kind:6s} sigma_t {sigma:7g}: ours {c['our_seconds']:8.2f}s  Mitsuba "
                  f"{c['mitsuba_seconds']:8.2f}s  ratio {c['ratio_mitsuba_over_ours']:6.2f}  "
                  f"equal-error ratio {c['efficiency_ratio_mitsuba_over_ours']:6.2f}  "
                  f"events/path {c['our_mean_events_per_path']:7.1f}  mean ours "
                  f"{c['our_image_mean'][0]:.5f} (+-{c['our_image_mean_sigma'][0]:.5f}) Mitsuba "
                  f"{c['mitsuba_image_mean'][0]:.5f}  diff "
                  f"{100 * c['relative_difference_of_means'][0]:+.2f}%", flush=True)
    results = {"settings": settings, "cases": cases}
    args.output.parent.mkdir(parents=True, exist_ok=True)
    args.output.write_text(json.dumps(results, indent=2) + "\n")
    print(f"wrote {args.output}")
    png = args.output.with_suffix(".png")
    if plot(results, png):
        print(f"wrote {png}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
