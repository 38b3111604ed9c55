#!/usr/bin/env python3
"""What denoising buys: the error of `pt` and `st` renders against a converged reference at
4, 16 and 64 spp, with and without Intel Open Image Denoise (the `denoise` extra, guided by
the first-hit albedo and normal AOVs), and the equal-error speed-up it gives.

The scene: scenes/marble.json (the bunny in Jensen et al.'s marble, 100 mm long, behind a
rough dielectric, on a floor, under a sun and a sky) at 160 x 120. The reference is `pt`
at --ref-spp samples per pixel.

Error: the relative mean squared error, the mean over pixels and channels of
(x - ref)^2 / (ref^2 + 0.01) (relMSE, as denoising papers measure it: a firefly counts for
its pixel, not for the image), less the reference's own noise (the same mean of its
variance, which every comparison with it adds; reported, and small beside the errors).
Without denoising a render's error falls as 1/spp, so the spp that reach the denoised
render's error are spp * (error without / error with); the speed-up is that render's time
over the denoised render's time, denoiser included.
(Denoising is biased: its error is mostly the denoiser's, and it does not fall as 1/spp.)

    python -m bench.denoise                    # about 8 minutes on 2 cores
    python -m bench.denoise --quick            # 64 x 48, reference 64 spp: a smoke run

Writes bench/results/denoise.json.
"""

from __future__ import annotations

import argparse
import datetime
import json
import time
from pathlib import Path

import numpy as np

import sssphere
from bench.machine import machine

HERE = Path(__file__).resolve().parent
REPO = HERE.parent


def relative_error(image: np.ndarray, reference: np.ndarray, reference_noise: float) -> float:
    diff = image.astype(np.float64) - reference
    return float(np.mean(diff ** 2 / (reference ** 2 + 0.01)) - reference_noise)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--width", type=int, default=160)
    parser.add_argument("--height", type=int, default=120)
    parser.add_argument("--ref-spp", type=int, default=2048, help="the reference's spp (pt)")
    parser.add_argument("--spp", type=int, nargs="+", default=[4, 16, 64])
    parser.add_argument("--threads", type=int, default=0, help="render threads (0: all)")
    parser.add_argument("--quick", action="store_true", help="64 x 48, reference 64 spp")
    parser.add_argument("--out", default=str(HERE / "results" / "denoise.json"))
    args = parser.parse_args()
    if args.quick:
        args.width, args.height, args.ref_spp, args.spp = 64, 48, 64, [4]

    scene = sssphere.load_scene(REPO / "scenes" / "marble.json")
    scene.camera.width, scene.camera.height = args.width, args.height
    t0 = time.perf_counter()
    ref = sssphere.render_full(scene, integrator="pt", spp=args.ref_spp, seed=12345,
                               threads=args.threads)
    print(f"reference: pt, {args.ref_spp} spp, {time.perf_counter() - t0:.0f} s")
    reference = ref.image.astype(np.float64)
    reference_noise = float(np.mean(ref.variance / (reference ** 2 + 0.01)))
    print(f"reference noise (relMSE): {reference_noise:.2e}")
    sssphere.denoise(np.zeros((8, 8, 3), np.float32))  # OIDN's set-up, not timed below

    rows = []
    for integrator in ("pt", "st"):
        for spp in args.spp:
            r = sssphere.render_full(scene, integrator=integrator, spp=spp, seed=1,
                                     threads=args.threads, aovs=True)
            t = time.perf_counter()
            denoised = sssphere.denoise(r.image, r.albedo, r.normal)
            denoise_seconds = time.perf_counter() - t
            noisy_error = relative_error(r.image, reference, reference_noise)
            denoised_error = relative_error(denoised, reference, reference_noise)
            equal_error_spp = spp * noisy_error / max(denoised_error, 1e-12)
            speedup = (r.seconds * equal_error_spp / spp) / (r.seconds + denoise_seconds)
            rows.append({"integrator": integrator, "spp": spp, "render_seconds": r.seconds,
                         "denoise_seconds": denoise_seconds,
                         "relative_mse": noisy_error, "relative_mse_denoised": denoised_error,
                         "equal_error_spp_without": equal_error_spp,
                         "equal_error_speedup": speedup})
            print(f"{integrator} {spp:4d} spp: {r.seconds:6.2f} s + denoise "
                  f"{denoise_seconds:5.2f} s; relative MSE {noisy_error:.2e} -> "
                  f"{denoised_error:.2e}; the same error without: {equal_error_spp:,.0f} spp, "
                  f"{speedup:.1f}x the time")
    result = {"date": datetime.date.today().isoformat(),
              "machine": machine(),
              "scene": "scenes/marble.json", "width": args.width, "height": args.height,
              "reference": {"integrator": "pt", "spp": args.ref_spp, "seconds": ref.seconds,
                            "noise": reference_noise},
              "rows": rows}
    Path(args.out).write_text(json.dumps(result, indent=2) + "\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
