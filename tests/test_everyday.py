"""Everyday use (issue 24): first-hit AOVs and multilayer EXR, denoising, editable scenes,
animations, shapes from numpy arrays."""

import copy
import dataclasses
import math
import re
import sys
import threading
import time

import numpy as np
import pytest

import sssphere
from sssphere import SceneError

REPO = __import__("pathlib").Path(__file__).resolve().parents[1]


def _aov_scene():
    """A ball of a medium stated by its colour, a diffuse floor under it and an area light
    in view, on a black background: each first-hit case in one 48x32 image."""
    return {
        "camera": {"origin": [0, 0.5, 5], "target": [0, 0.2, 0], "fov": 40, "width": 48,
                   "height": 32},
        "shapes": [
            {"name": "ball", "sphere": {"center": [0, 0, 0], "radius": 1, "subdivisions": 5},
             "medium": {"color": [0.2, 0.5, 0.8], "mean_free_path": [0.1, 0.1, 0.1], "g": 0.6},
             "boundary": {"type": "dielectric", "ior": 1.4}},
            {"name": "floor", "mesh": str(REPO / "scenes/meshes/floor.obj"),
             "transform": {"scale": 20, "translate": [0, -1, 0]},
             "surface": {"type": "diffuse", "reflectance": [0.3, 0.6, 0.9]}},
        ],
        "lights": [{"type": "area", "corner": [1.2, 1.0, 0], "edge1": [0.6, 0, 0],
                    "edge2": [0, 0.6, 0], "radiance": [5, 5, 5]}],
        "render": {"spp": 4, "seed": 3},
    }


def _ray(scene_dict, x, y):
    """The camera ray through the centre of pixel (x, y), as render/camera.h makes it."""
    cam = scene_dict["camera"]
    o, t = np.array(cam["origin"], float), np.array(cam["target"], float)
    f = (t - o) / np.linalg.norm(t - o)
    r = np.cross(f, [0, 1, 0])
    r /= np.linalg.norm(r)
    u = np.cross(r, f)
    th = math.tan(math.radians(cam["fov"]) / 2)
    w, h = cam["width"], cam["height"]
    d = f + r * (2 * (x + 0.5) / w - 1) * th * w / h + u * (1 - 2 * (y + 0.5) / h) * th
    return o, d / np.linalg.norm(d)


def test_first_hit_aovs_see_the_medium_colour_the_surface_the_light_and_nothing():
    d = _aov_scene()
    scene = sssphere.load_scene(d)
    a = sssphere.first_hit_aovs(scene, seed=3, samples=16)
    assert a["albedo"].shape == (32, 48, 3) and a["depth"].shape == (32, 48)
    # The ball's centre pixel: every ray hits the ball. Its albedo is the multiple-scattering
    # albedo of the medium, which `color` states: the forward fit inverts the inversion.
    o, ray = _ray(d, 24, 19)
    cy, cx = 19, 24
    assert a["depth"][cy, cx] > 0
    hit = o + ray * a["depth"][cy, cx]
    assert abs(np.linalg.norm(hit) - 1) < 2e-3  # on the (icosphere) ball
    np.testing.assert_allclose(a["albedo"][cy, cx], [0.2, 0.5, 0.8], atol=1e-4)
    n = a["normal"][cy, cx]
    np.testing.assert_allclose(n, hit / np.linalg.norm(hit), atol=0.02)
    assert np.dot(n, ray) < 0  # faces the camera
    # Bottom corner: the floor, its reflectance; normal up.
    np.testing.assert_allclose(a["albedo"][31, 0], [0.3, 0.6, 0.9], atol=1e-6)
    np.testing.assert_allclose(a["normal"][31, 0], [0, 1, 0], atol=1e-5)
    # The area light: albedo 1. Top-left corner: nothing, all zero.
    lit = np.all(a["albedo"] == 1.0, axis=2)
    assert lit.sum() > 4
    assert np.all(a["albedo"][0, 0] == 0) and np.all(a["normal"][0, 0] == 0)
    assert a["depth"][0, 0] == 0


def test_aovs_do_not_depend_on_threads_and_follow_the_seed():
    scene = sssphere.load_scene(_aov_scene())
    one = sssphere.first_hit_aovs(scene, seed=3, samples=4, threads=1)
    two = sssphere.first_hit_aovs(scene, seed=3, samples=4, threads=2)
    other = sssphere.first_hit_aovs(scene, seed=4, samples=4, threads=2)
    for k in ("albedo", "normal", "depth"):
        np.testing.assert_array_equal(one[k], two[k])
    assert not np.array_equal(one["depth"], other["depth"])  # antialiased edges move


def test_render_full_aovs_and_multilayer_exr_round_trip(tmp_path):
    r = sssphere.render_full(_aov_scene(), aovs=True)
    a = sssphere.first_hit_aovs(_aov_scene(), seed=3, samples=4)  # min(spp, 16) rays
    np.testing.assert_array_equal(r.albedo, a["albedo"])
    np.testing.assert_array_equal(r.depth, a["depth"])
    written = r.save(tmp_path / "x.exr", aovs=True)
    assert written == [str(tmp_path / "x.exr")]  # one file
    layers = sssphere.read_layers(tmp_path / "x.exr")
    assert set(layers) == {"", "variance", "events", "albedo", "normal", "depth"}
    np.testing.assert_array_equal(layers[""], r.image)
    np.testing.assert_array_equal(layers["variance"], r.variance)
    np.testing.assert_array_equal(layers["events"][:, :, 0], r.events)
    np.testing.assert_array_equal(layers["albedo"], r.albedo)
    np.testing.assert_array_equal(layers["normal"], r.normal)
    np.testing.assert_array_equal(layers["depth"][:, :, 0], r.depth)
    # Beside a .png: one file per layer.
    written = r.save(tmp_path / "y.png", aovs=True)
    assert sorted(p.rsplit("/", 1)[1] for p in written) == sorted(
        ["y.png", "y_variance.exr", "y_events.exr", "y_albedo.exr", "y_normal.exr",
         "y_depth.exr"])
    np.testing.assert_array_equal(sssphere.read_image(tmp_path / "y_normal.exr"), r.normal)
    # Its repr names every field and each array by dtype and shape, not its numbers.
    text = repr(r)
    h, w = r.image.shape[:2]
    assert f"image=<float32 array ({h}, {w}, 3)>" in text and f"depth=<float32 array ({h}, {w})>" in text
    assert all(f"{f.name}=" in text for f in dataclasses.fields(r))
    assert len(text) < 1500, text


def test_read_layers_refuses_what_is_not_an_exr(tmp_path):
    (tmp_path / "a.exr").write_bytes(b"not an exr at all")
    with pytest.raises(SceneError, match="a.exr"):
        sssphere.read_layers(tmp_path / "a.exr")
    with pytest.raises(SceneError, match=r"\.exr"):
        sssphere.write_layers(tmp_path / "a.png", [("", ("R", "G", "B"),
                                                   np.zeros((2, 2, 3), np.float32))])
    # A channel named twice (here "a.Y" from two layers) is refused, not mixed up.
    one = np.zeros((2, 2, 1), np.float32)
    with pytest.raises(SceneError, match="channel 'a.Y' is given twice"):
        sssphere.write_layers(tmp_path / "b.exr", [("a", ("Y",), one), ("a", ("Y",), one + 1)])
    assert not (tmp_path / "b.exr").exists()


def _relative_mse(image, reference):
    return float(np.mean((image - reference) ** 2) / np.mean(reference ** 2))


def test_denoising_brings_a_noisy_render_closer_to_the_converged_one():
    pytest.importorskip("pyoidn", reason="the denoise extra (pyoidn) is not installed")
    d = _aov_scene()
    d["camera"].update(width=96, height=64)
    d["lights"].append({"type": "environment", "radiance": [0.3, 0.3, 0.3]})
    reference = sssphere.render(d, spp=1024, seed=11)
    noisy = sssphere.render_full(d, spp=4, seed=1, denoise=True)
    assert noisy.denoised is not None and noisy.denoised.shape == noisy.image.shape
    assert np.all(np.isfinite(noisy.denoised))
    before, after = _relative_mse(noisy.image, reference), _relative_mse(noisy.denoised, reference)
    # Denoising must remove most of the noise: the reference's own noise (1024 spp against
    # 4) is 1/256 of the noisy image's, so the denoised error is the denoiser's bias alone.
    assert after < 0.5 * before, (before, after)
    # render(denoise=True) returns the same denoised picture.
    np.testing.assert_array_equal(sssphere.render(d, spp=4, seed=1, denoise=True),
                                  noisy.denoised)


def test_denoise_without_the_extra_says_how_to_install_it(monkeypatch):
    monkeypatch.setitem(sys.modules, "pyoidn", None)  # import pyoidn now raises ImportError
    with pytest.raises(ImportError, match=r"sssphere\[denoise\]"):
        sssphere.render_full(_aov_scene(), denoise=True)
    with pytest.raises(ImportError, match=r"sssphere\[denoise\]"):
        sssphere.denoise(np.zeros((4, 4, 3), np.float32))


def test_denoise_checks_its_inputs():
    img = np.zeros((4, 5, 3), np.float32)
    with pytest.raises(ValueError, match="albedo and normal together"):
        sssphere.denoise(img, albedo=img)
    with pytest.raises(ValueError, match=r"normal must have the image's shape \(4, 5, 3\), got \(4, 4, 3\)"):
        sssphere.denoise(img, albedo=img, normal=np.zeros((4, 4, 3), np.float32))
    for bad in ((4, 5, 2), (0, 5, 3)):  # the image itself, said once (and before pyoidn)
        with pytest.raises(ValueError, match=r"image must have shape \(height, width, 3\).*got " + re.escape(str(bad))):
            sssphere.denoise(np.zeros(bad, np.float32))
    with pytest.raises(ValueError, match="non-finite"):
        sssphere.denoise(np.full((4, 5, 3), np.nan, np.float32))


# --- editable scenes ---------------------------------------------------------------------


def _renders_like_a_fresh_load(scene, integrator="pt"):
    """The edited scene renders what loading its dict afresh renders, bit for bit."""
    edited = sssphere.render(scene, integrator=integrator, spp=2)
    fresh = sssphere.render(sssphere.load_scene(scene.to_dict(), base_dir=scene.base_dir),
                            integrator=integrator, spp=2)
    np.testing.assert_array_equal(edited, fresh)
    return edited


@pytest.mark.parametrize("integrator", ["pt", "st"])
def test_material_light_and_camera_edits_rebuild_nothing(small_scene, integrator):
    small_scene["shapes"][0]["medium"]["sigma_t"] = [60, 60, 60]  # deep enough for st steps
    scene = sssphere.load_scene(small_scene)
    before = sssphere.render(scene, integrator=integrator, spp=2)
    scene.shapes[0].medium.albedo = [0.5, 0.7, 0.9]
    assert scene.rebuilt == []
    scene.shapes[0].medium.g = 0.5
    scene.lights[0].intensity = [20, 5, 5]
    scene.camera.fov = 25
    scene.render.seed = 7
    assert scene.rebuilt == []
    after = _renders_like_a_fresh_load(scene, integrator)
    assert not np.array_equal(before, after)
    assert scene.shapes[0].medium.g == 0.5 and scene.camera.fov == 25
    assert scene.shapes[0].medium.albedo == [0.5, 0.7, 0.9]
    np.testing.assert_array_equal(np.asarray(scene.lights[0].intensity), [20, 5, 5])


def test_geometry_edits_rebuild_the_bvh_and_grid_and_say_so(small_scene):
    scene = sssphere.load_scene(small_scene)
    scene.shapes[0].transform = {"scale": 0.8}
    assert "BVH" in scene.rebuilt
    assert any("distance grid of shape 'ball' (its mesh changed)" in r for r in scene.rebuilt)
    _renders_like_a_fresh_load(scene)
    # An area light's quad is in the BVH; the ball's grid stays.
    scene.lights = [{"type": "area", "corner": [-1, 2, -1], "edge1": [2, 0, 0],
                     "edge2": [0, 0, 2], "radiance": [2, 2, 2]}]
    assert scene.rebuilt == ["BVH"]
    scene.lights[0].corner = [-1, 2.5, -1]
    assert scene.rebuilt == ["BVH"]
    _renders_like_a_fresh_load(scene)


def test_a_density_change_that_changes_the_grid_resolution_rebuilds_that_grid(small_scene):
    scene = sssphere.load_scene(small_scene)
    assert scene.grid_resolutions == [16]  # 10 mean free paths across: one per cell
    scene.shapes[0].medium.sigma_t = 20  # 40 across
    assert scene.grid_resolutions == [64]
    scene.shapes[0].medium.sigma_t = 600  # a 64th of the side is now 10-30 mean free paths
    assert scene.grid_resolutions == [128]
    assert scene.rebuilt == ["distance grid of shape 'ball' (64 -> 128 cells: the resolution "
                             "follows sigma_t unless render.grid_resolution sets it)"]
    scene.render.grid_resolution = 128
    scene.shapes[0].medium.sigma_t = 5
    assert scene.rebuilt == []


def test_a_bad_assignment_raises_the_files_error_and_changes_nothing(small_scene):
    scene = sssphere.load_scene(small_scene)
    before = sssphere.render(scene)
    bad = copy.deepcopy(small_scene)
    bad["shapes"][0]["medium"]["albedo"] = [0.5, 1.5, 0.5]
    with pytest.raises(SceneError) as from_dict:
        sssphere.load_scene(bad)
    with pytest.raises(SceneError) as from_edit:
        scene.shapes[0].medium.albedo = [0.5, 1.5, 0.5]
    assert str(from_edit.value) == str(from_dict.value)
    assert "shapes[0].medium.albedo" in str(from_edit.value)
    with pytest.raises(SceneError, match="not a finite number"):
        scene.camera.fov = float("nan")
    # JSON has no complex numbers or sets: named, not json.dumps's TypeError
    with pytest.raises(SceneError, match=r"camera\.origin\[0\]: a complex is not a scene value"):
        scene.camera.origin = np.array([0, 0, 4], dtype=complex)
    bad = copy.deepcopy(small_scene)
    bad["shapes"][0]["medium"]["sigma_t"] = {1, 2}
    with pytest.raises(SceneError, match=r"<dict>: shapes\[0\]\.medium\.sigma_t: a set is not"):
        sssphere.load_scene(bad)
    with pytest.raises(IndexError, match=r"shapes\[3\]: no such field"):
        scene.shapes[3].medium.g = 0.1
    with pytest.raises(SceneError, match=r"shapes\[0\]\.medium\.nonsense: unknown"):
        scene.shapes[0].medium.nonsense = 1
    # A misspelt block was a new Python attribute that changed nothing
    with pytest.raises(SceneError, match=r"<dict>: lightz: no such field in the scene \(allowed: "
                                         r"camera, shapes, lights, render\)"):
        scene.lightz = []
    assert "lightz" not in scene.to_dict() and not hasattr(scene, "lightz")
    with pytest.raises(AttributeError, match="shapes\\[0\\].medium.nonsense"):
        scene.shapes[0].medium.nonsense  # noqa: B018 (reading it raises)
    with pytest.raises(SceneError, match="camera.origin.*inside shape 'ball'"):
        scene.camera.origin = [0.1, 0, 0.5]
    np.testing.assert_array_equal(sssphere.render(scene), before)
    assert scene.to_dict() == small_scene


def test_shapes_from_numpy_arrays_render_like_their_mesh_file(small_scene, tmp_path):
    ball = sssphere.load_scene(small_scene)
    v, f = ball.shape_mesh(0)
    obj = tmp_path / "ball.obj"
    obj.write_text("".join(f"v {x!r} {y!r} {z!r}\n" for x, y, z in v.astype(float).tolist())
                   + "".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in f))
    from_file, from_arrays = copy.deepcopy(small_scene), copy.deepcopy(small_scene)
    del from_file["shapes"][0]["sphere"], from_arrays["shapes"][0]["sphere"]
    from_file["shapes"][0]["mesh"] = str(obj)
    from_arrays["shapes"][0].update(vertices=v, faces=f)
    np.testing.assert_array_equal(sssphere.render(from_arrays), sssphere.render(from_file))
    # Bad arrays are named.
    broken = copy.deepcopy(from_arrays)
    broken["shapes"][0]["faces"] = f[:-1]  # an open mesh
    with pytest.raises(SceneError, match=r"shapes\[0\].*open"):
        sssphere.load_scene(broken)
    broken["shapes"][0]["faces"] = np.array([[0, 1, len(v)]])
    with pytest.raises(SceneError, match=r"shapes\[0\]\.faces\[0\]\[2\].*index into 'vertices'"):
        sssphere.load_scene(broken)


# --- animation ---------------------------------------------------------------------------


def test_orbit_cameras_circle_the_target(small_scene):
    scene = sssphere.load_scene(small_scene)
    cams = sssphere.orbit_cameras(scene, 4)
    assert cams[0]["origin"] == pytest.approx([0, 0, 4])
    assert cams[1]["origin"] == pytest.approx([4, 0, 0], abs=1e-12)  # a quarter turn about +y
    assert cams[2]["origin"] == pytest.approx([0, 0, -4], abs=1e-12)
    assert all(c["target"] == [0, 0, 0] and c["fov"] == 30 for c in cams)


def test_api_arguments_taken_and_refused_as_the_rest_of_the_api_does(small_scene, tmp_path):
    """A review found these out of line with the rest of the API: orbit_cameras refused a
    NumPy integer (spp, seed and threads take them), first_hit_aovs refused threads=None
    (render takes it: all cores), write_image did not say which shape it got, and an
    image's path that is a directory was "not a image file"."""
    scene = sssphere.load_scene(small_scene)
    assert sssphere.orbit_cameras(scene, np.int64(3)) == sssphere.orbit_cameras(scene, 3)
    for bad in (True, 2.0, 0):
        with pytest.raises(ValueError, match="frames must be an integer >= 1"):
            sssphere.orbit_cameras(scene, bad)
    np.testing.assert_array_equal(sssphere.first_hit_aovs(scene, threads=None)["depth"],
                                  sssphere.first_hit_aovs(scene, threads=1)["depth"])
    with pytest.raises(SceneError, match=r"x\.exr: image must have shape \(height, width, 3\) "
                       r"or \(height, width, 1\), got \(4, 4, 4\)"):
        sssphere.write_image(tmp_path / "x.exr", np.ones((4, 4, 4), np.float32))
    with pytest.raises(SceneError, match="is a directory, not an image file"):
        sssphere.read_image(tmp_path)


def test_render_frames_renders_each_camera_with_one_progress(small_scene):
    scene = sssphere.load_scene(small_scene)
    cams = sssphere.orbit_cameras(scene, 3)
    seen, finished = [], []
    frames = sssphere.render_frames(scene, cams, progress=seen.append,
                                    on_frame=lambda k, r: finished.append(k), spp=2)
    assert len(frames) == 3 and finished == [0, 1, 2]
    assert scene.rebuilt == [] and scene.camera.to_python() == small_scene["camera"]
    for cam, result in zip(cams, frames):
        alone = copy.deepcopy(small_scene)
        alone["camera"] = cam
        np.testing.assert_array_equal(result.image, sssphere.render(alone, spp=2))
    assert seen == sorted(seen) and seen[-1] <= 1.0 and seen[-1] > 2 / 3


# --- sssphere info -----------------------------------------------------------------------


@pytest.mark.parametrize("boundary", [{"type": "index_matched"},
                                      {"type": "dielectric", "ior": 1.4}])
def test_info_predicts_the_events_of_paths_entering_a_ball_where_theory_is_exact(boundary):
    """Without absorption, a path entering a body under uniform isotropic light scatters
    sigma_t 4 eta^2 V/S times on average, whatever g (docs/info.md). A sphere seen from
    far away is lit so (a parallel beam over its disk is uniform isotropic incidence on
    a sphere): the render's mean events per entering path must match within its noise."""
    from sssphere.info import scene_info

    far = 200.0
    d = {"camera": {"origin": [0, 0, far], "target": [0, 0, 0],
                    "fov": 2 * math.degrees(math.atan(1.05 / far)), "width": 32, "height": 32},
         "shapes": [{"name": "ball", "sphere": {"center": [0, 0, 0], "radius": 1},
                     "medium": {"sigma_t": 20, "albedo": 1.0, "g": 0.5}, "boundary": boundary}],
         "lights": [{"type": "environment", "radiance": 1}], "render": {"spp": 16, "seed": 1}}
    scene = sssphere.load_scene(d)
    predicted = scene_info(scene)["shapes"][0]["pt_events"]
    r = sssphere.render_full(scene, record_paths=True)
    # The render's own rays (same seed): the albedo AOV is the share of them that hit the
    # ball (its albedo is 1), so this counts the entering paths exactly.
    hits = sssphere.first_hit_aovs(scene, seed=1, samples=16)["albedo"][..., 0].sum() * 16
    events = r.path_events.astype(np.float64)
    measured = events.sum() / hits
    sigma = events[events > 0].std() / math.sqrt(hits)
    assert abs(measured - predicted) < 4 * sigma + 0.005 * predicted, (measured, predicted, sigma)



def test_info_counts_the_clearance_of_steps_under_point_lights(small_scene):
    """st's default NEE keeps a step 10 mean free paths from the boundary where its events
    sample a point light (index-matched): info's share of the volume deep enough to step
    shrinks as the renderer's does, and only there (not without the point light, nor behind
    a dielectric)."""
    from sssphere.info import scene_info

    small_scene["shapes"][0]["medium"]["sigma_t"] = 60

    def deep(edit=lambda s: None):
        scene = copy.deepcopy(small_scene)
        edit(scene)
        return scene_info(sssphere.load_scene(scene))["shapes"][0]["deep_fraction"]

    cleared = deep()
    assert 0 < cleared < deep(lambda s: s["lights"].pop(0))  # the point light removed
    assert cleared < deep(lambda s: s["shapes"][0].update(
        boundary={"type": "dielectric", "ior": 1.4}))

def test_info_predicts_no_steps_in_a_medium_the_models_were_not_trained_for(small_scene,
                                                                            models_with):
    """st renders such a medium as pt does, and says so; info predicted sphere steps there."""
    from sssphere.info import format_info, scene_info

    small_scene["shapes"][0]["medium"]["sigma_t"] = 60
    small_scene["render"]["models"] = str(models_with(g=[-0.2, 0.2]))  # the ball's g is 0.3
    info = scene_info(sssphere.load_scene(small_scene))
    ball = info["shapes"][0]
    assert ball["st_untrained"] and ball["st_steps"] == 0, ball
    assert ball["st_events"] == ball["pt_events"] and ball["deep_fraction"] == 0, ball
    assert "none: the sphere-step models were not trained for this medium" in format_info(info)
    assert "shapes[0] ('ball')" in info["st_warnings"][0]
    del small_scene["render"]["models"]
    trained = scene_info(sssphere.load_scene(small_scene))["shapes"][0]
    assert not trained["st_untrained"] and trained["st_steps"] > 0, trained


def test_info_names_the_surfaces_a_medium_meets():
    """A cube resting on a floor meets it (docs/scene-format.md, "Scene rules"): info names
    the floor under the cube, and nothing once the cube is lifted off it."""
    from bench.robustness import cube_on_floor
    from sssphere.info import format_info, scene_info

    info = scene_info(sssphere.load_scene(cube_on_floor(0.0)))
    assert info["shapes"][0]["surfaces_meeting"] == [1], info["shapes"][0]
    assert "meets the opaque surface(s) 'floor': resting on one as across a gap" in \
        format_info(info)
    info = scene_info(sssphere.load_scene(cube_on_floor(1e-3)))
    assert info["shapes"][0]["surfaces_meeting"] == []
    assert "meets the opaque surface" not in format_info(info)


def test_info_says_when_st_cannot_render_the_scene(small_scene, tmp_path):
    """Without sphere-step models st cannot render: info keeps the transport-theory
    estimates and says why, in the text and as st_error."""
    from sssphere.info import format_info, scene_info

    small_scene["render"]["models"] = str(tmp_path)  # an empty directory
    info = scene_info(sssphere.load_scene(small_scene))
    assert info["st_error"] and str(tmp_path) in info["st_error"], info["st_error"]
    assert f"st cannot render this scene: {info['st_error']}" in format_info(info)
    assert info["shapes"][0]["pt_events"] > 0


def test_info_command_describes_the_scene(small_scene, tmp_path):
    import json
    import subprocess

    (tmp_path / "s.json").write_text(json.dumps(small_scene))
    r = subprocess.run([sys.executable, "-m", "sssphere.cli", "info", str(tmp_path / "s.json"),
                        "--set", "shapes[0].medium.sigma_t=50"],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert "shape 'ball': medium" in r.stdout and "sigma_t 50 per unit" in r.stdout, r.stdout
    assert "pt: ~" in r.stdout and "sphere steps" in r.stdout and "lights: point, environment" \
        in r.stdout, r.stdout
    r = subprocess.run([sys.executable, "-m", "sssphere.cli", "info", str(tmp_path / "s.json"),
                        "--json"], capture_output=True, text=True, timeout=300)
    info = json.loads(r.stdout)
    ball = info["shapes"][0]
    assert ball["triangles"] == 1280 and ball["grid_resolution"] == 16  # sigma_t 5: 10 mfp across
    assert ball["mean_path_length"] == pytest.approx(4 * ball["volume"] / ball["area"])
    assert 0 < ball["coverage"] < 1 and info["lights"] == ["point", "environment"]


def test_an_edit_while_the_scene_renders_is_refused_and_the_render_unchanged(small_scene):
    """A material or light edited while another thread renders the same scene changed that
    render part-way (a data race in C++). Such an edit is now refused, naming the field;
    the render equals one of the unedited scene, and the edit works once it has returned."""
    scene = sssphere.load_scene(small_scene)
    expected = sssphere.render(sssphere.load_scene(small_scene), spp=64, seed=3)
    started, edited = threading.Event(), threading.Event()
    errors = []

    def progress(fraction):
        started.set()
        edited.wait(timeout=60)  # the render goes on only once the edit was tried
        return True

    def edit():
        started.wait(timeout=60)
        for field, value in (("sigma_t", 100), ("albedo", 0.5)):
            try:
                setattr(scene.shapes[0].medium, field, value)
            except SceneError as e:
                errors.append(str(e))
        try:
            scene.lights[0].intensity = 100
        except SceneError as e:
            errors.append(str(e))
        edited.set()

    editor = threading.Thread(target=edit)
    editor.start()
    got = sssphere.render_full(scene, spp=64, seed=3, progress=progress)
    editor.join()
    np.testing.assert_array_equal(got.image, expected)
    assert len(errors) == 3, errors
    assert "shapes[0].medium.sigma_t: cannot be changed while the scene is being rendered" \
        in errors[0], errors
    assert "lights[0].intensity" in errors[2]
    scene.shapes[0].medium.sigma_t = 100  # the render has returned
    assert scene.shapes[0].medium.sigma_t == 100


def test_edits_from_two_threads_are_both_kept(small_scene, monkeypatch):
    """An edit copied the scene's description before taking the scene's lock, so a second
    thread's edit made while the first one rebuilt started from the old description and
    dropped the first (a review: 8-19 of 30 barrier-started pairs lost one). Here the first
    edit's rebuild waits a little once the second has started: both must be kept."""
    scene = sssphere.load_scene(small_scene)
    rebuilding, second_started = threading.Event(), threading.Event()
    real = sssphere.Scene._rebuild

    def slow_rebuild(self, *args):
        if not rebuilding.is_set():  # the first edit only
            rebuilding.set()
            second_started.wait(timeout=60)
            time.sleep(0.3)  # long enough for the second edit to copy a stale description
        return real(self, *args)

    monkeypatch.setattr(sssphere.Scene, "_rebuild", slow_rebuild)

    def second():
        rebuilding.wait(timeout=60)
        second_started.set()
        scene.camera.fov = 41

    other = threading.Thread(target=second)
    other.start()
    scene.shapes[0].medium.albedo = 0.5
    other.join()
    assert scene.shapes[0].medium.albedo == 0.5 and scene.camera.fov == 41, scene.to_dict()
    expected = sssphere.load_scene(scene.to_dict(), base_dir=scene.base_dir)
    np.testing.assert_array_equal(sssphere.render(scene, spp=4, seed=1),
                                  sssphere.render(expected, spp=4, seed=1))


def test_a_render_from_another_thread_waits_for_render_frames(small_scene):
    """render_frames sets the scene's camera between its frames. A render of the scene from
    another thread in the meantime rendered from a frame's camera, and its running made
    render_frames' next camera change (or the restoring one) fail, losing the frames (a
    review). That render now waits for render_frames: it sees the scene's own camera, and
    the frames are those of their cameras."""
    scene = sssphere.load_scene(small_scene)
    cameras = [{"origin": [0.5, 0.2, 4.0]}, {"origin": [-0.4, 0.3, 4.0]}]
    alone = [sssphere.render(sssphere.load_scene({**small_scene, "camera": {
        **small_scene["camera"], **c}}), spp=8, seed=2) for c in cameras]
    own = sssphere.render(sssphere.load_scene(small_scene), spp=8, seed=2)
    other_started, other_image = threading.Event(), []

    def other():
        other_started.set()
        other_image.append(sssphere.render(scene, spp=8, seed=2))

    thread = threading.Thread(target=other)

    def on_frame(k, result):
        if k == 0:
            thread.start()
            other_started.wait(timeout=60)
            time.sleep(0.3)  # the other render would run now, from this frame's camera

    frames = sssphere.render_frames(scene, cameras, on_frame=on_frame, spp=8, seed=2)
    thread.join()
    for k in range(2):
        np.testing.assert_array_equal(frames[k].image, alone[k], err_msg=f"frame {k}")
    np.testing.assert_array_equal(other_image[0], own)
    assert scene.camera.to_python() == small_scene["camera"]
