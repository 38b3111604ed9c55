#!/usr/bin/env python3
"""Is a bias of `st` the models' or the integrator's? One scene rendered with `pt`, with `st`
on exact sphere walks (unbiased: only the integrator and the geometry can be wrong), with
`st` on the learned models, and with `st` on the models with `step_nee="event"` (EventGen's
representative event for NEE), each against `pt` directly: the relative difference of the
image means per channel with the one-sigma from both renders' variances. Seeds are fixed.

    python -m bench.st_bias                       # scenes/bunny.json, 64x64, 1024 spp: ~40 s
    python -m bench.st_bias --scene scenes/sphere.json --spp 256
    python -m bench.st_bias --scene scenes/showcase.json --resolution 96 --spp 256

`--set PATH=VALUE` edits the scene as on the command lines, e.g. a near-white medium under a
point light alone, where `hits` keeps its steps clear of the boundary and `event` leans on
EventGen (docs/sphere-tracing.md, "What is approximate"):

    python -m bench.st_bias --scene scenes/sphere.json --resolution 32 --spp 1024 \
        --set 'shapes[0].medium={"sigma_t": 100, "albedo": 0.9999, "g": 0}' \
        --set 'lights=[{"type": "point", "position": [3, 3, 3], "intensity": 20}]'

Writes bench/results/st_bias.json (one entry per scene and edits, replacing an earlier one).
"""

from __future__ import annotations

import argparse
import datetime
import json
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
REPO = HERE.parent

import sssphere  # noqa: E402
from sssphere import _core  # noqa: E402


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--scene", type=Path, default=REPO / "scenes" / "bunny.json")
    p.add_argument("--resolution", type=int, default=64)
    p.add_argument("--spp", type=int, default=1024)
    p.add_argument("--threads", type=int, default=0, help="0 = all cores")
    p.add_argument("--models", default=None, help="model directory (default: the repository's models/)")
    p.add_argument("--set", action="append", default=[], metavar="PATH=VALUE",
                   help="edit the scene (as sssphere render --set); repeatable")
    p.add_argument("--output", type=Path, default=HERE / "results" / "st_bias.json")
    args = p.parse_args(argv)

    d = json.loads(_core.edit_scene_json(args.scene.read_text(), str(args.scene), args.set, 0, 0))
    d["camera"]["width"] = d["camera"]["height"] = args.resolution
    d.pop("render", None)
    # Relative paths (meshes, maps) as the scene file resolves them.
    scene = sssphere.load_scene(d, base_dir=args.scene.parent, threads=args.threads)

    def run(seed, **kw):
        return sssphere.render_full(scene, spp=args.spp, seed=seed, threads=args.threads, **kw)

    renders = {"pt": run(11, integrator="pt"),
               "st_walks": run(12, integrator="st", sphere_sampler="walk"),
               "st_models": run(13, integrator="st", models=args.models),
               "st_event": run(14, integrator="st", models=args.models, step_nee="event")}
    pt = renders["pt"]
    n = pt.image.shape[0] * pt.image.shape[1]
    mean_pt = pt.image.astype(np.float64).mean(axis=(0, 1))
    entry = {"scene": str(args.scene.resolve().relative_to(REPO) if args.scene.resolve().is_relative_to(REPO)
                          else args.scene),
             "set": args.set, "resolution": args.resolution, "spp": args.spp,
             "date": datetime.datetime.now().isoformat(timespec="seconds")}
    print(f"{'pt':10s} {pt.seconds:6.1f} s")
    for name, r in renders.items():
        mean = r.image.astype(np.float64).mean(axis=(0, 1))
        row = {"seconds": r.seconds, "events_per_path": r.mean_events_per_path,
               "sphere_steps_per_path": r.mean_sphere_steps_per_path, "image_mean": mean.tolist()}
        if name != "pt":
            sigma = np.sqrt(r.variance.astype(np.float64).sum(axis=(0, 1))
                            + pt.variance.astype(np.float64).sum(axis=(0, 1))) / n
            row["vs_pt"] = ((mean - mean_pt) / mean_pt).tolist()
            row["vs_pt_sigma"] = (sigma / mean_pt).tolist()
            print(f"{name:10s} {r.seconds:6.1f} s, {r.mean_sphere_steps_per_path:5.2f} steps/path, vs pt: "
                  + ", ".join(f"{100 * b:+.2f} ± {100 * s:.2f} %" for b, s in zip(row["vs_pt"], row["vs_pt_sigma"])))
        entry[name] = row

    out = {}
    if args.output.exists():
        out = json.loads(args.output.read_text())
    out[" ".join([entry["scene"], *args.set])] = entry
    args.output.parent.mkdir(parents=True, exist_ok=True)
    args.output.write_text(json.dumps(out, indent=1) + "\n")
    print(f"wrote {args.output}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
