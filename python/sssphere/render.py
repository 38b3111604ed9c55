"""Rendering: numpy out, the GIL released while the C++ renderer runs."""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import Callable, Optional, Union

import numpy as np

from sssphere import _core
from sssphere._core import SceneError
from sssphere.scene import Scene, load_scene

INTEGRATORS = ("pt",)


@dataclass
class RenderResult:
    """Everything a render produces.

    image : (height, width, 3) float32, mean linear radiance per pixel.
    variance : (height, width, 3) float32, estimated variance of that mean.
    events : (height, width) float32, mean scattering events per path (complexity picture).
    samples : (height, width) uint32, samples taken per pixel (fewer if interrupted).
    seconds : wall-clock render time.
    interrupted : True if Ctrl-C (or a progress callback returning False) stopped it early.
    """

    image: np.ndarray
    variance: np.ndarray
    events: np.ndarray
    samples: np.ndarray
    seconds: float
    interrupted: bool
    mean_events_per_path: float


def _resolve(scene, integrator, spp, seed, threads, max_bounces):
    if not isinstance(scene, Scene):
        scene = load_scene(scene)
    integrator = scene.integrator if integrator is None else integrator
    if integrator not in INTEGRATORS:
        raise SceneError(
            f"{scene.source}: integrator {integrator!r} is not available yet "
            f"(allowed: {', '.join(repr(i) for i in INTEGRATORS)}; 'st' comes with the sphere tracer)"
        )
    spp = scene.spp if spp is None else spp
    if isinstance(spp, bool) or not isinstance(spp, (int, np.integer)) or spp < 1:
        raise SceneError(f"spp must be an integer >= 1, got {spp!r}")
    seed = scene.seed if seed is None else seed
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise SceneError(f"seed must be an integer >= 0, got {seed!r}")
    threads = 0 if threads is None else threads
    if isinstance(threads, bool) or not isinstance(threads, (int, np.integer)) or threads < 0:
        raise SceneError(f"threads must be an integer >= 0 (0 = all cores), got {threads!r}")
    max_bounces = scene.max_bounces if max_bounces is None else max_bounces
    return scene, integrator, int(spp), int(seed), int(threads), int(max_bounces)


def render_full(
    scene: Union[Scene, str, os.PathLike, dict],
    integrator: Optional[str] = None,
    spp: Optional[int] = None,
    seed: Optional[int] = None,
    threads: Optional[int] = None,
    max_bounces: Optional[int] = None,
    progress: Optional[Callable[[float], Optional[bool]]] = None,
    nee: bool = True,
) -> RenderResult:
    """Render and return the image with its variance and complexity (see RenderResult).

    Settings left as None come from the scene's ``render`` block. ``progress(fraction)``
    is called about ten times a second; returning False stops early. Ctrl-C also stops
    early: the result then has ``interrupted=True`` and holds what was rendered.
    ``nee=False`` turns off light sampling (emitters count only when paths hit them).
    """
    scene, integrator, spp, seed, threads, max_bounces = _resolve(
        scene, integrator, spp, seed, threads, max_bounces)
    r = _core.render(scene, integrator, spp, seed, threads, max_bounces, bool(nee), progress)
    paths = max(1, int(r["total_paths"]))
    return RenderResult(
        image=r["image"],
        variance=r["variance"],
        events=r["events"],
        samples=r["samples"],
        seconds=float(r["seconds"]),
        interrupted=bool(r["cancelled"]),
        mean_events_per_path=float(r["total_events"]) / paths,
    )


def render(
    scene: Union[Scene, str, os.PathLike, dict],
    integrator: Optional[str] = None,
    spp: Optional[int] = None,
    seed: Optional[int] = None,
    threads: Optional[int] = None,
    nee: bool = True,
) -> np.ndarray:
    """Render a scene to a (height, width, 3) float32 array of linear radiance.

    Ctrl-C raises KeyboardInterrupt (use render_full to keep a partial image).
    """
    result = render_full(scene, integrator=integrator, spp=spp, seed=seed, threads=threads, nee=nee)
    if result.interrupted:
        raise KeyboardInterrupt
    return result.image


def read_image(path: Union[str, os.PathLike]) -> np.ndarray:
    """Read an image as (height, width, channels) float32 (8-bit files: stored value / 255)."""
    return _core.read_image(str(path))


def write_image(path: Union[str, os.PathLike], image: np.ndarray) -> None:
    """Write (height, width, 3) linear radiance: .exr as float, .png as 8-bit sRGB."""
    image = np.asarray(image, dtype=np.float32)
    if image.ndim == 2:
        image = image[:, :, None]
    _core.write_image(str(path), image)
