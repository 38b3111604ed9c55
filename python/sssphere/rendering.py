"""Rendering: numpy out, the GIL released while the C++ renderer runs."""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import Callable, Optional, Union

import numpy as np

from sssphere import _core
from sssphere.model import DEFAULT_MODELS
from sssphere.scene import Scene, load_scene

# The render options are defined once, in C++ (render/options.h); these name their choices.
RENDER_OPTIONS = _core.render_option_specs()  # name, kind, choices, metavar, help, command_line
_SPECS = {s["name"]: s for s in RENDER_OPTIONS}
INTEGRATORS = tuple(_SPECS["integrator"]["choices"])
SPHERE_SAMPLERS = tuple(_SPECS["sphere_sampler"]["choices"])
STEP_NEE = tuple(_SPECS["step_nee"]["choices"])
BACKENDS = tuple(_SPECS["backend"]["choices"])
DEFAULT_SPHERE_THRESHOLD = float(_core.DEFAULT_SPHERE_THRESHOLD)


class Image(np.ndarray):
    """A rendered image: a (height, width, 3) float32 numpy array of linear radiance that
    shows itself in Jupyter (``_repr_png_``: sRGB, 8 bits, values clamped to [0, 1], as the
    .png output) and saves itself (``save("x.exr")``; .exr linear, .png sRGB). Everything
    else is numpy's."""

    def save(self, path: Union[str, os.PathLike]) -> None:
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
    options : the options the render used, resolved (defaults < the scene's render block <
        the arguments): integrator, spp, seed, threads, max_bounces, nee, sphere_threshold,
        models, sphere_sampler, step_nee, record_paths, backend, time_limit.
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

    def save(self, path: Union[str, os.PathLike], aovs: bool = False) -> list[str]:
        """Write the image to ``path`` (.exr linear, .png sRGB); with ``aovs``, also
        ``STEM_variance.exr``, ``STEM_events.exr`` and, if the render took sphere steps,
        ``STEM_sphere_steps.exr`` (as ``sssphere render --aovs``). Returns the paths
        written."""
        write_image(path, self.image)
        written = [str(path)]
        if aovs:
            stem = os.path.splitext(str(path))[0]
            layers = [("variance", self.variance), ("events", self.events[:, :, None])]
            if self.mean_sphere_steps_per_path > 0:
                layers.append(("sphere_steps", self.sphere_steps[:, :, None]))
            for name, data in layers:
                write_image(f"{stem}_{name}.exr", data)
                written.append(f"{stem}_{name}.exr")
        return written

    def _repr_png_(self) -> bytes:
        """Jupyter shows a result as its image (sRGB, clamped)."""
        return _png_bytes(self.image)


def _render(scene: Scene, progress, options: dict, text: Optional[dict] = None) -> dict:
    """The C++ render on the options given (None: not given), resolved once in C++
    (render/options.h: defaults < the scene's render block < command-line text < these)."""
    given = {k: v for k, v in options.items() if v is not None}
    return _core.render(scene, os.fspath(DEFAULT_MODELS), progress, text or {}, **given)


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
    sphere_sampler: Optional[str] = None,
    step_nee: Optional[str] = None,
    record_paths: Optional[bool] = None,
    backend: Optional[str] = None,
    time_limit: Optional[float] = None,
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
    with EventGen's representative event connecting only to point and directional lights;
    ``"event"`` (the paper's) from EventGen's event connecting to every kind of light
    (docs/sphere-tracing.md, "NEE for a sphere step").

    ``time_limit=S`` stops the render after S seconds of rendering (the scene's
    ``render.time_limit``, else none) with the passes every pixel has finished, at least one
    sample per pixel: ``spp`` is then the most it takes, and unlimited unless given.
    The result's ``spp`` and ``time_limit_reached`` say where it stopped.

    ``record_paths=True`` also returns every path's event and step counts (``path_events``,
    ``path_steps``; 8 bytes per path, at most 2**27 paths): the distribution of path
    lengths, not only their means.

    ``backend="vulkan"`` renders on a Vulkan device (a GPU, or Mesa's lavapipe on the CPU;
    docs/gpu.md): ``"pt"`` and ``"st"`` with the CPU's estimators (light sampling with
    ``nee=True``, ``step_nee="hits"`` for ``"st"``, EventGen included).
    ``step_nee="event"``, ``sphere_sampler="walk"`` and ``threads`` are CPU-only.
    """
    if not isinstance(scene, Scene):
        scene = load_scene(scene)
    options = dict(integrator=integrator, spp=spp, seed=seed, threads=threads,
                   max_bounces=max_bounces, nee=nee, sphere_threshold=sphere_threshold,
                   models=models, sphere_sampler=sphere_sampler, step_nee=step_nee,
                   record_paths=record_paths, backend=backend, time_limit=time_limit)
    return _result(_render(scene, progress, options))


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
    )


def render(
    scene: Union[Scene, str, os.PathLike, dict],
    integrator: Optional[str] = None,
    spp: Optional[int] = None,
    seed: Optional[int] = None,
    threads: Optional[int] = None,
    nee: Optional[bool] = None,
    sphere_threshold: Optional[float] = None,
    models: Union[str, os.PathLike, None] = None,
    step_nee: Optional[str] = None,
    backend: Optional[str] = None,
    time_limit: Optional[float] = None,
) -> Image:
    """Render a scene to a (height, width, 3) float32 array of linear radiance (an Image:
    a numpy array that shows itself in Jupyter and has ``save(path)``).

    ``integrator="st"`` renders with sphere tracing; ``sphere_threshold``, ``models`` and
    ``step_nee`` are described in render_full, and so is ``backend`` (``"vulkan"``: the GPU
    path) and ``time_limit`` (seconds). Ctrl-C raises KeyboardInterrupt (use render_full to keep a
    partial image).
    """
    result = render_full(scene, integrator=integrator, spp=spp, seed=seed, threads=threads, nee=nee,
                         sphere_threshold=sphere_threshold, models=models, step_nee=step_nee,
                         backend=backend, time_limit=time_limit)
    if result.interrupted:
        raise KeyboardInterrupt
    return result.image


def read_image(path: Union[str, os.PathLike]) -> np.ndarray:
    """Read an image as (height, width, channels) float32 (8-bit files: stored value / 255)."""
    from sssphere import _image  # OpenImageIO is loaded on first use, not by `import sssphere`

    return _image.read_image(str(path))


def write_image(path: Union[str, os.PathLike], image: np.ndarray) -> None:
    """Write (height, width, 3) linear radiance: .exr as float, .png as 8-bit sRGB."""
    image = np.asarray(image, dtype=np.float32)
    if image.ndim == 2:
        image = image[:, :, None]
    from sssphere import _image

    _image.write_image(str(path), image)
