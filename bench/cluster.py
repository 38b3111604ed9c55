#!/usr/bin/env python3
"""Rendering on a Ray cluster (issue 25): scaling, per-task overhead, exactness, and a model
of a 100-node render of the bunny sweep.

All on this one machine, with ray.cluster_utils.Cluster: a head node that runs no tasks and
W worker nodes of one CPU each (separate raylets and object stores, as separate machines
would have). The scene is bench/st_vs_pt.py's bunny (dielectric boundary, sigma_t =
500 x scale), 64x64.

* Scaling: for W = 1, 2, 4 workers, the wall time of a render on the cluster, cold (a new
  cluster: worker processes start, fetch the scene's package and build it) and warm (the
  same render again: the scenes are cached in the workers), against a local render on one
  thread of the same spp. Efficiency = local 1-thread time / (W x cluster time). On a machine
  with fewer cores than W the workers share them: the efficiency is then bounded by
  cores / W, and the report says how many cores there were.
* Per-task overhead: on W = 1, a render of --overhead-tasks tasks of one sample of a 4x4
  image (no real work): (wall time - the tasks' own render seconds) / tasks.
* Exactness: the cluster image against the local render at --spp (pt and st): the largest
  relative difference per pixel, the share of bit-identical float32 values, and whether the
  counts (events, steps) are equal.
* Driver merge: the time to add one task's film sums (64 bytes per pixel) at 64x64 and
  512x512; the scene's build, and its rebuild for the sweep's next density (an edit).
* The 100-node model: from those figures, the predicted wall time and efficiency of the bunny
  sweep (4 densities) at a reference's spp on 100 nodes of --model-cores cores, rendered
  with threads = cores per task (one task per node at a time) or with one-thread tasks.

    python -m bench.cluster              # ~5 min here
    python -m bench.cluster --quick      # 32x32, fewer samples: ~1.5 min

Writes bench/results/cluster.json.
"""

from __future__ import annotations

import argparse
import datetime
import json
import heapq
import math
import time
from pathlib import Path

import numpy as np

import sssphere
from bench.st_vs_pt import BASE_SIGMA, SCALES, scene_dict
from bench.machine import machine
from sssphere import cluster
from sssphere.cluster import TASKS_PER_SLOT, group_size

HERE = Path(__file__).resolve().parent


def start_cluster(workers: int):
    return cluster.local_cluster(workers)


def stop_cluster(c) -> None:
    import ray

    ray.shutdown()
    c.shutdown()


def exactness(local, remote) -> dict:
    rel = np.abs(remote.image.astype(np.float64) - local.image) / np.maximum(np.abs(local.image),
                                                                           1e-30)
    return {"max_rel_diff": float(rel.max()),
            "bit_identical_share": float(np.mean(remote.image == local.image)),
            "variance_max_rel_diff": float((np.abs(remote.variance.astype(np.float64) - local.variance)
                                            / np.maximum(local.variance, 1e-30)).max()),
            "events_equal": bool(np.array_equal(remote.events, local.events)),
            "steps_equal": bool(np.array_equal(remote.sphere_steps, local.sphere_steps))}


def merge_seconds(pixels: int, repeat: int = 20) -> float:
    """Adding one task's sums into the image's (what the driver does per task)."""
    film = {"sum": np.zeros((pixels, 3)), "sum_sq": np.zeros((pixels, 3)),
            "events": np.zeros(pixels, np.uint64), "steps": np.zeros(pixels, np.uint64)}
    part = {k: np.ones_like(v) for k, v in film.items()}
    t = time.perf_counter()
    for _ in range(repeat):
        for k in film:
            film[k] += part[k]
    return (time.perf_counter() - t) / repeat


def model_100_nodes(per_path: dict, overhead_s: float, setup_s: list[float],
                    merge_s_per_pixel: float, nodes: int, cores: int, spp: int, res: int,
                    network_gbit: float) -> list[dict]:
    """Predicted wall time of the sweep's renders, one after another, on the cluster.

    Per render: T = build + max(render, driver, reduce), where
    * build: the scene's build on every worker, in parallel (the first render), or its
      rebuild from the one before (the later renders: setup_s, measured; a density change
      keeps the BVH, and the distance grid unless its automatic resolution changes);
    * render: the tasks, those of cluster._sample_ranges (TASKS_PER_SLOT per slot, sizes
      within one sample, the larger first), each cut into cluster._bands of rows when the
      samples are too few, handed in order to the first free slot (as Ray does); a task of
      s samples of p pixels on t threads takes s x p x per-path / t + the per-task overhead
      (the per-path time measured on one thread; a node's threads taken to scale
      perfectly, as the local renderer nearly does);
    * driver: it receives and adds one film per group of group_size(slots) tasks (64 bytes
      a pixel over its network link of network_gbit, plus merge_s_per_pixel a pixel);
    * reduce: the workers receiving and adding the films of their groups, spread over the
      nodes' links.
    The three overlap (the driver and the reducers work while tasks render), so the longest
    counts."""
    pixels = res * res
    transfer = 64 * 8 / (network_gbit * 1e9)  # seconds a pixel's sums take on a link
    rows = []
    for layout, threads in (("one task per node, threads = cores", cores),
                            ("one-thread tasks", 1)):
        slots = nodes * cores // threads
        total = ideal = 0.0
        parts = {}
        for i, t_path in enumerate(per_path.values()):
            ranges = list(cluster._sample_ranges(spp, slots, pixels, False))
            bands = [b or (0, res) for b in cluster._bands(spp, slots, res)]
            group = group_size(slots, len(bands))
            tasks = len(ranges) * len(bands)
            band_pixels = pixels / len(bands)
            # Ray hands each task, in order, to the first free slot
            free = [0.0] * slots
            for _, count in ranges:
                for a, b in bands:
                    heapq.heappush(free, heapq.heappop(free) + overhead_s
                                   + count * (b - a) * res * t_path / threads)
            render_s = max(free)
            rounds = math.ceil(tasks / slots)
            driver_s = math.ceil(tasks / group) * pixels * (merge_s_per_pixel + transfer)
            reduce_s = (tasks * band_pixels * (merge_s_per_pixel + transfer) / nodes
                        if group > 1 else 0.0)
            total += setup_s[i] + max(render_s, driver_s, reduce_s)
            ideal += spp * pixels * t_path / (nodes * cores)
            parts = {"tasks_per_render": tasks, "bands": len(bands), "group": group,
                     "rounds": rounds,
                     "render_seconds": render_s,
                     "driver_seconds": driver_s, "reduce_seconds": reduce_s}
        rows.append({"layout": layout, "threads_per_task": threads, "slots": slots,
                     "last_render": parts, "predicted_seconds": total, "ideal_seconds": ideal,
                     "efficiency": ideal / total})
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--workers", type=int, nargs="+", default=[1, 2, 4])
    parser.add_argument("--resolution", type=int, default=64)
    parser.add_argument("--spp", type=int, default=256)
    parser.add_argument("--scale", type=float, default=1.0, help="sigma_t = 500 x scale")
    parser.add_argument("--overhead-tasks", type=int, default=200)
    parser.add_argument("--model-nodes", type=int, default=100)
    parser.add_argument("--model-cores", type=int, default=16)
    parser.add_argument("--model-spp", type=int, default=2048)
    parser.add_argument("--model-resolution", type=int, default=512)
    parser.add_argument("--model-network-gbit", type=float, default=10.0,
                        help="the driver's network link in the model")
    parser.add_argument("--model-only", action="store_true",
                        help="recompute the model from the measurements in --out")
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--out", default=str(HERE / "results" / "cluster.json"))
    args = parser.parse_args()
    if args.quick:
        args.resolution, args.spp, args.overhead_tasks = 32, 8, 50

    if args.model_only:
        out = json.loads(Path(args.out).read_text())
        write_model(out, args)
        return
    scene = sssphere.load_scene(scene_dict("bunny", "dielectric", BASE_SIGMA * args.scale,
                                           args.resolution))
    out: dict = {"date": datetime.datetime.now().isoformat(timespec="seconds"),
                 "machine": machine(),
                 "scene": {"shape": "bunny", "boundary": "dielectric",
                           "sigma_t": BASE_SIGMA * args.scale, "resolution": args.resolution},
                 "spp": args.spp}

    local = {}
    for integrator in ("pt", "st"):
        local[integrator] = sssphere.render_full(scene, integrator=integrator, spp=args.spp, seed=1,
                                                 threads=1)
        print(f"local {integrator}, 1 thread: {local[integrator].seconds:.2f} s")
    out["local_1_thread_seconds"] = {k: r.seconds for k, r in local.items()}

    scaling = []
    for workers in args.workers:
        c = start_cluster(workers)
        try:
            row = {"workers": workers}
            for integrator in ("pt", "st"):
                times = []
                for _ in range(2):  # cold, then warm
                    t = time.perf_counter()
                    r = sssphere.render_full(scene, integrator=integrator, spp=args.spp, seed=1,
                                             ray_address=c.address)
                    times.append(time.perf_counter() - t)
                base = local[integrator].seconds
                row[integrator] = {
                    "cold_seconds": times[0], "warm_seconds": times[1],
                    "efficiency_cold": base / (workers * times[0]),
                    "efficiency_warm": base / (workers * times[1]),
                    "tasks": r.cluster["tasks"], "builds_warm": r.cluster["builds"],
                    "task_render_seconds": sum(r.cluster["task_seconds"]),
                }
                if workers == args.workers[-1]:
                    out.setdefault("exactness", {})[integrator] = exactness(local[integrator], r)
                print(f"W={workers} {integrator}: cold {times[0]:.2f} s, warm {times[1]:.2f} s, "
                      f"efficiency {row[integrator]['efficiency_warm']:.2f} (warm)")
            if workers == 1:
                tiny = sssphere.load_scene(scene_dict("bunny", "dielectric", BASE_SIGMA, 4))
                sssphere.render_full(tiny, spp=4, ray_address=c.address)  # build it first
                cluster.TASKS_PER_SLOT = args.overhead_tasks  # one sample per task
                try:
                    t = time.perf_counter()
                    r = sssphere.render_full(tiny, spp=args.overhead_tasks, ray_address=c.address)
                    wall = time.perf_counter() - t
                finally:
                    cluster.TASKS_PER_SLOT = TASKS_PER_SLOT
                out["per_task_overhead_seconds"] = (wall - sum(r.cluster["task_seconds"])) / r.cluster["tasks"]
                out["overhead_tasks"] = r.cluster["tasks"]
                out["build_seconds_cached"] = float(np.median(r.cluster["build_seconds"]))
                print(f"per-task overhead: {1e3 * out['per_task_overhead_seconds']:.1f} ms "
                      f"over {r.cluster['tasks']} tasks")
            scaling.append(row)
        finally:
            stop_cluster(c)
    out["scaling"] = scaling

    out["sweep_setup_seconds"] = sweep_setup_seconds(args.resolution)
    out["merge_seconds_per_task"] = {f"{n}x{n}": merge_seconds(n * n) for n in (64, 512)}

    # per-path cost of the sweep on one thread, from short local renders
    per_path = {}
    for s in SCALES:
        sc = sssphere.load_scene(scene_dict("bunny", "dielectric", BASE_SIGMA * s, 32))
        r = sssphere.render_full(sc, integrator="st", spp=2, seed=1, threads=1)
        per_path[BASE_SIGMA * s] = r.seconds / (2 * 32 * 32)
    out["sweep_st_seconds_per_path_1_thread"] = per_path
    write_model(out, args)


def sweep_setup_seconds(resolution: int) -> list[float]:
    """The bunny sweep's scene set-ups on a worker: the first density built, each next one an
    edit of the one before (the grid is rebuilt where its automatic resolution changes)."""
    times = []
    t = time.perf_counter()
    bunny = sssphere.load_scene(scene_dict("bunny", "dielectric", BASE_SIGMA * SCALES[0], resolution))
    times.append(time.perf_counter() - t)
    for s in SCALES[1:]:
        t = time.perf_counter()
        bunny.shapes[0].medium.sigma_t = BASE_SIGMA * s
        times.append(time.perf_counter() - t)
    return times


def write_model(out: dict, args) -> None:
    if "sweep_setup_seconds" not in out:
        out["sweep_setup_seconds"] = sweep_setup_seconds(out["scene"]["resolution"])
    merge_per_pixel = out["merge_seconds_per_task"]["512x512"] / (512 * 512)
    per_path = {float(k): v for k, v in out["sweep_st_seconds_per_path_1_thread"].items()}
    out["model"] = {
        "nodes": args.model_nodes, "cores_per_node": args.model_cores, "spp": args.model_spp,
        "resolution": args.model_resolution, "integrator": "st",
        "network_gbit": args.model_network_gbit, "renders": len(per_path),
        "rows": model_100_nodes(per_path, out["per_task_overhead_seconds"],
                                out["sweep_setup_seconds"], merge_per_pixel, args.model_nodes,
                                args.model_cores, args.model_spp, args.model_resolution,
                                args.model_network_gbit),
    }
    for row in out["model"]["rows"]:
        print(f"model, {args.model_nodes} nodes x {args.model_cores} cores, {row['layout']}: "
              f"{row['predicted_seconds']:.0f} s (ideal {row['ideal_seconds']:.0f} s, "
              f"efficiency {row['efficiency']:.2f})")
    Path(args.out).write_text(json.dumps(out, indent=2) + "\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
