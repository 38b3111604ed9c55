#!/usr/bin/env python3
"""How well EventGen's representative event serves next-event estimation.

For one sphere step of optical radius sigma (unit sphere, photon entering at the centre along
+z, g = 0.9), a path tracer with NEE at every event adds sum_k phi^k D(x_k, w_k); the
representative-event estimator adds Lambda D(X, W) (docs/sphere-tracing.md). Take the boundary a
plane touching the sphere with outward normal n and a distant light along n: up to a common
factor, D(x, w) = HG(w . n) exp(-sigma (1 - x . n)). This script compares E[Lambda D(X, W)] from
the learned models (ScatteringModel.sample) with the same from exact walks (sphere_walks), for
n behind (-z), beside (+x) and ahead (+z) of the entering photon, and reports the statistics
behind the difference: how much of EventGen's X falls outside the unit ball (the sampler
projects it onto the sphere), and the mean of W_z.

    python -m bench.eventgen_nee            # ~15 s
    python -m bench.eventgen_nee --samples 1000000 --albedo 0.999

Writes bench/results/eventgen_nee.json.
"""

from __future__ import annotations

import argparse
import datetime
import json
from pathlib import Path

import numpy as np

import sssphere
from sssphere import _core

HERE = Path(__file__).resolve().parent
NORMALS = {"behind": (0.0, 0.0, -1.0), "beside": (1.0, 0.0, 0.0), "ahead": (0.0, 0.0, 1.0)}


def hg(c, g):
    return (1 - g * g) / (4 * np.pi * (1 + g * g - 2 * g * c) ** 1.5)


def nee_terms(d, phi, sigma, g, n):
    """Lambda HG(W . n) exp(-sigma (1 - X . n)) per sample."""
    N = d["N"].astype(np.float64)
    X, W = d["X"].astype(np.float64), d["W"].astype(np.float64)
    lam = N if phi == 1.0 else phi * -np.expm1(N * np.log(phi)) / (1 - phi)
    return lam * hg(W @ n, g) * np.exp(-sigma * (1 - X @ n))


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--samples", type=int, default=400_000)
    p.add_argument("--sigmas", type=float, nargs="+", default=[6, 12, 25, 50, 100, 200])
    p.add_argument("--g", type=float, default=0.9)
    p.add_argument("--albedo", type=float, default=0.99995)
    p.add_argument("--models", default=None)
    p.add_argument("--threads", type=int, default=0, help="0 = all cores")
    p.add_argument("--output", type=Path, default=HERE / "results" / "eventgen_nee.json")
    args = p.parse_args(argv)
    model = sssphere.ScatteringModel.load(args.models) if args.models else sssphere.ScatteringModel.load()
    n, g, phi = args.samples, args.g, args.albedo
    rows = []
    for sigma in args.sigmas:
        full = lambda v: np.full(n, v, np.float32)  # noqa: E731
        dm = model.sample(full(sigma), full(g), full(phi), n, seed=3, threads=args.threads or None)
        dw = _core.sphere_walks(full(sigma), full(g), full(phi), n, seed=5, threads=args.threads)
        rm, rw = np.linalg.norm(dm["X"], axis=1), np.linalg.norm(dw["X"], axis=1)
        row = {"sigma": sigma,
               # Projected onto the sphere by the sampler: |X| = 1 up to rounding.
               "model_X_outside_ball": float(np.mean(rm > 1 - 1e-6)),
               "walk_X_within_1e-3_of_surface": float(np.mean(rw > 1 - 1e-3)),
               "model_X_within_1e-3_of_surface": float(np.mean(rm > 1 - 1e-3)),
               "model_mean_W_z": float(dm["W"][:, 2].mean()), "walk_mean_W_z": float(dw["W"][:, 2].mean()),
               "nee": {}}
        for name, nv in NORMALS.items():
            nv = np.array(nv)
            a, b = nee_terms(dm, phi, sigma, g, nv), nee_terms(dw, phi, sigma, g, nv)
            ma, mb = a.mean(), b.mean()
            sa, sb = a.std() / np.sqrt(n), b.std() / np.sqrt(n)
            row["nee"][name] = {"model": ma, "walk": mb, "ratio": ma / mb,
                                "ratio_sigma": float(np.hypot(sa / mb, ma * sb / mb ** 2))}
        rows.append(row)
        print(f"sigma {sigma:5g}: X outside the ball {100 * row['model_X_outside_ball']:.1f} %, "
              f"W_z {row['model_mean_W_z']:+.2f} (walks {row['walk_mean_W_z']:+.2f}); NEE model / exact: "
              + ", ".join(f"{k} {v['ratio']:.2f} ± {v['ratio_sigma']:.2f}" for k, v in row["nee"].items()),
              flush=True)
    out = {"date": datetime.datetime.now().isoformat(timespec="seconds"),
           "settings": {"samples": n, "g": g, "albedo": phi, "models": args.models or "models/"},
           "rows": rows}
    args.output.parent.mkdir(parents=True, exist_ok=True)
    args.output.write_text(json.dumps(out, indent=1, default=float))
    print(f"wrote {args.output}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
