"""Learned steps in a sphere cut by a plane (issue 26; docs/learning.md, "Learned cut sphere
steps"). The renderer takes such steps with the render option ``cut_models``
(docs/sphere-tracing.md, "Cut sphere steps"; C++ `cpp/nn/cut_step_model.h`).

The walk is the cut sphere problem of docs/notation.md: the unit sphere cut by the plane z = h,
the medium z < h, the photon arriving at the centre with direction (√(1 − μ0²), 0, μ0) and
scattering there. A step is sampled as the sphere step is (docs/notation.md, "Sampling a sphere
step"):

1. The first flight exactly: a direction w from HG about the arriving one, the distance
   d(w) = min(1, h / w_z for w_z > 0) to the region's boundary, and an exponential flight of
   rate σ; it leaves (N = 1) where the flight reaches d(w), at w·d(w) with direction w.
2. Otherwise N ≥ 2 from CutLengthGen(σ, g, h, μ0), then CutPathGen(σ, g, h, μ0, N): the exit
   point seen from the centre, P = (√(1 − cos_p²) cos ψ, √(1 − cos_p²) sin ψ, cos_p) with
   cos ψ = ``cos_psi`` and sin ψ ≥ 0, and the exit direction D = α t + β b + √(1 − α² − β²) n
   in the frame of the exit surface there (`exit_frame`). The exit point is the region's
   boundary in direction P: the plane (cos_p > h, ``through_plane``) at P·h/cos_p, else the
   cap at P. Last, one more uniform mirrors P and D in y with probability ½ (the problem is
   symmetric in y; the networks learn the half y ≥ 0). Every sample is a valid exit.

Step 2 needs the walks with N ≥ 2 only: the first flight's exact branch happens with its exact
probability, and a model conditioned on N ≥ 2 supplies the rest, as for the sphere step.

    data = generate_cut_data(1_000_000, seed=0)
    train_cut(data, "models/cut", epochs=20)
    sampler = CutSampler.from_dir("models/cut")
    steps = sampler.sample(sigma=12.0, g=0.9, h=0.1, mu0=-1.0, n=10_000, rng=rng)

No representative event (X, W) is learned: a smooth dielectric boundary passes no shadow
rays from inside, and there the cut step needs none. Index-matched scenes would need a
CutEventGen for next-event estimation.
"""

from __future__ import annotations

import json
import sys
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Optional

import numpy as np

from sssphere.learn.numpy_decoder import _hg_sample_cos, load_decoder
from sssphere.learn.spec import CUT_LENGTHGEN, CUT_PATHGEN, CUT_SPECS
from sssphere.walks import cut_sphere_walks

SIGMA_RANGE = (0.5, 32.0)  # optical radius σt·R: R of 0.5 to 32 mean free paths
G_MAX = 0.95
H_RANGE = (0.01, 1.0)  # the plane's distance in radii (1: it touches the sphere)
MU0_RANGE = (-1.0, 1.0)
CONDITION_RANGES = {"sigma": SIGMA_RANGE, "g": (-G_MAX, G_MAX), "h": H_RANGE, "mu0": MU0_RANGE}


@dataclass
class CutData:
    """Cut sphere walks and their conditions: σ, g, h, μ0 (n,), N (n,) int64, the exit point
    seen from the centre P (n, 3, unit) and the exit direction D (n, 3, unit)."""

    sigma: np.ndarray
    g: np.ndarray
    h: np.ndarray
    mu0: np.ndarray
    N: np.ndarray
    P: np.ndarray
    D: np.ndarray
    path: str = "<memory>"
    meta: dict = field(default_factory=dict)

    def __len__(self) -> int:
        return int(self.N.shape[0])

    # The networks' variables (spec.CUT_PATHGEN), from P and D mirrored to P_y >= 0.
    @property
    def _mirror(self) -> np.ndarray:
        return np.where(self.P[:, 1:2] < 0, [[1.0, -1.0, 1.0]], [[1.0, 1.0, 1.0]])

    @property
    def cos_p(self) -> np.ndarray:
        return np.clip(self.P[:, 2], -1.0, 1.0)

    @property
    def cos_psi(self) -> np.ndarray:
        rho = np.hypot(self.P[:, 0], self.P[:, 1])
        return np.where(rho > 0, self.P[:, 0] / np.where(rho > 0, rho, 1.0), 1.0).clip(-1, 1)

    def _local_direction(self) -> np.ndarray:
        t, b, _ = exit_frame(self.P * self._mirror, self.P[:, 2] > self.h)
        D = self.D * self._mirror
        return np.stack([np.sum(D * t, axis=1), np.sum(D * b, axis=1)], axis=1)

    @property
    def alpha(self) -> np.ndarray:
        return self._local_direction()[:, 0]

    @property
    def beta(self) -> np.ndarray:
        return self._local_direction()[:, 1]

    def subset(self, mask) -> "CutData":
        keys = ("sigma", "g", "h", "mu0", "N", "P", "D")
        return CutData(**{k: getattr(self, k)[mask] for k in keys}, path=self.path,
                       meta=self.meta)


def sample_cut_conditions(n: int, seed: int = 0) -> dict:
    """(σ, g, h, μ0) for n walks: σ log-uniform on SIGMA_RANGE; g 60 % uniform on ±G_MAX,
    40 % |g| uniform on [0.6, G_MAX] with a random sign (as the sphere data); h uniform on
    H_RANGE; μ0 uniform on [−1, 1]."""
    if n < 1:
        raise ValueError(f"n must be >= 1, got {n}")
    rng = np.random.default_rng([seed, 0xC075])
    lo, hi = SIGMA_RANGE
    sigma = lo * (hi / lo) ** rng.random(n)
    strong = np.where(rng.random(n) < 0.5, -1.0, 1.0) * (0.6 + (G_MAX - 0.6) * rng.random(n))
    g = np.where(rng.random(n) < 0.6, G_MAX * (2.0 * rng.random(n) - 1.0), strong)
    h = H_RANGE[0] + (H_RANGE[1] - H_RANGE[0]) * rng.random(n)
    mu0 = 2.0 * rng.random(n) - 1.0
    return {k: np.clip(v, *CONDITION_RANGES[k]).astype(np.float32)
            for k, v in (("sigma", sigma), ("g", g), ("h", h), ("mu0", mu0))}


def generate_cut_data(n: int, seed: int = 0, threads: Optional[int] = None) -> CutData:
    """n walks of the cut sphere problem at `sample_cut_conditions(n, seed)` (albedo 1: the
    albedo does not change a walk, only its weight)."""
    c = sample_cut_conditions(n, seed)
    w = cut_sphere_walks(c["sigma"], c["g"], c["h"], c["mu0"], 1.0, n, seed=seed,
                         threads=threads)
    pos = w["exit_pos"].astype(np.float64)
    P = pos / np.linalg.norm(pos, axis=1, keepdims=True)
    D = w["exit_dir"].astype(np.float64)
    D /= np.linalg.norm(D, axis=1, keepdims=True)
    meta = {"generator": "sssphere.learn.cut.generate_cut_data", "n": n, "seed": seed,
            **{f"{k}_range": list(v) for k, v in CONDITION_RANGES.items()}}
    return CutData(**{k: c[k].astype(np.float64) for k in c}, N=w["N"].astype(np.int64),
                   P=P, D=D, meta=meta)


def train_cut(data: CutData, out_dir, epochs: int = 20, seed: int = 0,
              max_minutes: float | None = None, progress: bool = True, config=None) -> dict:
    """Train CutLengthGen and CutPathGen on data (walks with N ≥ 2) and write
    ``cutlengthgen.json/.onnx`` and ``cutpathgen.json/.onnx`` into out_dir, together once
    both are trained (an interrupted or failed run leaves out_dir as it was).
    Returns per model its training report, and ``"files"``."""
    import torch

    from sssphere.learn.export import staged_output, write_model
    from sssphere.learn.train import TrainConfig, train_cvae

    cfg = TrainConfig(**asdict(config)) if config is not None else TrainConfig()
    cfg.epochs = int(epochs)
    if cfg.epochs < 1:
        raise ValueError(f"epochs must be >= 1, got {epochs}")
    if max_minutes is not None and not max_minutes > 0:
        raise ValueError(f"max_minutes must be > 0, got {max_minutes}")
    out = Path(out_dir)
    names = [f"{spec.file_stem}.{ext}" for spec in CUT_SPECS for ext in ("json", "onnx")]
    shares = {"CutLengthGen": 0.3, "CutPathGen": 0.7}
    threads_before = torch.get_num_threads()
    det_before = torch.are_deterministic_algorithms_enabled()
    torch.set_num_threads(max(1, cfg.threads))
    torch.use_deterministic_algorithms(True)
    results = {}
    t0 = time.monotonic()
    try:
        with staged_output(out, names) as stage:
            for spec in CUT_SPECS:
                budget = 60.0 * max_minutes * shares[spec.name] if max_minutes else None
                model, enc, report = train_cvae(spec, data, cfg, seed, budget, progress)
                training = {
                    **{k: [float(lo), float(hi)] for k, (lo, hi) in CONDITION_RANGES.items()},
                    "data_meta": data.meta, "n_walks": len(data), "n_samples": report["n_train"],
                    "n_validation": report["n_val"], "epochs": cfg.epochs,
                    "epochs_completed": report["epochs_completed"], "seed": seed,
                    **{k: v for k, v in asdict(cfg).items() if k != "epochs"},
                    "rows": "N >= 2",
                    "noise": "targets N + U[0,1)" if spec is CUT_LENGTHGEN else "none",
                    "torch_version": torch.__version__,
                }
                metrics = {k: report[k] for k in ("val_nll", "val_kl", "val_loss",
                                                  "kl_per_latent_dim", "latent_dims_active")}
                write_model(stage, spec, model, enc, training, metrics)
                results[spec.name] = report
    finally:
        torch.set_num_threads(threads_before)
        torch.use_deterministic_algorithms(det_before)
    results["files"] = [str(out / n) for n in names]
    results["seconds"] = time.monotonic() - t0
    return results


def _unit_rows(v: np.ndarray, fallback) -> np.ndarray:
    r = np.linalg.norm(v, axis=1, keepdims=True)
    return np.where(r > 0, v / np.where(r > 0, r, 1.0), np.asarray(fallback, dtype=np.float64))


def _hg_directions(w_in: np.ndarray, g: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Directions scattered by HG(g) about the unit rows of w_in."""
    cos = _hg_sample_cos(g, rng.random(g.shape[0]))
    phi = 2.0 * np.pi * rng.random(g.shape[0])
    sin = np.sqrt(np.maximum(0.0, 1.0 - cos * cos))
    # An orthonormal frame (s, t, w_in): s ⟂ w_in from whichever axis is least aligned.
    helper = np.where(np.abs(w_in[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    s = _unit_rows(np.cross(helper, w_in), [1.0, 0.0, 0.0])
    t = np.cross(w_in, s)
    return (s * (sin * np.cos(phi))[:, None] + t * (sin * np.sin(phi))[:, None]
            + w_in * cos[:, None])


def exit_frame(P: np.ndarray, plane: np.ndarray):
    """The frame (t, b, n) of the exit surface at the exit point in direction P (unit rows):
    on the plane n = +z, t the radial direction (P_x, P_y, 0)/ρ, b = n × t; on the cap n = P,
    b = (−P_y, P_x, 0)/ρ, t = b × n. (+x, +y) where ρ = 0."""
    rho = np.hypot(P[:, 0], P[:, 1])
    ok = rho > 1e-12
    safe = np.where(ok, rho, 1.0)
    radial = np.where(ok[:, None], np.stack([P[:, 0] / safe, P[:, 1] / safe,
                                             np.zeros(len(P))], axis=1), [[1.0, 0.0, 0.0]])
    around = np.stack([-radial[:, 1], radial[:, 0], np.zeros(len(P))], axis=1)  # z × radial
    z = np.broadcast_to([0.0, 0.0, 1.0], P.shape)
    n = np.where(plane[:, None], z, P)
    t = np.where(plane[:, None], radial, np.cross(around, P))
    return t, around, n


def region_exit(P: np.ndarray, D: np.ndarray, h: np.ndarray) -> dict:
    """The exit point in direction P (unit rows) on the boundary of {|x| ≤ 1, z ≤ h} and the
    direction D (unit rows) reflected outwards there if it points in. Returns through_plane,
    exit_pos, exit_dir."""
    plane = P[:, 2] > h
    pos = np.where(plane[:, None], P * (h / np.where(plane, P[:, 2], 1.0))[:, None], P)
    pos[plane, 2] = h[plane]
    normal = np.where(plane[:, None], [[0.0, 0.0, 1.0]], P)
    dn = np.sum(D * normal, axis=1, keepdims=True)
    out_dir = np.where(dn < 0, D - 2.0 * dn * normal, D)
    return {"through_plane": plane.astype(np.uint8), "exit_pos": pos, "exit_dir": out_dir}


class CutSampler:
    """A whole cut sphere step: the first flight exactly, CutLengthGen and CutPathGen after."""

    def __init__(self, lengthgen, pathgen):
        for dec, spec in ((lengthgen, CUT_LENGTHGEN), (pathgen, CUT_PATHGEN)):
            if dec.name != spec.name:
                raise ValueError(f"{dec.path} holds {dec.name}, expected {spec.name}")
        self.lengthgen, self.pathgen = lengthgen, pathgen

    @classmethod
    def from_dir(cls, directory) -> "CutSampler":
        d = Path(directory)
        return cls(load_decoder(d / f"{CUT_LENGTHGEN.file_stem}.json"),
                   load_decoder(d / f"{CUT_PATHGEN.file_stem}.json"))

    def sample(self, sigma, g, h, mu0, n: int, rng: np.random.Generator) -> dict:
        """n steps; sigma, g, h, mu0 scalars or (n,) arrays inside the training ranges.
        Returns N, through_plane, exit_pos, exit_dir as `cut_sphere_walks` does."""
        sigma, g, h, mu0 = (np.broadcast_to(np.asarray(v, dtype=np.float64), (n,)).copy()
                            for v in (sigma, g, h, mu0))
        for name, v in (("sigma", sigma), ("g", g), ("h", h), ("mu0", mu0)):
            lo, hi = CONDITION_RANGES[name]
            bad = ~((v >= lo) & (v <= hi))
            if bad.any():
                raise ValueError(f"{name} = {float(v[bad][0])!r} is outside the cut models' "
                                 f"training range [{lo}, {hi}]")
        w_in = np.stack([np.sqrt(np.maximum(0.0, 1.0 - mu0 * mu0)), np.zeros(n), mu0], axis=1)
        w = _hg_directions(w_in, g, rng)
        with np.errstate(divide="ignore"):
            d = np.where(w[:, 2] > h, h / w[:, 2], 1.0)
        flight = -np.log1p(-rng.random(n)) / sigma
        one = flight >= d
        P, D = w.copy(), w.copy()  # N = 1: the exit point lies in the direction of flight
        N = np.ones(n, dtype=np.int64)
        m = ~one
        if m.any():
            cond = {"sigma": sigma[m], "g": g[m], "h": h[m], "mu0": mu0[m]}
            N[m] = self.lengthgen.sample(cond, rng)["N"]
            p = self.pathgen.sample({**cond, "N": N[m]}, rng)
            cos_p = np.clip(p["cos_p"], -1.0, 1.0)
            cos_psi = np.clip(p["cos_psi"], -1.0, 1.0)
            sin_p = np.sqrt(np.maximum(0.0, 1.0 - cos_p * cos_p))
            sin_psi = np.sqrt(np.maximum(0.0, 1.0 - cos_psi * cos_psi))
            Pm = np.stack([sin_p * cos_psi, sin_p * sin_psi, cos_p], axis=1)
            t, b, nrm = exit_frame(Pm, cos_p > h[m])
            a, bb = p["alpha"], p["beta"]  # in the unit disc (postprocess)
            gamma = np.sqrt(np.maximum(0.0, 1.0 - a * a - bb * bb))
            Dm = _unit_rows(t * a[:, None] + b * bb[:, None] + nrm * gamma[:, None], nrm)
            flip = rng.random(int(m.sum())) < 0.5
            Pm[flip, 1] *= -1.0
            Dm[flip, 1] *= -1.0
            P[m], D[m] = Pm, Dm
        return {"N": N, **region_exit(P, D, h)}


# --------------------------------------------------------------------------------------
# Fidelity
# --------------------------------------------------------------------------------------
EVAL_SIGMAS = (2.0, 6.0, 12.0, 24.0)
EVAL_GS = (0.0, 0.9)
EVAL_HS = (0.05, 0.3, 0.7)
EVAL_MU0S = (-1.0, 0.0, 1.0)
TARGET_KS = 0.05  # the sphere models' aim (models/README.md)
# The test suite fails past these (the shipped models' worst cells: KS 0.32, through-plane
# share 0.20 off; models/cut/README.md): a guard against regressions, not a fidelity aim.
REGRESSION_KS = 0.4
REGRESSION_PLANE = 0.25


def _exit_cosine(d: dict) -> np.ndarray:
    """Cosine between the exit direction and the boundary's outward normal at the exit."""
    normal = np.where(d["through_plane"][:, None] == 1, [[0.0, 0.0, 1.0]], d["exit_pos"])
    return np.sum(d["exit_dir"] * normal, axis=1)


CUT_METRICS = {
    "log_N": lambda d: np.log(d["N"].astype(np.float64)),
    "exit_z": lambda d: d["exit_pos"][:, 2],
    "exit_x": lambda d: d["exit_pos"][:, 0],
    "exit_cos": _exit_cosine,
    "dir_z": lambda d: d["exit_dir"][:, 2],
}


def evaluate_cut(sampler: CutSampler, samples: int = 10_000, seed: int = 0,
                 sigmas=EVAL_SIGMAS, gs=EVAL_GS, hs=EVAL_HS, mu0s=EVAL_MU0S) -> list[dict]:
    """Per cell (σ, g, h, μ0): `samples` steps from the sampler and from `cut_sphere_walks`;
    the KS statistic of each CUT_METRICS variable, and the share leaving through the plane in
    both with the standard error of their difference."""
    from scipy import stats

    cells = []
    grid = [(s, g, h, m) for s in sigmas for g in gs for h in hs for m in mu0s]
    for k, (sigma, g, h, mu0) in enumerate(grid):
        truth = cut_sphere_walks(sigma, g, h, mu0, 1.0, samples, seed=seed + 2 * k)
        truth = {**truth, "exit_pos": truth["exit_pos"].astype(np.float64),
                 "exit_dir": truth["exit_dir"].astype(np.float64)}
        model = sampler.sample(sigma, g, h, mu0, samples, np.random.default_rng([seed, k]))
        ks = {name: float(stats.ks_2samp(np.round(f(truth), 6), np.round(f(model), 6)).statistic)
              for name, f in CUT_METRICS.items()}
        pt, pm = float(truth["through_plane"].mean()), float(model["through_plane"].mean())
        se = float(np.sqrt((pt * (1 - pt) + pm * (1 - pm)) / samples))
        cells.append({"sigma": sigma, "g": g, "h": h, "mu0": mu0, "ks": ks,
                      "plane_truth": pt, "plane_model": pm, "plane_se": se,
                      "mean_N_truth": float(truth["N"].mean()),
                      "mean_N_model": float(model["N"].mean())})
    return cells


def table_markdown(cells: list[dict]) -> str:
    """One row per cell: KS per metric (bold above TARGET_KS), the share through the plane
    (truth / model) and mean N (truth / model)."""
    head = (["σ", "g", "h", "μ0"] + [f"{m} KS" for m in CUT_METRICS]
            + ["through plane (truth / model)", "mean N (truth / model)"])
    rows = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for c in cells:
        ks = [f"**{v:.3f}**" if v > TARGET_KS else f"{v:.3f}" for v in c["ks"].values()]
        rows.append(f"| {c['sigma']:g} | {c['g']:g} | {c['h']:g} | {c['mu0']:g} | "
                    + " | ".join(ks)
                    + f" | {c['plane_truth']:.3f} / {c['plane_model']:.3f}"
                    + f" | {c['mean_N_truth']:.1f} / {c['mean_N_model']:.1f} |")
    return "\n".join(rows)


def summary(cells: list[dict]) -> dict:
    """Median and worst KS per metric, and the worst through-plane difference in standard
    errors."""
    out = {}
    for name in CUT_METRICS:
        v = np.array([c["ks"][name] for c in cells])
        out[name] = {"median_ks": float(np.median(v)), "worst_ks": float(v.max()),
                     "cells_over_target": int((v > TARGET_KS).sum())}
    z = [abs(c["plane_model"] - c["plane_truth"]) / max(c["plane_se"], 1e-12) for c in cells]
    d = [abs(c["plane_model"] - c["plane_truth"]) for c in cells]
    out["through_plane"] = {"worst_abs_difference": float(max(d)),
                            "median_abs_difference": float(np.median(d)),
                            "worst_standard_errors": float(max(z))}
    out["cells"] = len(cells)
    return out


def _count(text: str) -> int:
    """An option's integer >= 1."""
    import argparse

    try:
        v = int(text)
    except ValueError:
        v = 0
    if v < 1:
        raise argparse.ArgumentTypeError(f"must be an integer >= 1, got {text!r}")
    return v


def main(argv=None) -> int:
    """The command line; bad input is one line naming it (exit 2), not a traceback."""
    import argparse

    prog = "python -m sssphere.learn.cut"
    ap = argparse.ArgumentParser(prog=prog,
                                 description="Train and check the cut sphere models.")
    sub = ap.add_subparsers(dest="command", required=True)
    t = sub.add_parser("train", help="generate walks and train CutLengthGen and CutPathGen")
    t.add_argument("-o", "--output", required=True, help="directory for the model files")
    t.add_argument("--walks", type=_count, default=4_000_000, help="walks to train on (>= 1)")
    t.add_argument("--epochs", type=_count, default=40, help="passes over the data (>= 1)")
    t.add_argument("--seed", type=int, default=0)
    e = sub.add_parser("eval", help="KS of the models against cut_sphere_walks, per cell")
    e.add_argument("models", help="directory holding cutlengthgen.json and cutpathgen.json")
    e.add_argument("--samples", type=_count, default=10_000, help="steps per cell (>= 1)")
    e.add_argument("--json", help="write the cells and summary here")
    args = ap.parse_args(argv)
    try:
        return _run(args)
    except (ValueError, OSError) as e:  # the messages name the file or the value
        print(f"{prog}: error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt as e:  # train_cut moves its files into place only when all are done
        from sssphere.learn.export import InterruptedAfterWrite

        done = isinstance(e, InterruptedAfterWrite)
        print(f"{prog}: interrupted: " + ("the models were written" if done else
                                          "wrote nothing"), file=sys.stderr)
        return 130


def _run(args) -> int:
    if args.command == "train":
        from sssphere.learn.export import prepare_output_dir

        # a bad output is told before minutes of walks and training, not after
        out = Path(args.output)
        created = prepare_output_dir(out, [f"{spec.file_stem}.{ext}" for spec in CUT_SPECS
                                           for ext in ("json", "onnx")])
        try:
            print(f"generating {args.walks:,} cut sphere walks ...", file=sys.stderr,
                  flush=True)
            data = generate_cut_data(args.walks, seed=args.seed)
            r = train_cut(data, out, epochs=args.epochs, seed=args.seed)
        except BaseException:
            if created and not any(out.iterdir()):
                out.rmdir()  # made for this run, and nothing was written
            raise
        for name in ("CutLengthGen", "CutPathGen"):
            print(f"{name}: val NLL {r[name]['val_nll']:.4f}, KL {r[name]['val_kl']:.4f}, "
                  f"{r[name]['seconds']:.0f} s")
        return 0
    cells = evaluate_cut(CutSampler.from_dir(args.models), samples=args.samples)
    print(table_markdown(cells))
    s = summary(cells)
    print(json.dumps(s, indent=1))
    if args.json:
        Path(args.json).write_text(json.dumps({"summary": s, "cells": cells}, indent=1) + "\n",
                                   encoding="utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
