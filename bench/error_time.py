#!/usr/bin/env python3
"""Error against time: `st` and `pt` at equal error, not only at equal samples (issue 26, item 3).

For each scene of bench/st_vs_pt.py's bunny (64x64, σt per ``--sigmas``, smooth dielectric and
index-matched), `pt` and `st` render at a doubling series of samples per pixel (each render its
own seed), and each image's sRGB RMSE against a converged `pt` reference is recorded with its
render time (the best of three identical renders where under a second). The reference's own
expected share of that error (from its per-pixel variance) is removed, as in
bench/st_vs_pt.py. A fit err² = a / t + b per integrator (a: the noise, b: what
more time does not remove, e.g. a model's bias) gives the time each needs for an error E,
t(E) = a / (E² − b); the **equal-error speed-up** is t_pt(E) / t_st(E), reported at
E = 0.02 and 0.01 (the issue's bar), extrapolated from the fits where the series stop short.

    python -m bench.error_time                    # ~8 min on 2 cores (references included)
    python -m bench.error_time --sigmas 1000 4000 --boundaries dielectric
    python -m bench.error_time --quick            # 16x16, short series: a smoke run

References are cached in bench/results/cache/ (as bench/st_vs_pt.py's). Writes
bench/results/error_time.json and, with matplotlib, error_time.png (the curves).
"""

from __future__ import annotations

import argparse
import datetime
import json
from pathlib import Path

import numpy as np

import sssphere
from bench.st_vs_pt import errors, reference, reference_error, scene_dict, timed
from bench.machine import machine

HERE = Path(__file__).resolve().parent


def fit(points: list[dict]) -> dict:
    """Least squares of err² = a / t + b over the series (b >= 0), in relative terms."""
    t = np.array([p["seconds"] for p in points])
    e2 = np.array([p["rmse_srgb_ref_corrected"] ** 2 for p in points])
    A = np.stack([1.0 / t, np.ones_like(t)], axis=1) / e2[:, None]
    (a, b), *_ = np.linalg.lstsq(A, np.ones_like(t), rcond=None)
    if b < 0:  # no floor resolved: err² = a / t alone
        a, b = float(np.sum(1.0 / (t * e2)) / np.sum(1.0 / (t * e2) ** 2)), 0.0
    return {"a": float(a), "b": float(b)}


def time_for(f: dict, err: float) -> float | None:
    """The time a fit needs for an error err (None: below its floor)."""
    room = err * err - f["b"]
    return f["a"] / room if room > 0 else None


def series(scene, integrator: str, spps: list[int], ref, ref_err, args) -> list[dict]:
    out = []
    for i, spp in enumerate(spps):
        # Under a second, the best time of three identical renders (bench/st_vs_pt.py).
        r = timed(scene, integrator, spp, 100 + i, args)
        e = errors(r, ref, ref_err)
        out.append({"spp": spp, "seconds": r.seconds, "rmse_srgb": e["rmse_srgb"],
                    "rmse_srgb_ref_corrected": e["rmse_srgb_ref_corrected"]})
        print(f"    {integrator} {spp:5d} spp  {r.seconds:7.2f} s  sRGB RMSE "
              f"{e['rmse_srgb']:.4f} ({e['rmse_srgb_ref_corrected']:.4f} without the reference's)",
              flush=True)
    return out


def plot(results: list[dict], path: Path) -> None:
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib not installed: no plot")
        return
    fig, axes = plt.subplots(1, len(results), figsize=(4.2 * len(results), 3.6), squeeze=False)
    for ax, res in zip(axes[0], results):
        for name, colour in (("pt", "tab:blue"), ("st", "tab:red")):
            pts = res["series"][name]
            t = np.array([p["seconds"] for p in pts])
            e = np.array([p["rmse_srgb_ref_corrected"] for p in pts])
            ax.loglog(t, e, "o", color=colour, label=name)
            f = res["fits"][name]
            reach = [t.max()] + [x for x in res["time_at"][name].values() if x]
            tt = np.geomspace(t.min() / 2, max(reach) * 1.5, 50)
            ax.loglog(tt, np.sqrt(f["a"] / tt + f["b"]), "-", color=colour, lw=1)
        ax.axhline(0.01, color="grey", lw=0.8, ls="--")
        s = res["speedup_at"]
        ax.set_title(f"{res['boundary']} bunny, σt {res['sigma']:g}\n"
                     f"equal error ×{s['0.02']:.1f} (0.02), ×{s['0.01']:.1f} (0.01)"
                     if s["0.01"] else f"{res['boundary']} bunny, σt {res['sigma']:g}", fontsize=9)
        ax.set_xlabel("render time (s, 2 threads)")
        ax.set_ylabel("sRGB RMSE vs converged pt")
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    print(f"wrote {path}")


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--sigmas", type=float, nargs="+", default=[1000.0])
    p.add_argument("--boundaries", nargs="+", default=["dielectric", "index_matched"],
                   choices=["dielectric", "index_matched"])
    p.add_argument("--resolution", type=int, default=64)
    p.add_argument("--pt-spp", type=int, nargs="+", default=[8, 16, 32, 64, 128])
    p.add_argument("--st-spp", type=int, nargs="+", default=[8, 16, 32, 64, 128, 256, 512])
    p.add_argument("--ref-spp", type=int, default=1024)
    p.add_argument("--threads", type=int, default=0)
    p.add_argument("--models", default=None, help="model directory (default: models/)")
    p.add_argument("--quick", action="store_true")
    p.add_argument("--cache", default=str(HERE / "results" / "cache"))
    p.add_argument("--output", type=Path, default=HERE / "results" / "error_time.json")
    args = p.parse_args()
    if args.models is None:
        args.models = str(HERE.parent / "models")
    if args.quick:
        args.resolution, args.pt_spp, args.st_spp, args.ref_spp = 16, [2, 4, 8], [2, 4, 8], 32

    results = []
    for boundary in args.boundaries:
        for sigma in args.sigmas:
            print(f"{boundary} bunny, sigma_t {sigma:g}", flush=True)
            scene = sssphere.load_scene(scene_dict("bunny", boundary, sigma, args.resolution),
                                        threads=args.threads)
            key = f"error_time_bunny_{boundary}_{sigma:g}_{args.resolution}_{args.ref_spp}"
            ref = reference(scene, key, args.ref_spp, args)
            ref_err = reference_error(ref)
            res = {"boundary": boundary, "sigma": sigma, "reference_spp": args.ref_spp,
                   "reference_rmse_srgb": ref_err["rmse_srgb"],
                   "series": {"pt": series(scene, "pt", args.pt_spp, ref, ref_err, args),
                              "st": series(scene, "st", args.st_spp, ref, ref_err, args)}}
            res["fits"] = {k: fit(v) for k, v in res["series"].items()}
            res["time_at"] = {k: {f"{e:g}": time_for(f, e) for e in (0.02, 0.01)}
                              for k, f in res["fits"].items()}
            res["speedup_at"] = {}
            for e in ("0.02", "0.01"):
                a, b = res["time_at"]["pt"][e], res["time_at"]["st"][e]
                res["speedup_at"][e] = a / b if a and b else None
            print(f"  fits err^2 = a/t + b: pt a {res['fits']['pt']['a']:.3g} b "
                  f"{res['fits']['pt']['b']:.3g}; st a {res['fits']['st']['a']:.3g} b "
                  f"{res['fits']['st']['b']:.3g}")
            for e in ("0.02", "0.01"):
                tp, ts, sp = res["time_at"]["pt"][e], res["time_at"]["st"][e], res["speedup_at"][e]
                print(f"  error {e}: pt {tp and f'{tp:.1f} s'}, st {ts and f'{ts:.1f} s'}, "
                      f"equal-error speed-up {sp and f'x{sp:.2f}'}", flush=True)
            results.append(res)

    args.output.parent.mkdir(parents=True, exist_ok=True)
    args.output.write_text(json.dumps({
        "date": datetime.datetime.now().isoformat(timespec="seconds"),
        "machine": machine(), "threads": args.threads, "resolution": args.resolution,
        "results": results}, indent=1) + "\n")
    print(f"wrote {args.output}")
    plot(results, args.output.with_suffix(".png"))


if __name__ == "__main__":
    main()
