#!/usr/bin/env python3
"""Sphere tracing (`st`) against path tracing (`pt`) and Mitsuba 3 over the paper's density sweep.

Scenes: the bunny (normalized, largest side 1) and the thin torus (scenes/thin_torus.json's
mesh, tube radius 0.035), each with a smooth dielectric boundary (eta = 1.5) and index-matched,
sigma_t = 500 x {0.25, 0.5, 1, 2} per unit, albedo (0.999, 0.99995, 0.999), g = 0.9. Lighting
everywhere as in scenes/bunny.json (area light above, dim environment); cameras from the scene
files. For every scene:

* equal spp (``--spp``, seed 1): `pt` (NEE on) and `st` (tau = the default): wall time,
  speed-up, mean scattering events per path (`pt`) and events + sphere steps per path (`st`),
  per-pixel heat maps of both (the paper's Fig. 7);
* a converged `pt` reference (seed 1000) at ``--ref-spp`` samples, lowered to a power of two
  whose projected time fits ``--ref-budget`` seconds; its own estimated error (from its
  per-pixel variance) is recorded next to it. References are cached in bench/results/cache/;
* equal time (the time of `pt` at ``--spp``): `st`, `pt` with NEE and `pt` without NEE, their
  spp scaled by their measured cost per sample; errors against the reference: RMSE of the
  sRGB-tonemapped images (clip to [0, 1], sRGB curve) and relative MSE
  (mean of (x - ref)^2 / (ref^2 + 0.01) over pixels and channels), both raw and with the
  reference's own expected contribution removed, plus the bias of the image mean;
* Mitsuba 3 `volpath` (scalar_rgb, max_depth -1, rr_depth 1e5, as bench/pt_vs_mitsuba.py) at
  the same spp as `st` on a subset (``--mitsuba``): time ratio Mitsuba / `st`.

The cost of one sphere step is derived from the renders: per (shape, boundary) a fit of `pt`'s
time per path, a + b * events, over all its `pt` renders gives the cost b of one event; the
time of each `st` render above a + b * events, divided by its steps, is the cost of a step.

    python -m bench.st_vs_pt            # full run, ~7 min on 2 cores
    python -m bench.st_vs_pt --quick    # smoke run, ~30 s
    python -m bench.st_vs_pt --table bench/results/st_vs_pt.json  # tables only

Writes bench/results/st_vs_pt.json (rewritten after each scene) and, with matplotlib,
st_vs_pt.png (speed-up, complexity, errors), st_vs_pt_steps.png (heat maps) and
st_vs_pt_images.png (the densest bunny at equal time) in bench/results/.
"""

from __future__ import annotations

import argparse
import copy
import datetime
import json
import math
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
REPO = HERE.parent

import sssphere  # noqa: E402
from sssphere.rendering import DEFAULT_SPHERE_THRESHOLD as DEFAULT_TAU  # noqa: E402
from bench.st_threshold import rmse_srgb, srgb  # noqa: E402
from bench.machine import machine  # noqa: E402

SHAPES = {"bunny": "scenes/bunny.json", "thin_torus": "scenes/thin_torus.json"}
BOUNDARIES = ("dielectric", "index_matched")
BASE_SIGMA = 500.0
SCALES = (0.25, 0.5, 1.0, 2.0)
ALBEDO = [0.999, 0.99995, 0.999]
G = 0.9
REL_EPS = 0.01  # relative MSE: (x - ref)^2 / (ref^2 + REL_EPS)
# Mitsuba subset: (shape, boundary, scale)
MITSUBA_CASES = (("bunny", "dielectric", 0.25), ("bunny", "dielectric", 2.0),
                 ("bunny", "index_matched", 0.25), ("bunny", "index_matched", 2.0))


def scene_dict(shape: str, boundary: str, sigma: float, res: int) -> dict:
    """The scene file's camera and mesh with the sweep's medium, boundary and bunny.json's lights."""
    d = json.loads((REPO / SHAPES[shape]).read_text())
    lights = json.loads((REPO / SHAPES["bunny"]).read_text())["lights"]
    d["camera"]["width"] = d["camera"]["height"] = res
    s = d["shapes"][0]
    mesh = Path(s["mesh"])
    s["mesh"] = str(mesh if mesh.is_absolute() else REPO / "scenes" / mesh)
    s["medium"] = {"sigma_t": [sigma] * 3, "albedo": list(ALBEDO), "g": G}
    s["boundary"] = {"type": "dielectric", "ior": 1.5} if boundary == "dielectric" \
        else {"type": "index_matched"}
    d["lights"] = copy.deepcopy(lights)
    d.pop("render", None)
    return d


def rel_mse(a: np.ndarray, ref: np.ndarray) -> float:
    return float(np.mean((a - ref) ** 2 / (ref ** 2 + REL_EPS)))


def srgb_slope(x: np.ndarray) -> np.ndarray:
    """d srgb / dx (0 where clipped): the delta method for the reference's own sRGB error."""
    y = np.where(x <= 0.0031308, 12.92, 1.055 / 2.4 * np.power(np.maximum(x, 1e-12), 1 / 2.4 - 1))
    return np.where((x <= 0) | (x >= 1), 0.0, y)


def noise_error(variance, ref_image) -> dict:
    """Expected error from noise alone, given a per-pixel variance of the mean (sRGB by the
    delta method, with the slope taken at the reference)."""
    var = np.asarray(variance, dtype=np.float64)
    img = np.asarray(ref_image, dtype=np.float64)
    return {"rmse_srgb": float(np.sqrt(np.nanmean(srgb_slope(img) ** 2 * var))),
            "rel_mse": float(np.nanmean(var / (img ** 2 + REL_EPS)))}


def reference_error(ref) -> dict:
    """Expected error of the reference itself from its per-pixel variance of the mean."""
    return noise_error(ref.variance, ref.image)


def errors(r, ref, ref_err: dict) -> dict:
    a, b = r.image.astype(np.float64), ref.image.astype(np.float64)
    # Pixels with a non-finite value in either image (a NaN sample) are left out and counted.
    bad = ~(np.isfinite(a).all(axis=2) & np.isfinite(b).all(axis=2))
    if bad.any():
        a, b = a[~bad][None], b[~bad][None]
        r = argparse.Namespace(image=a, variance=r.variance[~bad][None])
        ref = argparse.Namespace(image=b, variance=ref.variance[~bad][None])
        ref_err = reference_error(ref)
    n = a.shape[0] * a.shape[1]
    mean, mean_ref = a.mean(axis=(0, 1)), b.mean(axis=(0, 1))
    sigma = np.sqrt(r.variance.astype(np.float64).sum(axis=(0, 1))
                    + ref.variance.astype(np.float64).sum(axis=(0, 1))) / n
    rmse, rmse_ref = rmse_srgb(a, b), ref_err["rmse_srgb"]
    rel, rel_ref = rel_mse(a, b), ref_err["rel_mse"]
    own = noise_error(r.variance, b)
    return {
        "rmse_srgb": rmse,
        # E[(x - ref)^2] = (x - truth)^2 + var(ref): remove the reference's expected share.
        "rmse_srgb_ref_corrected": float(math.sqrt(max(rmse ** 2 - rmse_ref ** 2, 0.0))),
        "rel_mse": rel,
        "rel_mse_ref_corrected": max(rel - rel_ref, 0.0),
        # Both renders' expected noise removed: what is left estimates the systematic error
        # (bias, model error); noisy itself where the noise dominates.
        "rmse_srgb_noise_removed": float(math.sqrt(max(
            rmse ** 2 - rmse_ref ** 2 - own["rmse_srgb"] ** 2, 0.0))),
        "rel_mse_noise_removed": max(rel - rel_ref - own["rel_mse"], 0.0),
        "own_noise": own,
        "non_finite_pixels_left_out": int(bad.sum()),
        "bias": ((mean - mean_ref) / mean_ref).tolist(),
        "bias_sigma": (sigma / mean_ref).tolist(),
    }


def render(scene, integrator, spp, seed, args, **kw):
    if integrator == "st":
        kw.setdefault("models", args.models)
    return sssphere.render_full(scene, integrator=integrator, spp=int(spp), seed=seed,
                                threads=args.threads, **kw)


def summary(r, spp) -> dict:
    img = r.image.astype(np.float64)
    steps = r.mean_sphere_steps_per_path * float(r.samples.sum())
    return {"spp": int(spp), "seconds": r.seconds, "events_per_path": r.mean_events_per_path,
            "sphere_steps_per_path": r.mean_sphere_steps_per_path,
            # One step's sampling (decoders, frame), timed in the render, per thread.
            "step_ns": 1e9 * r.step_seconds / steps if steps > 0 else None,
            "non_finite_pixels": int((~np.isfinite(img).all(axis=2)).sum()),
            "image_mean": np.nanmean(img, axis=(0, 1)).tolist()}


def timed(scene, integrator, spp, seed, args, **kw):
    """A render whose time, if under a second, is the best of three identical renders (the
    image is the same: renders are deterministic); short renders are otherwise too noisy."""
    r = render(scene, integrator, spp, seed, args, **kw)
    if r.seconds < 1.0:
        r.seconds = min([r.seconds] + [render(scene, integrator, spp, seed, args, **kw).seconds
                                       for _ in range(2)])
    return r


def reference(scene, key, spp, args):
    file = Path(args.cache) / f"{key}.npz"
    if file.exists():
        z = np.load(file)
        return argparse.Namespace(image=z["image"], variance=z["variance"],
                                  seconds=float(z["seconds"]), events=float(z["events"]), cached=True)
    r = render(scene, "pt", spp, 1000, args)
    file.parent.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(file, image=r.image, variance=r.variance, seconds=r.seconds,
                        events=r.mean_events_per_path)
    return argparse.Namespace(image=r.image, variance=r.variance, seconds=r.seconds,
                              events=r.mean_events_per_path, cached=False)


def run_scene(shape, boundary, scale, args, maps) -> dict:
    sigma = BASE_SIGMA * scale
    sd = scene_dict(shape, boundary, sigma, args.resolution)
    scene = sssphere.load_scene(sd, threads=args.threads)
    S = args.spp
    pt = timed(scene, "pt", S, 1, args)
    st = timed(scene, "st", S, 1, args)
    # Reference: the largest power of two <= ref_spp whose projected time fits the budget.
    per_spp = pt.seconds / S
    ref_spp = args.ref_spp
    while ref_spp > 4 * S and ref_spp * per_spp > args.ref_budget:
        ref_spp //= 2
    key = f"{shape}_{boundary}_s{sigma:g}_{args.resolution}px_{ref_spp}spp"
    ref = reference(scene, key, ref_spp, args)
    ref_err = reference_error(ref)
    nonee = timed(scene, "pt", S, 2, args, nee=False)
    # Equal time: pt's time at S spp; the others' spp scaled by their cost per sample.
    st_spp = max(1, round(S * pt.seconds / st.seconds))
    st_eq = render(scene, "st", st_spp, 3, args)
    nonee_spp = max(1, round(S * pt.seconds / nonee.seconds))
    nonee_eq = nonee if abs(nonee_spp - S) <= 0.1 * S else render(scene, "pt", nonee_spp, 4, args, nee=False)
    if abs(nonee_spp - S) <= 0.1 * S:
        nonee_spp = S
    # The densest bunny: st at the reference's spp too, to see its error near convergence.
    dense = shape == "bunny" and scale == max(args.scales)
    st_conv = None
    if dense:
        c = render(scene, "st", ref_spp, 6, args)
        st_conv = {**summary(c, ref_spp), **errors(c, ref, ref_err)}
    # Index-matched: st with the paper's step NEE (EventGen's event connects to every light)
    # next to the default (area and environment light from the exit flight's hits).
    event = None
    if boundary == "index_matched":
        ev = timed(scene, "st", S, 1, args, step_nee="event")
        ev_spp = max(1, round(S * pt.seconds / ev.seconds))
        ev_eq = render(scene, "st", ev_spp, 3, args, step_nee="event")
        event = {"equal_spp": {**summary(ev, S), **errors(ev, ref, ref_err)},
                 "speedup": pt.seconds / ev.seconds,
                 "equal_time": {**summary(ev_eq, ev_spp), **errors(ev_eq, ref, ref_err)}}
        if dense:
            c = render(scene, "st", ref_spp, 6, args, step_nee="event")
            event["at_reference_spp"] = {**summary(c, ref_spp), **errors(c, ref, ref_err)}
    # Index-matched: st without NEE too, next to pt without NEE (large lights, where
    # phase-sampled hits find the light and NEE costs more than it saves).
    st_nonee = None
    if boundary == "index_matched":
        sn = timed(scene, "st", S, 2, args, nee=False)
        sn_spp = max(1, round(S * pt.seconds / sn.seconds))
        sn_eq = render(scene, "st", sn_spp, 4, args, nee=False)
        st_nonee = {"equal_spp": summary(sn, S), "speedup_over_pt_no_nee": nonee.seconds / sn.seconds,
                    "equal_time": {**summary(sn_eq, sn_spp), **errors(sn_eq, ref, ref_err)}}
    maps[(shape, boundary, scale)] = {
        "pt": pt.events, "st": st.events + st.sphere_steps, "st_steps": st.sphere_steps,
        "ref": ref.image, "pt_img": pt.image, "st_eq_img": st_eq.image, "nonee_eq_img": nonee_eq.image}
    paths = args.resolution ** 2
    row = {
        "shape": shape, "boundary": boundary, "sigma_t": sigma, "scale": scale,
        "resolution": args.resolution, "spp": S,
        "pt": summary(pt, S), "st": summary(st, S),
        "speedup": pt.seconds / st.seconds,
        "pt_events_per_path": pt.mean_events_per_path,
        "st_events_plus_steps_per_path": st.mean_events_per_path + st.mean_sphere_steps_per_path,
        "equal_spp_errors": {"pt": errors(pt, ref, ref_err), "st": errors(st, ref, ref_err)},
        "reference": {"spp": ref_spp, "seconds": ref.seconds, "cached": ref.cached,
                      "own_error": ref_err,
                      "non_finite_pixels": int((~np.isfinite(ref.image).all(axis=2)).sum()),
                      "image_mean": np.nanmean(ref.image.astype(np.float64), axis=(0, 1)).tolist()},
        "equal_time": {
            "pt_nee": {**summary(pt, S), **errors(pt, ref, ref_err)},
            "pt_no_nee": {**summary(nonee_eq, nonee_spp), **errors(nonee_eq, ref, ref_err)},
            "st": {**summary(st_eq, st_spp), **errors(st_eq, ref, ref_err)},
        },
        "pt_no_nee_equal_spp": summary(nonee, S),
        "st_at_reference_spp": st_conv,
        "st_step_nee_event": event,
        "st_no_nee": st_nonee,
        "ns_per_path": {"pt": 1e9 * pt.seconds / (paths * S), "st": 1e9 * st.seconds / (paths * S),
                        "ref": 1e9 * ref.seconds / (paths * ref_spp),
                        "st_eq": 1e9 * st_eq.seconds / (paths * st_spp)},
        "st_eq_events_per_path": st_eq.mean_events_per_path,
        "st_eq_steps_per_path": st_eq.mean_sphere_steps_per_path,
        "ref_events_per_path": ref.events,
    }
    return row


def step_cost(rows, threads: int) -> dict:
    """Per (shape, boundary): the cost of a `pt` event, from a fit of pt's ns per path = a + b *
    events over its pt renders (wall time with `threads` threads, so b * threads is one event
    on one thread), next to the cost of a sphere step timed inside the st renders (sampling:
    decoders and frame, per thread). Also each st render's ns per path above a + b * events,
    per step: what its steps and the events it has left cost beyond pt's average event."""
    out = {}
    for shape in SHAPES:
        for boundary in BOUNDARIES:
            fam = [r for r in rows if r["shape"] == shape and r["boundary"] == boundary]
            if len(fam) < 2:
                continue
            # pt renders at --spp, and the references where timed in this run.
            x = np.array([r["pt_events_per_path"] for r in fam]
                         + [r["ref_events_per_path"] for r in fam if r["ns_per_path"]["ref"]])
            y = np.array([r["ns_per_path"]["pt"] for r in fam]
                         + [r["ns_per_path"]["ref"] for r in fam if r["ns_per_path"]["ref"]])
            b, a = np.polyfit(x, y, 1)
            per = []
            for r in fam:
                for ns, summ in ((r["ns_per_path"]["st"], r["st"]),
                                 (r["ns_per_path"]["st_eq"], r["equal_time"]["st"])):
                    stp = summ["sphere_steps_per_path"]
                    if stp > 0.5:  # too few steps: the residual is noise
                        per.append({"sigma_t": r["sigma_t"], "steps_per_path": stp,
                                    "step_ns_timed": summ.get("step_ns"),
                                    "excess_ns_per_step": (ns - a - b * summ["events_per_path"]) / stp})
            timed_ns = [p["step_ns_timed"] for p in per if p["step_ns_timed"] is not None]
            ns_step = float(np.median(timed_ns)) if timed_ns else None
            excess = float(np.median([p["excess_ns_per_step"] for p in per])) if per else None
            event_ns = float(b) * threads
            out[f"{shape}/{boundary}"] = {
                "pt_ns_per_path_fixed": float(a), "pt_ns_per_event": float(b),
                "pt_thread_ns_per_event": event_ns,
                "st_thread_ns_per_step": ns_step,
                "step_in_pt_events": ns_step / event_ns if ns_step is not None and b > 0 else None,
                "st_excess_ns_per_step": excess,
                "excess_in_pt_events": excess / b if excess is not None and b > 0 else None,
                "per_render": per}
    return out


def mitsuba_case(shape, boundary, scale, args, mu, mi, warm, st_row) -> dict:
    sd = scene_dict(shape, boundary, BASE_SIGMA * scale, args.resolution)
    scene = sssphere.load_scene(sd, threads=args.threads)
    with tempfile.TemporaryDirectory(prefix="st_vs_pt-") as tmp:
        mi_scene = mi.load_dict(mu.mitsuba_scene_dict(sd, scene, tmp, spp=args.mitsuba_spp, seed=1,
                                                      rr_depth=mu.RR_DEPTH, max_depth=-1))
        if not warm:
            mi.render(mi_scene, spp=1, seed=1)
        t0 = time.perf_counter()
        img = np.array(mi.render(mi_scene, spp=args.mitsuba_spp, seed=1), dtype=np.float64)[:, :, :3]
        mi_s = time.perf_counter() - t0
        del mi_scene
    st = render(scene, "st", args.mitsuba_spp, 5, args)
    pt = render(scene, "pt", args.mitsuba_spp, 5, args)
    ref_mean = np.array(st_row["reference"]["image_mean"])
    return {"shape": shape, "boundary": boundary, "sigma_t": BASE_SIGMA * scale,
            "spp": args.mitsuba_spp, "mitsuba_seconds": mi_s, "st_seconds": st.seconds,
            "pt_seconds": pt.seconds,
            "ratio_mitsuba_over_st": mi_s / st.seconds, "ratio_mitsuba_over_pt": mi_s / pt.seconds,
            "mitsuba_mean_vs_reference": (np.nanmean(img, axis=(0, 1)) / ref_mean - 1).tolist(),
            "pt_mean_vs_reference": (pt.image.mean(axis=(0, 1)) / ref_mean - 1).tolist(),
            "st_mean_vs_reference": (st.image.mean(axis=(0, 1)) / ref_mean - 1).tolist()}


def pyplot():
    """matplotlib.pyplot on the file-only Agg backend, or None (with a message) without it."""
    try:
        import matplotlib
    except ImportError:
        print("matplotlib is not installed: no plots", file=sys.stderr)
        return None
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def plot(results, maps, output: Path):
    """The figures, named after the JSON file (st_vs_pt.json: st_vs_pt.png, st_vs_pt_steps.png,
    st_vs_pt_images.png)."""
    plt = pyplot()
    if plt is None:
        return []
    from matplotlib.colors import LogNorm

    rows = results["scenes"]
    fams = [(s, b) for s in SHAPES for b in BOUNDARIES]
    style = {("bunny", "dielectric"): "o-", ("bunny", "index_matched"): "s-",
             ("thin_torus", "dielectric"): "^--", ("thin_torus", "index_matched"): "v--"}
    written = []
    fig, ax = plt.subplots(1, 4, figsize=(19, 4.3))
    for fam in fams:
        fr = [r for r in rows if (r["shape"], r["boundary"]) == fam]
        if not fr:
            continue
        s = [r["sigma_t"] for r in fr]
        lab = f"{fam[0]}, {fam[1]}"
        ax[0].semilogx(s, [r["speedup"] for r in fr], style[fam], label=lab)
        ax[1].loglog(s, [r["pt_events_per_path"] for r in fr], style[fam], label=f"pt, {lab}")
        ax[1].loglog(s, [r["st_events_plus_steps_per_path"] for r in fr], style[fam], alpha=0.5,
                     mfc="none", label=f"st, {lab}")
        for k, (name, m) in enumerate((("st", "st"), ("pt_nee", "pt"), ("pt_no_nee", "pt no NEE"))):
            if fam == ("bunny", "dielectric") or fam == ("bunny", "index_matched"):
                ax[2 if fam[1] == "dielectric" else 3].loglog(
                    s, [r["equal_time"][name]["rmse_srgb"] for r in fr], "os^"[k] + "-", label=m)
    ax[0].axhline(1, color="grey", lw=0.6)
    ax[0].axhline(16, color="red", lw=0.6, ls=":")
    ax[0].set(xlabel="sigma_t per unit", ylabel="time pt / time st", title="speed-up at equal spp")
    ax[1].set(xlabel="sigma_t per unit", ylabel="per path",
              title="pt events (filled) vs st events + steps (open)")
    for i, b in ((2, "dielectric"), (3, "index_matched")):
        fr = [r for r in rows if (r["shape"], r["boundary"]) == ("bunny", b)]
        if fr:
            ax[i].loglog([r["sigma_t"] for r in fr], [r["reference"]["own_error"]["rmse_srgb"] for r in fr],
                         "k:", label="reference's own (est.)")
        ax[i].axhline(0.01, color="red", lw=0.6, ls=":")
        ax[i].set(xlabel="sigma_t per unit", ylabel="sRGB RMSE vs reference",
                  title=f"bunny, {b}: equal time")
    for a in ax:
        a.grid(True, which="both", alpha=0.3)
        a.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(output.with_name(output.stem + ".png"), dpi=100)
    plt.close(fig)
    written.append(output.with_name(output.stem + ".png"))

    # Heat maps (Fig. 7): per pixel, pt events per path and st events + steps per path.
    scales = sorted({k[2] for k in maps})
    fams = [f for f in fams if any((f[0], f[1], sc) in maps for sc in scales)]
    if maps:
        vmax = max(float(np.max(m["pt"])) for m in maps.values())
        norm = LogNorm(vmin=0.5, vmax=max(vmax, 1.0))
        fig, ax = plt.subplots(len(scales), 2 * len(fams), figsize=(2.1 * 2 * len(fams), 2.2 * len(scales)),
                               squeeze=False)
        im = None
        for i, sc in enumerate(scales):
            for j, fam in enumerate(fams):
                m = maps.get((fam[0], fam[1], sc))
                for k, name in enumerate(("pt", "st")):
                    a = ax[i, 2 * j + k]
                    a.set_xticks([])
                    a.set_yticks([])
                    if m is None:
                        continue
                    im = a.imshow(np.maximum(m[name], 0.5), norm=norm, cmap="inferno")
                    a.set_title(f"{fam[0]} {fam[1][:6]} {name}\nsigma_t {BASE_SIGMA * sc:g}: "
                                f"{float(np.mean(m[name])):.0f}/path", fontsize=7)
        if im is not None:
            fig.colorbar(im, ax=ax, shrink=0.6, label="pt: events per path; st: events + steps")
        fig.savefig(output.with_name(output.stem + "_steps.png"), dpi=90)
        plt.close(fig)
        written.append(output.with_name(output.stem + "_steps.png"))

    # The densest bunny at equal time: reference, pt (NEE), pt (no NEE), st.
    dense = [k for k in maps if k[0] == "bunny" and k[2] == max(scales)]
    if dense:
        fig, ax = plt.subplots(len(dense), 4, figsize=(12, 3.2 * len(dense)), squeeze=False)
        for i, k in enumerate(sorted(dense)):
            m = maps[k]
            for j, (name, t) in enumerate((("ref", "pt reference"), ("pt_img", "pt, NEE"),
                                           ("nonee_eq_img", "pt, no NEE"), ("st_eq_img", "st"))):
                ax[i, j].imshow(srgb(np.nan_to_num(m[name])))
                ax[i, j].set_title(f"bunny {k[1]}, sigma_t {BASE_SIGMA * k[2]:g}: {t}", fontsize=8)
                ax[i, j].axis("off")
        fig.tight_layout()
        fig.savefig(output.with_name(output.stem + "_images.png"), dpi=100)
        plt.close(fig)
        written.append(output.with_name(output.stem + "_images.png"))
    return written


def tables(results) -> str:
    """The README's markdown tables from a results dict."""
    out = ["| object | boundary | σt | pt s | st s | speed-up | pt events/path | st events + steps/path "
           "| sRGB RMSE st / pt / pt no NEE | rel. MSE st / pt / pt no NEE | st bias of mean | ref spp, own RMSE |",
           "|---|---|---:|---:|---:|---:|---:|---:|---|---|---|---|"]
    for r in results["scenes"]:
        et = r["equal_time"]
        b = np.array(et["st"]["bias"])
        k = int(np.argmax(np.abs(b)))
        out.append(
            f"| {r['shape']} | {r['boundary'].replace('_', '-')} | {r['sigma_t']:g} | {r['pt']['seconds']:.2f} "
            f"| {r['st']['seconds']:.2f} | ×{r['speedup']:.2f} | {r['pt_events_per_path']:.1f} "
            f"| {r['st']['events_per_path']:.1f} + {r['st']['sphere_steps_per_path']:.2f} "
            f"| {et['st']['rmse_srgb']:.4f} / {et['pt_nee']['rmse_srgb']:.4f} / {et['pt_no_nee']['rmse_srgb']:.4f} "
            f"| {et['st']['rel_mse']:.2e} / {et['pt_nee']['rel_mse']:.2e} / {et['pt_no_nee']['rel_mse']:.2e} "
            f"| {100 * b[k]:+.1f} ± {100 * et['st']['bias_sigma'][k]:.1f} % "
            f"| {r['reference']['spp']}, {r['reference']['own_error']['rmse_srgb']:.4f} |")
    ev = [r for r in results["scenes"] if r.get("st_step_nee_event")]
    if ev:
        out += ["", "| index-matched | speed-up hits / event | equal-time sRGB RMSE hits / event "
                "| rel. MSE hits / event | bias of mean (G) hits / event |",
                "|---|---:|---:|---:|---|"]
        for r in ev:
            e, h = r["st_step_nee_event"]["equal_time"], r["equal_time"]["st"]
            out.append(f"| {r['shape']}, σt {r['sigma_t']:g} | ×{r['speedup']:.2f} / "
                       f"×{r['st_step_nee_event']['speedup']:.2f} "
                       f"| {h['rmse_srgb']:.4f} / {e['rmse_srgb']:.4f} | {h['rel_mse']:.2e} / {e['rel_mse']:.2e} "
                       f"| {100 * h['bias'][1]:+.1f} ± {100 * h['bias_sigma'][1]:.1f} % / "
                       f"{100 * e['bias'][1]:+.1f} ± {100 * e['bias_sigma'][1]:.1f} % |")
    nn = [r for r in results["scenes"] if r.get("st_no_nee")]
    if nn:
        out += ["", "| index-matched, NEE off | speed-up st / pt, both without NEE "
                "| equal-time rel. MSE: st / st no NEE / pt / pt no NEE |", "|---|---:|---|"]
        for r in nn:
            et, sn = r["equal_time"], r["st_no_nee"]
            out.append(f"| {r['shape']}, σt {r['sigma_t']:g} | ×{sn['speedup_over_pt_no_nee']:.2f} "
                       f"| {et['st']['rel_mse']:.2e} / {sn['equal_time']['rel_mse']:.2e} / "
                       f"{et['pt_nee']['rel_mse']:.2e} / {et['pt_no_nee']['rel_mse']:.2e} |")
    conv = [(r, r["st_at_reference_spp"], "hits" if r["boundary"] == "index_matched" else "")
            for r in results["scenes"] if r.get("st_at_reference_spp")]
    conv += [(r, r["st_step_nee_event"]["at_reference_spp"], "event") for r in results["scenes"]
             if (r.get("st_step_nee_event") or {}).get("at_reference_spp")]
    if conv:
        out += ["", "| densest bunny | st spp | st s | sRGB RMSE vs ref | noise removed | rel. MSE | "
                "noise removed | bias of mean (per channel) |", "|---|---:|---:|---:|---:|---:|---:|---|"]
        for r, c, mode in conv:
            out.append(f"| {r['boundary'].replace('_', '-')}, σt {r['sigma_t']:g}"
                       f"{', step_nee ' + mode if mode else ''} | {c['spp']} | {c['seconds']:.1f} "
                       f"| {c['rmse_srgb']:.4f} | {c['rmse_srgb_noise_removed']:.4f} | {c['rel_mse']:.2e} "
                       f"| {c['rel_mse_noise_removed']:.2e} | "
                       + ", ".join(f"{100 * x:+.1f} ± {100 * y:.1f} %" for x, y in zip(c["bias"], c["bias_sigma"]))
                       + " |")
    if results.get("mitsuba"):
        out += ["", "| Mitsuba case | spp | Mitsuba s | st s | pt s | Mitsuba / st | Mitsuba / pt | "
                "Mitsuba mean vs ref (G) |", "|---|---:|---:|---:|---:|---:|---:|---:|"]
        for c in results["mitsuba"]:
            out.append(f"| bunny {c['boundary'].replace('_', '-')}, σt {c['sigma_t']:g} | {c['spp']} "
                       f"| {c['mitsuba_seconds']:.2f} | {c['st_seconds']:.2f} | {c['pt_seconds']:.2f} "
                       f"| {c['ratio_mitsuba_over_st']:.2f} | {c['ratio_mitsuba_over_pt']:.2f} "
                       + (f"| {100 * c['mitsuba_mean_vs_reference'][1]:+.1f} % |"
                          if c["mitsuba_mean_vs_reference"] else "| – |"))
    if results.get("step_cost"):
        out += ["", "| family | pt event, ns per thread (fit) | st step, ns per thread (timed) "
                "| step in pt events | st excess over the fit per step, in pt events |",
                "|---|---:|---:|---:|---:|"]
        for k, v in results["step_cost"].items():
            ns, ev, ex = v["st_thread_ns_per_step"], v["step_in_pt_events"], v["excess_in_pt_events"]
            out.append(f"| {k.replace('_', '-')} | {v['pt_thread_ns_per_event']:.0f} "
                       f"| {'–' if ns is None else f'{ns:.0f}'} | {'–' if ev is None else f'{ev:.1f}'} "
                       f"| {'–' if ex is None else f'{ex:.1f}'} |")
    return "\n".join(out)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--resolution", type=int, default=None, help="square image side (default 64; quick 16)")
    p.add_argument("--spp", type=int, default=None, help="equal-spp samples per pixel (default 32; quick 2)")
    p.add_argument("--ref-spp", type=int, default=None, help="largest reference spp (default 2048; quick 16)")
    p.add_argument("--ref-budget", type=float, default=None,
                   help="seconds one reference may take, projected from pt (default 60; quick 5)")
    p.add_argument("--scales", type=float, nargs="+", default=list(SCALES), help="sigma_t / 500")
    p.add_argument("--shapes", nargs="+", default=list(SHAPES), choices=list(SHAPES))
    p.add_argument("--boundaries", nargs="+", default=list(BOUNDARIES), choices=list(BOUNDARIES))
    p.add_argument("--mitsuba", choices=["subset", "none"], default="subset",
                   help="Mitsuba 3 volpath on the bunny at sigma_t 125 and 1000, both boundaries")
    p.add_argument("--mitsuba-spp", type=int, default=None, help="spp of the Mitsuba comparison (default 8)")
    p.add_argument("--threads", type=int, default=0, help="0 = all cores")
    p.add_argument("--models", default=None, help="model directory (default: the repository's models/)")
    p.add_argument("--simd-target", default="",
                   help="pin the decoders' SIMD target (AVX2, SSE4, ...: another CPU's step cost); "
                        "default: the best here")
    p.add_argument("--quick", action="store_true", help="16x16, 2 spp, reference 16 spp: a smoke run")
    p.add_argument("--cache", default=str(HERE / "results" / "cache"))
    p.add_argument("--output", type=Path, default=HERE / "results" / "st_vs_pt.json")
    p.add_argument("--table", type=Path, default=None,
                   help="print the markdown tables of an existing results JSON and exit")
    args = p.parse_args(argv)
    if args.table:
        print(tables(json.loads(args.table.read_text())))
        return 0
    q = args.quick
    args.resolution = args.resolution or (16 if q else 64)
    args.spp = args.spp or (2 if q else 32)
    args.ref_spp = args.ref_spp or (16 if q else 2048)
    args.ref_budget = args.ref_budget if args.ref_budget is not None else (5.0 if q else 60.0)
    args.mitsuba_spp = args.mitsuba_spp or (1 if q else 8)
    if q and args.scales == list(SCALES):
        args.scales = [0.25, 2.0]
    if q and args.output == HERE / "results" / "st_vs_pt.json":
        args.output = Path(tempfile.gettempdir()) / "st_vs_pt_quick" / "st_vs_pt.json"
    threads = args.threads if args.threads > 0 else (os.cpu_count() or 1)
    sssphere.ScatteringModel.use_simd_target(args.simd_target)
    settings = {k: (str(v) if isinstance(v, Path) else v) for k, v in vars(args).items()}
    settings.update({
        "sphere_threshold": DEFAULT_TAU, "albedo": ALBEDO, "g": G,
        "base_sigma_t": BASE_SIGMA, "threads_used": threads, "rel_mse_epsilon": REL_EPS,
        "simd_target_used": sssphere.ScatteringModel.simd_target(),
        "lights": "scenes/bunny.json's (area + environment) for every scene",
        "timing": "render_full's own wall clock (scene loading excluded); Mitsuba: mi.render",
    })
    results = {"date": datetime.datetime.now().isoformat(timespec="seconds"),
               "machine": machine(),
               "settings": settings, "scenes": [], "mitsuba": [], "step_cost": {}}
    args.output.parent.mkdir(parents=True, exist_ok=True)

    def save():
        results["step_cost"] = step_cost(results["scenes"], threads)
        tmp = args.output.with_suffix(".json.tmp")
        tmp.write_text(json.dumps(results, indent=1) + "\n")
        tmp.replace(args.output)

    t_start = time.perf_counter()
    warm_scene = sssphere.load_scene(scene_dict("bunny", "index_matched", 500, 8), threads=args.threads)
    render(warm_scene, "st", 1, 1, args)  # load models, warm caches (untimed)
    maps = {}
    print(f"{args.resolution}x{args.resolution}, {args.spp} spp, {threads} threads, tau "
          f"{settings['sphere_threshold']:g}, decoders on {settings['simd_target_used']}", flush=True)
    for shape in args.shapes:
        for boundary in args.boundaries:
            for scale in args.scales:
                r = run_scene(shape, boundary, scale, args, maps)
                results["scenes"].append(r)
                save()
                et = r["equal_time"]
                print(f"{shape:10s} {boundary:13s} sigma_t {r['sigma_t']:6g}: pt {r['pt']['seconds']:6.2f}s "
                      f"st {r['st']['seconds']:6.2f}s x{r['speedup']:5.2f}  events pt "
                      f"{r['pt_events_per_path']:7.1f} st {r['st']['events_per_path']:6.1f}+"
                      f"{r['st']['sphere_steps_per_path']:5.2f}  eq-time sRGB RMSE st "
                      f"{et['st']['rmse_srgb']:.4f} pt {et['pt_nee']['rmse_srgb']:.4f} pt-noNEE "
                      f"{et['pt_no_nee']['rmse_srgb']:.4f} (ref {r['reference']['spp']} spp, own "
                      f"{r['reference']['own_error']['rmse_srgb']:.4f})  "
                      f"[{time.perf_counter() - t_start:.0f} s]", flush=True)

    if args.mitsuba == "subset":
        import sssphere.mitsuba as mu

        mi = mu.import_mitsuba("scalar_rgb")
        import drjit as dr

        dr.set_thread_count(max(threads, 2))
        results["settings"]["mitsuba"] = {
            "version": mi.__version__, "variant": mi.variant(), "integrator": "volpath",
            "max_depth": -1, "rr_depth": mu.RR_DEPTH, "threads": int(dr.thread_count())}
        warm = False
        for shape, boundary, scale in MITSUBA_CASES:
            row = next((r for r in results["scenes"] if (r["shape"], r["boundary"], r["scale"])
                        == (shape, boundary, scale)), None)
            if row is None:
                continue
            c = mitsuba_case(shape, boundary, scale, args, mu, mi, warm, row)
            warm = True
            results["mitsuba"].append(c)
            save()
            print(f"mitsuba {shape} {boundary} sigma_t {c['sigma_t']:g}, {c['spp']} spp: Mitsuba "
                  f"{c['mitsuba_seconds']:.2f}s st {c['st_seconds']:.2f}s pt {c['pt_seconds']:.2f}s  "
                  f"Mitsuba/st {c['ratio_mitsuba_over_st']:.2f}  "
                  f"[{time.perf_counter() - t_start:.0f} s]", flush=True)

    results["total_seconds"] = time.perf_counter() - t_start
    save()
    for k, v in results["step_cost"].items():
        ns, ev = v["st_thread_ns_per_step"], v["step_in_pt_events"]
        print(f"step cost {k}: pt event {v['pt_thread_ns_per_event']:.0f} ns, st step "
              f"{'-' if ns is None else round(ns)} ns = {'-' if ev is None else round(ev, 1)} events "
              "(per thread)")
    print(tables(results))
    print(f"wrote {args.output}")
    for f in plot(results, maps, args.output):
        print(f"wrote {f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
