#!/usr/bin/env python3
"""How long a path Mesa's lavapipe lets the GPU path finish.

Lavapipe gives a shader invocation 65,535 loop iterations in all (docs/robustness.md, "The
GPU path"), so a change to render.glsl that adds loops, or inlined copies of code that
holds them, shortens the longest path it can finish, even where that code never runs. This
renders the scene of tests/test_gpu.py's clearance test (st, a point light inside an
index-matched sphere with chromatic extinction) on the Vulkan backend at five rising albedos,
and records for each seed whether every path finished and the longest path's events.

    python -m bench.lavapipe_budget     # ~1 min on 2 cores (lavapipe)

Writes bench/results/lavapipe_budget.json (--output elsewhere; --models DIR renders with
other models). Compare the longest paths that finish before and after a shader change (the
same seeds give the same paths while nothing fails and the models stay the same).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO / "tests"))

import sssphere  # noqa: E402
from test_gpu import DIRECTIONAL, ENV, INDEX_MATCHED, sphere_scene  # noqa: E402

ALBEDOS = [(0.99, 0.99, 0.99), (0.995, 0.99, 0.98), (0.997, 0.994, 0.99), (0.998, 0.996, 0.99),
           (0.999, 0.998, 0.995)]
SEEDS = (1, 2)


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--models", type=Path, default=None,
                   help="model directory (default: the shipped models, tilt included)")
    p.add_argument("--output", type=Path,
                   default=REPO / "bench" / "results" / "lavapipe_budget.json")
    args = p.parse_args(argv)
    inside = {"type": "point", "position": [0.45, 0, 0], "intensity": [2, 2, 2]}
    rows = []
    for albedo in ALBEDOS:
        scene = sssphere.load_scene(sphere_scene(sigma_t=[40.0, 50.0, 65.0], albedo=albedo, g=0.5,
                                                 boundary=INDEX_MATCHED,
                                                 lights=[inside, DIRECTIONAL, ENV]))
        for seed in SEEDS:
            row = {"albedo": list(albedo), "seed": seed}
            try:
                r = sssphere.render_full(scene, spp=128, seed=seed, record_paths=True,
                                         backend="vulkan", integrator="st", nee=True,
                                         models=args.models)
                row.update(finished=True, longest_path_events=int(r.path_events.max()))
            except sssphere.SceneError as e:
                row.update(finished=False, error=str(e).split(". ")[0])
            print(row, flush=True)
            rows.append(row)
    out = args.output
    out.write_text(json.dumps({"spp": 128, "rows": rows}, indent=1) + "\n")
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
