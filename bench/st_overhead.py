#!/usr/bin/env python3
"""What `st` costs where it takes (almost) no sphere steps: `pt` and `st` timed on the same
scene, interleaved, several times each, medians compared.

The sweep in st_vs_pt.py renders each case once at 64x64, 32 spp: 30-50 ms on the thin torus,
too short to tell a few per cent from noise. Here each render is larger and repeated, and
`pt` and `st` alternate so that drifts in the machine's speed hit both alike. Default cases:
the thin torus (st_vs_pt.py's scene) at sigma_t = 125 and 250, dielectric and index-matched,
where `st` takes 0.00-0.01 steps per path.

    python -m bench.st_overhead            # ~2 min on 2 cores
    python -m bench.st_overhead --repeats 3 --spp 64   # quicker

Writes bench/results/st_overhead.json: per case the times of every render, the medians,
their ratio st / pt (> 1: st slower), and the steps per path.
"""

from __future__ import annotations

import argparse
import datetime
import json
import statistics
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent

import sssphere  # noqa: E402
from sssphere.rendering import render_full  # noqa: E402
from bench.st_vs_pt import BASE_SIGMA, BOUNDARIES, scene_dict  # noqa: E402
from bench.machine import machine  # noqa: E402


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--shape", default="thin_torus", choices=["thin_torus", "bunny"])
    p.add_argument("--scales", type=float, nargs="+", default=[0.25, 0.5], help="sigma_t / 500")
    p.add_argument("--boundaries", nargs="+", default=list(BOUNDARIES), choices=list(BOUNDARIES))
    p.add_argument("--resolution", type=int, default=128)
    p.add_argument("--spp", type=int, default=256)
    p.add_argument("--repeats", type=int, default=5, help="renders per integrator and case")
    p.add_argument("--threads", type=int, default=0, help="0 = all cores")
    p.add_argument("--output", type=Path, default=HERE / "results" / "st_overhead.json")
    args = p.parse_args(argv)

    cases = []
    for boundary in args.boundaries:
        for scale in args.scales:
            sigma = BASE_SIGMA * scale
            scene = sssphere.load_scene(scene_dict(args.shape, boundary, sigma, args.resolution))
            times = {"pt": [], "st": []}
            steps = 0.0
            for _ in range(args.repeats):
                for integrator in ("pt", "st"):
                    r = render_full(scene, integrator=integrator, spp=args.spp, seed=1,
                                    threads=args.threads)
                    times[integrator].append(r.seconds)
                    if integrator == "st":
                        steps = r.mean_sphere_steps_per_path
            med = {k: statistics.median(v) for k, v in times.items()}
            case = {"shape": args.shape, "boundary": boundary, "sigma_t": sigma,
                    "times": times, "median_seconds": med,
                    "ratio_st_over_pt": med["st"] / med["pt"],
                    "st_sphere_steps_per_path": steps}
            cases.append(case)
            print(f"{args.shape} {boundary:13s} sigma_t {sigma:6.0f}: pt {med['pt']:.3f}s "
                  f"st {med['st']:.3f}s  st/pt {case['ratio_st_over_pt']:.3f}  "
                  f"steps/path {steps:.3f}", flush=True)

    out = {"settings": {"resolution": args.resolution, "spp": args.spp, "repeats": args.repeats,
                        "threads": args.threads, "timing": "render_full seconds, medians",
                        "machine": machine(),
                        "date": datetime.datetime.now().isoformat(timespec="seconds")},
           "cases": cases}
    args.output.parent.mkdir(parents=True, exist_ok=True)
    args.output.write_text(json.dumps(out, indent=1) + "\n")
    print(f"wrote {args.output}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
