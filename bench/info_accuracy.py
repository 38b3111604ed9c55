#!/usr/bin/env python3
"""How far `sssphere info`'s expected counts are from a render's (docs/info.md): the bunny
of scenes/bunny.json (sigma_t 500 unless said) with several media and boundaries, rendered
with `pt` and `st`; per camera path, the scattering events (and `st`'s sphere steps) that
scene_info expects beside those the render counted.

    python -m bench.info_accuracy            # 64 x 64, 4 spp (about a minute)

Writes bench/results/info_accuracy.json.
"""

from __future__ import annotations

import argparse
import copy
import datetime
import json
from pathlib import Path

import sssphere
from sssphere.info import scene_info
from bench.machine import machine

HERE = Path(__file__).resolve().parent
REPO = HERE.parent

CASES = [  # name, medium changes, boundary
    ("a=1 g=0 index-matched", {"albedo": 1.0, "g": 0.0}, {"type": "index_matched"}),
    ("a=1 g=0.9 index-matched", {"albedo": 1.0, "g": 0.9}, {"type": "index_matched"}),
    ("a=0.99 g=0 index-matched", {"albedo": 0.99, "g": 0.0}, {"type": "index_matched"}),
    ("a=0.999 g=0.9 index-matched", {"albedo": 0.999, "g": 0.9}, {"type": "index_matched"}),
    ("a=1 g=0 dielectric 1.5", {"albedo": 1.0, "g": 0.0}, {"type": "dielectric", "ior": 1.5}),
    ("a=0.999 g=0.9 dielectric 1.5", {"albedo": 0.999, "g": 0.9},
     {"type": "dielectric", "ior": 1.5}),
    ("sigma_t=2000 a=1 g=0 index-matched", {"sigma_t": 2000, "albedo": 1.0, "g": 0.0},
     {"type": "index_matched"}),
]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--res", type=int, default=64, help="image side in pixels")
    parser.add_argument("--spp", type=int, default=4, help="samples per pixel")
    parser.add_argument("--out", default=str(HERE / "results" / "info_accuracy.json"))
    args = parser.parse_args()

    base = sssphere.load_scene(REPO / "scenes" / "bunny.json").to_dict()
    base["camera"].update(width=args.res, height=args.res)
    rows = []
    for name, medium, boundary in CASES:
        d = copy.deepcopy(base)
        d["shapes"][0]["medium"].update(medium)
        d["shapes"][0]["boundary"] = boundary
        scene = sssphere.load_scene(d, base_dir=REPO / "scenes")
        expected = scene_info(scene)["per_camera_path"]
        pt = sssphere.render_full(scene, integrator="pt", spp=args.spp)
        st = sssphere.render_full(scene, integrator="st", spp=args.spp)
        row = {"case": name, "expected": expected,
               "measured": {"pt_events": pt.mean_events_per_path,
                            "st_events": st.mean_events_per_path,
                            "st_steps": st.mean_sphere_steps_per_path}}
        rows.append(row)
        print(f"{name:38s} pt events {expected['pt_events']:7.1f} / {pt.mean_events_per_path:7.1f}"
              f"   st events {expected['st_events']:6.1f} / {st.mean_events_per_path:6.1f}"
              f"   st steps {expected['st_steps']:5.2f} / {st.mean_sphere_steps_per_path:5.2f}"
              "   (expected / measured)")
    result = {"date": datetime.date.today().isoformat(),
              "machine": machine(),
              "res": args.res, "spp": args.spp, "rows": rows}
    Path(args.out).write_text(json.dumps(result, indent=2) + "\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
