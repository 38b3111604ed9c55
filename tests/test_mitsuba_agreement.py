"""Our path tracer against Mitsuba 3 `volpath` (scalar_rgb), an independent implementation.

Both renderers get the same triangle mesh, camera, lights and media (tests/mitsuba_util.py
describes the translation). Mitsuba runs with max_depth = -1 and rr_depth = 100000, so neither
renderer truncates paths: the expected images are identical and any difference must be noise.

The test compares 4 x 4 pixel block means. Our variance of a block mean comes from our own
per-pixel variance estimate (RenderResult.variance); Mitsuba's from the spread of K independent
renders (different seeds). With z = (ours - mitsuba) / sqrt(var_ours + var_mitsuba) per block and
channel, a scene passes when the chi-square of z^2 (per channel, alpha / 3 each) is not
significant and no |z| exceeds the Bonferroni limit, both at family-wise alpha = 1e-3.
Nothing is tuned: every tolerance comes from the variance estimates.

Sensitivity (checked by hand): rendering our side with the albedo scaled by 0.95 fails every
scene by a wide margin (chi-square p ~ 0, max |z| 18 to 46); so does a scale of 0.99 (max |z|
5.5 to 11, chi-square p < 1e-50). For the floors: Mitsuba's floor reflectance scaled by 0.98
fails (e) and (f) (chi-square p ~ 0, max |z| 24 and 13).

Scenes: (a) thin sphere, point light; (b) bunny, directional light; (c) dielectric sphere, area
light + environment (no next-event estimation through the dielectric); (d) index-matched sphere,
area light + environment (next-event estimation and phase sampling both reach the lights, so
the MIS weights are exercised); (e)-(g) an opaque diffuse floor (an open mesh): alone under
three kinds of light, under an index-matched medium, under a dielectric one; (h) an environment
map; (i) a rough dielectric medium under three kinds of light; (j) a rough dielectric on a floor
under an environment map and a directional light; (k) a point light inside a medium; (l) the
same behind glass (a dielectric boundary).

Known Mitsuba-side bias (measured, see mitsuba_util.py): Mitsuba re-spawns rays at every null
(index-matched) interface with an offset of (1 + max|p|) * 8.9e-5 along the normal, which skips a
thin layer of medium. Its images come out darker by roughly 0.35 * sigma_t * offset: 0.1-0.2 %
for the bunny of (b) (sigma_t = 30 at unit scale; seen in repeated runs), and for a sphere of
radius 0.45 with the same medium 0.15 % at unit scale, 0.4-0.9 % shrunk 10x, 6-11 % shrunk
100x, none detectable grown 10x (ours is scale-invariant). The block statistics below cannot see 0.1 % (blocks are
known to a few per cent); do not raise the sample counts by orders of magnitude, or the scenes'
density, without scaling the scenes up.

Runtime: about 65 s on 2 idle cores (twice that on a busy machine). Deselect with ``-m 'not slow'``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

# scipy and mitsuba are test dependencies (pyproject's [test] extra): missing them is an
# error, never a skip.
import mitsuba  # noqa: E402,F401
import scipy  # noqa: E402,F401

import mitsuba_util as mu  # noqa: E402  (tests/ is on sys.path under pytest's default import mode)

import sssphere  # noqa: E402

BUNNY = "/usr/share/glmark2/models/bunny.obj"

RES = 48            # square images
BLOCK = 4           # block size for the statistics: 12 x 12 blocks
OUR_SPP = 2048      # one render of ours
MI_SPP = 128        # per Mitsuba render ...
MI_SEEDS = tuple(range(1000, 1016))  # ... times 16 seeds: the same 2048 samples per pixel
OUR_SEED = 20240601
ALPHA = 1e-3


def _camera(origin, res=RES, fov=30.0):
    return {"origin": list(origin), "target": [0, 0, 0], "up": [0, 1, 0], "fov": fov,
            "width": res, "height": res}


def scene_thin_sphere_point() -> dict:
    """(a) A low-density index-matched sphere lit by a point light up and to the right."""
    return {
        "camera": _camera([0, 0, 4]),
        "shapes": [{
            "sphere": {"center": [0, 0, 0], "radius": 1},
            "medium": {"sigma_t": [2, 2, 2], "albedo": [0.9, 0.85, 0.8], "g": 0.3},
            "boundary": {"type": "index_matched"},
        }],
        "lights": [{"type": "point", "position": [2.5, 2, 2.5], "intensity": [10, 10, 10]}],
    }


def scene_point_light_inside_sphere() -> dict:
    """(k) A point light inside an index-matched sphere, off its centre (a candle in wax).
    The shadow-ray roulette bounded every shadow ray's transmittance by the medium it must
    cross to leave, which a light inside does not: it came through almost never, with a huge
    weight, and the sphere rendered 40x too dark at this density (an outside sweep)."""
    return {
        "camera": _camera([0, 0, 2.5]),
        "shapes": [{
            "sphere": {"center": [0, 0, 0], "radius": 0.5},
            "medium": {"sigma_t": [20, 20, 20], "albedo": [0.9, 0.85, 0.8], "g": 0.0},
            "boundary": {"type": "index_matched"},
        }],
        "lights": [{"type": "point", "position": [0.1, 0.05, 0.0], "intensity": [1, 1, 1]}],
    }


def scene_point_light_inside_dielectric_sphere() -> dict:
    """(l) (k) behind glass: a point light inside a dielectric sphere (ior 1.5). Shadow rays
    never leave a dielectric, so its scattering events sampled no light and the sphere
    rendered 120x too dark (a review); they sample the light inside, and its radiance
    counts 1 / 1.5^2 on the camera's side (docs/notation.md, "No η² radiance scaling")."""
    scene = scene_point_light_inside_sphere()
    scene["shapes"][0]["boundary"] = {"type": "dielectric", "ior": 1.5}
    return scene


def scene_bunny_directional() -> dict:
    """(b) The bunny (normalized: largest side 1), moderate density, directional light."""
    return {
        "camera": _camera([0, 0.1, 2.6]),
        "shapes": [{
            "mesh": BUNNY, "normalize": True,
            "medium": {"sigma_t": [30, 30, 30], "albedo": [0.95, 0.92, 0.9], "g": 0.2},
            "boundary": {"type": "index_matched"},
        }],
        "lights": [{"type": "directional", "direction": [-0.5, -1, -0.6], "irradiance": [3, 3, 3]}],
    }


def scene_dielectric_sphere_area_env() -> dict:
    """(c) A dielectric (ior 1.5) sphere under a downward-facing area light, in a constant
    environment. Shadow rays cannot cross the dielectric boundary (in either renderer), so all
    light arrives through sampled refraction paths."""
    return {
        "camera": _camera([0, 0, 4]),
        "shapes": [{
            "sphere": {"center": [0, 0, 0], "radius": 1},
            "medium": {"sigma_t": [5, 5, 5], "albedo": [0.95, 0.9, 0.85], "g": 0.0},
            "boundary": {"type": "dielectric", "ior": 1.5},
        }],
        "lights": [
            # normalize(cross(edge1, edge2)) = (0, -1, 0): emits down, towards the sphere.
            {"type": "area", "corner": [-0.5, 1.6, -0.5], "edge1": [1, 0, 0], "edge2": [0, 0, 1],
             "radiance": [10, 10, 10]},
            {"type": "environment", "radiance": [0.2, 0.2, 0.2]},
        ],
    }


def scene_matched_sphere_area_env() -> dict:
    """(d) The index-matched counterpart of (c): here shadow rays do leave the medium, so the
    area light and the environment are reached both by next-event estimation and by phase
    sampling, and the MIS weights of both strategies matter (the dielectric scene gives the
    escaping path weight 1 after its specular boundary and never tests them)."""
    return {
        "camera": _camera([0, 0, 4]),
        "shapes": [{
            "sphere": {"center": [0, 0, 0], "radius": 1},
            "medium": {"sigma_t": [4, 4, 4], "albedo": [0.95, 0.9, 0.85], "g": 0.4},
            "boundary": {"type": "index_matched"},
        }],
        "lights": [
            {"type": "area", "corner": [-0.4, 1.4, -0.4], "edge1": [0.8, 0, 0], "edge2": [0, 0, 0.8],
             "radiance": [10, 10, 10]},
            {"type": "environment", "radiance": [0.2, 0.2, 0.2]},
        ],
    }


FLOOR = str(Path(__file__).resolve().parents[1] / "scenes" / "meshes" / "floor.obj")


def _floor(y: float, reflectance) -> dict:
    """An open two-triangle floor, 8 x 8, in the plane y: an opaque diffuse surface."""
    return {"mesh": FLOOR, "transform": {"scale": 8, "translate": [0, y, 0]},
            "surface": {"type": "diffuse", "reflectance": reflectance}}


def scene_floor_lights() -> dict:
    """(e) A diffuse floor alone, seen from above at an angle, under a point light, an area
    light and a constant environment: light sampling at a surface, and its MIS with BSDF
    sampling against the area light and the environment."""
    return {
        "camera": _camera([0, 2.5, 3]),
        "shapes": [_floor(-0.5, [0.7, 0.5, 0.3])],
        "lights": [
            {"type": "point", "position": [1, 1, 0.5], "intensity": [3, 3, 3]},
            {"type": "area", "corner": [-1.2, 0.6, -0.8], "edge1": [0.6, 0, 0],
             "edge2": [0, 0, 0.6], "radiance": [6, 6, 6]},
            {"type": "environment", "radiance": [0.3, 0.4, 0.5]},
        ],
    }


def scene_matched_sphere_on_floor() -> dict:
    """(f) An index-matched medium above a diffuse floor, a point light and an environment:
    light reaches the floor through the medium (shadow rays across the medium's boundary),
    the medium sees the floor's reflected light and casts a shadow on it."""
    return {
        "camera": _camera([0, 1.2, 4]),
        "shapes": [
            {"sphere": {"center": [0, 0.1, 0], "radius": 0.8},
             "medium": {"sigma_t": [3, 3, 3], "albedo": [0.95, 0.8, 0.6], "g": 0.3}},
            _floor(-0.75, [0.6, 0.6, 0.6]),
        ],
        "lights": [
            {"type": "point", "position": [1.5, 2.5, 1], "intensity": [12, 12, 12]},
            {"type": "environment", "radiance": [0.2, 0.2, 0.25]},
        ],
    }


def scene_dielectric_sphere_on_floor() -> dict:
    """(g) A dielectric medium above a diffuse floor under an area light: the floor's light
    enters the medium only through sampled refraction, and the floor sees the light both
    straight and through the dielectric (caustic paths found by BSDF sampling)."""
    return {
        "camera": _camera([0, 1.2, 4]),
        "shapes": [
            {"sphere": {"center": [0, 0.1, 0], "radius": 0.8},
             "medium": {"sigma_t": [4, 4, 4], "albedo": [0.9, 0.9, 0.8], "g": 0.0},
             "boundary": {"type": "dielectric", "ior": 1.4}},
            _floor(-0.75, [0.5, 0.6, 0.7]),
        ],
        "lights": [
            {"type": "area", "corner": [-0.5, 1.8, -0.5], "edge1": [1, 0, 0], "edge2": [0, 0, 1],
             "radiance": [8, 8, 8]},
            {"type": "environment", "radiance": [0.1, 0.1, 0.1]},
        ],
    }


def _asymmetric_sky(path: Path) -> str:
    """scenes/make_sky.py's sky without its sun disc, with a red patch to the right of the
    camera's view (+x) and a green one to its left, low over the horizon, and behind the
    object as the camera sees it (travel along -z: u = 0, where the map wraps around) stripes
    of 2 pixels of uneven colours: an image no mirror or turn maps onto itself, with detail
    where the camera sees the map itself."""
    import sys

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "scenes"))
    import make_sky

    img = make_sky.sky(96, sun_elevation=30, sun_azimuth=200, sun_radiance=1.0)
    h, w = img.shape[:2]
    img[h // 3: h // 2 - 2, w // 8: w // 4] = [2.0, 0.2, 0.1]         # phi ~ 30-90 deg: +x
    img[h // 4: h // 2 - 4, 5 * w // 8: 3 * w // 4] = [0.1, 1.5, 0.2]  # phi ~ 225-270: -x
    for x in range(-8, 8):  # around u = 0, across the seam
        img[h // 3: h // 2, x % w] *= [1.0, 0.4, 0.2] if (x // 2) % 2 else [0.3, 0.8, 1.6]
    sssphere.write_image(path, img)
    return str(path)


def scene_environment_map(map_path: str, rotate=None) -> dict:
    """(h) An index-matched medium on a diffuse floor lit by an environment map alone, seen
    with the map behind it: the background pixels must match Mitsuba's envmap exactly (the
    same orientation, the same bilinear lookup), and the lit object statistically (the
    map's importance sampling, MIS at the medium and at the floor)."""
    light = {"type": "environment", "map": map_path, "scale": 1.5}
    if rotate is not None:
        light["rotate_deg"] = rotate
    return {
        "camera": _camera([0, 0.6, 4], fov=40),
        "shapes": [
            {"sphere": {"center": [0, 0, 0], "radius": 0.7},
             "medium": {"sigma_t": [4, 5, 6], "albedo": [0.95, 0.9, 0.85], "g": 0.3}},
            _floor(-0.72, [0.5, 0.5, 0.5]),
        ],
        "lights": [light],
    }


def scene_rough_dielectric_sphere() -> dict:
    """(i) A rough dielectric (GGX alpha 0.25, ior 1.5) medium under a point light, an area
    light and a constant environment: light enters only at boundary vertices, by light
    sampling through the rough BSDF (a delta light, an area light with MIS) and by sampled
    refraction; the point light's glossy highlight comes from light sampling alone."""
    return {
        "camera": _camera([0, 0.5, 4]),
        "shapes": [{
            "sphere": {"center": [0, 0, 0], "radius": 1},
            "medium": {"sigma_t": [5, 5, 5], "albedo": [0.95, 0.9, 0.85], "g": 0.2},
            "boundary": {"type": "dielectric", "ior": 1.5, "roughness": 0.25},
        }],
        "lights": [
            {"type": "point", "position": [1.5, 2, 2], "intensity": [10, 10, 10]},
            {"type": "area", "corner": [-1.5, 1.6, -0.5], "edge1": [0, 0, 1], "edge2": [1, 0, 0],
             "radiance": [6, 6, 6]},
            {"type": "environment", "radiance": [0.15, 0.15, 0.2]},
        ],
    }


def scene_rough_dielectric_on_floor(map_path: str) -> dict:
    """(j) Everything together: a rough dielectric (alpha 0.1, ior 1.33) medium on a diffuse
    floor, lit by an environment map and a directional light (a sun): NEE at medium-less
    boundary vertices, at the floor and from the map, with MIS wherever a light can be hit."""
    return {
        "camera": _camera([0, 0.8, 4], fov=40),
        "shapes": [
            {"sphere": {"center": [0, 0, 0], "radius": 0.7},
             "medium": {"sigma_t": [4, 5, 6], "albedo": [0.95, 0.9, 0.85], "g": 0.3},
             "boundary": {"type": "dielectric", "ior": 1.33, "roughness": 0.1}},
            _floor(-0.72, [0.5, 0.5, 0.5]),
        ],
        "lights": [
            {"type": "environment", "map": map_path, "scale": 1.0},
            {"type": "directional", "direction": [-0.4, -1, -0.3], "irradiance": [2, 2, 2]},
        ],
    }


def _halves(img: np.ndarray) -> tuple[float, float, float, float]:
    g = img.mean(axis=2)
    h, w = g.shape
    return g[:, : w // 2].mean(), g[:, w // 2:].mean(), g[: h // 2].mean(), g[h // 2:].mean()


@pytest.mark.slow
def test_camera_orientation_matches(tmp_path):
    """Before any statistics: the two renderers' images are not mirrored or flipped. A sphere
    off to the right (+x), lit by a point light up and to the right: both renderers must put
    the bright side in the top right of the image."""
    sd = {
        "camera": _camera([0, 0, 4], res=32),
        "shapes": [{
            "sphere": {"center": [0.3, 0, 0], "radius": 0.8, "subdivisions": 4},
            "medium": {"sigma_t": [2, 2, 2], "albedo": [0.9, 0.9, 0.9], "g": 0.0},
            "boundary": {"type": "index_matched"},
        }],
        "lights": [{"type": "point", "position": [3, 2, 3], "intensity": [10, 10, 10]}],
    }
    ours_scene = sssphere.load_scene(sd)
    ours = sssphere.render_full(ours_scene, spp=64, seed=1).image
    theirs = mu.render_mitsuba(mu.load_mitsuba_scene(sd, ours_scene, tmp_path, 64), 64, 1)
    for name, img in (("ours", ours), ("mitsuba", theirs)):
        left, right, top, bottom = _halves(img)
        assert right > 2 * left, f"{name}: right half {right} not brighter than left {left}"
        assert top > 1.2 * bottom, f"{name}: top half {top} not brighter than bottom {bottom}"
    # Same picture, up to noise: the half-image means agree to a few per cent.
    np.testing.assert_allclose(_halves(ours), _halves(theirs), rtol=0.05)


def _check(scene_dict: dict) -> None:
    run = mu.compare_with_mitsuba(
        scene_dict, our_spp=OUR_SPP, mitsuba_spp=MI_SPP, mitsuba_seeds=MI_SEEDS, block=BLOCK,
        our_seed=OUR_SEED, alpha=ALPHA,
    )
    c = run.comparison
    print(f"\n{c.summary()}\nours {run.ours_seconds:.1f}s ({run.ours_events_per_path:.1f} "
          f"events/path), mitsuba {run.mitsuba_seconds:.1f}s for {len(MI_SEEDS)} renders")
    assert c.dof.min() >= 20, f"too few blocks with signal: {c.dof}"
    # Blocks with no variance in either renderer (pure background) must agree exactly.
    scale = max(float(np.max(np.abs(c.mean_theirs))), 1e-30)
    assert c.zero_var_max_abs_diff <= 1e-5 * scale + 1e-7, c.summary()
    assert c.chi2_ok, c.summary()
    assert c.z_ok, c.summary()


@pytest.mark.slow
def test_thin_sphere_point_light_matches_mitsuba():
    _check(scene_thin_sphere_point())


@pytest.mark.slow
def test_point_light_inside_a_medium_matches_mitsuba():
    _check(scene_point_light_inside_sphere())


@pytest.mark.slow
def test_point_light_inside_a_dielectric_medium_matches_mitsuba():
    _check(scene_point_light_inside_dielectric_sphere())


@pytest.mark.slow
def test_bunny_directional_light_matches_mitsuba():
    _check(scene_bunny_directional())


@pytest.mark.slow
def test_dielectric_sphere_area_and_environment_matches_mitsuba():
    _check(scene_dielectric_sphere_area_env())


@pytest.mark.slow
def test_index_matched_sphere_area_and_environment_matches_mitsuba():
    _check(scene_matched_sphere_area_env())


@pytest.mark.slow
def test_diffuse_floor_matches_mitsuba():
    _check(scene_floor_lights())


@pytest.mark.slow
def test_index_matched_sphere_on_diffuse_floor_matches_mitsuba():
    _check(scene_matched_sphere_on_floor())


@pytest.mark.slow
def test_dielectric_sphere_on_diffuse_floor_matches_mitsuba():
    _check(scene_dielectric_sphere_on_floor())


@pytest.mark.slow
def test_environment_map_matches_mitsuba(tmp_path):
    _check(scene_environment_map(_asymmetric_sky(tmp_path / "sky.exr")))


@pytest.mark.slow
def test_rotated_environment_map_matches_mitsuba(tmp_path):
    _check(scene_environment_map(_asymmetric_sky(tmp_path / "sky.exr"), rotate=[10, 75, -5]))


@pytest.mark.slow
def test_rough_dielectric_sphere_matches_mitsuba():
    _check(scene_rough_dielectric_sphere())


@pytest.mark.slow
def test_rough_dielectric_on_floor_under_sky_and_sun_matches_mitsuba(tmp_path):
    _check(scene_rough_dielectric_on_floor(_asymmetric_sky(tmp_path / "sky.exr")))
