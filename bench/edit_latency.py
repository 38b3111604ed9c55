#!/usr/bin/env python3
"""How long an edit of a loaded scene takes before the render starts (issue 24: a material
change on the bunny must reach its first sample within 50 ms).

scenes/bunny.json is loaded once (timed: that is what a reload would cost), then edited
in place (a material, the camera, a light) and rendered at 1 spp after each edit. For each
edit: the assignment's time (parse, checks, the rebuild of what changed), and the render
call's time outside its sampling (the call's wall time less the render's own `seconds`:
options, integrator and models set up, and the result handed back), an upper bound on the
time from the call to its first sample. Their sum is the time from the assignment to the
first sample. Each edit is repeated --repeat times; the median is reported.

    python -m bench.edit_latency

Writes bench/results/edit_latency.json.
"""

from __future__ import annotations

import argparse
import datetime
import json
import statistics
import time
from pathlib import Path

import sssphere
from bench.machine import machine

HERE = Path(__file__).resolve().parent
REPO = HERE.parent


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=9)
    parser.add_argument("--out", default=str(HERE / "results" / "edit_latency.json"))
    args = parser.parse_args()

    t = time.perf_counter()
    scene = sssphere.load_scene(REPO / "scenes" / "bunny.json")
    load_seconds = time.perf_counter() - t
    print(f"load (what a reload costs): {1e3 * load_seconds:.0f} ms")

    def albedo(k):
        scene.shapes[0].medium.albedo = [0.99, 0.995 - 0.001 * k, 0.999]

    def g(k):
        scene.shapes[0].medium.g = 0.5 + 0.01 * k

    def camera(k):
        scene.camera.origin = [0.01 * k, 0.1, 2.6]

    def light(k):
        scene.lights[0].radiance = [1.5 + 0.1 * k, 1.5, 1.5]

    rows = []
    for name, edit in (("medium.albedo", albedo), ("medium.g", g), ("camera.origin", camera),
                       ("area light radiance", light)):
        for integrator in ("pt", "st"):
            edits, setups = [], []
            for k in range(args.repeat):
                t = time.perf_counter()
                edit(k)
                edits.append(time.perf_counter() - t)
                assert scene.rebuilt == [], scene.rebuilt
                t = time.perf_counter()
                r = sssphere.render_full(scene, integrator=integrator, spp=1)
                setups.append(time.perf_counter() - t - r.seconds)
            row = {"edit": name, "integrator": integrator,
                   "edit_ms": 1e3 * statistics.median(edits),
                   "render_setup_ms": 1e3 * statistics.median(setups)}
            row["to_first_sample_ms"] = row["edit_ms"] + row["render_setup_ms"]
            rows.append(row)
            print(f"{name:20s} {integrator}: edit {row['edit_ms']:5.1f} ms + render set-up "
                  f"{row['render_setup_ms']:5.1f} ms = {row['to_first_sample_ms']:5.1f} ms to "
                  "the first sample; nothing rebuilt")
    result = {"date": datetime.date.today().isoformat(),
              "machine": machine(),
              "scene": "scenes/bunny.json", "load_ms": 1e3 * load_seconds,
              "repeat": args.repeat, "rows": rows}
    Path(args.out).write_text(json.dumps(result, indent=2) + "\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
