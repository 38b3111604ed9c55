"""Rendering: numpy out, the GIL released while the C++ renderer runs."""

from __future__ import annotations

import inspect
import numbers
import os
import sys
import warnings
from dataclasses import dataclass, fields
from typing import Any, Callable, Optional, Union

import numpy as np

from sssphere import _core
from sssphere._core import SceneError
from sssphere.model import DEFAULT_MODELS
from sssphere.scene import Scene, SceneWarning, load_scene

# The render options are defined once, in C++ (render/options.h); these name their choices.
RENDER_OPTIONS = _core.render_option_specs()  # name, kind, choices, metavar, help, command_line
_SPECS = {s["name"]: s for s in RENDER_OPTIONS}
INTEGRATORS = tuple(_SPECS["integrator"]["choices"])
SPHERE_SAMPLERS = tuple(_SPECS["sphere_sampler"]["choices"])
STEP_NEE = tuple(_SPECS["step_nee"]["choices"])
BACKENDS = tuple(_SPECS["backend"]["choices"])
DEFAULT_SPHERE_THRESHOLD = float(_core.DEFAULT_SPHERE_THRESHOLD)
# Every name RenderResult.layers() may give, in its order.
ONE_SAMPLE_VARIANCE = ("variance: one sample per pixel gives no estimate of the variance: its "
                       "layer is 0, which does not mean 'no noise' (render 2 or more samples "
                       "per pixel)")
AOV_LAYERS = ("noisy", "variance", "events", "sphere_steps", "albedo", "normal", "depth")
DEFAULT_AOV_SAMPLES = int(_core.DEFAULT_AOV_SAMPLES)


class Image(np.ndarray):
    """A rendered image: a (height, width, 3) float32 numpy array of linear radiance that
    shows itself in Jupyter (``_repr_png_``: sRGB, 8 bits, values clamped to [0, 1], as the
    .png output) and saves itself (``save("x.exr")``; .exr linear, .png sRGB). Everything
    else is numpy's."""

    def save(self, path: Union[str, os.PathLike]) -> None:
        """Write the image to ``path``: .exr linear float, .png sRGB (8 bits, clamped)."""
        write_image(path, self)

    def _repr_png_(self) -> bytes:
        return _png_bytes(self)


def _png_bytes(image: np.ndarray) -> bytes:
    import tempfile

    with tempfile.TemporaryDirectory(prefix="sssphere-") as tmp:
        path = os.path.join(tmp, "image.png")
        write_image(path, image)
        with open(path, "rb") as f:
            return f.read()


@dataclass
class RenderResult:
    """Everything a render produces.

    image : (height, width, 3) float32, mean linear radiance per pixel.
    variance : (height, width, 3) float32, estimated variance of that mean.
    events : (height, width) float32, mean ordinary scattering events per path (complexity
        picture; with ``integrator="st"`` the events not inside sphere steps).
    sphere_steps : (height, width) float32, mean sphere steps per path (0 for ``"pt"``).
    samples : (height, width) uint32, samples taken per pixel: ``spp`` everywhere.
    spp : samples per pixel reached: the options' spp, fewer if stopped early (every pixel
        has the same samples: a render stops between passes).
    seconds : wall-clock render time.
    step_seconds : time spent sampling sphere steps (decoders and frames, ``"st"``), summed
        over the threads; step_seconds / (mean_sphere_steps_per_path * paths) is one step.
    interrupted : True if Ctrl-C (or a progress callback returning False) stopped it early.
    time_limit_reached : True if ``time_limit`` stopped it before ``spp``.
    mean_events_per_path, mean_sphere_steps_per_path : the same two counts over the whole image.
    path_events, path_steps : with ``record_paths=True``, (spp, height, width) uint32: the
        ordinary events and sphere steps of every path, sample k of pixel (y, x) at [k, y, x]
        (0 where k >= samples[y, x]); else None.
    backend : ``"cpu"`` or ``"vulkan"``.
    gpu_seconds : ``backend="vulkan"``: the GPU time of the render's dispatches (timestamps);
        else None.
    device : the Vulkan device that rendered (``backend="vulkan"``), else None.
    albedo, normal : with ``aovs=True`` (or ``denoise=True``), (height, width, 3) float32
        first-hit AOVs: the albedo of what each pixel's camera rays meet first (a medium's
        multiple-scattering albedo, a surface's colour, 1 for a light, 0 for the
        background) and its unit normal turned to the camera (0: background); else None.
    depth : with ``aovs=True`` (or ``denoise=True``), (height, width) float32, the distance to that first hit
        along the ray (0: background); else None. The AOVs average the render's first
        min(spp, DEFAULT_AOV_SAMPLES) camera rays of each pixel (first_hit_aovs).
    cluster : with ``ray_address``, how the render ran on the cluster (a dict): ``tasks``
        submitted and ``tasks_merged`` (in sample order; fewer when stopped early), the
        sample ``ranges`` (first, count) merged, each cut into ``bands`` tasks of rows
        (1 unless the samples are too few for the cluster), ``slots`` (tasks the cluster
        runs at once), ``group`` (tasks added up on a worker before the driver gets them),
        ``builds`` (scene builds by worker processes: one per process, not per task),
        ``processes`` and ``nodes`` that ran the merged tasks, and per task
        ``task_seconds`` (its render) and ``build_seconds`` (getting its scene); else None.
    denoised : with ``denoise=True``, ``image`` denoised by Intel Open Image Denoise with
        the albedo and normal AOVs (an Image); else None. ``image`` stays the unbiased
        estimate that ``variance`` describes.
    warnings : what the render warned of (each also a SceneWarning), e.g. a medium
        ``"st"`` takes no sphere steps in because its models were not trained for it;
        () if nothing.
    options : the options the render used, resolved (defaults < the scene's render block <
        the arguments): integrator, spp, seed, threads, max_bounces, nee, sphere_threshold,
        models, cut_models, sphere_sampler, step_nee, record_paths, backend, time_limit.
    """

    image: np.ndarray
    variance: np.ndarray
    events: np.ndarray
    sphere_steps: np.ndarray
    samples: np.ndarray
    spp: int
    seconds: float
    step_seconds: float
    interrupted: bool
    time_limit_reached: bool
    mean_events_per_path: float
    mean_sphere_steps_per_path: float
    path_events: Optional[np.ndarray] = None
    path_steps: Optional[np.ndarray] = None
    backend: str = "cpu"
    options: Optional[dict] = None
    gpu_seconds: Optional[float] = None
    device: Optional[str] = None
    albedo: Optional[np.ndarray] = None
    normal: Optional[np.ndarray] = None
    depth: Optional[np.ndarray] = None
    denoised: Optional[np.ndarray] = None
    cluster: Optional[dict] = None
    warnings: tuple = ()

    @property
    def picture(self) -> np.ndarray:
        """What the result shows and saves: ``denoised`` if there is one, else ``image``."""
        return self.image if self.denoised is None else self.denoised

    def layers(self) -> list[tuple[str, tuple[str, ...], np.ndarray]]:  # names: AOV_LAYERS
        """The AOVs as (name, channel names, (height, width, channels) array), in the
        order ``save(..., aovs=True)`` writes them: ``noisy`` (the estimate, when the
        picture is denoised), ``variance``, ``events``, ``sphere_steps`` (if the render
        took sphere steps), ``albedo``, ``normal``, ``depth`` (those computed)."""
        rgb, xyz = ("R", "G", "B"), ("X", "Y", "Z")
        out = []
        if self.denoised is not None:
            out.append(("noisy", rgb, self.image))
        out += [("variance", rgb, self.variance), ("events", ("Y",), self.events[:, :, None])]
        if self.mean_sphere_steps_per_path > 0:
            out.append(("sphere_steps", ("Y",), self.sphere_steps[:, :, None]))
        for name, channels, data in (("albedo", rgb, self.albedo),
                                     ("normal", xyz, self.normal),
                                     ("depth", ("Z",), self.depth)):
            if data is not None:
                out.append((name, channels, data if data.ndim == 3 else data[:, :, None]))
        return out

    def save(self, path: Union[str, os.PathLike], aovs: bool = False) -> list[str]:
        """Write the picture (``denoised`` if there is one, else ``image``) to ``path``
        (.exr linear, .png sRGB). With ``aovs``, also the layers(): into the same file for
        an .exr (one multilayer EXR: the picture as R, G, B, each AOV as NAME.CHANNEL,
        e.g. ``albedo.R``, ``depth.Z``; read them with read_layers), as ``STEM_NAME.exr``
        files beside a .png. As ``sssphere render --aovs``. Returns the paths written."""
        path = str(path)
        if not aovs:
            write_image(path, self.picture)
            return [path]
        if self.spp < 2:  # the same words as sssphere-render's
            warnings.warn(ONE_SAMPLE_VARIANCE, SceneWarning,
                          stacklevel=_caller_outside_sssphere())
        if path.lower().endswith(".exr"):
            write_layers(path, [("", ("R", "G", "B"), self.picture)] + self.layers())
            return [path]
        write_image(path, self.picture)
        written = [path]
        stem = os.path.splitext(path)[0]
        for name, channels, data in self.layers():  # channels named as in the .exr's layers
            write_layers(f"{stem}_{name}.exr", [("", channels, data)])
            written.append(f"{stem}_{name}.exr")
        return written

    def __repr__(self) -> str:
        """The fields, with each array as its dtype and shape (printing a 512x512 image's
        numbers helps nobody) and ``cluster`` as its number of tasks."""
        def brief(name: str, value: Any) -> str:
            if isinstance(value, np.ndarray):
                return f"{name}=<{value.dtype} array {value.shape}>"
            if name == "cluster" and value is not None:
                return f"{name}=<{value.get('tasks_merged', '?')} tasks merged>"
            return f"{name}={value!r}"
        body = ", ".join(brief(f.name, getattr(self, f.name)) for f in fields(self))
        return f"RenderResult({body})"

    def _repr_png_(self) -> bytes:
        """Jupyter shows a result as its picture (sRGB, clamped)."""
        return _png_bytes(self.picture)


def _render(scene: Scene, progress, options: dict, text: Optional[dict] = None,
            ray_address: Optional[str] = None) -> dict:
    """The C++ render on the options given (None: not given), resolved once in C++
    (render/options.h: defaults < the scene's render block < command-line text < these);
    with ``ray_address``, the same render split into tasks on that Ray cluster
    (sssphere.cluster)."""
    if progress is not None and not callable(progress):
        raise TypeError(f"progress must be a function of the fraction done (or None), got "
                        f"{progress!r}")
    models, given = os.fspath(DEFAULT_MODELS), {k: v for k, v in options.items() if v is not None}
    said = []  # media "st" takes no steps in, said before the render (which may be long)
    if _core.resolve_render_options(scene, models, text or {}, **given)["integrator"] == "st":
        said = _core.check_sphere_steps(scene, models, text or {}, **given)["warnings"]
    for message in said:
        warnings.warn(message, SceneWarning, stacklevel=_caller_outside_sssphere())
    with scene._rendered():
        if ray_address is not None:
            from sssphere import cluster

            r = cluster.render(scene, ray_address, progress, options, text, models)
        else:
            r = _core.render(scene, models, progress, text or {}, **given)
    for message in r.get("warnings", ()):  # the cut models' checks, say
        if message not in said:
            warnings.warn(message, SceneWarning, stacklevel=_caller_outside_sssphere())
    return r


def _caller_outside_sssphere() -> int:
    """The stacklevel, for a warning raised by the caller of this function, of the first
    frame outside the sssphere package (the user's call)."""
    frame, level = sys._getframe(1), 1
    while frame is not None and (frame.f_globals.get("__name__", "") == "sssphere" or
                                 frame.f_globals.get("__name__", "").startswith("sssphere.")):
        frame, level = frame.f_back, level + 1
    return level


def render_full(
    scene: Union[Scene, str, os.PathLike, dict],
    integrator: Optional[str] = None,
    spp: Optional[int] = None,
    seed: Optional[int] = None,
    threads: Optional[int] = None,
    max_bounces: Optional[int] = None,
    progress: Optional[Callable[[float], Optional[bool]]] = None,
    nee: Optional[bool] = None,
    sphere_threshold: Optional[float] = None,
    models: Union[str, os.PathLike, None] = None,
    cut_models: Union[str, os.PathLike, None] = None,
    sphere_sampler: Optional[str] = None,
    step_nee: Optional[str] = None,
    record_paths: Optional[bool] = None,
    backend: Optional[str] = None,
    time_limit: Optional[float] = None,
    aovs: bool = False,
    denoise: bool = False,
    ray_address: Optional[str] = None,
) -> RenderResult:
    """Render and return the image with its variance and complexity (see RenderResult).

    Options left as None come from the scene's ``render`` block, else their defaults (one
    table for the API and both command lines: docs/options.md). ``progress(fraction)``
    is called about ten times a second; returning False stops early. Ctrl-C also stops
    early: the result then has ``interrupted=True`` and holds what was rendered.
    ``nee=False`` turns off light sampling (emitters count only when paths hit them).

    Sphere tracing (``integrator="st"``, docs/sphere-tracing.md) also reads
    ``sphere_threshold`` (τ >= 0: a collision takes a sphere step where σt·r >= τ;
    ``math.inf`` gives the image of ``"pt"``; default: the scene's, else
    DEFAULT_SPHERE_THRESHOLD) and ``models`` (the directory of lengthgen.json, pathgen.json,
    eventgen.json; default: the scene's ``render.models``, else the repository's ``models/``).
    ``sphere_sampler="walk"`` replaces the networks by exact sphere walks (as slow as path
    tracing; it validates the integrator without model error). ``step_nee`` says how the
    events inside a sphere step get their direct light when ``nee`` is on: ``"hits"`` (the
    default) from the step's exit flight when it reaches an area light or the environment,
    while under point and directional lights, which no flight reaches, the steps keep 10 mean
    free paths from the boundary and the point lights; ``"event"`` (the paper's) from
    EventGen's representative event connecting to every kind of light (docs/sphere-tracing.md,
    "NEE for a sphere step"). ``cut_models`` (experimental): the
    directory of cutlengthgen.json and cutpathgen.json (the repository's ``models/cut``);
    collisions too close to the boundary for a sphere step
    then take cut sphere steps where a plane certifies the region, in media whose scattering
    events get no light sampling (docs/sphere-tracing.md, "Cut sphere steps").

    ``time_limit=S`` stops the render after S seconds of rendering (the scene's
    ``render.time_limit``, else none) with the passes every pixel has finished, at least one
    sample per pixel: ``spp`` is then the most it takes, and unlimited unless given.
    The result's ``spp`` and ``time_limit_reached`` say where it stopped.

    ``aovs=True`` adds the first-hit ``albedo``, ``normal`` and ``depth`` to the result
    (first_hit_aovs; they do not depend on the integrator or backend). ``denoise=True``
    adds ``denoised``: the image denoised by Intel Open Image Denoise with the albedo and
    normal AOVs (the optional extra ``pip install 'sssphere[denoise]'``; see denoise()).

    ``ray_address`` renders on a Ray cluster (``"auto"``, ``"HOST:PORT"``, ... as
    ``ray.init`` takes it; docs/cluster.md): the samples are split into tasks by sample
    ranges, run on any node (the scene and its files travel through Ray's object store)
    and merged in sample order, giving this render's image up to the order of float64
    sums (the counts exactly). ``threads`` is then each task's threads and the CPUs it
    asks Ray for (default 1). Needs ``pip install 'sssphere[cluster]'``.

    ``record_paths=True`` also returns every path's event and step counts (``path_events``,
    ``path_steps``; 8 bytes per path, at most 2**27 paths): the distribution of path
    lengths, not only their means.

    ``backend="vulkan"`` renders on a Vulkan device (a GPU, or Mesa's lavapipe on the CPU;
    docs/gpu.md): ``"pt"`` and ``"st"`` with the CPU's estimators (light sampling with
    ``nee=True``, ``step_nee="hits"`` for ``"st"``, and ``cut_models``).
    ``step_nee="event"``, ``sphere_sampler="walk"`` and ``threads`` are CPU-only.
    """
    options = dict(integrator=integrator, spp=spp, seed=seed, threads=threads,
                   max_bounces=max_bounces, nee=nee, sphere_threshold=sphere_threshold,
                   models=models, sphere_sampler=sphere_sampler, step_nee=step_nee,
                   record_paths=record_paths, backend=backend, time_limit=time_limit,
                   cut_models=None if cut_models is None else os.fspath(cut_models))
    if not isinstance(scene, Scene):
        _core.check_option_values(**options)  # a bad value costs no scene build
        scene = load_scene(scene)
    if denoise:
        _denoiser()  # before the render: a missing extra should not cost one
    return with_aovs(scene, _result(_render(scene, progress, options, ray_address=ray_address)),
                     aovs, denoise)


def with_aovs(scene: Scene, result: RenderResult, aovs: bool, denoise: bool) -> RenderResult:
    """``result`` with its first-hit AOVs (``aovs`` or ``denoise``) and its denoised image
    (``denoise``)."""
    if not (aovs or denoise):
        return result
    a = first_hit_aovs(scene, seed=int(result.options["seed"]),
                       samples=max(1, min(result.spp, DEFAULT_AOV_SAMPLES)),
                       threads=int(result.options["threads"]))
    result.albedo, result.normal, result.depth = a["albedo"], a["normal"], a["depth"]
    if denoise:
        result.denoised = _denoise(result.image, result.albedo, result.normal)
    return result


def orbit_cameras(scene: Scene, frames: int) -> list[dict]:
    """``frames`` cameras on a full circle about the scene camera's target: its origin
    turned by 360/frames degrees per frame about the axis through the target along the
    camera's ``up`` (frame 0 is the scene's camera). Each is a camera block as in the
    scene file; render them with render_frames."""
    if isinstance(frames, bool) or not isinstance(frames, numbers.Integral) or frames < 1:
        raise ValueError(f"frames must be an integer >= 1, got {frames!r}")
    frames = int(frames)
    camera = scene.camera.to_python()
    origin = np.asarray(camera["origin"], np.float64)
    target = np.asarray(camera["target"], np.float64)
    up = np.asarray(camera.get("up", [0.0, 1.0, 0.0]), np.float64)
    axis = up / np.linalg.norm(up)
    v = origin - target
    cameras = []
    for k in range(frames):
        a = 2.0 * np.pi * k / frames
        # Rodrigues' rotation of v about the axis by a
        w = (v * np.cos(a) + np.cross(axis, v) * np.sin(a)
             + axis * np.dot(axis, v) * (1.0 - np.cos(a)))
        cameras.append({**camera, "origin": (target + w).tolist()})
    return cameras


def render_frames(scene: Union[Scene, str, os.PathLike, dict], cameras: list[dict],
                  progress: Optional[Callable[[float], Optional[bool]]] = None,
                  on_frame: Optional[Callable[[int, RenderResult], None]] = None,
                  aovs: bool = False, denoise: bool = False, ray_address: Optional[str] = None,
                  **options) -> list[RenderResult]:
    """Render the scene from each camera in turn: an animation without rebuilding
    anything (a camera change keeps the BVH and distance grids; see Scene). A camera is a
    dict of camera fields (docs/scene-format.md) that replace the scene camera's, e.g.
    ``{"origin": [0, 1, 4]}``; orbit_cameras makes a turntable. ``options`` are
    render_full's, and so is ``ray_address``; ``progress(fraction)`` sees the whole animation (returning False
    stops it); ``on_frame(k, result)`` is called as each frame finishes (to save it, say).
    Ctrl-C stops the animation: the results so far are returned, the last one
    ``interrupted``. The scene's camera is restored afterwards. Renders of the scene from
    other threads wait until it returns (they would see its cameras), and it starts once
    those running have returned."""
    return _render_frames(scene, cameras, progress, on_frame, aovs, denoise, None, ray_address,
                          options)


def _render_frames(scene, cameras, progress, on_frame, aovs: bool, denoise: bool,
                   text: Optional[dict], ray_address: Optional[str],
                   options: dict, keep: bool = True) -> list[RenderResult]:
    """render_frames, with the command line's option text (render/options.h) besides.
    keep=False returns the last frame's result only (the others were on_frame's to save),
    and lets each go before the next renders: a long turntable's memory is one frame's."""
    unknown = set(options) - set(_SPECS)
    if unknown:
        raise TypeError(f"render_frames: unknown options {sorted(unknown)} (allowed: "
                        f"{', '.join(_SPECS)})")
    if not isinstance(scene, Scene):
        _core.check_option_values(text or {}, **options)  # a bad value costs no scene build
        scene = load_scene(scene)
    cameras = list(cameras)
    for k, camera in enumerate(cameras):
        if not isinstance(camera, dict):
            raise ValueError(f"cameras[{k}] must be a dict of camera fields, got {camera!r}")
    if denoise:
        _denoiser()
    with scene._posed():  # other threads' renders of the scene wait: they would see our cameras
        return _render_posed(scene, cameras, progress, on_frame, aovs, denoise, text,
                             ray_address, options, keep)


def _render_posed(scene, cameras, progress, on_frame, aovs, denoise, text, ray_address,
                  options, keep) -> list[RenderResult]:
    """_render_frames' frames, the scene held (Scene._posed)."""
    original = scene.camera.to_python()
    results: list[RenderResult] = []
    try:
        for k, camera in enumerate(cameras):
            if not keep:  # the frame before is saved: let it go before this one renders
                results.clear()
                result = None
            scene.camera = {**original, **camera}

            def frame_progress(fraction: float, k: int = k):
                return None if progress is None else progress((k + fraction) / len(cameras))

            result = _result(_render(scene, frame_progress, options, text, ray_address))
            if not (result.interrupted and result.spp == 0):  # nothing to add AOVs to
                result = with_aovs(scene, result, aovs, denoise)
            results.append(result)
            if on_frame is not None:
                on_frame(k, result)
            if result.interrupted:
                break
    finally:
        scene.camera = original
    return results


def first_hit_aovs(scene: Union[Scene, str, os.PathLike, dict], seed: int = 0,
                   samples: int = DEFAULT_AOV_SAMPLES, threads: Optional[int] = 0) -> dict:
    """The first-hit AOVs of the scene's camera: ``albedo`` (H, W, 3), ``normal`` (H, W, 3)
    and ``depth`` (H, W), each the mean over the first ``samples`` camera rays of a pixel
    (the render's own rays under ``seed``). What a ray meets first gives: a medium, its
    multiple-scattering albedo (the colour a thick slab of it reflects, whatever its
    boundary); a surface, its colour; an area light, 1; nothing, 0 (normal and depth 0
    too). Normals are unit triangle normals turned to face the camera; depth is the
    distance along the ray. ``shape`` (H, W) int32 is the index of the shape that a
    pixel's first ray hits (-1: a light or nothing), an object-ID mask. They depend on the
    scene, camera and seed alone."""
    if not isinstance(scene, Scene):
        scene = load_scene(scene)
    with scene._rendered():
        return _core.first_hit_aovs(scene, seed=seed, samples=samples,
                                    threads=0 if threads is None else threads)


def _denoiser():
    try:
        import pyoidn
    except ImportError:
        raise ImportError("denoising needs Intel Open Image Denoise, an optional extra: "
                          "pip install 'sssphere[denoise]' (the PyPI package pyoidn)") from None
    return pyoidn


def _denoise(image: np.ndarray, albedo: Optional[np.ndarray],
             normal: Optional[np.ndarray]) -> "Image":
    c = np.ascontiguousarray(image, dtype=np.float32)
    aux = {}
    if albedo is not None and normal is not None:
        aux = dict(albedo=np.ascontiguousarray(albedo, dtype=np.float32),
                   normal=np.ascontiguousarray(normal, dtype=np.float32), clean_aux=True)
    return np.asarray(_denoiser().denoise(c, hdr=True, **aux), dtype=np.float32).view(Image)


def denoise(image: np.ndarray, albedo: Optional[np.ndarray] = None,
            normal: Optional[np.ndarray] = None) -> "Image":
    """Denoise a (height, width, 3) linear radiance image with Intel Open Image Denoise
    (its "RT" filter, HDR), guided by the first-hit albedo and normal AOVs when given
    (both or neither; render_full(aovs=True) or first_hit_aovs give them; they are noise
    free). Needs the optional extra ``pip install 'sssphere[denoise]'``."""
    if (albedo is None) != (normal is None):
        raise ValueError("denoise takes albedo and normal together (or neither)")
    if np.ndim(image) != 3 or np.shape(image)[2] != 3 or 0 in np.shape(image):
        raise ValueError(f"denoise: image must have shape (height, width, 3), height and width "
                         f">= 1, got {np.shape(image)}")
    for name, a in (("albedo", albedo), ("normal", normal)):
        if a is not None and np.shape(a) != np.shape(image):
            raise ValueError(f"denoise: {name} must have the image's shape {np.shape(image)}, "
                             f"got {np.shape(a)}")
    if not np.all(np.isfinite(image)):
        raise ValueError("denoise: the image has non-finite pixels")
    return _denoise(image, albedo, normal)


def _result(r: dict) -> RenderResult:
    paths = max(1, int(r["total_paths"]))
    return RenderResult(
        image=r["image"].view(Image),
        variance=r["variance"],
        events=r["events"],
        sphere_steps=r["sphere_steps"],
        samples=r["samples"],
        spp=int(r["spp"]),
        seconds=float(r["seconds"]),
        step_seconds=float(r["step_seconds"]),
        interrupted=bool(r["cancelled"]),
        time_limit_reached=bool(r["time_limit_reached"]),
        mean_events_per_path=float(r["total_events"]) / paths,
        mean_sphere_steps_per_path=float(r["total_sphere_steps"]) / paths,
        path_events=r.get("path_events"),
        path_steps=r.get("path_steps"),
        backend=r["options"]["backend"],
        options=r["options"],
        gpu_seconds=r.get("gpu_seconds"),
        device=r.get("device"),
        cluster=r.get("cluster"),
        warnings=tuple(r.get("warnings", ())),
    )


# render_full's keywords that render does not take, each with the call to make instead: what
# they give (progress reports and an early stop, AOVs, every path's counts) is in
# render_full's result alone. render takes every other one, the render options included.
_RENDER_FULL_ONLY = {
    "progress": "render_full(scene, progress=...) reports progress and keeps a render stopped early",
    "aovs": "render_full(scene, aovs=True) returns the image with its AOVs",
    "record_paths": "render_full(scene, record_paths=True) returns the image with every path's counts",
}


def render(scene: Union[Scene, str, os.PathLike, dict], *args, **kwargs) -> Image:
    """Render a scene to a (height, width, 3) float32 array of linear radiance (an Image:
    a numpy array that shows itself in Jupyter and has ``save(path)``).

    Takes render_full's arguments, described there (every render option of
    docs/options.md, ``denoise``, ``ray_address``), but ``progress``, ``aovs`` and
    ``record_paths``: what they give only render_full's result holds (a render stopped
    early, the AOVs, every path's counts). After ``threads``, keywords only.
    ``integrator="st"`` renders with sphere tracing; ``denoise=True`` returns the image
    denoised with its albedo and normal AOVs. Ctrl-C raises KeyboardInterrupt (use
    render_full to keep a partial image).
    """
    full_only = sorted(_RENDER_FULL_ONLY.keys() & kwargs.keys())
    if full_only:
        raise TypeError(f"render() takes no {full_only[0]!r}: {_RENDER_FULL_ONLY[full_only[0]]}")
    try:
        bound = render.__signature__.bind(scene, *args, **kwargs)
    except TypeError as e:
        allowed = ", ".join(list(render.__signature__.parameters)[1:])
        raise TypeError(f"render(): {e} (allowed after the scene: {allowed})") from None
    result = render_full(**bound.arguments)
    if result.interrupted:
        raise KeyboardInterrupt
    return result.picture


def _render_signature() -> inspect.Signature:
    """render_full's signature less _RENDER_FULL_ONLY, keyword-only after ``threads``: the
    positions render always had (render_full's next ones differ)."""
    full = inspect.signature(render_full)
    last_positional = list(full.parameters).index("threads")
    parameters = [p if i <= last_positional else p.replace(kind=p.KEYWORD_ONLY)
                  for i, p in enumerate(full.parameters.values())
                  if p.name not in _RENDER_FULL_ONLY]
    return full.replace(parameters=parameters, return_annotation="Image")


render.__signature__ = _render_signature()


def read_image(path: Union[str, os.PathLike]) -> np.ndarray:
    """Read an image as (height, width, channels) float32 (8-bit files: stored value / 255)."""
    from sssphere import _image  # OpenImageIO is loaded on first use, not by `import sssphere`

    return _image.read_image(str(path))


def write_layers(path: Union[str, os.PathLike],
                 layers: list[tuple[str, tuple[str, ...], np.ndarray]]) -> None:
    """Write one multilayer .exr: ``layers`` are (name, channel names, (height, width,
    channels) array); a channel is stored as NAME.CHANNEL (CHANNEL alone for the name
    "", the layer viewers show)."""
    from sssphere import _image

    _image.write_exr_layers(str(path), [(name, list(channels), np.asarray(data, np.float32))
                                        for name, channels, data in layers])


def read_layers(path: Union[str, os.PathLike]) -> dict[str, np.ndarray]:
    """The layers of an .exr file as {name: (height, width, channels) float32} ("" for the
    channels without a layer name, e.g. R, G, B). OpenEXR keeps channels sorted by name,
    so a layer's channels come back in the order R, G, B, A, X, Y, Z, then the others by
    name."""
    from sssphere import _image

    names, data = _image.read_exr_layers(str(path))
    rank = {c: i for i, c in enumerate("RGBAXYZ")}
    groups: dict[str, list[tuple]] = {}
    for i, name in enumerate(names):
        layer, _, channel = name.rpartition(".")
        groups.setdefault(layer, []).append((rank.get(channel, len(rank)), channel, i))
    return {layer: np.ascontiguousarray(data[:, :, [i for *_, i in sorted(channels)]])
            for layer, channels in groups.items()}


def write_image(path: Union[str, os.PathLike], image: np.ndarray) -> None:
    """Write (height, width, 3) linear radiance: .exr as float, .png as 8-bit sRGB."""
    dtype = np.asarray(image).dtype
    if dtype.kind != "f":  # 8-bit pixels (0-255) would be taken as radiance 0-255
        raise SceneError(f"{path}: image of dtype {dtype} is not allowed (allowed: floating "
                         "point, linear radiance; 8-bit sRGB values must be decoded first)")
    image = np.asarray(image, dtype=np.float32)
    if image.ndim == 2:
        image = image[:, :, None]
    if str(path).lower().endswith(".png") and not np.isfinite(image).all():
        bad = np.argwhere(~np.isfinite(image))[0]  # a PNG would show them black
        raise SceneError(f"{path}: image holds {int((~np.isfinite(image)).sum())} non-finite "
                         f"value(s) (first {image[tuple(bad)]} at pixel ({bad[1]}, {bad[0]})), "
                         "which a PNG cannot show (write an .exr)")
    from sssphere import _image

    _image.write_image(str(path), image)
