"""sssphere: fast rendering of dense translucent media.

The public API::

    scene = sssphere.load_scene("scenes/bunny.json")      # or a dict
    image = sssphere.render(scene, spp=64)                 # (height, width, 3) float32
    sssphere.write_image("bunny.exr", image)

    model = sssphere.ScatteringModel.load()                # the learned sphere step
    steps = model.sample(sigma_t=5.0, g=0.3, albedo=0.9, n=1000)

`import sssphere` loads nothing but this file: each name below is imported on first use
(PEP 562), so a script or a command that needs one part does not pay for the others
(NumPy, the C++ module, OpenImageIO for image files, PyTorch for training).
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

from sssphere._version import __version__

# public name -> the module that defines it
_EXPORTS = {
    "Image": "sssphere.rendering",
    "RenderResult": "sssphere.rendering",
    "ScatteringModel": "sssphere.model",
    "Scene": "sssphere.scene",
    "SceneError": "sssphere._core",
    "SceneWarning": "sssphere.scene",
    "load_mesh": "sssphere.scene",
    "load_scene": "sssphere.scene",
    "presets": "sssphere.scene",
    "read_image": "sssphere.rendering",
    "render": "sssphere.rendering",
    "render_full": "sssphere.rendering",
    "sphere_walks": "sssphere.walks",
    "write_image": "sssphere.rendering",
    "denoise": "sssphere.rendering",
    "first_hit_aovs": "sssphere.rendering",
    "orbit_cameras": "sssphere.rendering",
    "render_frames": "sssphere.rendering",
    "SceneNode": "sssphere.scene",
    "read_layers": "sssphere.rendering",
    "write_layers": "sssphere.rendering",
}

__all__ = [
    "Image",
    "RenderResult",
    "ScatteringModel",
    "Scene",
    "SceneError",
    "SceneNode",
    "SceneWarning",
    "__version__",
    "denoise",
    "first_hit_aovs",
    "load_mesh",
    "load_scene",
    "orbit_cameras",
    "presets",
    "read_image",
    "read_layers",
    "render",
    "render_frames",
    "render_full",
    "sphere_walks",
    "write_image",
    "write_layers",
]

if TYPE_CHECKING:
    from sssphere._core import SceneError
    from sssphere.model import ScatteringModel
    from sssphere.rendering import (Image, RenderResult, denoise, first_hit_aovs, orbit_cameras,
                                    read_image, read_layers, render, render_frames, render_full,
                                    write_image, write_layers)
    from sssphere.scene import Scene, SceneNode, SceneWarning, load_mesh, load_scene, presets
    from sssphere.walks import sphere_walks


def __getattr__(name: str):
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'sssphere' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value  # later lookups skip this function
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_EXPORTS))
