"""Which SIMD target the decoders should use in renders, not only alone.

`sssphere-bench-decoder` times the decoders by themselves; a render also pays for what their
instructions do to the rest of the core. On Intel's family 6, model 85 (Skylake-SP, Cascade
Lake, Cooper Lake) 512-bit arithmetic lowers the core's clock for about a millisecond, and
`st` samples steps more often than that, so its path loop runs slower with AVX-512 decoders
than with AVX2 ones although the AVX-512 decoders are faster alone. This renders `pt` and
`st` with every target this CPU runs (`ScatteringModel.use_simd_target`), interleaved,
several times each, on bench/st_vs_pt.py's scenes, and reports medians and `st` / `pt`.

    python -m bench.simd_render          # ~3 min here -> bench/results/simd_render.json
"""

from __future__ import annotations

import argparse
import datetime
import json
import statistics
from pathlib import Path

import sssphere
from bench.machine import machine
from bench.st_vs_pt import scene_dict

HERE = Path(__file__).resolve().parent
# (shape, boundary, sigma_t, resolution, spp): few steps per path (thin torus, the sparse
# index-matched bunny) and many (the dense dielectric bunny).
CASES = (("thin_torus", "dielectric", 250, 128, 64), ("thin_torus", "dielectric", 500, 128, 64),
         ("bunny", "index_matched", 125, 64, 32), ("bunny", "dielectric", 1000, 64, 32))


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--repeats", type=int, default=3, help="renders per integrator, target and case")
    p.add_argument("--threads", type=int, default=0, help="0 = all cores")
    p.add_argument("--output", type=Path, default=HERE / "results" / "simd_render.json")
    args = p.parse_args()

    targets = sssphere.ScatteringModel.simd_targets()
    rows = []
    try:
        for shape, boundary, sigma_t, res, spp in CASES:
            scene = sssphere.load_scene(scene_dict(shape, boundary, sigma_t, res), threads=args.threads)
            sssphere.render_full(scene, integrator="st", spp=1, seed=1, threads=args.threads)  # warm
            times: dict[str, list[float]] = {k: [] for k in ["pt", *targets]}
            steps = 0.0
            for _ in range(args.repeats):
                for key in times:
                    sssphere.ScatteringModel.use_simd_target("" if key == "pt" else key)
                    r = sssphere.render_full(scene, integrator="pt" if key == "pt" else "st", spp=spp,
                                             seed=1, threads=args.threads)
                    times[key].append(r.seconds)
                    if key != "pt":
                        steps = r.mean_sphere_steps_per_path
            med = {k: statistics.median(v) for k, v in times.items()}
            row = {"shape": shape, "boundary": boundary, "sigma_t": sigma_t, "resolution": res, "spp": spp,
                   "steps_per_path": steps, "seconds": med, "times": times,
                   "st_over_pt": {t: med[t] / med["pt"] for t in targets}}
            rows.append(row)
            print(f"{shape:10s} {boundary:13s} sigma_t {sigma_t:5g}: pt {med['pt']:.3f}s  "
                  + "  ".join(f"st {t} x{med['pt'] / med[t]:.2f}" for t in targets)
                  + f"  ({steps:.2f} steps/path)", flush=True)
    finally:
        sssphere.ScatteringModel.use_simd_target("")
    args.output.parent.mkdir(parents=True, exist_ok=True)
    args.output.write_text(json.dumps({
        "date": datetime.datetime.now().isoformat(timespec="seconds"), "machine": machine(),
        "default_target": sssphere.ScatteringModel.simd_default_target(), "targets": targets,
        "repeats": args.repeats, "threads": args.threads, "rows": rows}, indent=1) + "\n")
    print(f"wrote {args.output}")


if __name__ == "__main__":
    main()
