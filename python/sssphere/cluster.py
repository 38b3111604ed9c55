"""Rendering and walk generation on a Ray cluster (docs/cluster.md).

A render is split into tasks by sample ranges: task k renders samples [s_k, s_k+1) of every
pixel, each with the random stream it has in a local render (render/scheduler.h), and
returns its film's sums (float64 radiance and squares, integer event and step counts).
The driver adds the sums in task order, whatever order the tasks finish in, and turns
them into the image as a local render does (``_core.film_result``). So the merged image is
the local render's up to the grouping of the float64 additions: the event and step counts
and path records are identical, and the float32 pixels are too unless a pixel's float64
sums round (float32 samples spanning more than about 2^29 in magnitude).

Nothing is assumed of the workers' file systems: the scene's description, its mesh files,
environment map and models travel through Ray's object store, and each worker process
builds the scene once and keeps it for the tasks that follow (``_worker_scene``; a new
scene is built from the kept one as an edit is). On a large cluster, groups of tasks are
added up on workers before the driver receives them (``GROUP_FILMS``). Tasks that die with
their worker or node are re-run by Ray (``max_retries``); being deterministic, they give
the same sums. Ctrl-C (or a progress callback returning False) cancels what is left and
returns the tasks merged so far, in order: a render of fewer samples per pixel, as locally.

Ray is an optional extra: ``pip install 'sssphere[cluster]'``.
"""

from __future__ import annotations

import hashlib
import json
import os
import signal
import tempfile
import threading
import time
from typing import Callable, Optional

import numpy as np

from sssphere import _core

#: Tasks per task slot (a slot: ``threads`` CPUs) when the samples allow: enough that a slow
#: or lost task delays the end little, few enough that each task's overhead stays small.
TASKS_PER_SLOT = 4
#: Times Ray re-runs a task whose worker process or node died.
MAX_RETRIES = 5
#: Slots per film the driver receives: on a cluster of more slots, groups of
#: slots // GROUP_FILMS consecutive tasks are added up on a worker first (the driver's
#: network link would otherwise bound a large cluster: docs/cluster.md).
GROUP_FILMS = 8
#: Walks per data-generation task.
WALK_CHUNK = 20_000

_INSTALL = "pip install 'sssphere[cluster]' (the PyPI package ray)"


def _ray():
    try:
        import ray
    except ImportError:
        raise ImportError(f"rendering on a cluster needs Ray, an optional extra: {_INSTALL}") from None
    return ray


def connect(address: str):
    """Connect this process to the Ray cluster at ``address`` (what ``ray.init`` takes:
    ``"auto"`` for the cluster in RAY_ADDRESS or one running on this machine,
    ``"HOST:PORT"``, ``"ray://HOST:PORT"``, or ``"local"`` to start one here), unless it
    is connected already. Returns the ray module."""
    if not isinstance(address, str) or not address:
        raise ValueError(f"ray_address must be a Ray address (a str such as 'auto' or "
                         f"'HOST:PORT'), got {address!r}")
    ray = _ray()
    if not ray.is_initialized():
        _check_reachable(address)
        # ray.init puts its own SIGTERM handler (sys.exit) in the main thread: the caller's
        # (the command line's, which keeps the image rendered so far) is put back.
        main = threading.current_thread() is threading.main_thread()
        sigterm = signal.getsignal(signal.SIGTERM) if main else None
        try:
            ray.init(address=None if address == "local" else address,
                     log_to_driver=False, configure_logging=False)
        except ConnectionError as e:
            raise ConnectionError(f"ray_address {address!r}: no Ray cluster there ({e}); start "
                                  "one with `ray start --head` (docs/cluster.md)") from None
        finally:
            if main and sigterm is not None:
                signal.signal(signal.SIGTERM, sigterm)
    return ray


def local_cluster(nodes: int, cpus_per_node: int = 1):
    """A Ray cluster on this machine, and this process connected to it: a head node that runs
    no tasks and ``nodes`` worker nodes of ``cpus_per_node`` CPUs, each its own raylet and
    object store as separate machines would have (``ray.cluster_utils.Cluster``). For tests,
    benchmarks and trying ``ray_address=cluster.address`` out; ``ray.shutdown()`` then
    ``cluster.shutdown()`` end it."""
    ray = _ray()
    from ray.cluster_utils import Cluster

    cluster = Cluster(initialize_head=True, head_node_args={"num_cpus": 0})
    for _ in range(nodes):
        cluster.add_node(num_cpus=cpus_per_node)
    cluster.wait_for_nodes()
    ray.init(address=cluster.address, log_to_driver=False, configure_logging=False)
    return cluster


def _check_reachable(address: str, seconds: float = 10.0) -> None:
    """A HOST:PORT that nothing answers on is said at once (Ray would wait for minutes)."""
    import socket

    host, sep, port = address.rpartition(":")
    if "://" in address or not sep or not port.isdigit():
        return  # auto, local, ray://...: Ray says what is wrong with those itself
    try:
        socket.create_connection((host, int(port)), timeout=seconds).close()
    except OSError as e:
        raise ConnectionError(f"ray_address {address!r}: nothing answers there ({e}); is the "
                              "head node started (`ray start --head`, docs/cluster.md)?") from None


# --- the scene's package: its description and files, for workers without our files ---

def _file_key(path: str, data: bytes) -> str:
    # the content's hash keeps the file name's suffix, by which the readers pick a format
    return f"{hashlib.sha256(data).hexdigest()[:24]}-{os.path.basename(path)}"


_PUT: dict = {}  # (job, path, size, mtime) -> (key, ref): files in the object store
_KEEP_PUT = 32


def _put_file(path: str, ray) -> tuple[str, object]:
    """A file put in the object store, once while it is unchanged (a turntable's frames, a
    sweep's renders share their meshes); the last _KEEP_PUT files stay there."""
    st = os.stat(path)
    cache_key = (ray.get_runtime_context().get_job_id(), path, st.st_size, st.st_mtime_ns)
    if cache_key not in _PUT:
        with open(path, "rb") as f:
            data = f.read()
        while len(_PUT) >= _KEEP_PUT:
            _PUT.pop(next(iter(_PUT)))
        _PUT[cache_key] = (_file_key(path, data), ray.put(data))
    return _PUT[cache_key]


def package_scene(scene, options: dict, ray) -> tuple[str, dict]:
    """The scene as (JSON text, {file key: object ref}): each file the scene reads (shape
    meshes, the environment map, the models of ``options``) put once in the object store,
    its path in the text replaced by its key. The cut sphere models of ``options``
    (``cut_models``) travel the same way."""
    doc = scene.to_dict()
    files: dict[str, object] = {}

    def ship(path: str, field: str = "") -> str:
        full = os.path.join(scene.base_dir, path)
        if field:  # one of the scene's files: the one the scene was built from
            stamp = scene._stamps.get(full)
            try:
                st = os.stat(full)
                now = (st.st_size, st.st_mtime_ns)
            except OSError:
                now = None
            if now != stamp:
                raise _core.SceneError(
                    f"{scene.source}: {field}: {full}: "
                    + ("the file is gone" if now is None else "the file changed on disk")
                    + " since the scene was built from it: a cluster render sends the "
                    "scene's files to its workers, which would not render this scene; "
                    "load the scene again (sssphere.load_scene)")
        key, ref = _put_file(full, ray)
        files[key] = ref
        return key

    for k, shape in enumerate(doc.get("shapes", [])):
        if isinstance(shape.get("mesh"), str):
            shape["mesh"] = ship(shape["mesh"], f"shapes[{k}].mesh")
    for k, light in enumerate(doc.get("lights", [])):
        if isinstance(light.get("map"), str):
            light["map"] = ship(light["map"], f"lights[{k}].map")
    for key in ("models", "cut_models"):  # the options carry the models
        doc.get("render", {}).pop(key, None)
    models = []
    if options["integrator"] == "st" and options["sphere_sampler"] == "model":
        # tilt.json too, where the directory has one: without it the workers' steps would
        # be the decoders' own, not the local render's
        for name in ("lengthgen.json", "pathgen.json", "eventgen.json", "tilt.json"):
            path = os.path.join(options["models"], name)
            if os.path.isfile(path):
                models.append(ship(path))
    cut_models = []
    if options["integrator"] == "st" and options.get("cut_models"):
        for name in ("cutlengthgen.json", "cutpathgen.json"):
            path = os.path.abspath(os.path.join(options["cut_models"], name))
            if not os.path.isfile(path):  # as the local render says it
                raise _core.SceneError(f"{path}: cannot open the model file (missing or unreadable)")
            cut_models.append(ship(path))
    package = {"scene": doc, "models": models, "cut_models": cut_models,
               "source": scene.source}
    return json.dumps(package, sort_keys=True), files


_FILES_DIR: Optional[str] = None
_SCENE: dict = {}  # this worker process's scene: key, scene, models directories


def _worker_scene(text: str, files: dict, threads: int):
    """The scene of a package, built in this process on its first task and kept for the
    next ones (a worker process runs many tasks). A new package is built from the scene
    before it (an edit: Scene's reusing rebuild), so a sweep over materials, lights or
    cameras keeps its BVH and distance grids. Returns (scene, models dir, cut models dir
    or "", built)."""
    global _FILES_DIR
    key = hashlib.sha256(text.encode()).hexdigest()
    if _SCENE.get("key") == key:
        return _SCENE["scene"], _SCENE["models"], _SCENE["cut_models"], False
    import ray

    from sssphere.scene import Scene

    if _FILES_DIR is None:
        _FILES_DIR = os.path.join(tempfile.gettempdir(), f"sssphere-cluster-{os.getuid()}")
        os.makedirs(_FILES_DIR, mode=0o700, exist_ok=True)
    for name, ref in files.items():
        path = os.path.join(_FILES_DIR, name)
        if not os.path.exists(path):
            part = f"{path}.{os.getpid()}.part"  # the node's workers share the directory
            with open(part, "wb") as f:
                f.write(ray.get(ref))
            os.replace(part, path)
    package = json.loads(text)
    models_dir = _link_models(package["models"], "models-" + key[:24])
    cut_dir = (_link_models(package["cut_models"], "cut-models-" + key[:24])
               if package.get("cut_models") else "")
    doc = json.dumps(package["scene"])
    scene = _SCENE.get("scene")
    if scene is None:
        scene = Scene(doc, _FILES_DIR, package["source"], threads)
    else:
        scene._rebuild(doc, _FILES_DIR, package["source"], threads, scene._meshes)
        scene._doc = package["scene"]
    _SCENE.update(key=key, scene=scene, models=models_dir, cut_models=cut_dir)
    return scene, models_dir, cut_dir, True


def _link_models(names: list, directory: str) -> str:
    """A directory of this node's files `names` (file keys) under their own names, as the
    renderer reads models: hard links to the files the object store delivered."""
    path = os.path.join(_FILES_DIR, directory)
    os.makedirs(path, exist_ok=True)
    for name in names:
        target = os.path.join(path, name.split("-", 1)[1])
        if not os.path.exists(target):
            try:
                os.link(os.path.join(_FILES_DIR, name), target)
            except FileExistsError:  # another worker of this node linked it meanwhile
                pass
    return path


def _render_part(text: str, files: dict, options: dict, first: int, spp: int,
                 rows: Optional[tuple[int, int]] = None) -> dict:
    """One task: samples [first, first + spp) of every pixel, or of the pixels of rows
    [rows[0], rows[1]), as film sums (a part; see _add_parts)."""
    import ray

    t0 = time.monotonic()
    scene, models_dir, cut_dir, built = _worker_scene(text, files, options["threads"])
    build_s = time.monotonic() - t0
    y0, y1 = rows if rows is not None else (0, scene.height)
    band = {} if rows is None else {"first_row": y0, "rows": y1 - y0}
    r = _core.render(scene, models_dir, None, {}, first_sample=first, keep_film=True, **band,
                     **{**options, "spp": spp, "cut_models": cut_dir,
                        "models": models_dir if options["integrator"] == "st" else None})
    if r["cancelled"]:  # Ray's cancel of this task arrived as a KeyboardInterrupt
        raise KeyboardInterrupt
    task = {"seconds": r["seconds"], "step_seconds": r["step_seconds"], "build_seconds": build_s,
            "built": built, "rebuilt": list(scene.rebuilt) if built else None,
            "pid": os.getpid(), "node": ray.get_runtime_context().get_node_id(),
            "device": r.get("device"), "gpu_seconds": r.get("gpu_seconds"),
            "warnings": [w.replace(models_dir, "{models}") for w in r.get("warnings", [])]}
    w = scene.width
    part = {"film": {key: a[y0 * w:y1 * w] for key, a in r["film"].items()},
            "rows": (y0, y1), "width": w, "tasks": [task]}
    if options["record_paths"]:
        part["path_events"], part["path_steps"] = r["path_events"], r["path_steps"]
    return part


def _add_part(film: dict, rows: tuple[int, int], part: dict) -> None:
    """Adds a part's sums to those of ``film``, which covers the image rows ``rows``."""
    w = part["width"]
    a, b = ((y - rows[0]) * w for y in part["rows"])
    for key in film:
        film[key][a:b] += part["film"][key]


def _add_parts(*parts: dict) -> dict:
    """Consecutive parts (tasks, or sums of tasks) as one: their films added in order (each
    to its rows), their tasks and path records one after another. Run on the workers, it
    cuts what the driver receives to one film per group of tasks (GROUP_FILMS)."""
    rows = (min(p["rows"][0] for p in parts), max(p["rows"][1] for p in parts))
    w = parts[0]["width"]
    film = {key: np.zeros((w * (rows[1] - rows[0]), *a.shape[1:]), a.dtype)
            for key, a in parts[0]["film"].items()}
    for part in parts:
        _add_part(film, rows, part)
    out = {"film": film, "rows": rows, "width": w,
           "tasks": [task for part in parts for task in part["tasks"]]}
    for key in ("path_events", "path_steps"):
        if key in parts[0]:
            out[key] = np.concatenate([part[key] for part in parts])
    return out


def _sample_ranges(spp: int, slots: int, pixels: int, timed: bool):
    """The tasks' sample ranges (first, count), in sample order: TASKS_PER_SLOT tasks per
    slot (fewer if spp is smaller), their sizes differing by at most one sample, so that
    every round of tasks keeps every slot busy. With a time limit, which ends the render at
    an unknown spp, tasks of at most 2^16 paths (samples x pixels) instead, so that the
    last ones, wasted when time is up, are short."""
    if timed:
        size = max(1, min(-(-spp // max(1, slots * TASKS_PER_SLOT)), 2 ** 16 // pixels))
        for first in range(0, spp, size):
            yield first, min(size, spp - first)
        return
    tasks = min(spp, max(1, slots * TASKS_PER_SLOT))
    first = 0
    for k in range(tasks):
        count = spp // tasks + (k < spp % tasks)
        yield first, count
        first += count


def group_size(slots: int, bands: int = 1) -> int:
    """Tasks whose films a worker adds up before the driver gets them: one group per
    GROUP_FILMS slots (1, no grouping, on small clusters), a whole number of sample ranges
    when a range is cut into ``bands`` tasks."""
    return max(1, slots // GROUP_FILMS // bands) * bands


def _bands(spp: int, slots: int, height: int) -> list[Optional[tuple[int, int]]]:
    """The bands of rows a sample range is cut into: [None] (the whole image) when the
    samples alone make TASKS_PER_SLOT tasks per slot, else as many bands as make up the
    difference (their heights within one row)."""
    n = min(height, -(-slots * TASKS_PER_SLOT // spp))
    if n <= 1:
        return [None]
    edges = [height * k // n for k in range(n + 1)]
    return [(edges[k], edges[k + 1]) for k in range(n)]


def render(scene, address: str, progress: Optional[Callable[[float], object]], options: dict,
           text: Optional[dict], models: str) -> dict:
    """A render on the cluster at ``address``: the dict ``_core.render`` returns for a local
    render of the same scene and options, with ``cluster`` added (tasks, builds, nodes,
    seconds; see RenderResult.cluster)."""
    ray = connect(address)
    t0 = time.monotonic()
    given = {k: v for k, v in options.items() if v is not None}
    resolved = _core.resolve_render_options(scene, models, text or {}, **given)
    # the CPUs each task asks Ray for, and its threads ("vulkan": one CPU drives the device)
    threads = resolved["threads"] or 1
    time_limit = resolved["time_limit"]
    task_options = {**resolved, "time_limit": 0.0}
    if resolved["integrator"] != "st":  # options of "st" only (render/options.cpp)
        task_options.update(models=None, sphere_threshold=None)
    if resolved["backend"] == "cpu":
        task_options["threads"] = threads
    spp = resolved["spp"]
    package, files = package_scene(scene, resolved, ray)

    resources = ray.cluster_resources()
    gpu = resolved["backend"] == "vulkan" and resources.get("GPU", 0) > 0
    slots = int(resources.get("GPU", 0)) if gpu else int(resources.get("CPU", 0) // threads)
    if slots < 1:
        raise RuntimeError(f"the Ray cluster at {address!r} has {resources.get('CPU', 0):g} CPUs: "
                           f"none can run a task of threads={threads}")
    timed = time_limit > 0
    # too few samples for the slots: each sample range is cut into bands of rows (CPU only;
    # record_paths keeps whole images)
    bands = (_bands(spp, slots, scene.height)
             if not (timed or resolved["backend"] != "cpu" or resolved["record_paths"]) else [None])
    tasks_in_order = ((first, count, band)
                      for first, count in _sample_ranges(spp, slots, scene.width * scene.height, timed)
                      for band in bands)
    # SPREAD: the tasks go round the nodes. Ray's default packs a node first, and places
    # tasks by a load view that lags: short tasks then all went to one node while another
    # idled (seen in CI, two one-CPU nodes, 8 tasks of a fraction of a second).
    remote = ray.remote(_render_part).options(
        num_cpus=0 if gpu else threads, num_gpus=1 if gpu else 0, max_retries=MAX_RETRIES,
        scheduling_strategy="SPREAD")
    add = ray.remote(_add_parts).options(num_cpus=0, max_retries=MAX_RETRIES)
    nb = len(bands)
    group = group_size(slots, nb)

    pixels = scene.width * scene.height
    film = {"sum": np.zeros((pixels, 3)), "sum_sq": np.zeros((pixels, 3)),
            "events": np.zeros(pixels, np.uint64), "steps": np.zeros(pixels, np.uint64)}
    merged: list[dict] = []  # the parts added to film, in sample order
    merged_tasks = 0

    def merge(part: dict) -> None:
        nonlocal merged_tasks
        _add_part(film, (0, scene.height), part)
        merged.append(part)
        merged_tasks += len(part["tasks"])

    # the tasks' (first sample, samples, band), in order: a range's bands, range by range
    submitted: list[tuple[int, int, Optional[tuple[int, int]]]] = []
    task_refs: list = []
    groups: list[tuple[int, object]] = []  # (first task, ref of the group's part)
    running: dict = {}  # task ref -> task number, not yet finished
    finished: set = set()  # task numbers
    fetched: dict[int, dict] = {}  # group number -> part, waiting for the groups before it
    cancelled = time_limit_reached = exhausted = False
    done_samples = 0
    try:
        while True:
            # at most two tasks a slot in flight: the rest wait here, cheap to drop
            while len(running) < 2 * slots and not exhausted:
                work = next(tasks_in_order, None)
                if work is None:
                    exhausted = True
                    break
                ref = remote.remote(package, files, task_options, *work)
                running[ref] = len(submitted)
                submitted.append(work)
                task_refs.append(ref)
            # a group's part: the task's own when groups are of one, else a sum on a worker
            start = groups[-1][0] + group if groups else 0
            while len(submitted) - start >= group or (exhausted and start < len(submitted)):
                members = task_refs[start:start + group]
                groups.append((start, members[0] if len(members) == 1 else add.remote(*members)))
                start += group
            if not running and len(merged) == len(groups) and exhausted:
                break
            if running:
                ready, _ = ray.wait(list(running), num_returns=len(running), timeout=0.1,
                                    fetch_local=False)
                for ref in ready:
                    k = running.pop(ref)
                    finished.add(k)
                    _, count, band = submitted[k]
                    done_samples += count * (1 if band is None
                                             else (band[1] - band[0]) / scene.height)
            waiting = [ref for g, (_, ref) in enumerate(groups)
                       if g >= len(merged) and g not in fetched]
            ready, _ = ray.wait(waiting, num_returns=len(waiting),
                                timeout=0 if running else 0.1) if waiting else ([], [])
            ready = set(ready)
            for g, (_, ref) in enumerate(groups):
                if ref in ready:
                    fetched[g] = ray.get(ref)
            while len(merged) in fetched:
                merge(fetched.pop(len(merged)))
            elapsed = time.monotonic() - t0
            if progress is not None:
                fraction = done_samples / spp
                if time_limit > 0:
                    fraction = max(fraction, elapsed / time_limit)
                if progress(min(1.0, fraction)) is False:
                    cancelled = True
                    break
            if time_limit > 0 and merged_tasks > 0 and elapsed >= time_limit:
                time_limit_reached = True
                break
    except KeyboardInterrupt:
        cancelled = True
    except ray.exceptions.RayTaskError as e:
        _cancel(ray, list(running) + [ref for _, ref in groups])
        raise _cause(e) from None
    except BaseException:  # a progress callback's error, say: no task outlives the render
        _cancel(ray, list(running) + [ref for _, ref in groups])
        raise
    if cancelled or time_limit_reached:
        _cancel(ray, list(running) + [ref for _, ref in groups[len(merged):]])
        # the sample ranges finished (all their bands) after the last merged group, in
        # order, are kept too: every pixel keeps the same samples
        k = merged_tasks
        while k + nb <= len(submitted) and all(j in finished for j in range(k, k + nb)):
            try:
                parts = [ray.get(task_refs[j], timeout=10) for j in range(k, k + nb)]
            except Exception:  # noqa: BLE001 -- lost with its node: the prefix ends here
                break
            for part in parts:
                merge(part)
            k += nb
    ranges = [(first, count) for first, count, _ in submitted[:merged_tasks:nb]]
    merged_spp = sum(count for _, count in ranges)
    shape = (scene.height, scene.width)
    r = _core.film_result(film["sum"], film["sum_sq"], film["events"].reshape(shape),
                          film["steps"], merged_spp)
    if progress is not None and not cancelled:
        progress(1.0)
    tasks = [task for part in merged for task in part["tasks"]]
    r["cancelled"] = cancelled
    r["interrupted"] = cancelled
    r["time_limit_reached"] = time_limit_reached
    r["seconds"] = time.monotonic() - t0
    r["step_seconds"] = sum(t["step_seconds"] for t in tasks)
    # once each, naming the models as given here (a task names its node's copy "{models}")
    r["warnings"] = list(dict.fromkeys(w.replace("{models}", str(resolved["models"]))
                                       for t in tasks for w in t["warnings"]))
    if resolved["record_paths"]:
        # (spp asked for, height, width), 0 past the samples taken, as a local render's
        for key in ("path_events", "path_steps"):
            r[key] = np.zeros((resolved["spp"], *shape), np.uint32)
            taken = np.concatenate([p[key] for p in merged]) if merged else r[key][:0]
            r[key][:len(taken)] = taken
    if resolved["backend"] == "vulkan":
        r["gpu_seconds"] = sum(t["gpu_seconds"] or 0.0 for t in tasks)
        r["device"] = tasks[0]["device"] if tasks else None
    r["options"] = {**resolved, "threads": task_options["threads"]}
    r["cluster"] = {
        "address": address, "tasks": len(submitted), "tasks_merged": merged_tasks,
        "slots": slots, "group": group, "ranges": ranges, "bands": nb,
        "builds": sum(t["built"] for t in tasks),
        "processes": len({(t["node"], t["pid"]) for t in tasks}),
        "nodes": sorted({t["node"] for t in tasks}),
        "task_seconds": [t["seconds"] for t in tasks],
        "build_seconds": [t["build_seconds"] for t in tasks],
        "rebuilt": [t["rebuilt"] for t in tasks if t["built"]],
    }
    return r


def _cause(error: Exception) -> Exception:
    """What a task raised (a SceneError, say), not Ray's wrapper around it."""
    cause = getattr(error, "cause", None)
    return cause if isinstance(cause, Exception) else error


def _cancel(ray, refs: list) -> None:
    for ref in refs:
        try:
            ray.cancel(ref, force=True)
        except Exception:  # noqa: BLE001 -- a task that ended meanwhile has nothing to cancel
            pass


# --- sphere walks (training data) ---

def _walk_part(sigma, g, albedo, seed: int, first_index: int) -> dict:
    from sssphere.walks import sphere_walks

    return sphere_walks(sigma, g, albedo, len(sigma), seed=seed, first_index=first_index, threads=1)


def walks(sigma, g, albedo, n: int, seed: int, first_index: int,
          address: str, chunk: int = WALK_CHUNK,
          progress: Optional[Callable[[float], object]] = None) -> tuple[list[dict], bool]:
    """Sphere walks i = 0 .. n - 1 (stream first_index + i; sigma, g, albedo: arrays of n,
    or of 1 for all) in tasks of ``chunk`` walks on the cluster at ``address``. Returns
    (the finished chunks from the first, in order; interrupted): Ctrl-C cancels the rest
    and keeps the chunks finished in order."""
    ray = connect(address)
    sigma, g, albedo = (np.ascontiguousarray(np.broadcast_to(a, n)) for a in (sigma, g, albedo))
    remote = ray.remote(_walk_part).options(num_cpus=1, max_retries=MAX_RETRIES,
                                            scheduling_strategy="SPREAD")  # as render's
    starts = list(range(0, n, chunk))
    refs = [remote.remote(sigma[s:s + chunk], g[s:s + chunk], albedo[s:s + chunk], seed,
                          first_index + s) for s in starts]
    index = {ref: k for k, ref in enumerate(refs)}
    finished: dict[int, dict] = {}
    parts: list[dict] = []
    pending = list(refs)
    interrupted = False
    try:
        while pending:
            ready, pending = ray.wait(pending, num_returns=len(pending), timeout=0.1)
            for ref in ready:
                finished[index[ref]] = ray.get(ref)
            while len(parts) in finished:
                parts.append(finished.pop(len(parts)))
            if progress is not None and ready:
                progress(sum(len(p["N"]) for p in parts) / n)
    except KeyboardInterrupt:
        interrupted = True
    except ray.exceptions.RayTaskError as e:
        _cancel(ray, pending)
        raise _cause(e) from None
    _cancel(ray, pending)
    return parts, interrupted
