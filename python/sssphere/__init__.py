"""sssphere: fast rendering of dense translucent media.

The public API::

    scene = sssphere.load_scene("scenes/bunny.json")      # or a dict
    image = sssphere.render(scene, spp=64)                 # (height, width, 3) float32
    sssphere.write_image("bunny.exr", image)

    model = sssphere.ScatteringModel.load()                # the learned sphere step
    steps = model.sample(sigma_t=5.0, g=0.3, albedo=0.9, n=1000)
"""

from sssphere._core import SceneError
from sssphere.model import ScatteringModel
from sssphere.render import RenderResult, read_image, render, render_full, write_image
from sssphere.scene import Scene, load_mesh, load_scene
from sssphere.walks import sphere_walks

__all__ = [
    "RenderResult",
    "ScatteringModel",
    "Scene",
    "SceneError",
    "load_mesh",
    "load_scene",
    "read_image",
    "render",
    "render_full",
    "sphere_walks",
    "write_image",
]
__version__ = "0.1.0"
