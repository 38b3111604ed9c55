"""PathGen's forward-memory tilt: calibrated against exact sphere walks (tilt.json).

A learned step's exit point and direction keep a small part of the entering direction (the
means of cos θ and of the exit direction's z, w_z). Where σ is large that part is a slight
tilt of an almost uniform distribution, which the decoders' loss hardly sees: PathGen misses
it by up to 0.04, and the miss adds up over the many steps light takes through a dense layer
(models/README.md, "Known weaknesses"). The renderer corrects it by keeping each learned step
(N ≥ 2) with probability (1 + a cos θ + b w_z) / (1 + M), M the largest value of
a cos θ + b w_z (``bound``), and drawing it again otherwise (cpp/shared/sphere_step.h,
``tilt_acceptance``). That reweights the decoders' distribution q by 1 + a cos θ + b w_z,
and a, b are chosen per (σ, g) so that the reweighted means of cos θ and w_z are the
walks'::

    for v in (cos θ, w_z):  E_q[v (1 + a cos θ + b w_z)] = t_v E_q[1 + a cos θ + b w_z]

with t_v the walks' mean: two equations, linear in (a, b). Both sides are taken over steps
with N ≥ 2 (N = 1 is sampled exactly). The table is interpolated bilinearly in (ln σ, g).

    sssphere calibrate-tilt --models DIR        # writes DIR/tilt.json, ~25 min on 2 cores
"""

from __future__ import annotations

import datetime
import json
from pathlib import Path
from typing import Callable, Optional

import numpy as np

from sssphere.walks import sphere_walks

#: The nodes: σ from below the default threshold (6) to the models' largest radius, denser
#: in g where the forward memory is large.
SIGMAS = (3.0, 4.5, 6.0, 9.0, 13.0, 19.0, 28.0, 42.0, 63.0, 94.0, 141.0, 200.0)
GS = (-0.95, -0.6, -0.3, 0.0, 0.3, 0.5, 0.65, 0.8, 0.9, 0.95)
ALBEDO = 0.9999  # not used by the exit (docs/notation.md), only asked for by the samplers
MODEL_SAMPLES = 1_000_000
#: Walks per node: as many as an event budget allows (the mean count of events is about
#: σ² (1 − g) / 2), within these bounds.
WALK_EVENTS, WALK_MIN, WALK_MAX = 3e8, 30_000, 300_000
MAX_SUM = 0.9  # |a| + |b| at most this (nn/step_tilt.h, kTiltMaxSum)
FORMAT, FORMAT_VERSION = "sssphere-step-tilt", 1


def walk_count(sigma: float, g: float) -> int:
    events = sigma * sigma * (1.0 - g) / 2.0 + sigma + 1.0
    return int(min(WALK_MAX, max(WALK_MIN, WALK_EVENTS / events)))


def moments(steps: dict) -> dict:
    """Means of cos θ, w_z and their products over the steps with N ≥ 2."""
    keep = steps["N"] >= 2
    mu = steps["cos_theta"].astype(np.float64)[keep]
    a = steps["alpha"].astype(np.float64)[keep]
    b = steps["beta"].astype(np.float64)[keep]
    wz = exit_z(mu, a, b)
    return {"n": int(keep.sum()), "mu": float(mu.mean()), "wz": float(wz.mean()),
            "mumu": float((mu * mu).mean()), "muwz": float((mu * wz).mean()),
            "wzwz": float((wz * wz).mean())}


def solve(model: dict, walks: dict) -> tuple[float, float]:
    """(a, b) that give the model's steps the walks' means of cos θ and w_z (module doc),
    scaled down to |a| + |b| ≤ MAX_SUM if the solution is larger."""
    tm, tw = walks["mu"], walks["wz"]
    m = np.array([[model["mumu"] - tm * model["mu"], model["muwz"] - tm * model["wz"]],
                  [model["muwz"] - tw * model["mu"], model["wzwz"] - tw * model["wz"]]])
    rhs = np.array([tm - model["mu"], tw - model["wz"]])
    a, b = np.linalg.solve(m, rhs)
    s = abs(a) + abs(b)
    if s > MAX_SUM:
        a, b = a * MAX_SUM / s, b * MAX_SUM / s
    return float(a), float(b)


def calibrate(model, sigmas=None, gs=None, seed: int = 11,
              progress: Optional[Callable[[float], object]] = None) -> dict:
    """The tilt of `model` (a ScatteringModel loaded with tilt=False) as tilt.json's dict, at
    the nodes `sigmas` × `gs` (default SIGMAS × GS)."""
    sigmas = tuple(SIGMAS if sigmas is None else sigmas)
    gs = tuple(GS if gs is None else gs)
    if model.tilted:
        raise ValueError("calibrate the decoders' own steps: load the model with tilt=False")
    cells, a, b = [], [], []
    total = sum(walk_count(s, g) * (s * s * (1 - g) / 2 + s + 1) for g in gs for s in sigmas)
    done = 0.0
    for g in gs:
        a.append([]), b.append([])
        for s in sigmas:
            n = walk_count(s, g)
            q = moments(model.sample(sigma_t=s, g=g, albedo=ALBEDO, n=MODEL_SAMPLES, seed=seed))
            t = moments(sphere_walks(s, g, ALBEDO, n, seed=seed + 1))
            ca, cb = solve(q, t)
            a[-1].append(round(ca, 6)), b[-1].append(round(cb, 6))
            cells.append({"sigma": s, "g": g, "walks": t, "model": q})
            done += n * (s * s * (1 - g) / 2 + s + 1)
            if progress:
                progress(done / total)
    return {"format": FORMAT, "format_version": FORMAT_VERSION, "sigma": list(sigmas),
            "g": list(gs), "a": a, "b": b,
            "calibration": {"date": datetime.date.today().isoformat(), "models": str(model.path),
                            "model_samples": MODEL_SAMPLES, "seed": seed,
                            "walks": {"events": WALK_EVENTS, "min": WALK_MIN, "max": WALK_MAX},
                            "cells": cells}}


def exit_z(cos_theta, alpha, beta) -> np.ndarray:
    """The exit direction's z in the exit frame (docs/notation.md)."""
    mu, a, b = (np.asarray(v, dtype=np.float64) for v in (cos_theta, alpha, beta))
    return np.sqrt(np.clip(1 - a * a - b * b, 0, None)) * mu - b * np.sqrt(np.clip(1 - mu * mu, 0, None))


def coefficients(tilt: dict, sigma, g) -> tuple[np.ndarray, np.ndarray]:
    """(a, b) at each (sigma, g): bilinear in (ln σ, g), clamped at the outer nodes, as the
    renderer interpolates them (nn/step_tilt.cpp)."""
    def locate(nodes, x):
        nodes = np.asarray(nodes, dtype=np.float64)
        if nodes.size == 1:
            return np.zeros(x.shape, dtype=np.int64), np.zeros(x.shape)
        i = np.clip(np.searchsorted(nodes, x, side="right") - 1, 0, nodes.size - 2)
        t = np.clip((x - nodes[i]) / (nodes[i + 1] - nodes[i]), 0.0, 1.0)
        return i, t

    sigma, g = np.broadcast_arrays(np.asarray(sigma, dtype=np.float64), np.asarray(g, dtype=np.float64))
    i, t = locate(np.log(tilt["sigma"]), np.log(sigma))
    k, u = locate(tilt["g"], g)
    ns, ng = len(tilt["sigma"]), len(tilt["g"])
    i1, k1 = np.minimum(i + 1, ns - 1), np.minimum(k + 1, ng - 1)

    def lerp2(table):
        v = np.asarray(table, dtype=np.float64)
        lo = v[k, i] + t * (v[k, i1] - v[k, i])
        hi = v[k1, i] + t * (v[k1, i1] - v[k1, i])
        return lo + u * (hi - lo)

    return lerp2(tilt["a"]), lerp2(tilt["b"])


def bound(a, b) -> np.ndarray:
    """The largest a cos θ + b w_z over the exits a step can have (shared/sphere_step.h,
    tilt_bound): |a| + |b| where a and b have one sign, √(a² + b²) otherwise."""
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    return np.where(a * b >= 0, np.abs(a) + np.abs(b), np.hypot(a, b))


def acceptance(cos_theta, alpha, beta, a, b) -> np.ndarray:
    """The probability that a drawn step is kept (shared/sphere_step.h, tilt_acceptance)."""
    return (1 + a * np.asarray(cos_theta) + b * exit_z(cos_theta, alpha, beta)) / (1 + bound(a, b))


#: Draws of one step before the last is kept (shared/sphere_step.h, kTiltMaxDraws).
MAX_DRAWS = 32


def read(path) -> dict:
    """tilt.json as a dict (the renderer's loader, nn/step_tilt.cpp, checks it in full)."""
    tilt = json.loads(Path(path).read_text())
    if not isinstance(tilt, dict) or tilt.get("format") != FORMAT:
        raise ValueError(f"{path}: not a tilt file (format {FORMAT!r})")
    return tilt


def write(tilt: dict, path: Path) -> Path:
    path = Path(path)
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(json.dumps(tilt, indent=1) + "\n")
    tmp.replace(path)
    return path
