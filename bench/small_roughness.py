#!/usr/bin/env python3
"""A rough dielectric of small alpha under a point light: how heavy the estimator's tail is
through the interface's own lobe (regularization 0, the exact estimator) and through the
regularization's (the default 0.05, which a rough interface below it takes for point and
directional lights since 2026-11-30; docs/scene-format.md, `regularization`).

A unit ball (sigma_t 10, albedo 0.9, eta 1.5) under one point light, 32 x 32. Per alpha and
estimator: the mean of eight 32-spp image means (seeds 0-7), their relative standard
deviation, and median / mean (a heavy tail puts the typical render far below the mean).

    python -m bench.small_roughness          # ~1 min on 2 cores

Writes bench/results/small_roughness.json.
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
ALPHAS = (0.001, 0.003, 0.01, 0.03, 0.1)


def scene(alpha: float, regularization: float) -> dict:
    return {"camera": {"origin": [0, 0, 4], "target": [0, 0, 0], "fov": 30, "width": 32,
                       "height": 32},
            "shapes": [{"sphere": {"center": [0, 0, 0], "radius": 1, "subdivisions": 4},
                        "medium": {"sigma_t": 10, "albedo": 0.9},
                        "boundary": {"type": "dielectric", "ior": 1.5, "roughness": alpha,
                                     "regularization": regularization}}],
            "lights": [{"type": "point", "position": [2, 3, 3], "intensity": 30}]}


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--spp", type=int, default=32)
    p.add_argument("--seeds", type=int, default=8)
    p.add_argument("--output", type=Path, default=HERE / "results" / "small_roughness.json")
    a = p.parse_args(argv)
    rows = []
    for regularization in (0.0, 0.05):
        for alpha in ALPHAS:
            s = sssphere.load_scene(scene(alpha, regularization))
            m = np.array([sssphere.render_full(s, spp=a.spp, seed=k, threads=2).image.mean()
                          for k in range(a.seeds)], np.float64)
            row = {"regularization": regularization, "alpha": alpha, "mean": m.mean(),
                   "relative_sd": m.std(ddof=1) / m.mean(), "median_over_mean":
                   float(np.median(m) / m.mean())}
            rows.append(row)
            print(f"regularization {regularization:g}, alpha {alpha:g}: mean {row['mean']:.4f}, "
                  f"relative sd {row['relative_sd']:.2f}, median/mean "
                  f"{row['median_over_mean']:.2f}", flush=True)
    a.output.parent.mkdir(parents=True, exist_ok=True)
    a.output.write_text(json.dumps({"date": datetime.date.today().isoformat(),
                                    "machine": machine(), "spp": a.spp, "seeds": a.seeds,
                                    "rows": rows}, indent=1) + "\n")
    print(f"wrote {a.output}")


if __name__ == "__main__":
    main()
