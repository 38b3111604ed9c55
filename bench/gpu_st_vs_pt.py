#!/usr/bin/env python3
"""Sphere tracing (`st`) against path tracing (`pt`) on a GPU: the Vulkan path (docs/gpu.md).

The scenes of bench/st_vs_pt.py (bunny and thin torus, dielectric and index-matched,
sigma_t = 500 x {0.25, 0.5, 1, 2}, and the bunny's dense sweep 4, 8, 16), rendered by
`sssphere-gpu-bench` with both integrators at equal spp on the GPU. The scenes are baked with
``nee=False``: for the dielectric scenes that is the same estimator as the CPU's `pt` with NEE
(no shadow ray leaves them), for the index-matched ones a noisier one of the same image. The
index-matched bunny is also run with light sampling (boundary ``index_matched_nee``: the
override ``nee=1``), the estimator of the CPU's table, and the dielectric bunny at sigma_t =
1000 and 4000 with cut sphere steps too (boundary ``dielectric_cut``: ``st`` with models/cut;
a baked file each, as the plane certificates depend on sigma_t). Errors are measured against the CPU's
converged `pt` references in bench/results/cache/ (st_vs_pt.py makes them).

Three steps, because the GPU machine has neither this package's libraries nor a network:

    python -m bench.gpu_st_vs_pt bake        # here: .devbench/ (~1 min)
    bash bench/gpu_device_run.sh                               # on the GPU machine, with
                                                               #   .devbench and .gl carried
    python -m bench.gpu_st_vs_pt report DIR  # here: DIR holds its $OUT

`report` writes bench/results/gpu_st_vs_pt.json and prints the table of bench/README.md.
The same steps run on Mesa's lavapipe here (``bash bench/gpu_device_run.sh`` with OUT set), as
a check of the pipeline, not of GPU speed.
"""

from __future__ import annotations

import argparse
import datetime
import gzip
import json
import shutil
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
REPO = HERE.parent

import sssphere  # noqa: E402
from sssphere import _core  # noqa: E402
from sssphere.rendering import DEFAULT_MODELS, DEFAULT_SPHERE_THRESHOLD  # noqa: E402
from bench import st_vs_pt as cpu  # noqa: E402

RES = 64
SPP = 256  # one dispatch of 64 x 64 x 256 = 2^20 paths: a full GPU
DENSE = (4.0, 8.0, 16.0)


NEE_SUFFIX = "_nee"  # a boundary label: that boundary, with light sampling on the GPU
CUT_SUFFIX = "_cut"  # a boundary label: that boundary, "st" with cut steps (models/cut)
CUT_SCALES = (2.0, 8.0)  # the dielectric bunny with cut steps at sigma_t = 1000 and 4000


def base_boundary(boundary: str) -> str:
    """The scene's boundary behind a run's label."""
    return boundary.removesuffix(NEE_SUFFIX).removesuffix(CUT_SUFFIX)


def runs():
    """(name, shape, boundary, sigma_t) of every render."""
    out = []
    for shape in cpu.SHAPES:
        boundaries = list(cpu.BOUNDARIES)
        if shape == "bunny":
            boundaries.append("index_matched" + NEE_SUFFIX)
        for boundary in boundaries:
            scales = list(cpu.SCALES) + (list(DENSE) if shape == "bunny" else [])
            for scale in scales:
                sigma = cpu.BASE_SIGMA * scale
                out.append((f"{shape}_{boundary}_s{sigma:g}", shape, boundary, sigma))
    for scale in CUT_SCALES:
        sigma = cpu.BASE_SIGMA * scale
        out.append((f"bunny_dielectric{CUT_SUFFIX}_s{sigma:g}", "bunny",
                    "dielectric" + CUT_SUFFIX, sigma))
    return out


def bake(args) -> int:
    """One baked file per (shape, grid resolution); the runs override medium and boundary.
    Runs with cut steps get a file each: the plane certificates depend on sigma_t."""
    d = Path(args.dir)
    if d.exists():
        shutil.rmtree(d)
    d.mkdir(parents=True)
    baked, lines = {}, []
    for name, shape, boundary, sigma in runs():
        desc = cpu.scene_dict(shape, "dielectric", sigma, RES)
        scene = sssphere.load_scene(desc)
        # The grid resolution Scene chose for this density (Scene::auto_grid_resolution).
        res = scene.grid_resolutions[0]
        cut = boundary.endswith(CUT_SUFFIX)
        key = f"{shape}_g{res}" + (f"_cut_s{sigma:g}" if cut else "")
        if key not in baked:
            path = d / f"{key}.bin"
            _core.bake_gpu_scene(scene, str(path), "st", False, DEFAULT_SPHERE_THRESHOLD,
                                 str(DEFAULT_MODELS),
                                 str(REPO / "models" / "cut") if cut else "")
            with open(path, "rb") as f, gzip.open(str(path) + ".gz", "wb", compresslevel=6) as g:
                shutil.copyfileobj(f, g)
            path.unlink()
            baked[key] = path.name
        nee = boundary.endswith(NEE_SUFFIX)
        lines.append(f"{name}={baked[key]},sigma_t={sigma:g},"
                     f"boundary={base_boundary(boundary)}" + (",nee=1" if nee else ""))
    (d / "runs.txt").write_text("\n".join(lines) + "\n")
    (d / "spp.txt").write_text(f"{args.spp}\n")
    binary = Path(args.build) / "cpp" / "sssphere-gpu-bench"
    shutil.copy(binary, d / binary.name)
    size = sum(f.stat().st_size for f in d.iterdir())
    print(f"{d}: {len(lines)} runs, {len(baked)} baked scenes, {size / 2**20:.1f} MiB")
    return 0


def reference(shape, boundary, sigma):
    boundary = base_boundary(boundary)  # the same image
    files = sorted(Path(REPO / "bench" / "results" / "cache").glob(
        f"{shape}_{boundary}_s{sigma:g}_{RES}px_*spp.npz"),
        key=lambda f: int(f.stem.rsplit("_", 1)[1][:-3]))
    if not files:
        return None
    z = np.load(files[-1])
    return argparse.Namespace(image=z["image"], variance=z["variance"], file=files[-1].name)


def report(args) -> int:
    d = Path(args.results)
    lines = [json.loads(line) for line in (d / "gpu_bench.jsonl").read_text().splitlines()
             if line.startswith("{")]
    rows = [r for r in lines if "scene" in r]
    step_rows = [r for r in lines if "ns_per_step" in r]
    images = np.load(d / "images.npz")
    results = []
    for name, shape, boundary, sigma in runs():
        entry = {"scene": name, "shape": shape, "boundary": boundary, "sigma_t": sigma}
        ref = reference(shape, boundary, sigma)
        entry["reference"] = ref.file if ref is not None else None
        for integ in ("pt", "st"):
            rs = [r for r in rows if r["scene"] == name and r["integrator"] == integ]
            if not rs:
                continue
            t = sorted(r["gpu_seconds"] for r in rs)
            e = {"gpu_seconds_median": t[len(t) // 2], "gpu_seconds_all": t,
                 "events_per_path": rs[-1]["events_per_path"],
                 "steps_per_path": rs[-1]["steps_per_path"], "spp": rs[-1]["spp"]}
            key = f"{name}_{integ}"
            if key in images and ref is not None:
                a = images[key].reshape(2, RES, RES, 3)
                r = argparse.Namespace(image=a[0], variance=a[1])
                e["errors"] = cpu.errors(r, ref, cpu.reference_error(ref))
            entry[integ] = e
            entry["device"] = rs[-1]["device"]
        if "pt" in entry and "st" in entry:
            entry["speedup"] = entry["pt"]["gpu_seconds_median"] / entry["st"]["gpu_seconds_median"]
        results.append(entry)
    # Runs outside the sweep (bench/gpu_device_run.sh with RUNS=...), e.g. threshold=inf.
    known = {name for name, *_ in runs()}
    extra = {}
    for r in rows:
        if r["scene"] not in known:
            extra.setdefault(r["scene"], {}).setdefault(r["integrator"], []).append(
                r["gpu_seconds"])
    extra = {k: {i: sorted(t)[len(t) // 2] for i, t in v.items()} for k, v in extra.items()}
    out = {"date": datetime.date.today().isoformat(), "resolution": RES,
           "extra_runs_gpu_seconds_median": extra,
           "step_alone_ns": (sorted(r["ns_per_step"] for r in step_rows)[len(step_rows) // 2]
                             if step_rows else None),
           "threshold": DEFAULT_SPHERE_THRESHOLD, "runs": results,
           "device": results[0].get("device") if results else None,
           "note": "GPU time of the dispatches (timestamps), median of the repeats; light "
                   "sampling on the GPU only for boundary index_matched_nee (else the "
                   "nee=False estimator)"}
    Path(args.output).write_text(json.dumps(out, indent=1) + "\n")
    print(table(out))
    if out["step_alone_ns"] is not None:
        print(f"one sphere step sampled alone: {out['step_alone_ns']:.3f} ns")
    for k, v in extra.items():
        print(k, {i: f"{1e3 * t:.1f} ms" for i, t in v.items()})
    return 0


def table(out) -> str:
    lines = [f"GPU: {out['device']}, {out['resolution']}x{out['resolution']}, "
             f"spp {out['runs'][0]['pt']['spp'] if out['runs'] else '?'}",
             "| scene | σt | pt ms | st ms | speed-up | pt events | st events + steps "
             "| RMSE pt | RMSE st | st bias (G) |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for r in out["runs"]:
        if "st" not in r or "pt" not in r:
            continue
        pt, st = r["pt"], r["st"]
        err = lambda e: (f"{e['errors']['rmse_srgb']:.4f}" if "errors" in e else "–")  # noqa: E731
        bias = (f"{100 * st['errors']['bias'][1]:+.1f} % ± {100 * st['errors']['bias_sigma'][1]:.1f}"
                if "errors" in st else "–")
        lines.append(
            f"| {r['shape']} {r['boundary'].replace('_', '-')} | {r['sigma_t']:g} "
            f"| {1e3 * pt['gpu_seconds_median']:.1f} | {1e3 * st['gpu_seconds_median']:.1f} "
            f"| ×{r['speedup']:.1f} | {pt['events_per_path']:.1f} "
            f"| {st['events_per_path'] + st['steps_per_path']:.1f} | {err(pt)} | {err(st)} "
            f"| {bias} |")
    return "\n".join(lines)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = p.add_subparsers(dest="cmd", required=True)
    b = sub.add_parser("bake", help="bake the scenes and the bench binary into --dir")
    b.add_argument("--dir", default=str(REPO / ".devbench"))
    b.add_argument("--spp", type=int, default=SPP)
    b.add_argument("--build", default=str(REPO / "build" / "dev"),
                   help="the build tree holding cpp/sssphere-gpu-bench")
    r = sub.add_parser("report", help="summarize a device run's $OUT")
    r.add_argument("results")
    r.add_argument("--output", default=str(HERE / "results" / "gpu_st_vs_pt.json"))
    t = sub.add_parser("table", help="print the table of a results JSON")
    t.add_argument("file")
    args = p.parse_args(argv)
    if args.cmd == "bake":
        return bake(args)
    if args.cmd == "report":
        return report(args)
    print(table(json.loads(Path(args.file).read_text())))
    return 0


if __name__ == "__main__":
    sys.exit(main())
