"""Geometric robustness (docs/robustness.md): the same picture wherever the scene sits and
however big it is.

* A black, optically thick sphere framed the same way from 2 to 10,000 radii: every pixel
  whose footprint lies inside the silhouette is exactly 0 and every one outside it exactly 1
  (albedo 0: a photon that meets the medium is absorbed at its first collision, so any other
  value is light that leaked through). Deterministic, for pt, st and the GLSL path.
* Uniform scale k = 1e-4 .. 1e4 (lengths x k, sigma / k, point intensity x k^2) and
  translations up to 1e4 of a sphere of radius 0.1: the same image. Translations are
  bit-identical by design (the render frame is centred on the shapes, in double precision);
  scaled images take the same random numbers and may differ only by rounding, so they are
  compared by z-scores from the renders' variances.
* Slivers: a pure absorber slab of thickness 1e-3 and 1e-4 of its width, rotated and moved
  1e4 away from the origin, against its exact transmittance (a per-pixel binomial test); and
  a scattering slab of thickness 1e-3 of its width against Mitsuba 3 rendering it at the
  origin (the only place where Mitsuba's own ray offsets are small enough: see
  mitsuba_util.py).
"""

from __future__ import annotations

import copy
import math
import re
import warnings
from pathlib import Path

import numpy as np
import pytest
from scipy import stats

import sssphere
from bench.robustness import cube_on_floor, two_slabs
from bench.robustness import rotation as axis_rotation
from sssphere import _core

REPO = Path(__file__).resolve().parent.parent
CUT_MODELS = REPO / "models" / "cut"

HAS_GPU = _core.gpu_status()[0]


# ---------------------------------------------------------------------------------------------
# The framed black sphere


def framed_sphere(d: float, res: int = 48) -> dict:
    fov = math.degrees(2 * math.asin(1 / d) / 0.8)
    return {
        "camera": {"origin": [0, 0, d], "target": [0, 0, 0], "up": [0, 1, 0], "fov": fov,
                   "width": res, "height": res},
        "shapes": [{"name": "black", "sphere": {"center": [0, 0, 0], "radius": 1, "subdivisions": 4},
                    "medium": {"sigma_t": 1000, "albedo": 0}, "boundary": {"type": "index_matched"}}],
        "lights": [{"type": "environment", "radiance": 1}],
    }


def silhouette_masks(d: float, res: int, margin: float = 0.05):
    """Pixels whose whole footprint lies inside (1 - margin) of the sphere's silhouette, and
    those wholly outside (1 + margin) of it. The silhouette's radius, in half-heights, is
    tan(asin(1/d)) / tan(fov / 2); the icosphere is inscribed in the sphere, within 1e-4 of it."""
    radius = math.tan(math.asin(1 / d)) / math.tan(math.asin(1 / d) / 0.8)
    c = (np.arange(res) + 0.5) / res * 2 - 1
    x, y = np.meshgrid(np.abs(c), np.abs(c))
    far_corner = np.hypot(x + 1 / res, y + 1 / res)
    near_corner = np.hypot(np.maximum(x - 1 / res, 0), np.maximum(y - 1 / res, 0))
    return far_corner < (1 - margin) * radius, near_corner > (1 + margin) * radius


@pytest.mark.parametrize("backend,integrator", [
    ("cpu", "pt"), ("cpu", "st"),
    pytest.param("vulkan", "pt", marks=pytest.mark.skipif(not HAS_GPU, reason="no Vulkan device")),
])
def test_framed_black_sphere_is_opaque_from_any_distance(backend, integrator):
    res = 48
    for d in (2, 10, 1000, 10000):
        r = sssphere.render_full(framed_sphere(d, res), integrator=integrator, spp=4, seed=5,
                                 backend=backend)
        lum = r.image.mean(axis=2)
        inside, outside = silhouette_masks(d, res)
        assert inside.sum() > 800 and outside.sum() > 600
        leaking = np.count_nonzero(lum[inside] != 0)
        assert leaking == 0, f"d = {d}: {leaking} pixels inside the silhouette let light through"
        assert np.all(lum[outside] == 1.0), f"d = {d}: pixels outside the silhouette are not 1"


# ---------------------------------------------------------------------------------------------
# Scale and translation


def scattering_scene(k: float = 1.0, t: float = 0.0, radius: float = 1.0, res: int = 32) -> dict:
    """A scattering sphere of `radius` (sigma_t 20 / radius, chromatic albedo) with a point
    light and an environment; lengths x k, then every position moved by t (1, -0.5, 0.25)."""
    shift = np.array([1.0, -0.5, 0.25]) * t

    def at(p):
        return [float(x) for x in np.asarray(p, float) * k + shift]

    return {
        "camera": {"origin": at([0.3 * radius, 0.2 * radius, 4 * radius]), "target": at([0, 0, 0]),
                   "fov": 30, "width": res, "height": res},
        "shapes": [{"name": "ball", "sphere": {"center": [0, 0, 0], "radius": radius, "subdivisions": 3},
                    "transform": {"scale": k, "translate": at([0, 0, 0])},
                    "medium": {"sigma_t": 20.0 / radius / k, "albedo": [0.95, 0.9, 0.8], "g": 0.3},
                    "boundary": {"type": "index_matched"}}],
        "lights": [{"type": "point", "position": at([3 * radius, 3 * radius, 3 * radius]),
                    "intensity": 10 * (k * radius) ** 2},
                   {"type": "environment", "radiance": 0.1}],
    }


def assert_same_image(ref, other, what: str):
    """Image means per channel and 4 x 4 block means within the renders' noise: the noise of
    two renders counted as independent (they share random numbers, so this is loose only
    for scale-invariant renders, which agree far better); Bonferroni at alpha = 1e-3."""
    var = ref.variance + other.variance
    diff = other.image.astype(np.float64) - ref.image
    z_mean = diff.reshape(-1, 3).sum(0) / np.sqrt(var.reshape(-1, 3).sum(0))
    blocks = diff.reshape(8, 4, 8, 4, 3).sum(axis=(1, 3))
    block_var = var.reshape(8, 4, 8, 4, 3).sum(axis=(1, 3))
    live = block_var > 0
    z_blocks = blocks[live] / np.sqrt(block_var[live])
    limit = stats.norm.isf(1e-3 / (2 * (live.sum() + 3)))
    assert np.all(np.abs(z_mean) < limit), f"{what}: image means differ, z = {z_mean}"
    assert np.all(np.abs(z_blocks) < limit), f"{what}: block means differ, max |z| = {np.abs(z_blocks).max():.1f}"
    assert np.all(diff[var == 0] == 0), f"{what}: pixels without noise differ"


@pytest.mark.parametrize("integrator", ["pt", "st"])
def test_scaling_the_scene_leaves_the_image(integrator):
    def render(scene):
        return sssphere.render_full(scene, integrator=integrator, spp=16, seed=2)

    ref = render(scattering_scene())
    for k in (1e-4, 1e-2, 1e2, 1e4):
        assert_same_image(ref, render(scattering_scene(k)), f"scale k = {k:g}")


@pytest.mark.parametrize("integrator,backend", [
    ("pt", "cpu"), ("st", "cpu"),
    pytest.param("pt", "vulkan", marks=pytest.mark.skipif(not HAS_GPU, reason="no Vulkan device")),
])
def test_moving_the_scene_leaves_the_image_bit_for_bit(integrator, backend):
    def render(scene):
        return sssphere.render_full(scene, integrator=integrator, spp=8, seed=2, backend=backend)

    ref = render(scattering_scene(radius=0.1))
    assert ref.image.max() > 0
    for t in (1e2, 1e4, -3e3):
        moved = render(scattering_scene(t=t, radius=0.1))
        assert np.array_equal(moved.image, ref.image), f"translation by {t:g} changed the image"


# ---------------------------------------------------------------------------------------------
# Slivers


def box_obj(path, size, thickness, offset=(0.0, 0.0, 0.0)) -> None:
    """A closed box [-size/2, size/2]^2 x [-thickness/2, thickness/2] + offset as an OBJ file."""
    s, h = size / 2, thickness / 2
    ox, oy, oz = offset
    v = [(x + ox, y + oy, z + oz) for z in (-h, h) for y in (-s, s) for x in (-s, s)]
    quads = [(1, 2, 4, 3), (5, 7, 8, 6), (1, 5, 6, 2), (3, 4, 8, 7), (1, 3, 7, 5), (2, 6, 8, 4)]
    path.write_text("".join(f"v {x!r} {y!r} {z!r}\n" for x, y, z in v)
                    + "".join("f " + " ".join(map(str, q)) + "\n" for q in quads))


def rotation(deg) -> np.ndarray:
    """Rz Ry Rx, as the scene format's rotate_deg."""
    ax, ay, az = np.radians(deg)
    rx = np.array([[1, 0, 0], [0, np.cos(ax), -np.sin(ax)], [0, np.sin(ax), np.cos(ax)]])
    ry = np.array([[np.cos(ay), 0, np.sin(ay)], [0, 1, 0], [-np.sin(ay), 0, np.cos(ay)]])
    rz = np.array([[np.cos(az), -np.sin(az), 0], [np.sin(az), np.cos(az), 0], [0, 0, 1]])
    return rz @ ry @ rx


def box_chords(origin, dirs, size, thickness) -> np.ndarray:
    """Length of each ray's chord through the box (box frame, double precision; slab method)."""
    half = np.array([size / 2, size / 2, thickness / 2])
    with np.errstate(divide="ignore", invalid="ignore"):
        t0 = (-half - origin) / dirs
        t1 = (half - origin) / dirs
    near = np.nanmax(np.minimum(t0, t1), axis=-1)
    far = np.nanmin(np.maximum(t0, t1), axis=-1)
    return np.maximum(far - np.maximum(near, 0.0), 0.0)


def camera_rays(cam: dict, sub: int) -> np.ndarray:
    """Unit directions of sub x sub stratified rays per pixel of the pinhole camera:
    (height, width, sub * sub, 3)."""
    o, t = np.array(cam["origin"], float), np.array(cam["target"], float)
    forward = (t - o) / np.linalg.norm(t - o)
    right = np.cross(forward, cam.get("up", [0, 1, 0]))
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    w, h = cam["width"], cam["height"]
    tan_half = math.tan(math.radians(cam["fov"]) / 2)
    s = (np.arange(sub) + 0.5) / sub
    fx = (np.arange(w)[:, None] + s[None, :]).ravel()
    fy = (np.arange(h)[:, None] + s[None, :]).ravel()
    u = (2 * fx / w - 1) * tan_half * w / h
    v = (1 - 2 * fy / h) * tan_half
    d = forward + u[None, :, None] * right + v[:, None, None] * up
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    return d.reshape(h, sub, w, sub, 3).transpose(0, 2, 1, 3, 4).reshape(h, w, sub * sub, 3)


@pytest.mark.parametrize("thickness", [1e-3, 1e-4])
def test_absorbing_sliver_far_from_the_origin_transmits_exactly(tmp_path, thickness):
    size = 1.0
    sigma = 1.0 / thickness  # one mean free path across
    box_obj(tmp_path / "slab.obj", size, thickness)
    rot_deg, shift = [30.0, -20.0, 10.0], np.array([1e4, -3e3, 5e3])
    rot = rotation(rot_deg)
    cam_box = np.array([0.15, -0.1, 0.9])  # in the box's frame, looking at its centre
    res = 32
    scene = {
        "camera": {"origin": list(rot @ cam_box + shift), "target": list(shift),
                   "up": list(rot @ [0, 1, 0]), "fov": 50, "width": res, "height": res},
        "shapes": [{"name": "sliver", "mesh": "slab.obj",
                    "transform": {"rotate_deg": rot_deg, "translate": list(shift)},
                    "medium": {"sigma_t": sigma, "albedo": 0}}],
        "lights": [{"type": "environment", "radiance": 1}],
    }
    spp = 256
    r = sssphere.render_full(sssphere.load_scene(scene, base_dir=tmp_path), spp=spp, seed=9)
    # The expected value of every pixel: exp(-sigma * chord) over its footprint (16 x 16 rays,
    # in the box's frame, where the camera is cam_box).
    dirs = camera_rays(scene["camera"], 16) @ rot  # world -> box frame: R^T d
    chords = box_chords(cam_box, dirs, size, thickness)
    p = np.exp(-sigma * chords).mean(axis=-1)
    smooth = (chords > 0).all(axis=-1)  # footprints wholly on the slab (no edge inside)
    empty = (chords == 0).all(axis=-1)
    assert smooth.sum() > 300
    got = r.image.mean(axis=2)
    assert np.all(got[empty] == 1.0)
    # Each sample passes (1) or is absorbed (0): a binomial mean per pixel.
    var = p * (1 - p) / spp
    z = (got[smooth] - p[smooth]) / np.sqrt(var[smooth])
    chi2 = float(np.sum(z**2))
    assert stats.chi2.sf(chi2, smooth.sum()) > 1e-3, f"chi2 {chi2:.0f} on {smooth.sum()} pixels"
    z_total = np.sum(got[smooth] - p[smooth]) / np.sqrt(np.sum(var[smooth]))
    assert abs(z_total) < 4, f"mean transmittance off by z = {z_total:.1f}"
    assert np.abs(z).max() < stats.norm.isf(1e-3 / (2 * smooth.sum()))


@pytest.mark.slow
def test_scattering_sliver_far_from_the_origin_matches_mitsuba(tmp_path):
    """A slab 1000 wide and 1 thick (sigma_t 1, albedo 0.9, g 0.5) lit by a directional light
    and an environment. Mitsuba renders it centred at the origin, where its own interface
    offset ((1 + |p|) 8.9e-5, about 1e-3 of the thickness in view) is negligible; we render it
    rotated and moved 1e4 away."""
    import mitsuba_util as mu

    box_obj(tmp_path / "slab.obj", 1000.0, 1.0)
    res = 32

    def scene(rot_deg, shift):
        rot = rotation(rot_deg)
        return {
            "camera": {"origin": list(rot @ [2.0, 1.0, 12.0] + shift), "target": list(rot @ [0, 0, 0] + shift),
                       "up": list(rot @ [0, 1, 0]), "fov": 40, "width": res, "height": res},
            "shapes": [{"name": "slab", "mesh": str(tmp_path / "slab.obj"),
                        "transform": {"rotate_deg": rot_deg, "translate": list(shift)},
                        "medium": {"sigma_t": [1.0] * 3, "albedo": [0.9] * 3, "g": 0.5}}],
            "lights": [{"type": "directional", "direction": list(rot @ [0.3, -0.2, -1.0]), "irradiance": [2.0] * 3},
                       {"type": "environment", "radiance": [0.1] * 3}],
        }

    ours = scene([15.0, 25.0, -40.0], np.array([1e4, 2e3, -7e3]))
    at_origin = scene([0.0, 0.0, 0.0], np.zeros(3))
    run = mu.compare_with_mitsuba(ours, our_spp=1024, mitsuba_spp=64, mitsuba_seeds=range(100, 116),
                                  block=4, our_seed=3, mitsuba_scene_dict_override=at_origin)
    c = run.comparison
    print(f"\n{c.summary()}")
    assert c.dof.min() >= 20
    assert c.chi2_ok, c.summary()
    assert c.z_ok, c.summary()


def test_a_mesh_file_far_from_the_origin_renders_as_the_mesh_moved_there(tmp_path):
    """Vertices 1e6 from the origin in the file itself are read in double and kept relative
    to the mesh's centre: bit for bit the image of the same mesh moved there by `transform`.
    (Before, they were rounded to float first, 0.0625 apart at 1e6: the box's sides moved.)"""
    far = [1e6, -2e6, 3e6]
    box_obj(tmp_path / "near.obj", 0.6, 0.6)
    box_obj(tmp_path / "far.obj", 0.6, 0.6, offset=far)

    def render(mesh, translate):
        scene = {"camera": {"origin": [far[0] + 0.7, far[1] + 0.9, far[2] + 2], "target": far,
                            "fov": 40, "width": 32, "height": 32},
                 "shapes": [{"mesh": mesh, "transform": {"translate": translate},
                             "medium": {"sigma_t": 1000, "albedo": 0},
                             "boundary": {"type": "index_matched"}}],
                 "lights": [{"type": "environment", "radiance": 1}]}
        return sssphere.render(sssphere.load_scene(scene, base_dir=tmp_path), "pt", spp=4, seed=1)

    moved, in_file = render("near.obj", far), render("far.obj", [0, 0, 0])
    assert 0.1 < moved.mean() < 0.9  # the box fills part of the frame
    assert np.array_equal(moved, in_file), f"{np.count_nonzero(moved != in_file)} values differ"


def lit_ball(k: float) -> dict:
    """An opaque diffuse ball of radius k under an environment and a point light, all lengths x k."""
    return {"camera": {"origin": [0.3 * k, 0.2 * k, 4 * k], "target": [0, 0, 0], "fov": 30,
                       "width": 32, "height": 32},
            "shapes": [{"sphere": {"center": [0, 0, 0], "radius": k},
                        "surface": {"type": "diffuse", "reflectance": 0.5}}],
            "lights": [{"type": "environment", "radiance": 1},
                       {"type": "point", "position": [3 * k, 3 * k, 3 * k], "intensity": 20 * k * k}]}


def test_scenes_too_small_or_large_for_float_are_refused_and_the_rest_render_alike():
    """Shapes 1e-8 to 1e10 across render the same image; past that Embree's float
    ray-triangle test overflows or underflows (a sphere of radius 1e12 hung, one of 1e-10
    aborted in Embree), so the parser refuses them, naming the extent."""
    def render(k):
        return sssphere.render_full(lit_ball(k), integrator="pt", spp=16, seed=2)

    ref = render(1.0)
    for k in (1e-8, 4e9):  # extents 2e-8 and 8e9
        assert_same_image(ref, render(k), f"scale k = {k:g}")
    for k, extent in ((2e-9, "4e-09"), (1e10, "2e+10")):
        with pytest.raises(sssphere.SceneError,
                           match=rf"shapes: their extent {re.escape(extent)} .* outside \[1e-8, 1e10\]"):
            sssphere.load_scene(lit_ball(k))


# ---------------------------------------------------------------------------------------------
# The limits: warnings, not errors


def _speck(d: float) -> dict:
    """A black triangle 0.01 across at (-d, -d, -d): out of sight, unlit, and far."""
    return {"name": "speck", "vertices": [[-d, -d, -d], [0.01 - d, -d, -d], [-d, 0.01 - d, -d]],
            "faces": [[0, 1, 2]], "surface": {"type": "diffuse", "reflectance": 0.0}}


def _dense_ball(sigma_t: float = 1000.0, centers=((0.0, 0.0, 0.0),)) -> dict:
    return {"camera": {"origin": [0, 1, 4], "target": [0, 0, 0], "fov": 35, "width": 32, "height": 32},
            "shapes": [{"name": f"ball{i}", "sphere": {"center": list(c), "radius": 1, "subdivisions": 2},
                        "medium": {"sigma_t": sigma_t, "albedo": 0.995}}
                       for i, c in enumerate(centers)],
            "lights": [{"type": "environment", "radiance": 0.1},
                       {"type": "point", "position": [1, 3, 2], "intensity": 5}]}


@pytest.mark.parametrize("integrator", ["pt", "st"])
def test_a_far_surface_leaves_a_dense_medium_as_it_was(integrator):
    """The render frame was centred on all shapes' bounds: a speck 3000 units away put a
    dense ball (sigma_t 1000) 2600 from the centre, where every crossing into it skipped
    about 1e-3, a mean free path, and the ball came out 4.4 % darker without a warning
    (an outside review; z = 38 at 128 spp). A floor reaching far to one side did the same.
    The frame is centred on the media: the speck changes nothing."""
    near = sssphere.render_full(_dense_ball(), integrator=integrator, spp=64, seed=1)
    far = _dense_ball()
    far["shapes"].append(_speck(3000.0))
    far = sssphere.load_scene(far)  # no warning (pytest makes one an error)
    assert far.warnings == []
    assert_same_image(near, sssphere.render_full(far, integrator=integrator, spp=64, seed=2),
                      f"{integrator}, speck at 3000")


def test_a_lamp_under_the_floor_stays_there_with_a_far_shape():
    """With the frame centred off the cube (a speck 3000 away), a lamp and an area light
    under a floor lit the dense cube resting on it through the floor: 3-37 of 3072 pixel
    channels at 64 spp, with pt and st (an outside review). All must be 0."""
    cube = [[x, y, z] for x in (-.5, .5) for y in (-.5, .5) for z in (-.5, .5)]
    scene = {"camera": {"origin": [1.2, 1.5, 3.0], "target": [0, -0.1, 0], "fov": 40,
                        "width": 32, "height": 32},
             "shapes": [{"name": "box", "vertices": cube,
                         "faces": [[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6],
                                   [0, 2, 6, 4], [1, 5, 7, 3]],
                         "medium": {"sigma_t": [100, 150, 200], "albedo": [0.99, 0.97, 0.95],
                                    "g": 0.3}},
                        {"name": "floor", "vertices": [[-3, -.5, -3], [3, -.5, -3], [3, -.5, 3], [-3, -.5, 3]],
                         "faces": [[0, 1, 2], [0, 2, 3]], "surface": {"type": "diffuse", "reflectance": 0.5}},
                        _speck(3000.0)],
             "lights": [{"type": "point", "position": [0.2, -0.9, 0.1], "intensity": 50},
                        {"type": "area", "corner": [-1, -2, -1], "edge1": [0, 0, 2],
                         "edge2": [2, 0, 0], "radiance": 5}]}
    for boundary in ({"type": "dielectric", "ior": 1.4, "roughness": 0.3},
                     {"type": "dielectric", "ior": 1.4}, {"type": "index_matched"}):
        scene["shapes"][0]["boundary"] = boundary
        for integrator in ("pt", "st"):
            lit = _lit_pixels(scene, "cpu", integrator=integrator, spp=64)
            assert lit == 0, f"{integrator}, {boundary}: {lit} pixel channels lit"


def test_dense_media_far_from_the_centre_warn():
    """Media far apart leave one of them off the frame's centre whatever it is: a dense
    one there is warned of, with the optical depth a crossing skips."""
    apart = _dense_ball(1000.0, ((-1500, 0, 0), (1500, 0, 0)))
    with pytest.warns(sssphere.SceneWarning) as said:
        sssphere.load_scene(apart)
    messages = [str(w.message) for w in said]
    assert len(messages) == 2, messages
    assert re.search(r"shapes\[1\] \('ball1'\): lies up to 1501 from the centre of the "
                     r"media's bounds, where a boundary crossing skips about 0\.00063\d*, "
                     r"0\.63\d* mean free paths", messages[1]), messages[1]
    # the same pair, not dense, and one dense ball with a far floor: no warning
    assert sssphere.load_scene(_dense_ball(10.0, ((-1500, 0, 0), (1500, 0, 0)))).warnings == []
    alone = _dense_ball()
    alone["shapes"].append(_speck(3000.0))
    assert sssphere.load_scene(alone).warnings == []


def test_scenes_past_the_precision_limits_warn(tmp_path):
    box_obj(tmp_path / "thin.obj", 1.0, 1e-5)
    slab = {"camera": {"origin": [0, 0, 3], "target": [0, 0, 0], "fov": 40, "width": 8, "height": 8},
            "shapes": [{"mesh": "thin.obj", "medium": {"sigma_t": 1, "albedo": 0.5}}],
            "lights": [{"type": "environment", "radiance": 1}]}
    thin = r"shapes\[0\].*mean thickness 4 V / A = 1.99996e-05 is below 0.00015"
    with pytest.warns(sssphere.SceneWarning, match=thin):
        scene = sssphere.load_scene(slab, base_dir=tmp_path)
    assert len(scene.warnings) == 1
    far = framed_sphere(10.0)
    far["lights"].append({"type": "point", "position": [0, 3e5, 0], "intensity": 1})
    with pytest.warns(sssphere.SceneWarning, match=r"lights\[1\]\.position lies 150000 times"):
        sssphere.load_scene(far)
    # Within the limits: no warning (pytest turns any warning into an error here)
    box_obj(tmp_path / "ok.obj", 1.0, 1e-4)
    slab["shapes"][0]["mesh"] = "ok.obj"
    assert sssphere.load_scene(slab, base_dir=tmp_path).warnings == []
    assert sssphere.load_scene(framed_sphere(1e5)).warnings == []


def _box_obj(path):
    """A unit cube, 8 vertices and 12 triangles."""
    v = [(x, y, z) for x in (-.5, .5) for y in (-.5, .5) for z in (-.5, .5)]
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    faces = [t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))]
    path.write_text("".join(f"v {x} {y} {z}\n" for x, y, z in v)
                    + "".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in faces))


def test_a_collision_on_the_surface_does_not_walk_on_outside_for_ever(tmp_path):
    """A collision that lands on the surface, to the float, starts a flight whose boundary
    ray cannot see the crossing at its origin: the photon went on as if inside, outside
    the mesh, and with albedo 1 never ended (one path in about a million here: this render
    has one, found by an outside sweep, which hung `pt` and `st` alike). Now a flight that
    ends outside the distance grid ends the medium. The longest path must be one the
    physics allows: 45-55 thousand events here (g = 0.95 across 50 reduced mean free
    paths); it had a million, the cap."""
    _box_obj(tmp_path / "box.obj")
    scene = sssphere.load_scene({
        "camera": {"origin": [0.5, 1.0, 3.2], "target": [0, 0, 0], "fov": 30,
                   "width": 48, "height": 48},
        "shapes": [{"mesh": "box.obj", "transform": {"rotate_deg": [20, 35, 10]},
                    "medium": {"sigma_t": 1000, "albedo": 1.0, "g": 0.95},
                    "boundary": {"type": "index_matched"}}],
        "lights": [{"type": "environment", "radiance": 0.5},
                   {"type": "area", "corner": [-0.75, 2.0, -0.75], "edge1": [1.5, 0, 0],
                    "edge2": [0, 0, 1.5], "radiance": 6}]}, base_dir=tmp_path)
    r = sssphere.render_full(scene, integrator="pt", spp=48, seed=5, max_bounces=10**6,
                             record_paths=True)
    assert r.path_events.max() < 200_000, np.unravel_index(r.path_events.argmax(),
                                                           r.path_events.shape)
    assert np.all(np.isfinite(r.image))


@pytest.mark.parametrize("backend", [
    "cpu", pytest.param("vulkan", marks=pytest.mark.skipif(not HAS_GPU, reason="no Vulkan device"))])
@pytest.mark.parametrize("integrator", ["pt", "st"])
def test_a_point_light_standing_on_a_floor_lights_the_scene(integrator, backend):
    """A lamp exactly on a (tilted) floor: every shadow ray towards it meets the floor at
    the lamp, where rounding decided whether the floor was in the way (an outside sweep
    measured 88 % of the light lost, and a different loss once the scene was rotated). A
    surface at the light no longer blocks it, as for an area light's quad: the image is
    that of the lamp lifted 3e-4 off the floor, past that allowance. The floor is black:
    lit at grazing angles, it would tell the lamp's height near the lamp."""
    n = np.array([0.3, 0.9, 0.2]) / np.linalg.norm([0.3, 0.9, 0.2])
    t1 = np.cross(n, [0.0, 0.0, 1.0])
    t1 /= np.linalg.norm(t1)
    t2 = np.cross(n, t1)
    corners = [3 * (a * t1 + b * t2) for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1))]

    def scene(lift: float) -> dict:
        return {
            "camera": {"origin": (3 * n + 3 * t2 + t1).tolist(), "target": (0.6 * n).tolist(),
                       "fov": 40, "width": 32, "height": 32},
            "shapes": [{"sphere": {"center": (0.6 * n).tolist(), "radius": 0.5},
                        "medium": {"sigma_t": 20, "albedo": 0.95}},
                       {"vertices": [c.tolist() for c in corners], "faces": [[0, 1, 2], [0, 2, 3]],
                        "surface": {"type": "diffuse", "reflectance": 0}}],
            "lights": [{"type": "point", "position": (0.9 * t1 + 0.7 * t2 + lift * n).tolist(),
                        "intensity": 4}]}

    on, lifted = (sssphere.render_full(scene(lift), integrator=integrator, spp=32, seed=2,
                                       backend=backend)
                  for lift in (0.0, 3e-4))
    assert lifted.image.mean() > 0.01
    assert_same_image(lifted, on, f"{integrator} on {backend}: a lamp on the floor")


@pytest.mark.parametrize("backend", [
    "cpu", pytest.param("vulkan", marks=pytest.mark.skipif(not HAS_GPU, reason="no Vulkan device"))])
@pytest.mark.parametrize("integrator", ["pt", "st"])
def test_a_point_light_on_a_glass_face_lights_it_as_one_just_inside(integrator, backend):
    """A lamp exactly on the top face of a glass cube counts as inside it (CGAL's exact
    test says so, and so its radiance takes 1 / ior^2), but every shadow ray towards it met
    the face at the lamp, and the glass blocked it: a review measured 0.0128 against 0.151
    inside (here 0.0019 against 0.0222 with pt). The face of the medium the light lies in,
    met at the light, no longer blocks it: the image is that of the lamp 3e-4 inside."""
    v = [(x, y, z) for x in (-.5, .5) for y in (-.5, .5) for z in (-.5, .5)]
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]

    def scene(depth: float) -> dict:
        return {
            "camera": {"origin": [0.3, -2.2, 1.8], "target": [0, 0, 0], "fov": 40,
                       "width": 32, "height": 32},
            "shapes": [{"vertices": v, "faces": [list(q) for q in quads],
                        "medium": {"sigma_t": 6, "albedo": 0.95},
                        "boundary": {"type": "dielectric", "ior": 1.5}}],
            "lights": [{"type": "point", "position": [0.1, 0.05, 0.5 - depth], "intensity": 1}]}

    inside, on = (sssphere.render_full(scene(depth), integrator=integrator, spp=32, seed=2,
                                       backend=backend)
                  for depth in (3e-4, 0.0))
    assert inside.image.mean() > 0.01, inside.image.mean()
    assert_same_image(inside, on, f"{integrator} on {backend}: a lamp on a glass face")


def test_media_nearly_touching_are_refused_and_the_gap_allowed_renders_right():
    """A ray leaving a medium starts past its surface by an offset that grows with the
    coordinates (ray_offset.h); a second medium within that offset was skipped (a sweep
    lost 93 % of the light across a gap of 1.5e-7 of the scene, with no word). Such media
    are refused, naming the gap they need; at that gap, the light crosses as across a wide
    one."""
    with pytest.raises(sssphere.SceneError) as refused:
        sssphere.load_scene(two_slabs(3e-7))
    msg = str(refused.value)
    assert "shapes[0] ('first') and shapes[1] ('second'): their media are" in msg, msg
    assert "too close for rays that leave a surface" in msg, msg
    needed = float(re.search(r"a gap of ([0-9.e+-]+) or more there", msg).group(1))
    assert 3e-7 < needed < 1e-5 * 2, msg  # at most 1e-5 of the scene (2 across)
    wide, allowed = (sssphere.render_full(two_slabs(gap), integrator="pt", spp=16, seed=3)
                     for gap in (1e-3, 1.1 * needed))
    assert wide.image.mean() > 0.1
    assert_same_image(wide, allowed, f"slabs {1.1 * needed:.3g} apart")


def _scene_warnings(scene) -> tuple:
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        loaded = sssphere.load_scene(scene)
    return loaded, [str(w.message) for w in said]


BACKENDS = ["cpu", pytest.param("vulkan", marks=pytest.mark.skipif(not HAS_GPU,
                                                                   reason="no Vulkan device"))]


def _turned() -> np.ndarray:
    """A turn of 1.1 rad about an oblique axis (no face of the cube stays axis-aligned)."""
    return axis_rotation([0.3, 1.0, -0.6], 1.1)


def _lit_pixels(scene, backend, **options) -> int:
    options = {"spp": 16, "seed": 1, **options}
    return int(np.count_nonzero(sssphere.render(scene, backend=backend, **options)))


@pytest.mark.parametrize("backend", BACKENDS)
def test_a_medium_resting_on_a_floor_is_exact(backend):
    """A cube resting exactly on a floor: which of the cube's bottom and the floor a ray meets
    first is rounding's choice, and a ray leaving the cube started past the floor. An outside
    sweep saw the lit cube from under the floor (500-650 of 2304 pixels, where all must be 0)
    and the floor around it darker by 1-8 %. The tracers take the floor where a face of the
    medium touching it is hit: the camera under the floor, all light above, sees exactly 0,
    also turned about an oblique axis with the floor off 0, with pt and st. From above, and
    with the floor ending under the cube, the image is that of the cube lifted by 1e-5 of the
    scene (index-matched: a gap then changes nothing)."""
    for turn, floor_y in ((np.eye(3), 0.0), (_turned(), -0.37)):
        scene, said = _scene_warnings(cube_on_floor(0.0, turn, floor_y))
        assert said == [], said
        for integrator in ("pt", "st"):
            lit = _lit_pixels(scene, backend, integrator=integrator)
            assert lit == 0, f"{integrator}, floor at {floor_y}: {lit} pixels see through"
        # the same cube seen from above is lit: the camera below sees 0 because the floor
        # is opaque, not because nothing is lit
        scene.camera.origin = (turn @ [0.3, floor_y + 4, 0.4]).tolist()
        assert sssphere.render(scene, spp=4, seed=1, backend=backend).mean() > 0.01
    # (on the GPU also a check that searching around touching faces, in meet_boundary and
    # in shadow rays, blocks no light it should not)
    for what, above, floor_x in (("from above", True, (-2.0, 2.0)),
                                 ("floor ending under it", False, (-2.0, 0.1))):
        renders = []
        for lift in (0.0, 4e-5):
            scene = cube_on_floor(lift, floor_x=floor_x, boundary="index_matched")
            if above:
                scene["camera"]["origin"] = [0.3, 4, 0.4]
            renders.append(sssphere.render_full(scene, integrator="pt", spp=16, seed=5,
                                                backend=backend))
        assert renders[0].image.mean() > 0.001, what
        assert_same_image(renders[1], renders[0], f"resting against lifted, {what}")


@pytest.mark.parametrize("backend", BACKENDS)
def test_a_floor_near_a_medium_stays_opaque_from_any_distance(backend):
    """Off by less than the rays' offsets (lifted, or sunk, by 1e-7 ... 1e-5 of the scene),
    with a bottom of four triangles around an extra vertex, and seen from 300 times the
    scene's size (hit distances then round at 1e-5 of the scene): a review and a sweep saw
    light through the floor in each, 3 to 549 of 1024 pixels. The tracers trace a ray that
    hit such a face again past the face, from its origin, and camera rays start near the
    scene (Scene::camera_ray_start)."""
    turn = _turned()
    for far, lift in ((1, 4e-7), (1, -1e-7), (30, 1e-6), (300, 4e-5)):
        scene = cube_on_floor(lift, turn, -0.37)
        camera = scene["camera"]
        eye, target = np.array(camera["origin"]), np.array(camera["target"])
        camera.update(origin=(target + far * (eye - target)).tolist(), fov=camera["fov"] / far)
        lit = _lit_pixels(scene, backend)
        assert lit == 0, f"{far} times as far, lifted by {lift}: {lit} pixels see through"
    scene = cube_on_floor(0.0, turn, -0.37)
    cube = scene["shapes"][0]
    cube["vertices"].append((turn @ [0.1, -0.37, 0.2]).tolist())  # the bottom as a fan of 4
    assert cube["faces"][2] == [0, 4, 5, 1]  # the bottom
    cube["faces"][2:3] = [[0, 4, 8], [4, 5, 8], [5, 1, 8], [1, 0, 8]]
    lit = _lit_pixels(scene, backend, spp=64)
    assert lit == 0, f"a fan of four at the bottom: {lit} pixels see through"


def test_first_hit_aovs_see_the_floor_a_medium_rests_on():
    """The denoiser's guides (first_hit_aovs) meet what the render meets: from under a floor
    the camera sees the floor, never the cube resting on it or lifted by less than the
    rays' offsets, also from 300 times as far. They traced from the camera itself and took
    the cube's bottom wherever rounding put it first: 3-71 of 1024 pixels on the turned
    cube, resting or lifted (a review of the open items). The depth counts from the
    camera."""
    turn = _turned()
    for far, lift in ((1, 0.0), (1, 4e-7), (30, 1e-6), (300, 4e-5), (300, 0.0)):
        scene = cube_on_floor(lift, turn, -0.37)
        camera = scene["camera"]
        eye, target = np.array(camera["origin"]), np.array(camera["target"])
        camera.update(origin=(target + far * (eye - target)).tolist(), fov=camera["fov"] / far)
        a = sssphere.first_hit_aovs(scene, seed=1, samples=16)
        cube = int(np.count_nonzero(a["shape"] == 0))
        assert cube == 0, f"{far} times as far, lifted by {lift}: {cube} pixels see the cube"
        assert np.all(np.abs(a["albedo"] - 0.8) < 1e-6), f"{far}, {lift}: not the floor's albedo"
        corners = np.array(scene["shapes"][1]["vertices"])
        to_floor = np.linalg.norm(corners - camera["origin"], axis=1)
        near = np.dot(turn @ [0, 1, 0], np.array(camera["origin"]) - corners[0])
        assert np.all((a["depth"] >= abs(near) * (1 - 1e-5)) &
                      (a["depth"] <= to_floor.max() * (1 + 1e-5))), f"{far}, {lift}: depth"


@pytest.mark.parametrize("backend", BACKENDS)
def test_a_dielectric_resting_on_a_floor_renders_as_lifted_off_it(backend):
    """A dielectric medium meets a floor it rests on as across a gap too thin to see: its
    face reflects and refracts, then the floor (black here, where a surface in optical
    contact would absorb every path that reaches it) reflects what comes out. Resting and
    lifted by 1e-5 of the scene render alike, and a floor through the cube (optical
    contact: no Fresnel) renders otherwise."""
    renders = {}
    for name, lift in (("resting", 0.0), ("lifted", 4e-5), ("sunk", -1e-3)):
        scene = cube_on_floor(lift, boundary="dielectric")
        scene["shapes"][1]["surface"]["reflectance"] = 0.0
        scene["camera"]["origin"] = [2.5, 3, 3.5]
        scene["lights"] = [{"type": "environment", "radiance": 1}]
        renders[name] = sssphere.render_full(scene, integrator="pt", spp=64, seed=5,
                                             backend=backend)
    assert_same_image(renders["lifted"], renders["resting"], "a dielectric resting, lifted")
    sunk, lifted = renders["sunk"], renders["lifted"]
    z = (sunk.image.mean() - lifted.image.mean()) / (
        np.sqrt(sunk.variance.sum() + lifted.variance.sum()) / sunk.image.size)
    assert z < -5, f"a floor 1e-3 into the cube is darker by z = {z} only"


@pytest.mark.parametrize("backend", BACKENDS)
def test_a_lamp_under_the_floor_does_not_light_a_medium_resting_on_it(backend):
    """A vertex on the face of a rough (or regularized smooth) dielectric samples lights;
    where the face rests on a floor, a shadow ray started off the face on the floor's side
    could start past the floor (a review). It did: a lamp under the floor lit the cube
    and, through it, the floor's top (1900-2100 of 3072 pixel channels lit, seen from
    above, with pt and st). The floor covers the face there: no light comes through it.
    An index-matched cube's shadow rays start in the medium: right on the CPU, which
    gathers all crossings of a shadow ray at once; the GPU's searched on past the bottom
    face, and past the floor (2616 lit)."""
    for turn, floor_y in ((np.eye(3), 0.0), (_turned(), -0.37)):
        for boundary in ({"type": "dielectric", "roughness": 0.3},
                         {"type": "dielectric", "roughness": 0.0},
                         {"type": "index_matched"}):
            scene = cube_on_floor(0.0, turn, floor_y)
            scene["shapes"][0]["boundary"] = boundary
            scene["camera"]["origin"] = (turn @ [0.3, floor_y + 4, 0.4]).tolist()
            scene["lights"][0]["position"] = (turn @ [0.2, floor_y - 1, 0.1]).tolist()
            for integrator in ("pt", "st"):
                lit = _lit_pixels(scene, backend, integrator=integrator, spp=32)
                assert lit == 0, (f"{integrator}, {boundary}, floor at {floor_y}: {lit} "
                                  "pixel channels lit from under the floor")
    # the same lamp above the floor lights them (the camera sees a lit scene when it can)
    scene["lights"][0]["position"] = (turn @ [0.2, floor_y + 3, 0.1]).tolist()
    assert _lit_pixels(scene, backend, integrator="pt", spp=8) > 1000


@pytest.mark.parametrize("backend", BACKENDS)
def test_an_opaque_surface_through_a_medium_is_exact(backend):
    """A floor through the middle of a cube: the distance grid that lets a flight skip its
    boundary ray, and sphere steps, did not see the floor, and 6-14 % of the light passed it.
    The grid now keeps clear of surfaces that meet the medium: the camera under the floor sees
    exactly 0, with pt and with st where it steps (sigma_t 500). Such scenes, a wick inside
    the medium and a cube on a smaller pedestal, load without a warning."""
    for sigma_t in (5, 500):
        scene = cube_on_floor(-0.5)
        scene["shapes"][0]["medium"]["sigma_t"] = sigma_t
        scene, said = _scene_warnings(scene)
        assert said == [], said
        for integrator in ("pt", "st") if sigma_t < 500 or backend == "cpu" else ("st",):
            lit = _lit_pixels(scene, backend, integrator=integrator)
            assert lit == 0, f"{integrator}, sigma_t {sigma_t}: {lit} pixels see through"
    if backend == "cpu":
        st = sssphere.render_full(scene, integrator="st", spp=4, seed=1)
        assert st.mean_sphere_steps_per_path > 0.02  # the steps are exercised
    # Cut steps (walks in a sphere cut by a plane; dielectric boundaries take them) take
    # their planes from the same grid: the floor's plane is one of them.
    scene = cube_on_floor(-0.5, boundary="dielectric")
    scene["shapes"][0]["medium"]["sigma_t"] = 500
    scene = sssphere.load_scene(scene)
    lit = _lit_pixels(scene, backend, integrator="st", cut_models=CUT_MODELS)
    assert lit == 0, f"st with cut steps: {lit} pixels see through"
    if backend == "cpu":
        plain, cut = (sssphere.render_full(scene, integrator="st", spp=4, seed=1, cut_models=m)
                      for m in (None, CUT_MODELS))
        # the cut steps are exercised
        assert cut.mean_sphere_steps_per_path > 2 * plain.mean_sphere_steps_per_path
    scene = cube_on_floor(0.0)
    wick = [[x, y, z] for x in (-0.05, 0.05) for y in (0.4, 0.6) for z in (-0.05, 0.05)]
    scene["shapes"][1].update(vertices=wick, faces=scene["shapes"][0]["faces"])
    assert _scene_warnings(scene)[1] == []
    top = [[x, 0.0, z] for x, z in ((-0.2, -0.2), (0.2, -0.2), (0.2, 0.2), (-0.2, 0.2))]
    scene["shapes"][1].update(vertices=top, faces=[[0, 2, 1], [0, 3, 2]])
    assert _scene_warnings(scene)[1] == []


def test_surfaces_meeting_a_medium_follow_edits():
    """An edit that tilts a floor through a lifted cube rebuilds the cube's grid with it (a
    grid kept from before would let light through), and the floor stays opaque; an edit that
    leaves the pair as it was (a light) keeps the grid."""
    scene, said = _scene_warnings(cube_on_floor(1e-3))
    assert said == []
    assert _lit_pixels(scene, "cpu") == 0
    # tilted through the cube; the scene's bounds, and so the cube's mesh in the render
    # frame, stay as they were
    scene.shapes[1].vertices = [[-2, 0, -2], [2, 0, -2], [2, 0.6, 2], [-2, 0.6, 2]]
    assert "distance grid of shape 'cube' (the opaque surfaces meeting it changed)" in \
        scene.rebuilt, scene.rebuilt
    assert _lit_pixels(scene, "cpu") == 0
    scene.lights[0].intensity = 20
    assert not any("distance grid" in r for r in scene.rebuilt), scene.rebuilt
    assert _lit_pixels(scene, "cpu", integrator="st") == 0



@pytest.mark.parametrize("backend", ["cpu", "vulkan"])
def test_long_vectors_and_far_area_lights_render_as_their_directions(small_scene, backend):
    """Vectors whose squares overflow float (past 1.8e19) were normalised to NaN or 0 (a
    review): a camera target 1e20 away aborted inside Embree, an `up` of 1e20 was "parallel
    to the viewing direction" and a directional light along [0, -1e20, 0] rendered black.
    They are directions: they render as the unit ones, bit for bit. An area light 1e10
    away gave NaN pixels (the square of its pdf, in the MIS weight, overflowed). An area
    light of area past 1.8e19 was never sampled: render/types_test.cpp."""
    def render(doc):
        r = sssphere.render_full(doc, integrator="pt", spp=2, seed=3, backend=backend,
                                 threads=0 if backend == "vulkan" else 1)
        assert np.isfinite(r.image).all()
        return r.image

    small_scene["lights"][0] = {"type": "directional", "direction": [0, -1, 0], "irradiance": 2}
    base = render(small_scene)
    for part, key, value in (("camera", "target", [0, 0, -1e20]), ("camera", "up", [0, 1e20, 0]),
                             ("light", "direction", [0, -1e20, 0])):
        doc = copy.deepcopy(small_scene)
        (doc["camera"] if part == "camera" else doc["lights"][0])[key] = value
        np.testing.assert_array_equal(render(doc), base, err_msg=key)

    small_scene["lights"] = [{"type": "area", "corner": [-1, 1e10, -1], "edge1": [2, 0, 0],
                              "edge2": [0, 0, 2], "radiance": 1e20}]  # facing down
    with pytest.warns(sssphere.SceneWarning, match="float precision may distort"):
        assert render(small_scene).mean() > 0
