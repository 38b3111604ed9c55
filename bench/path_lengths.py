#!/usr/bin/env python3
"""How long single paths are in `pt` and `st`, and what that predicts for a GPU.

The paper's ×16 (its Fig. 7 and 8) is a GPU figure: "up to 3000 scattering events per path"
in path tracing against "less than 50 steps", "reduced by a factor of up to 60x". A GPU runs
the paths of a warp in lockstep, so a warp takes as long as its longest path, and the tail of
the path-length distribution sets the time. A CPU thread runs one path after another, so the
mean does. This script measures the distribution (`render_full(record_paths=True)`) over
st_vs_pt.py's scenes and settings (equal spp, seed 1) and reports, per scene:

* per path: mean, median, 90th / 99th / 99.9th percentile and maximum of `pt`'s scattering
  events and of `st`'s events + sphere steps (and `st`'s steps alone);
* the **lockstep estimate**: warps of 32 lanes, each an 8x4 block of pixels at one sample
  index (a compute shader with one path per pixel and dispatch, no path regeneration, as in
  the paper); a lane costs one unit per `pt` event, and per `st` event + c units per step
  (c = 1, and c = 3: the issue's bound on a step's cost). The estimate is
  sum over warps of the longest lane in `pt` / the same in `st`. Next to it the same ratio
  of sums over all lanes (what a CPU sees when a step costs c events) and the lockstep
  efficiency (useful lane work / 32 x the longest lane) of both;
* the CPU's measured speed-up of the same renders (2 threads; st_vs_pt.py times more
  carefully).

The estimate is a model, not a GPU measurement: it ignores that lanes' iterations differ in
cost (boundary rays, shadow rays, the decoders), memory, occupancy and path regeneration.

    python -m bench.path_lengths                 # ~1 min on 2 cores
    python -m bench.path_lengths --dense         # + sigma_t 2000-8000, ~1.5 min
    python -m bench.path_lengths --table bench/results/path_lengths.json
    python -m bench.path_lengths --plot bench/results/path_lengths.json

Writes bench/results/path_lengths.json and, with matplotlib, path_lengths.png (the
distribution of path lengths at every density, and the estimates against sigma_t).
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent

import sssphere  # noqa: E402
from bench.st_vs_pt import BASE_SIGMA, BOUNDARIES, SCALES, SHAPES, pyplot, scene_dict, timed  # noqa: E402
from bench.machine import machine  # noqa: E402

WARP = (4, 8)  # lanes of one warp: 4 rows x 8 columns of pixels, one sample index
STEP_COSTS = (1.0, 3.0)  # lane units per sphere step, one pt event = 1
QUANTILES = (50, 90, 99, 99.9)
DENSE_SCALES = (4.0, 8.0, 16.0)
CCDF_AT = np.unique(np.round(np.logspace(0, 6, 241)).astype(np.int64))  # path lengths 1 .. 1e6


def ccdf(n: np.ndarray) -> list:
    """The fraction of paths at least CCDF_AT[i] long."""
    n = np.sort(n.ravel())
    return (1.0 - np.searchsorted(n, CCDF_AT, side="left") / n.size).tolist()


def distribution(n: np.ndarray) -> dict:
    n = n.astype(np.float64).ravel()
    q = np.percentile(n, QUANTILES)
    return {"mean": float(n.mean()), **{f"p{k:g}": float(v) for k, v in zip(QUANTILES, q)},
            "max": float(n.max())}


def warp_max(cost: np.ndarray) -> np.ndarray:
    """The longest lane of each warp: cost is (spp, H, W), H and W multiples of WARP."""
    k, h, w = cost.shape
    wy, wx = WARP
    return cost.reshape(k, h // wy, wy, w // wx, wx).max(axis=(2, 4))


def lockstep(pt_events: np.ndarray, st_events: np.ndarray, st_steps: np.ndarray) -> dict:
    lanes = WARP[0] * WARP[1]
    pt = pt_events.astype(np.float64)
    pt_max = warp_max(pt).sum()
    out = {"pt_efficiency": float(pt.sum() / (lanes * pt_max))}
    for c in STEP_COSTS:
        st = st_events.astype(np.float64) + c * st_steps
        st_max = warp_max(st).sum()
        out[f"c{c:g}"] = {"lockstep_ratio": float(pt_max / st_max),
                          "mean_ratio": float(pt.sum() / st.sum()),
                          "st_efficiency": float(st.sum() / (lanes * st_max))}
    return out


def run_case(shape, boundary, scale, args) -> dict:
    sigma = BASE_SIGMA * scale
    scene = sssphere.load_scene(scene_dict(shape, boundary, sigma, args.resolution), threads=args.threads)
    kw = dict(record_paths=True)
    pt = timed(scene, "pt", args.spp, 1, args, **kw)
    st = timed(scene, "st", args.spp, 1, args, **kw)
    return {"shape": shape, "boundary": boundary, "sigma_t": sigma, "scale": scale,
            "pt_events": distribution(pt.path_events),
            "st_events_plus_steps": distribution(st.path_events + st.path_steps),
            "st_steps": distribution(st.path_steps),
            "lockstep": lockstep(pt.path_events, st.path_events, st.path_steps),
            "cpu": {"pt_seconds": pt.seconds, "st_seconds": st.seconds,
                    "speedup": pt.seconds / st.seconds},
            "ccdf": {"length": CCDF_AT.tolist(), "pt": ccdf(pt.path_events),
                     "st": ccdf(st.path_events + st.path_steps)}}


def tables(results) -> str:
    out = ["| scene | σt | pt events per path: mean / p99 / p99.9 / max | st events + steps: mean / p99 / "
           "p99.9 / max | st steps max | CPU speed-up (measured) | mean ratio, c = 1 / 3 | "
           "lockstep estimate, c = 1 / 3 | lockstep efficiency pt / st (c = 3) |",
           "|---|---:|---|---|---:|---:|---|---|---|"]
    for r in results["scenes"]:
        p, s, ls = r["pt_events"], r["st_events_plus_steps"], r["lockstep"]
        out.append(
            f"| {r['shape'].replace('_', ' ')}, {r['boundary'].replace('_', '-')} | {r['sigma_t']:g} "
            f"| {p['mean']:.0f} / {p['p99']:.0f} / {p['p99.9']:.0f} / {p['max']:.0f} "
            f"| {s['mean']:.1f} / {s['p99']:.0f} / {s['p99.9']:.0f} / {s['max']:.0f} "
            f"| {r['st_steps']['max']:.0f} | ×{r['cpu']['speedup']:.2f} "
            f"| ×{ls['c1']['mean_ratio']:.1f} / ×{ls['c3']['mean_ratio']:.1f} "
            f"| **×{ls['c1']['lockstep_ratio']:.1f} / ×{ls['c3']['lockstep_ratio']:.1f}** "
            f"| {ls['pt_efficiency']:.2f} / {ls['c3']['st_efficiency']:.2f} |")
    return "\n".join(out)


def plot(results, output: Path) -> list:
    plt = pyplot()
    if plt is None:
        return []

    rows = results["scenes"]
    fams = [(s, b) for s in SHAPES for b in BOUNDARIES if any((r["shape"], r["boundary"]) == (s, b) for r in rows)]
    fig, ax = plt.subplots(1, 1 + len(fams[:2]), figsize=(6 * (1 + len(fams[:2])), 4.5))
    # The complementary CDF of per-path lengths, one panel per bunny family.
    for a, fam in zip(ax[1:], fams[:2]):
        fr = [r for r in rows if (r["shape"], r["boundary"]) == fam]
        cmap = plt.get_cmap("viridis")
        for i, r in enumerate(fr):
            col = cmap(i / max(1, len(fr) - 1))
            x = np.asarray(r["ccdf"]["length"])
            for key, ls in (("pt", "-"), ("st", "--")):
                y = np.asarray(r["ccdf"][key])
                keep = y > 0
                a.loglog(x[keep], y[keep], ls, color=col, label=f"{key}, σt {r['sigma_t']:g}")
        a.set_xlabel("pt events / st events + steps per path")
        a.set_ylabel("fraction of paths at least this long")
        a.set_title(f"{fam[0]}, {fam[1]}: path lengths (pt solid, st dashed)")
        a.legend(fontsize=7, ncol=2)
    style = {"dielectric": "o-", "index_matched": "s-"}
    for fam in fams:
        fr = [r for r in rows if (r["shape"], r["boundary"]) == fam]
        s = [r["sigma_t"] for r in fr]
        lab = f"{fam[0]}, {fam[1]}"
        mk = style[fam[1]] if fam[0] == "bunny" else style[fam[1]].replace("-", ":")
        ax[0].semilogx(s, [r["cpu"]["speedup"] for r in fr], mk, color="k", label=f"CPU measured, {lab}")
        ax[0].semilogx(s, [r["lockstep"]["c3"]["lockstep_ratio"] for r in fr], mk, color="C3",
                       label=f"lockstep estimate (c = 3), {lab}")
    sig = sorted({r["sigma_t"] for r in rows})
    ax[0].set_xticks(sig, [f"{x:g}" for x in sig], fontsize=8)
    ax[0].minorticks_off()
    ax[0].axhline(16, color="grey", lw=0.8, ls=":")
    ax[0].set_xlabel("σt per unit length")
    ax[0].set_ylabel("pt / st")
    ax[0].set_title("speed-up: CPU measured vs GPU-lockstep estimate")
    ax[0].legend(fontsize=7)
    fig.tight_layout()
    f = output.with_suffix(".png")
    fig.savefig(f, dpi=110)
    plt.close(fig)
    return [f]


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--resolution", type=int, default=64, help="square image side, a multiple of 8")
    p.add_argument("--spp", type=int, default=32)
    p.add_argument("--scales", type=float, nargs="+", default=list(SCALES), help="sigma_t / 500")
    p.add_argument("--dense", action="store_true", help="add sigma_t 2000, 4000, 8000 (bunny only)")
    p.add_argument("--shapes", nargs="+", default=list(SHAPES), choices=list(SHAPES))
    p.add_argument("--boundaries", nargs="+", default=list(BOUNDARIES), choices=list(BOUNDARIES))
    p.add_argument("--threads", type=int, default=0, help="0 = all cores")
    p.add_argument("--models", default=None, help="model directory (default: the repository's models/)")
    p.add_argument("--output", type=Path, default=HERE / "results" / "path_lengths.json")
    p.add_argument("--table", type=Path, default=None, help="print the table of an existing JSON and exit")
    p.add_argument("--plot", type=Path, default=None, help="draw the figure of an existing JSON and exit")
    args = p.parse_args(argv)
    if args.table:
        print(tables(json.loads(args.table.read_text())))
        return 0
    if args.plot:
        for f in plot(json.loads(args.plot.read_text()), args.plot):
            print(f"wrote {f}")
        return 0
    if args.resolution % 8:
        p.error(f"--resolution {args.resolution} is not a multiple of 8 (warps are 8x4 pixels)")
    threads = args.threads if args.threads > 0 else (os.cpu_count() or 1)
    results = {"date": datetime.datetime.now().isoformat(timespec="seconds"),
               "machine": machine(),
               "settings": {**{k: (str(v) if isinstance(v, Path) else v) for k, v in vars(args).items()},
                            "threads_used": threads, "warp_pixels": list(WARP),
                            "step_costs": list(STEP_COSTS), "seed": 1},
               "scenes": []}
    t0 = time.perf_counter()
    cases = [(s, b, x) for s in args.shapes for b in args.boundaries for x in args.scales]
    if args.dense:
        cases += [("bunny", b, x) for b in args.boundaries for x in DENSE_SCALES]
    cases.sort(key=lambda c: (list(SHAPES).index(c[0]), BOUNDARIES.index(c[1]), c[2]))
    for shape, boundary, scale in cases:
        r = run_case(shape, boundary, scale, args)
        results["scenes"].append(r)
        ls = r["lockstep"]
        print(f"{shape:10s} {boundary:13s} sigma_t {r['sigma_t']:6g}: pt max {r['pt_events']['max']:7.0f} "
              f"st max {r['st_events_plus_steps']['max']:5.0f}  CPU x{r['cpu']['speedup']:5.2f}  lockstep "
              f"x{ls['c1']['lockstep_ratio']:5.1f} (c 1) x{ls['c3']['lockstep_ratio']:5.1f} (c 3)  "
              f"[{time.perf_counter() - t0:.0f} s]", flush=True)
    results["total_seconds"] = time.perf_counter() - t0
    args.output.parent.mkdir(parents=True, exist_ok=True)
    args.output.write_text(json.dumps(results) + "\n")
    print(tables(results))
    print(f"wrote {args.output}")
    for f in plot(results, args.output):
        print(f"wrote {f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
