#!/usr/bin/env python3
"""How long lavapipe takes to build the GPU path's shaders when Mesa's cache is cold.

A new kind of render (other specialization constants: NEE, the decoders' shapes, cut steps)
makes Mesa compile its pipelines with LLVM; the result goes to ~/.cache/mesa_shader_cache,
so only the first such render on a machine waits, but CI starts with an empty cache. Each
case below runs in a fresh process with MESA_SHADER_CACHE_DISABLE=true and times one tiny
call (4x4 pixels, 1 spp, or 4 steps), which is almost all compile time:

- `cut`: "st" on a dielectric cube (sigma_t 500) with cut steps (models/cut);
- `plain`: the same cube index-matched (no cut steps);
- `cut_sampler`: `_core.gpu_sample_cut_steps` (sample_cut_steps.comp) on its own.

    python -m bench.shader_compile      # ~2 min on 2 cores

Writes bench/results/shader_compile.json (seconds per case, the machine). On 2 Zen 3 cores,
2026-12-02: the cut decoders read from a storage buffer made `cut` take 314 s and
`cut_sampler` 88 s; from a uniform block, 61-67 s and 18 s (`plain` 28-30 s).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
CASES = ("cut", "plain", "cut_sampler")


def run_case(case: str) -> float:
    """One case, in this process (the caller made the cache cold): its wall seconds."""
    import numpy as np

    import sssphere
    from bench.robustness import cube_on_floor
    from sssphere import _core

    cut_models = str(REPO / "models" / "cut")
    start = time.perf_counter()
    if case == "cut_sampler":
        steps = [np.full(4, v, np.float32) for v in (6.0, 0.5, 0.5, 0.3)]
        _core.gpu_sample_cut_steps(cut_models, *steps, 5)
        return time.perf_counter() - start
    scene = cube_on_floor(-0.5, boundary="dielectric" if case == "cut" else None)
    scene["shapes"][0]["medium"]["sigma_t"] = 500
    scene["camera"].update(width=4, height=4)
    scene = sssphere.load_scene(scene)
    start = time.perf_counter()
    sssphere.render_full(scene, integrator="st", spp=1, seed=1, backend="vulkan",
                         **({"cut_models": cut_models} if case == "cut" else {}))
    return time.perf_counter() - start


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--case", choices=CASES, help=argparse.SUPPRESS)  # one case, in a child
    args = p.parse_args(argv)
    if args.case:
        print(json.dumps({"seconds": run_case(args.case)}))
        return
    from bench.machine import machine

    env = {**os.environ, "MESA_SHADER_CACHE_DISABLE": "true"}
    seconds = {}
    for case in CASES:
        r = subprocess.run([sys.executable, "-m", "bench.shader_compile", "--case", case],
                           cwd=REPO, env=env, capture_output=True, text=True, check=True)
        seconds[case] = round(json.loads(r.stdout.strip().splitlines()[-1])["seconds"], 1)
        print(f"{case}: {seconds[case]} s", flush=True)
    out = REPO / "bench" / "results" / "shader_compile.json"
    out.write_text(json.dumps({"date": time.strftime("%Y-%m-%d"), "machine": machine(),
                               "cold_seconds": seconds}, indent=1) + "\n")
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
