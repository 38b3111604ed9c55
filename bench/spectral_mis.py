#!/usr/bin/env python3
"""Colour noise on a chromatic medium: our `pt` with spectral MIS, our `st` (the same until a
path's first sphere step, one channel after it), Mitsuba 3's `volpathmis` and, optionally, an
earlier build of ours (one channel per path, weight 3), side by side.

The scene: the bunny (largest side 1) of a skin-like medium (the `skin1` preset of Jensen et
al. 2001, `scale` mm per unit: sigma_t differs by about 2x between red and blue), an
index-matched boundary, a directional light and a dim constant environment; 128 x 128 pixels.

Per channel, the mean per-pixel variance of the pixel means (over all pixels, and over the
pixels that see the bunny), the render time (samples only: the scene and its distance grid
are loaded before the clock starts), and the equal-time figure time x variance (the variance
each would reach in one second). Mitsuba renders in four parts with different seeds, whose
spread gives its per-pixel variance; ours report theirs. Mitsuba runs with max_depth -1 and
rr_depth 100000 (as bench/pt_vs_mitsuba.py: the same unbiased estimate as ours).

    python -m bench.spectral_mis                       # ours and Mitsuba
    python -m bench.spectral_mis --before ../before/build/cpp/sssphere-render
    python -m bench.spectral_mis --quick               # 32 x 32, 8 spp: a smoke run

`--before` takes a `sssphere-render` built from an earlier commit (bench/ab.py says how) and
renders the same scene file with it (its printed render time, its `_variance.exr`).

Writes bench/results/spectral_mis.json.
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent

import sssphere  # noqa: E402
from bench.ab import render_seconds  # noqa: E402
from bench.machine import machine  # noqa: E402

BUNNY = "/usr/share/glmark2/models/bunny.obj"
MITSUBA_SPLITS = 4


def scene_dict(res: int, scale: float, preset: str) -> dict:
    return {
        "camera": {"origin": [0, 0.1, 2.6], "target": [0, 0, 0], "up": [0, 1, 0], "fov": 30,
                   "width": res, "height": res},
        "shapes": [{"name": "bunny", "mesh": BUNNY, "normalize": True,
                    "medium": {"preset": preset, "scale": scale},
                    "boundary": {"type": "index_matched"}}],
        "lights": [
            {"type": "directional", "direction": [-0.5, -1, -0.6], "irradiance": [3, 3, 3]},
            {"type": "environment", "radiance": [0.1, 0.1, 0.1]},
        ],
    }


def summary(image: np.ndarray, var: np.ndarray, seconds: float, mask: np.ndarray) -> dict:
    var = var.astype(np.float64)
    v_all = var.mean(axis=(0, 1))
    v_obj = var[mask].mean(axis=0)
    return {
        "seconds": seconds,
        "image_mean": image.astype(np.float64).mean(axis=(0, 1)).tolist(),
        "image_mean_sigma": (np.sqrt(var.sum(axis=(0, 1))) / mask.size).tolist(),
        "mean_pixel_variance": v_all.tolist(),
        "mean_pixel_variance_object": v_obj.tolist(),
        "time_x_variance_object": (seconds * v_obj).tolist(),
    }


def render_before(binary: str, scene: dict, spp: int, seed: int, threads: int, mask_shape):
    with tempfile.TemporaryDirectory(prefix="spectral_mis-") as tmp:
        path = Path(tmp) / "scene.json"
        path.write_text(json.dumps(scene))
        out = Path(tmp) / "before.exr"
        cmd = [binary, str(path), "-o", str(out), "--integrator", "pt", "--spp", str(spp),
               "--seed", str(seed), "--threads", str(threads), "--aovs", "--quiet"]
        p = subprocess.run(cmd, capture_output=True, text=True, check=True)
        seconds = render_seconds(p.stdout + p.stderr)
        if seconds is None:
            raise RuntimeError(f"no render time in the output of {cmd}:\n{p.stdout}{p.stderr}")
        image = sssphere.read_image(out)
        var = sssphere.read_image(Path(tmp) / "before_variance.exr")
    assert image.shape[:2] == mask_shape
    return image, var, seconds


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--spp", type=int, default=None, help="samples per pixel (default 64; quick 8)")
    p.add_argument("--resolution", type=int, default=None, help="image side (default 128; quick 32)")
    p.add_argument("--preset", default="skin1", help="the medium's preset (default skin1)")
    p.add_argument("--scale", type=float, default=50.0,
                   help="mm per scene unit: the bunny's size in mm (default 50)")
    p.add_argument("--before", default=None,
                   help="an earlier build's sssphere-render to compare with (optional)")
    p.add_argument("--no-mitsuba", action="store_true", help="leave Mitsuba 3 out")
    p.add_argument("--threads", type=int, default=0, help="threads (0 = all cores)")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--quick", action="store_true", help="32 x 32, 8 spp: a smoke run")
    p.add_argument("--output", type=Path, default=HERE / "results" / "spectral_mis.json")
    args = p.parse_args(argv)
    args.spp = args.spp or (8 if args.quick else 64)
    args.resolution = args.resolution or (32 if args.quick else 128)
    if args.spp % MITSUBA_SPLITS:
        p.error(f"--spp must be a multiple of {MITSUBA_SPLITS}")
    threads = args.threads if args.threads > 0 else (os.cpu_count() or 1)

    sd = scene_dict(args.resolution, args.scale, args.preset)
    scene = sssphere.load_scene(sd, threads=threads)
    from sssphere import _core

    medium = _core.medium_coefficients(json.dumps(sd["shapes"][0]["medium"]))
    medium = {k: list(map(float, v)) for k, v in medium.items()}
    sssphere.render_full(scene, spp=1, seed=99, threads=threads)  # warm-up
    t0 = time.perf_counter()
    r = sssphere.render_full(scene, integrator="pt", spp=args.spp, seed=args.seed,
                             threads=threads)
    ours_wall = time.perf_counter() - t0
    mask = r.events.reshape(r.image.shape[:2]) > 0  # pixels whose paths met the medium
    results = {"ours": summary(r.image, r.variance, r.seconds, mask)}
    results["ours"]["wall_seconds"] = ours_wall
    results["ours"]["mean_events_per_path"] = r.mean_events_per_path
    print(f"ours (spectral MIS): {r.seconds:.2f} s", flush=True)
    # "st" carries one channel after a path's first step (docs/notation.md, "Colour"): its
    # noise next to pt's.
    sssphere.render_full(scene, integrator="st", spp=1, seed=99, threads=threads)  # warm-up
    s = sssphere.render_full(scene, integrator="st", spp=args.spp, seed=args.seed,
                             threads=threads)
    results["ours_st"] = summary(s.image, s.variance, s.seconds, mask)
    results["ours_st"]["mean_sphere_steps_per_path"] = s.mean_sphere_steps_per_path
    results["ours_st"]["mean_events_per_path"] = s.mean_events_per_path
    print(f"ours st: {s.seconds:.2f} s, {s.mean_sphere_steps_per_path:.3f} steps per path",
          flush=True)

    if args.before:
        img, var, sec = render_before(args.before, sd, args.spp, args.seed, threads, mask.shape)
        results["before"] = summary(img, var, sec, mask)
        results["before"]["binary"] = "given by --before"
        print(f"before (one channel per path): {sec:.2f} s", flush=True)

    settings = {
        "spp": args.spp, "resolution": args.resolution, "preset": args.preset,
        "scale_mm_per_unit": args.scale, "medium": medium, "threads": threads,
        "seed": args.seed, "scene": sd, "ours": {"integrator": "pt", "version": sssphere.__version__},
        "machine": machine(),
        "date": datetime.datetime.now().isoformat(timespec="seconds"),
    }
    if not args.no_mitsuba:
        import sssphere.mitsuba as mu

        mi = mu.import_mitsuba("scalar_rgb")
        import drjit as dr

        dr.set_thread_count(max(threads, 2))
        with tempfile.TemporaryDirectory(prefix="spectral_mis-") as tmp:
            md = mu.mitsuba_scene_dict(sd, scene, tmp, spp=args.spp, seed=args.seed,
                                       rr_depth=mu.RR_DEPTH, max_depth=-1)
            md["integrator"]["type"] = "volpathmis"
            mi_scene = mi.load_dict(md)
            mi.render(mi_scene, spp=1, seed=99)  # warm-up
            parts, seconds = [], 0.0
            for k in range(MITSUBA_SPLITS):
                t0 = time.perf_counter()
                img = mi.render(mi_scene, spp=args.spp // MITSUBA_SPLITS,
                                seed=args.seed + 1000 * k)
                seconds += time.perf_counter() - t0
                parts.append(np.array(img, dtype=np.float64)[:, :, :3])
            del mi_scene, img
        parts = np.stack(parts)
        results["mitsuba_volpathmis"] = summary(
            parts.mean(axis=0), parts.var(axis=0, ddof=1) / MITSUBA_SPLITS, seconds, mask)
        settings["mitsuba"] = {"version": mi.__version__, "variant": mi.variant(),
                               "integrator": "volpathmis", "max_depth": -1,
                               "rr_depth": mu.RR_DEPTH, "threads": int(dr.thread_count())}
        print(f"Mitsuba volpathmis: {seconds:.2f} s", flush=True)

    ours = results["ours"]
    ratios = {}
    for peer in ("mitsuba_volpathmis", "before", "ours_st"):
        if peer in results:
            other = results[peer]
            ratios[f"variance_equal_spp_ours_over_{peer}"] = [
                a / b for a, b in zip(ours["mean_pixel_variance_object"],
                                      other["mean_pixel_variance_object"])]
            ratios[f"variance_equal_time_ours_over_{peer}"] = [
                a / b for a, b in zip(ours["time_x_variance_object"],
                                      other["time_x_variance_object"])]
    results["ratios"] = ratios
    for k, v in ratios.items():
        print(f"{k}: " + " ".join(f"{x:.3f}" for x in v))
    out = {"settings": settings, "results": results}
    args.output.parent.mkdir(parents=True, exist_ok=True)
    args.output.write_text(json.dumps(out, indent=2) + "\n")
    print(f"wrote {args.output}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
