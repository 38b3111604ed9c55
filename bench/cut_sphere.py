#!/usr/bin/env python3
"""What a learned step near a flat boundary could gain (issue 26, item 1): measured on exact walks.

`st` leaves about 17–20 scattering events per path to delta tracking on the bunny at
σt = 1000: the events within τ = 6 mean free paths of the surface, where the largest sphere
free of the boundary is optically thin (bench/README.md, "The ×16 target"). A step in a
sphere cut by the local tangent plane ("The cut sphere problem" in docs/notation.md;
`sssphere.walks.cut_sphere_walks`) could take them. Before any model is trained, this bench
measures with exact walks what such steps would save:

1. **Per step** (g = 0.9): the mean number of events a cut sphere step of optical radius σR
   replaces and how often it leaves through the plane, over the plane's distance h = d / R
   and the cosine μ0 between the arriving direction and the boundary's normal.
2. **Per path**, in a half-space of a dense medium (mean free path 1; albedo 0.999, g = 0.9,
   an index-matched boundary: a path ends when it crosses the plane), photons entering along
   the normal, three integrators on the same exact walks:
   * ``pt``: delta tracking only;
   * ``st``: a sphere step of radius d (capped at ``--sigma-max``) wherever the distance d to
     the plane is at least τ, delta tracking elsewhere (what the renderer does);
   * ``st+cut``: the same, and a cut sphere step of optical radius ``--cut-radius`` wherever
     d < τ.
   Reported: events and steps per path, and a projected speed-up over ``pt`` for a step
   costing ``c`` events (the renderer's sphere step costs about 2; a cut step's model would be
   about as large).
3. **How flat the bunny is** at the radii tried: the sagitta a cut plane loses to its
   curvature, and the half-space runs again with the plane lowered by the median sagitta.

Absorption is simulated: an event survives with probability φ, a step of N events with φ^N.

    python -m bench.cut_sphere               # ~20 s on 2 cores
    python -m bench.cut_sphere --paths 2000  # a smoke run

Writes bench/results/cut_sphere.json.
"""

from __future__ import annotations

import argparse
import datetime
import json
from pathlib import Path

import numpy as np

from sssphere.walks import cut_sphere_walks
from bench.machine import machine

HERE = Path(__file__).resolve().parent


def hg_sample(w: np.ndarray, g: float, rng: np.random.Generator) -> np.ndarray:
    """Henyey-Greenstein directions about the unit rows of w."""
    n = len(w)
    u1, u2 = rng.random(n), rng.random(n)
    sq = (1 - g * g) / (1 - g + 2 * g * u1)
    c = np.clip((1 + g * g - sq * sq) / (2 * g), -1.0, 1.0)
    s = np.sqrt(np.maximum(0.0, 1 - c * c))
    phi = 2 * np.pi * u2
    e1, e2 = perpendicular_frame(w)
    return (s * np.cos(phi))[:, None] * e1 + (s * np.sin(phi))[:, None] * e2 + c[:, None] * w


def perpendicular_frame(w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors completing each unit row of w to an orthonormal frame."""
    a = np.where(np.abs(w[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    e1 = np.cross(w, a)
    e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
    return e1, np.cross(w, e1)


def step(pos, d, radius_optical, depth_cut, g, albedo, rng, seed, sagitta=0.0):
    """Exact (cut) sphere steps at pos (depth = pos[:, 2] > 0, the boundary z = 0) with
    arriving directions d: the sphere of optical radius `radius_optical`, cut by the plane at
    depth `sagitta` if depth_cut (h = (depth - sagitta) / radius), whole otherwise. Returns the
    exit positions and directions, N, and whether the walk left the medium (through the plane
    when it is the boundary itself, sagitta 0)."""
    n = len(pos)
    zw = np.tile([0.0, 0.0, -1.0], (n, 1))  # the walk's +z: towards the boundary
    mu0 = np.clip(-d[:, 2], -1.0, 1.0)
    perp = d - mu0[:, None] * zw
    norm = np.linalg.norm(perp, axis=1, keepdims=True)
    fallback, _ = perpendicular_frame(zw)
    xw = np.where(norm > 1e-6, perp / np.maximum(norm, 1e-12), fallback)
    yw = np.cross(zw, xw)
    h = np.where(depth_cut, (pos[:, 2] - sagitta) / radius_optical, 2.0)
    w = cut_sphere_walks(radius_optical, g, h, mu0, albedo, n, seed=seed)

    def world(v):
        return v[:, :1] * xw + v[:, 1:2] * yw + v[:, 2:] * zw

    exit_pos = pos + world(w["exit_pos"].astype(np.float64)) * radius_optical[:, None]
    exit_dir = world(w["exit_dir"].astype(np.float64))
    exit_dir /= np.linalg.norm(exit_dir, axis=1, keepdims=True)
    through = w["through_plane"].astype(bool)
    exit_pos[through, 2] = sagitta
    return exit_pos, exit_dir, w["N"], through & (sagitta == 0.0)


def half_space(mode: str, paths: int, tau: float, cut_radius: float, sigma_max: float, g: float,
               albedo: float, seed: int, sagitta: float = 0.0) -> dict:
    """One integrator's paths in the half-space; returns events, steps and exits per path.
    sagitta: how far below the boundary the cut plane lies (a curved surface's loss, mean free
    paths); a walk leaving through such a plane is still inside and flies on from there, and a
    collision whose plane would lie within a tenth of a mean free path is delta tracked."""
    rng = np.random.default_rng(seed)
    pos = np.zeros((paths, 3))
    d = np.tile([0.0, 0.0, 1.0], (paths, 1))
    events = np.zeros(paths, np.int64)
    sphere_steps = np.zeros(paths, np.int64)
    cut_steps = np.zeros(paths, np.int64)
    replaced = np.zeros(paths, np.int64)  # events inside the steps
    exited = np.zeros(paths, bool)
    active = np.arange(paths)
    call = 0
    while active.size:
        # A free flight from each active photon; crossing the plane ends the path.
        t = rng.exponential(size=active.size)
        z = pos[active, 2] + d[active, 2] * t
        out = z <= 0.0
        exited[active[out]] = True
        active = active[~out]
        t = t[~out]
        pos[active] += d[active] * t[:, None]
        if not active.size:
            break
        depth = pos[active, 2]
        sphere = (mode != "pt") & (depth >= tau)
        cut = (mode == "st+cut") & ~sphere & (depth - sagitta > 0.1)
        stepping = sphere | cut
        # Delta tracking: one event, then absorption and an HG direction.
        dt = active[~stepping]
        events[dt] += 1
        d[dt] = hg_sample(d[dt], g, rng)
        alive_dt = rng.random(dt.size) < albedo
        # Steps: exact walks (sphere or cut sphere), absorption as albedo^N.
        st = active[stepping]
        alive_st = np.ones(st.size, bool)
        if st.size:
            radius = np.where(sphere[stepping], np.minimum(depth[stepping], sigma_max), cut_radius)
            call += 1
            p, w, N, through = step(pos[st], d[st], radius, cut[stepping], g, 1.0, rng,
                                    seed * 1000003 + call, sagitta)
            pos[st], d[st] = p, w
            sphere_steps[st[sphere[stepping]]] += 1
            cut_steps[st[cut[stepping]]] += 1
            replaced[st] += N
            alive_st = rng.random(st.size) < albedo ** N.astype(np.float64)
            exited[st[through & alive_st]] = True
            alive_st &= ~through
        active = np.concatenate([dt[alive_dt], st[alive_st]])
    return {"events": float(events.mean()), "sphere_steps": float(sphere_steps.mean()),
            "cut_steps": float(cut_steps.mean()), "events_in_steps": float(replaced.mean()),
            "exit_fraction": float(exited.mean()),
            "exit_fraction_se": float(np.sqrt(exited.mean() * (1 - exited.mean()) / paths))}


def bunny_sagitta(sigma_t: float, radii: list[float], points: int, tau: float, seed: int) -> dict:
    """How flat the bunny (st_vs_pt.py's, largest side 1) is at the scale of a cut sphere step.

    Points of the near-surface layer (depth uniform below tau mean free paths at sigma_t, under
    area-weighted points of the surface); for each optical radius R, over the surface within
    the ball of radius R about p, the smallest distance towards the surface along p's normal:
    the cut plane's distance. Its shortfall against p's depth is the sagitta the plane loses to
    curvature (mean free paths). Distances are to 4 million points sampled on the surface, not
    to the triangles: their spacing (in the result) bounds the error of each distance to about
    spacing² / depth, small against a mean free path except for the shallowest points."""
    from scipy.spatial import cKDTree

    from bench.st_vs_pt import scene_dict
    from sssphere import load_scene

    rng = np.random.default_rng(seed)
    v, f = load_scene(scene_dict("bunny", "dielectric", sigma_t, 8)).shape_mesh(0)
    tri = np.asarray(v, np.float64)[np.asarray(f)]
    cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    area = 0.5 * np.linalg.norm(cross, axis=1)
    normal = cross / (2 * area[:, None])

    def on_surface(n):
        t = rng.choice(len(tri), n, p=area / area.sum())
        a, b = rng.random(n), rng.random(n)
        flip = a + b > 1
        a[flip], b[flip] = 1 - a[flip], 1 - b[flip]
        return tri[t, 0] + a[:, None] * (tri[t, 1] - tri[t, 0]) + b[:, None] * (tri[t, 2] - tri[t, 0]), t

    surface, _ = on_surface(4_000_000)
    tree = cKDTree(surface)
    q, t = on_surface(points)
    depth = rng.random(points) * tau / sigma_t
    p = q - normal[t] * depth[:, None]
    d, nearest = tree.query(p)
    keep = d > 0.5 * depth  # not through a thin part to the far side
    p, d, towards = p[keep], d[keep], (surface[nearest[keep]] - p[keep]) / d[keep, None]
    out = {"sigma_t": sigma_t, "points": int(keep.sum()), "radii": {},
           "sample_spacing_mfp": float(np.sqrt(area.sum() / len(surface)) * sigma_t)}
    for R in radii:
        sag = np.empty(len(p))
        for i, ball in enumerate(tree.query_ball_point(p, R / sigma_t)):
            # No surface within R (a point deeper than R): the sphere is whole, nothing lost.
            sag[i] = d[i] - np.min((surface[ball] - p[i]) @ towards[i]) if ball else 0.0
        sag *= sigma_t
        out["radii"][f"{R:g}"] = {"median": float(np.median(sag)), "p90": float(np.quantile(sag, 0.9)),
                                  "mean": float(sag.mean())}
    return out


def per_step_table(sigma_rs, hs, mu0s, g, n, seed) -> list[dict]:
    rows = []
    for s in sigma_rs:
        for h in hs:
            for mu0 in mu0s:
                w = cut_sphere_walks(s, g, h, mu0, 1.0, n, seed=seed)
                rows.append({"sigma_r": s, "h": h, "mu0": mu0, "mean_N": float(w["N"].mean()),
                             "through_plane": float(w["through_plane"].mean())})
    return rows


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--paths", type=int, default=20000, help="photons per integrator")
    p.add_argument("--tau", type=float, default=6.0, help="sphere threshold (optical)")
    p.add_argument("--cut-radius", type=float, nargs="+", default=[6.0, 12.0, 24.0],
                   help="optical radii of the cut sphere steps to try")
    p.add_argument("--sigma-max", type=float, default=100.0, help="largest sphere step (optical)")
    p.add_argument("--g", type=float, default=0.9)
    p.add_argument("--albedo", type=float, default=0.999)
    p.add_argument("--cost", type=float, nargs="+", default=[2.0, 3.0],
                   help="a step's cost in events, for the projected speed-ups")
    p.add_argument("--bunny-sigma", type=float, default=1000.0,
                   help="measure the bunny's sagitta at this sigma_t (0: skip)")
    p.add_argument("--bunny-points", type=int, default=5000, help="points of the bunny's layer")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--output", type=Path, default=HERE / "results" / "cut_sphere.json")
    args = p.parse_args()

    table = per_step_table([6.0, 12.0, 24.0], [0.05, 0.1, 0.25, 0.5], [-1.0, 0.0, 1.0], args.g,
                           100000, args.seed)
    print("per step (g = %.2f): mean events replaced / fraction through the plane" % args.g)
    for r in table:
        print(f"  sigma R {r['sigma_r']:5.1f}  h {r['h']:.2f}  mu0 {r['mu0']:+.0f}:"
              f"  N {r['mean_N']:6.2f}  plane {r['through_plane']:.3f}")

    bunny = None
    if args.bunny_sigma > 0:
        bunny = bunny_sagitta(args.bunny_sigma, args.cut_radius, args.bunny_points, args.tau,
                              args.seed)
        print(f"\nthe bunny at sigma_t {args.bunny_sigma:g}: sagitta of the cut plane (mean free "
              f"paths) over {bunny['points']} points of its layer (surface samples "
              f"{bunny['sample_spacing_mfp']:.2f} mean free paths apart)")
        for r, v in bunny["radii"].items():
            print(f"  R {r:>4s}: median {v['median']:.2f}  p90 {v['p90']:.2f}  mean {v['mean']:.2f}")

    runs = {"pt": half_space("pt", args.paths, args.tau, 0.0, args.sigma_max, args.g,
                             args.albedo, args.seed),
            "st": half_space("st", args.paths, args.tau, 0.0, args.sigma_max, args.g,
                             args.albedo, args.seed)}
    for r in args.cut_radius:
        runs[f"st+cut {r:g}"] = half_space("st+cut", args.paths, args.tau, r, args.sigma_max,
                                           args.g, args.albedo, args.seed)
        if bunny:  # the plane lowered by the bunny's median sagitta at this radius
            sag = bunny["radii"][f"{r:g}"]["median"]
            runs[f"st+cut {r:g}, sagitta {sag:.2f}"] = half_space(
                "st+cut", args.paths, args.tau, r, args.sigma_max, args.g, args.albedo, args.seed,
                sagitta=sag)
    pt_events = runs["pt"]["events"]
    print(f"\nhalf-space, {args.paths} paths per integrator, albedo {args.albedo}, g {args.g}")
    for name, r in runs.items():
        steps = r["sphere_steps"] + r["cut_steps"]
        r["projected_speedup"] = {f"c={c:g}": pt_events / (r["events"] + c * steps)
                                  for c in args.cost}
        print(f"  {name:12s} events {r['events']:8.2f}  sphere steps {r['sphere_steps']:6.2f}"
              f"  cut steps {r['cut_steps']:6.2f}  leave {r['exit_fraction']:.4f}"
              f" ± {r['exit_fraction_se']:.4f}  projected x" +
              " / ".join(f"{v:.1f}" for v in r["projected_speedup"].values()))

    args.output.parent.mkdir(parents=True, exist_ok=True)
    args.output.write_text(json.dumps({
        "date": datetime.datetime.now().isoformat(timespec="seconds"),
        "machine": machine(),
        "settings": {k: v for k, v in vars(args).items() if k != "output"},
        "per_step": table, "bunny_sagitta": bunny, "half_space": runs}, indent=1) + "\n")
    print(f"wrote {args.output}")


if __name__ == "__main__":
    main()
