"""Scene loading: one parser (the C++ one) for files, dicts and the command line."""

from __future__ import annotations

import json
import math
import os
import warnings
from pathlib import Path
from typing import Any, Union

import numpy as np

from sssphere import _core
from sssphere._core import SceneError

Scene = _core.Scene


class SceneWarning(UserWarning):
    """A scene past the limits of docs/robustness.md: it renders, but float precision may
    make it differ from the exact answer by more than 1 %."""


def _warned(scene: Scene) -> Scene:
    for message in scene.warnings:
        warnings.warn(message, SceneWarning, stacklevel=3)
    return scene


def _find_non_finite(value: Any, path: str) -> str | None:
    """Path of the first NaN or infinite number in a nested dict/list, or None."""
    if isinstance(value, float) and not math.isfinite(value):
        return path
    if isinstance(value, dict):
        for k, v in value.items():
            found = _find_non_finite(v, f"{path}.{k}" if path else str(k))
            if found:
                return found
    if isinstance(value, (list, tuple)):
        for i, v in enumerate(value):
            found = _find_non_finite(v, f"{path}[{i}]")
            if found:
                return found
    return None


def load_scene(
    scene: Union[str, os.PathLike, dict], base_dir: Union[str, os.PathLike, None] = None,
    threads: int | None = None,
) -> Scene:
    """Load and validate a scene, build its acceleration structures.

    Parameters
    ----------
    scene : path to a JSON scene file, or a dict with the same structure
        (docs/scene-format.md).
    base_dir : directory that relative mesh paths in a dict are resolved against
        (default: the current directory). Ignored for files (their own directory is used).
    threads : worker threads for building distance grids (default: all cores).

    Raises
    ------
    SceneError (a ValueError) naming the file, the field, the value and what is allowed.

    Warns
    -----
    SceneWarning where the scene goes past the precision limits of docs/robustness.md
    (also in ``Scene.warnings``).
    """
    threads = 0 if threads is None else int(threads)
    if isinstance(scene, dict):
        try:
            bad = _find_non_finite(scene, "")
            text = json.dumps(scene)
        except RecursionError:
            raise SceneError("<dict>: nested too deeply (the scene format nests at most a few "
                             "levels)") from None
        if bad:
            raise SceneError(f"<dict>: {bad}: value is not a finite number")
        base = str(base_dir) if base_dir is not None else os.getcwd()
        return _warned(_core.Scene(text, base, "<dict>", threads))
    path = Path(scene)
    if not path.exists():
        raise SceneError(f"{path}: scene file does not exist")
    if path.is_dir():
        raise SceneError(f"{path}: is a directory, not a scene file")
    if not path.is_file():  # a FIFO, device or socket would block the read
        raise SceneError(f"{path}: is not a regular file (a FIFO, device or socket?); a scene file "
                         "must be a regular file")
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as e:
        raise SceneError(f"{path}: scene file cannot be read: {e}") from None
    return _warned(_core.Scene(text, str(path.parent), str(path), threads))


def load_mesh(path: Union[str, os.PathLike]) -> tuple[np.ndarray, np.ndarray]:
    """Load, check and orient a closed mesh. Returns (vertices (n, 3) float32,
    triangles (m, 3) uint32), counter-clockwise = outward."""
    return _core.load_mesh(str(path))


def presets() -> list[dict]:
    """The measured media a scene's ``"preset"`` names (docs/scene-format.md, "Ways to state a
    medium"): one dict per medium with ``name``, ``sigma_s_prime`` (reduced scattering) and
    ``sigma_a`` (absorption), RGB in mm^-1, ``ior`` (the source's index of refraction, or
    None) and ``source``. A preset medium gets sigma_s = sigma_s_prime / (1 - g) for its own
    ``g``, times its ``scale`` (scene units per mm)."""
    return [dict(p) for p in _core.medium_presets()]


def load_scene_with(path: Union[str, os.PathLike], assignments: list[str] | None = None,
                    width: int | None = None, height: int | None = None,
                    threads: int | None = None) -> Scene:
    """A scene file with the command line's changes: ``--set PATH=VALUE`` assignments (PATH
    as the parser's messages name fields, e.g. ``shapes[0].medium.sigma_t``; VALUE is JSON,
    else a string), then the image size (one of width and height alone keeps the camera's
    aspect ratio). The same code as `sssphere-render`'s (render/scene.h, edit_scene_json);
    errors name the file, as for the file itself."""
    if not assignments and width is None and height is None:
        return load_scene(path, threads=threads)
    path = Path(path)
    if not path.is_file():
        return load_scene(path, threads=threads)  # says what is wrong with the path
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError):
        return load_scene(path, threads=threads)
    text = _core.edit_scene_json(text, str(path), list(assignments or []), width or 0,
                                 height or 0)
    threads = 0 if threads is None else int(threads)
    return _warned(_core.Scene(text, str(path.parent), str(path), threads))
