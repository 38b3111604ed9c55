"""Bad input gets a clear error naming the file, the field, the value and what is allowed:
never a crash, a hang or a NaN image."""

import copy
import json
import math
import os
import re
import subprocess
import sys
import warnings

import numpy as np
import pytest

import sssphere
from sssphere import SceneError
from sssphere.scene import load_scene_with


def error_of(scene, **kwargs):
    with pytest.raises(SceneError) as info:
        s = sssphere.load_scene(scene, **kwargs)
        sssphere.render(s, spp=1)
    return str(info.value)


@pytest.mark.parametrize(
    "edit, expected",
    [
        (lambda s: s["camera"].update(zoom=2), ["camera.zoom", "unknown key", "allowed here"]),
        (lambda s: s.update(materials=[]), ["materials", "unknown key"]),
        (lambda s: s["camera"].update(fov="wide"), ["camera.fov", "expected a number", "\"wide\""]),
        (lambda s: s["shapes"][0]["medium"].update(sigma_t=[1, -1, 1]),
         ["shapes[0].medium.sigma_t", "[1,-1,1]", "[0, 1e7]"]),
        (lambda s: s["shapes"][0]["medium"].update(albedo=[0.5, 1.5, 0.5]),
         ["shapes[0].medium.albedo", "[0, 1]"]),
        (lambda s: s["shapes"][0]["medium"].update(albedo=-0.1), ["medium.albedo", "-0.1"]),
        (lambda s: s["shapes"][0]["medium"].update(g=1.0), ["medium.g", "-1 < g < 1"]),
        (lambda s: s["shapes"][0]["medium"].update(g=-1.5), ["medium.g", "-1.5"]),
        (lambda s: s["render"].update(spp=0), ["render.spp", "1 to"]),
        (lambda s: s["render"].update(spp=-3), ["render.spp", "-3"]),
        (lambda s: s["camera"].update(width=100000), ["camera.width", "1 to 16384"]),
        (lambda s: s["camera"].update(width=16384, height=16384), ["too large"]),
        (lambda s: s["camera"].update(height=0), ["camera.height", "0"]),
        (lambda s: s["shapes"][0]["sphere"].update(radius=0), ["sphere.radius", "[1e-30, 1e30]"]),
        (lambda s: s["shapes"][0].update(boundary={"type": "glass"}),
         ["boundary.type", "\"index_matched\", \"dielectric\""]),
        # Ways to state a medium: exactly one, whole, with known presets and a sane scale.
        (lambda s: s["shapes"][0]["medium"].update(preset="skin1"),
         ["shapes[0].medium", "exactly one of", "sigma_t", "preset"]),
        (lambda s: s["shapes"][0].update(medium={"sigma_s": [1, 1, 1]}),
         ["shapes[0].medium", "sigma_s needs sigma_a"]),
        (lambda s: s["shapes"][0].update(medium={"preset": "skin3"}),
         ["shapes[0].medium.preset", "skin3", "skin1", "sssphere presets"]),
        (lambda s: s["shapes"][0].update(medium={"preset": 3}), ["shapes[0].medium.preset", "3"]),
        (lambda s: s["shapes"][0].update(medium={"preset": "marble", "scale": -2}),
         ["shapes[0].medium.scale", "-2", "[1e-9, 1e9]"]),
        (lambda s: s["shapes"][0].update(medium={"preset": "marble", "scale": 1e8}),
         ["shapes[0].medium", "above 1e7", "scale"]),
        (lambda s: s["shapes"][0].update(medium={"sigma_s": [1, -1, 1], "sigma_a": 0}),
         ["shapes[0].medium.sigma_s", "[1,-1,1]"]),
        (lambda s: s["shapes"][0].update(medium={"g": 0.5}), ["shapes[0].medium", "missing a medium"]),
        (lambda s: s["shapes"][0].update(medium={"color": [0.8, 0.5, 0.3]}),
         ["shapes[0].medium", "color needs mean_free_path"]),
        (lambda s: s["shapes"][0].update(medium={"color": [0.8, 1.2, 0.3], "mean_free_path": 1}),
         ["shapes[0].medium.color", "[0, 1]"]),
        (lambda s: s["shapes"][0].update(medium={"color": 0.5, "mean_free_path": [1, 0, 1]}),
         ["shapes[0].medium.mean_free_path", "[1e-7, 1e7]"]),
        (lambda s: s["shapes"][0].update(medium={"color": 0.5, "mean_free_path": 1,
                                                 "sigma_t": 3}),
         ["shapes[0].medium", "exactly one of", "color + mean_free_path"]),
        (lambda s: s["shapes"][0].update(boundary={"type": "dielectric", "roughness": 1.5}),
         ["shapes[0].boundary.roughness", "1.5", "[0, 1]"]),
        (lambda s: s["shapes"][0].update(boundary={"type": "dielectric", "roughness": -0.1}),
         ["shapes[0].boundary.roughness", "-0.1", "[0, 1]"]),
        (lambda s: s["shapes"][0].update(boundary={"type": "dielectric", "regularization": 2}),
         ["shapes[0].boundary.regularization", "2", "[0, 1]"]),
        (lambda s: s["shapes"][0].update(boundary={"type": "index_matched",
                                                   "regularization": 0.1}),
         ["shapes[0].boundary", "regularization"]),
        (lambda s: s["shapes"][0].update(boundary={"type": "index_matched", "roughness": 0.1}),
         ["shapes[0].boundary", "roughness"]),
        (lambda s: s["lights"][0].update(intensity=[1, 1]), ["lights[0].intensity", "3 numbers"]),
        (lambda s: s["lights"].append({"type": "area", "corner": [0, 0, 0], "edge1": [1, 0, 0],
                                       "edge2": [2, 0, 0], "radiance": 1}),
         ["lights[2]", "no area"]),
        # an area single precision cannot resolve (its squares underflow) is not "no area"
        (lambda s: s["lights"].append({"type": "area", "corner": [0, 0, 0],
                                       "edge1": [1e-12, 0, 0], "edge2": [0, 1e-12, 0],
                                       "radiance": 1}),
         ["lights[2]", "span an area of 1e-24", "at least 1e-18"]),
        # ... nor one whose power overflows it (it rendered black)
        (lambda s: s["lights"].append({"type": "area", "corner": [0, 5, 0],
                                       "edge1": [5e18, 0, 0], "edge2": [0, 0, 5e18],
                                       "radiance": 1}),
         ["lights[2]", "span an area of 2.5e+37", "at most 1e+30"]),
        (lambda s: s["shapes"][0]["medium"].update(g=math.nan), ["shapes[0].medium.g", "finite"]),
        (lambda s: s["camera"].update(origin=[0, 0, math.inf]), ["camera.origin[2]", "finite"]),
        (lambda s: s.update(shapes=[]), ["shapes", "non-empty"]),
        (lambda s: s["render"].update(integrator="mc"), ["render.integrator", "\"pt\", \"st\""]),
        (lambda s: s["render"].update(sphere_threshold=-1), ["render.sphere_threshold", "a number >= 0"]),
        # past 2^64 - 1 the JSON parser makes it a float: out of range, not "not an integer"
        (lambda s: s["render"].update(seed=2**64), ["render.seed", "is not allowed",
                                                    "[0, 2^63 - 1]"]),
        (lambda s: s["render"].update(seed=-2**63 - 1), ["render.seed", "is not allowed",
                                                         "[0, 2^63 - 1]"]),
        (lambda s: s["render"].update(models=3), ["render.models", "directory path"]),
        (lambda s: s["render"].update(integrator="st", models="nowhere"), ["nowhere: not a directory"]),
        # Opaque surfaces: exactly one of medium and surface, no boundary, checked values.
        (lambda s: s["shapes"][0].update(surface={"type": "diffuse"}),
         ["shapes[0]", "exactly one of 'medium'", "'surface'"]),
        (lambda s: s["shapes"][0].pop("medium"), ["shapes[0]", "exactly one of 'medium'"]),
        (lambda s: (s["shapes"][0].pop("medium"), s["shapes"][0].update(surface={"type": "diffuse"})),
         ["shapes[0].boundary", "no boundary"]),
        (lambda s: (s["shapes"][0].pop("medium"), s["shapes"][0].pop("boundary"),
                    s["shapes"][0].update(surface={"type": "diffuse", "reflectance": [0.5, 1.2, 0]})),
         ["shapes[0].surface.reflectance", "[0.5,1.2,0]", "[0, 1]"]),
        (lambda s: (s["shapes"][0].pop("medium"), s["shapes"][0].pop("boundary"),
                    s["shapes"][0].update(surface={"type": "metal"})),
         ["shapes[0].surface.type", "\"metal\"", "\"diffuse\""]),
        (lambda s: (s["shapes"][0].pop("medium"), s["shapes"][0].pop("boundary"),
                    s["shapes"][0].update(surface={"type": "diffuse", "roughness": 1})),
         ["shapes[0].surface.roughness", "unknown key"]),
    ],
)
def test_bad_scene_dict_names_field_and_value(small_scene, edit, expected):
    edit(small_scene)
    msg = error_of(small_scene)
    for part in expected:
        assert part in msg, msg


def test_missing_unreadable_and_malformed_files(tmp_path):
    assert "does not exist" in error_of(tmp_path / "nope.json")
    assert "is a directory" in error_of(tmp_path)
    bad = tmp_path / "bad.json"
    bad.write_text('{"camera": {"origin": [0, 0, 1],}')
    msg = error_of(bad)
    assert "bad.json" in msg and "malformed JSON" in msg
    huge = tmp_path / "huge.json"
    huge.write_text('{"camera": {"fov": 1e999}}')
    msg = error_of(huge)
    assert "huge.json" in msg and "1e999" in msg
    binary = tmp_path / "binary.json"
    binary.write_bytes(b"\xff\xfe\x00garbage")
    assert "binary.json" in error_of(binary)
    # The parser's message quotes what it last read, which stops inside the é: not UTF-8
    # (pybind11 raised a UnicodeDecodeError instead of the SceneError)
    accent = tmp_path / "accent.json"
    accent.write_text('{"camera": é}', encoding="utf-8")
    msg = error_of(accent)
    assert "accent.json: malformed JSON" in msg and "last read" in msg, msg
    with pytest.raises(SceneError, match="accent.json: malformed JSON"):  # as --set reads it
        load_scene_with(accent, ["render.spp=2"])


def _write_off(path, verts, faces):
    lines = ["OFF", f"{len(verts)} {len(faces)} 0"]
    lines += [" ".join(map(str, v)) for v in verts]
    lines += [f"{len(f)} " + " ".join(map(str, f)) for f in faces]
    path.write_text("\n".join(lines) + "\n")


CUBE_V = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1)]
CUBE_F = [(0, 3, 2, 1), (4, 5, 6, 7), (0, 1, 5, 4), (2, 3, 7, 6), (1, 2, 6, 5), (0, 4, 7, 3)]


@pytest.mark.parametrize(
    "faces, expected",
    [
        (CUBE_F[:-1], "not closed"),
        (CUBE_F[:-1] + [(0, 4, 4)], "degenerate"),
        ([], "no faces"),
    ],
)
def test_bad_meshes_are_refused_with_the_file_named(tmp_path, small_scene, faces, expected):
    _write_off(tmp_path / "m.off", CUBE_V, faces)
    del small_scene["shapes"][0]["sphere"]
    small_scene["shapes"][0]["mesh"] = "m.off"
    small_scene["camera"]["origin"] = [0.5, 0.5, 5]
    (tmp_path / "scene.json").write_text(json.dumps(small_scene))
    msg = error_of(tmp_path / "scene.json")
    assert "shapes[0].mesh" in msg and "m.off" in msg and expected in msg, msg


def _mesh_error(small_scene, vertices, faces):
    del small_scene["shapes"][0]["sphere"]
    small_scene["shapes"][0].update(vertices=vertices, faces=faces)
    small_scene["camera"]["origin"] = [0.5, 0.5, 9]
    return error_of(small_scene)


def test_mesh_errors_say_where_the_defects_are_and_how_to_repair_them(small_scene):
    import copy

    # A cube without its last face: 4 open edges, named by their corners.
    msg = _mesh_error(copy.deepcopy(small_scene), CUBE_V, CUBE_F[:-1])
    assert "shapes[0]" in msg and "not closed: 4 edges belong to one triangle only" in msg, msg
    assert "(0, 0, 0)-(0, 1, 0)" in msg and "pymeshfix" in msg and "'surface'" in msg, msg
    # Two cubes sharing the edge x = y = 1: it has four triangles.
    shifted = [(x + 1, y + 1, z) for x, y, z in CUBE_V]
    faces = CUBE_F + [tuple(i + 8 for i in f) for f in CUBE_F]
    msg = _mesh_error(copy.deepcopy(small_scene), CUBE_V + shifted, faces)
    assert "not manifold: 1 edges are shared by more than two triangles" in msg, msg
    assert "(1, 1, 0)-(1, 1, 1) (4 triangles)" in msg, msg
    # Two cubes touching at the corner (1, 1, 1) only: a vertex joining two sheets.
    shifted = [(x + 1, y + 1, z + 1) for x, y, z in CUBE_V]
    msg = _mesh_error(copy.deepcopy(small_scene), CUBE_V + shifted, faces)
    assert "1 vertices join separate sheets" in msg and "(1, 1, 1) (2 fans)" in msg, msg


def _box(lo, hi, name):
    """A closed box of the small scene's medium, as an inline mesh."""
    vertices = [[lo[i] if not (c >> i) & 1 else hi[i] for i in range(3)]
                for c in (0, 1, 3, 2, 4, 5, 7, 6)]  # CUBE_V's order
    return {"name": name, "vertices": vertices, "faces": [list(f) for f in CUBE_F],
            "medium": {"sigma_t": [5, 5, 5], "albedo": [0.9, 0.9, 0.9]}}


@pytest.mark.parametrize("second, meets", [
    (([0.5, 0.2, 0.2], [1.5, 0.8, 0.8]), True),      # across the first's face
    (([1, 0, 0], [2, 1, 1]), True),                   # sharing the face x = 1
    (([1, 1, 1], [2, 2, 2]), True),                   # touching at a corner
    (([0.25, 0.25, 0.25], [0.75, 0.75, 0.75]), True),  # inside the first
    (([-1, -1, -1], [2, 2, 2]), True),                # around the first
    (([1 + 2e-5, 0, 0], [2, 1, 1]), False),           # a gap of 1e-5 of the scene
    (([0.5, 0.5, 1.25], [1.5, 1.5, 2]), False),       # boxes apart by z only
])
def test_media_that_overlap_touch_or_nest_are_refused(small_scene, second, meets):
    """A path inside a medium leaves to vacuum at any surface it meets, so media that meet
    rendered wrong without a word (an outside sweep saw a cube vanish from one side)."""
    small_scene["shapes"] = [_box([0, 0, 0], [1, 1, 1], "first"), _box(*second, "second")]
    small_scene["camera"]["origin"] = [0.5, 0.5, 9]
    if not meets:
        assert np.isfinite(sssphere.render(small_scene, spp=1)).all()
        return
    msg = error_of(small_scene)
    assert ("shapes[0] ('first') and shapes[1] ('second'): their media overlap, touch or lie "
            "one inside the other") in msg and "media apart, by 1e-5 of the scene" in msg, msg


@pytest.mark.parametrize("corner, meets", [
    ([0.25, 0.25, 0.5], True),   # inside the medium
    ([0.25, 0.25, 1], True),     # on its top face
    ([0.25, 0.25, 1.5], False),  # above it
])
def test_an_area_light_inside_or_on_a_medium_is_refused(small_scene, corner, meets):
    small_scene["shapes"] = [_box([0, 0, 0], [1, 1, 1], "box")]
    small_scene["camera"]["origin"] = [0.5, 0.5, 9]
    small_scene["lights"] = [{"type": "area", "corner": corner, "edge1": [0.5, 0, 0],
                              "edge2": [0, 0.5, 0], "radiance": [1, 1, 1]}]
    if not meets:
        assert np.isfinite(sssphere.render(small_scene, spp=1)).all()
        return
    msg = error_of(small_scene)
    assert "lights[0]: the area light meets shapes[0] ('box')" in msg, msg


def test_a_scene_edit_that_makes_media_meet_is_refused(small_scene):
    small_scene["shapes"] = [_box([0, 0, 0], [1, 1, 1], "first"),
                             _box([2, 0, 0], [3, 1, 1], "second")]
    small_scene["camera"]["origin"] = [1.5, 0.5, 9]
    scene = sssphere.load_scene(small_scene)
    with pytest.raises(SceneError, match="their media overlap, touch"):
        scene.shapes[1].transform = {"translate": [-1.5, 0, 0]}


def test_media_and_lights_whose_boxes_overlap_but_that_are_apart_are_taken(small_scene):
    """The check is exact, not by bounding boxes: two balls whose boxes overlap and an area
    light in a corner of a ball's box, all apart, render."""
    ball = small_scene["shapes"][0]
    small_scene["shapes"] = [ball, {**ball, "name": "other",
                                    "sphere": {**ball["sphere"], "center": [1.5, 1.5, 1.5]}}]
    small_scene["camera"]["origin"] = [0, 0, 9]
    small_scene["lights"] = [{"type": "area", "corner": [0.75, 0.75, -0.95], "edge1": [0.2, 0, 0],
                              "edge2": [0, 0.2, 0], "radiance": [1, 1, 1]}]
    assert np.isfinite(sssphere.render(small_scene, spp=1)).all()


def test_an_edit_that_turns_an_overlapping_surface_into_a_medium_is_refused(small_scene):
    """An opaque surface may pass through a medium; made a medium, the same mesh is an
    error. Apart, it is taken. (The render frame is centred on the media, so a new medium
    moves it and everything is built again, as a fresh load would: docs/robustness.md.)"""
    for lo, hi, meets in (([0.5] * 3, [1.5] * 3, True), ([2, 0, 0], [3, 1, 1], False)):
        second = _box(lo, hi, "second")
        medium = second.pop("medium")
        scene_dict = copy.deepcopy(small_scene)
        scene_dict["shapes"] = [_box([0, 0, 0], [1, 1, 1], "first"),
                                {**second, "surface": {"type": "diffuse"}}]
        scene_dict["camera"]["origin"] = [0.5, 0.5, 9]
        if meets:
            scene = sssphere.load_scene(scene_dict)
            with pytest.raises(SceneError, match=r"shapes\[1\] \('second'\): their media"):
                scene.shapes[1] = {**second, "medium": medium}
        else:
            scene = sssphere.load_scene(scene_dict)
            scene.shapes[1] = {**second, "medium": medium}
            assert "distance grid of shape 'second' (new)" in scene.rebuilt, scene.rebuilt
            fresh = sssphere.load_scene(scene.to_dict())
            np.testing.assert_array_equal(sssphere.render(scene, spp=1),
                                          sssphere.render(fresh, spp=1))


def test_open_meshes_make_surfaces_but_not_media(tmp_path, small_scene):
    """A floor of two triangles is an opaque surface; the same open mesh cannot hold a
    medium (the error says it is not closed)."""
    _write_off(tmp_path / "floor.off", [(-2, -1, -2), (2, -1, -2), (2, -1, 2), (-2, -1, 2)],
               [(0, 2, 1), (0, 3, 2)])
    floor = {"mesh": str(tmp_path / "floor.off"), "medium": small_scene["shapes"][0]["medium"]}
    small_scene["shapes"].append(floor)
    msg = error_of(small_scene)
    assert "shapes[1].mesh" in msg and "floor.off" in msg and "not closed" in msg, msg
    del floor["medium"]
    floor["surface"] = {"type": "diffuse", "reflectance": 0.5}
    img = sssphere.render(sssphere.load_scene(small_scene), spp=4)
    assert np.isfinite(img).all() and img.mean() > 0


def test_bad_environment_maps_are_refused_with_file_and_field_named(tmp_path, small_scene):
    """An environment light takes exactly one of radiance and map; the map must exist, be an
    EXR or HDR file twice as wide as high, with radiance from 0 to 1e30, times scale too (a
    map of 3e38, or of 1e10 with scale 1e30, gave Inf pixels: an outside sweep)."""
    def env_error(**light):
        scene = json.loads(json.dumps(small_scene))
        scene["lights"] = [dict(type="environment", **light)]
        return error_of(scene, base_dir=tmp_path)

    sssphere.write_image(tmp_path / "ok.exr", np.full((4, 8, 3), 0.5, np.float32))
    sssphere.write_image(tmp_path / "square.exr", np.full((8, 8, 3), 0.5, np.float32))
    bad = np.full((4, 8, 3), 0.5, np.float32)
    bad[1, 2, 1] = -1
    sssphere.write_image(tmp_path / "negative.exr", bad)
    (tmp_path / "broken.exr").write_bytes(b"not an image")
    huge = np.full((4, 8, 3), 0.5, np.float32)
    huge[3, 5, 2] = 3e38
    sssphere.write_image(tmp_path / "huge.exr", huge)
    bright = np.full((4, 8, 3), 0.5, np.float32)
    bright[2, 1, 0] = 1e10
    sssphere.write_image(tmp_path / "bright.exr", bright)
    cases = [
        (dict(radiance=1, map="ok.exr"), ["lights[0]", "exactly one of 'radiance'", "'map'"]),
        (dict(), ["lights[0]", "exactly one of 'radiance'"]),
        (dict(radiance=1, scale=2), ["lights[0].scale", "'map' only"]),
        (dict(map="missing.exr"), ["lights[0].map", "missing.exr", "does not exist"]),
        (dict(map="ok.png"), ["lights[0].map", "'.png'", "allowed: .exr, linear radiance"]),
        (dict(map="square.exr"), ["lights[0].map", "square.exr", "8 x 8", "twice as wide"]),
        (dict(map="negative.exr"), ["lights[0].map", "pixel (2, 1) channel 1", "-1",
                                    "from 0 to 1e30"]),
        (dict(map="huge.exr"), ["lights[0].map", "pixel (5, 3) channel 2", "3e+38",
                                "from 0 to 1e30"]),
        (dict(map="bright.exr", scale=1e30), ["lights[0].scale", "brightest pixel, 1e+10 at (1, 2)",
                                              "bright.exr", "1e+40", "at most 1e30"]),
        (dict(map="broken.exr"), ["lights[0].map", "broken.exr"]),
        (dict(map="ok.exr", scale=-1), ["lights[0].scale", "-1", "[0, 1e30]"]),
        (dict(map="ok.exr", rotate_deg=[0, 1]), ["lights[0].rotate_deg", "3 numbers"]),
        (dict(map=3), ["lights[0].map", "image file path"]),
    ]
    for light, expected in cases:
        msg = env_error(**light)
        for part in expected:
            assert part in msg, (light, part, msg)
    # And the good one renders.
    scene = json.loads(json.dumps(small_scene))
    scene["lights"] = [{"type": "environment", "map": "ok.exr", "scale": 2}]
    img = sssphere.render(sssphere.load_scene(scene, base_dir=tmp_path), spp=2)
    assert np.isfinite(img).all() and img.max() > 0
    # the largest radiance allowed, from the largest scale allowed: loads (it was refused,
    # the double 1e30 below the float one, by a message saying 1e+30 is above 1e30)
    sssphere.write_image(tmp_path / "ones.exr", np.ones((4, 8, 3), np.float32))
    scene["lights"] = [{"type": "environment", "map": "ones.exr", "scale": 1e30}]
    sssphere.load_scene(scene, base_dir=tmp_path)


def _write_binary_stl(path, count_in_header=None, name=b"binary cube"):
    """The unit cube as a binary STL; the header's triangle count may lie."""
    import struct

    tris = [(q[0], q[k], q[k + 1]) for q in CUBE_F for k in (1, 2)]
    body = b"".join(struct.pack("<12fH", 0, 0, 0, *(c for v in t for c in CUBE_V[v]), 0)
                    for t in tris)
    count = len(tris) if count_in_header is None else count_in_header
    path.write_bytes(name.ljust(80, b" ") + struct.pack("<I", count) + body)


def test_a_truncated_binary_stl_says_what_its_header_and_size_disagree_on(tmp_path, small_scene):
    """A binary STL whose header counts more triangles than the file holds (a cut download)
    was only 'malformed .stl file' (an outside sweep); now the message says what disagrees."""
    del small_scene["shapes"][0]["sphere"]
    small_scene["shapes"][0]["mesh"] = str(tmp_path / "cube.stl")
    small_scene["camera"]["origin"] = [0.5, 0.5, 4]
    _write_binary_stl(tmp_path / "cube.stl")
    sssphere.load_scene(small_scene)  # the honest file loads
    for name in (b"binary cube", b"solid cube"):  # a binary header may start as ASCII's does
        _write_binary_stl(tmp_path / "cube.stl", count_in_header=1000, name=name)
        msg = error_of(small_scene)
        assert ("cube.stl: malformed binary STL file: its header counts 1000 "
                "triangles, which take 50084 bytes, but the file has 684 bytes") in msg, msg
    # A broken ASCII file gets no note made up from its text read as a header, but its line
    (tmp_path / "cube.stl").write_text("  solid cube\n facet normal 0 0 1\n  outer loop\n"
                                       "   vertex 0 0\n" + "x" * 100)
    msg = error_of(small_scene)
    assert "cube.stl: malformed ASCII STL file, line 4: a vertex needs three numbers" in msg, msg
    assert "header counts" not in msg, msg


def test_flat_mesh_is_refused(tmp_path, small_scene):
    # Two triangles back to back: closed and manifold, but no volume.
    _write_off(tmp_path / "flat.off", [(0, 0, 0), (1, 0, 0), (0, 1, 0)], [(0, 1, 2), (0, 2, 1)])
    del small_scene["shapes"][0]["sphere"]
    small_scene["shapes"][0]["mesh"] = str(tmp_path / "flat.off")
    msg = error_of(small_scene)
    assert "flat.off" in msg
    # A sliver with a vertex far away has a large volume, but not for its size: the message
    # says what it is measured against (it said "no volume (..., volume 1.7e+29)").
    _write_off(tmp_path / "sliver.off", [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1e30)],
               [(0, 2, 1), (0, 1, 3), (1, 2, 3), (0, 3, 2)])
    small_scene["shapes"][0]["mesh"] = str(tmp_path / "sliver.off")
    msg = error_of(small_scene)
    assert "sliver.off" in msg and "not above 1e-9 L^3 = 1e+81" in msg and "L = 1e+30" in msg, msg


def test_consistently_fixable_orientation_is_fixed(tmp_path):
    faces = [f if i % 2 else tuple(reversed(f)) for i, f in enumerate(CUBE_F)]
    _write_off(tmp_path / "cube.off", CUBE_V, faces)
    v, t = sssphere.load_mesh(tmp_path / "cube.off")
    a, b, c = v[t[:, 0]], v[t[:, 1]], v[t[:, 2]]
    volume = (a * (b[:, [1, 2, 0]] * c[:, [2, 0, 1]] - b[:, [2, 0, 1]] * c[:, [1, 2, 0]])).sum() / 6
    assert volume == pytest.approx(1.0)


def test_what_fuzzing_found_in_the_mesh_readers(tmp_path):
    """Inputs from tests/fuzz/regressions, as a user would meet them. A PLY header with a
    property before any element crashed CGAL's reader (now refused before it reads); a
    mesh with vertices no face uses overflowed a buffer in CGAL's orientation (now the
    unused vertices are dropped)."""
    ply = tmp_path / "bad.ply"
    ply.write_text("ply\nformat ascii 1.0\nproperty float x\nelement vertex 1\nend_header\n0\n")
    with pytest.raises(SceneError, match=r"bad\.ply: malformed PLY header, line 3: a 'property' "
                                         r"line before any 'element' line"):
        sssphere.load_mesh(ply)
    _write_off(tmp_path / "extra.off", CUBE_V + [(5, 5, 5), (6, 6, 6)], CUBE_F)
    v, t = sssphere.load_mesh(tmp_path / "extra.off")
    assert len(v) == 8 and t.max() == 7



def test_obj_faces_in_every_form_read_as_the_off_cube_and_bad_lines_are_named(tmp_path):
    """Our OBJ reader: faces as v, v/vt, v/vt/vn, v//vn and negative indices give the
    triangles of the same cube written as OFF; a malformed line is refused by number."""
    _write_off(tmp_path / "cube.off", CUBE_V, CUBE_F)
    forms = ["{}", "{}/1", "{}/1/1", "{}//1", "-{}"]
    lines = ["vt 0 0", "vn 0 0 1"] + [f"v {x} {y} {z}" for x, y, z in CUBE_V]
    for i, face in enumerate(CUBE_F):
        form = forms[i % len(forms)]
        lines.append("f " + " ".join(
            form.format(len(CUBE_V) - k) if form.startswith("-") else form.format(k + 1)
            for k in face))
    (tmp_path / "cube.obj").write_text("\n".join(lines) + "\n")
    v_off, t_off = sssphere.load_mesh(tmp_path / "cube.off")
    v_obj, t_obj = sssphere.load_mesh(tmp_path / "cube.obj")
    np.testing.assert_array_equal(v_obj, v_off)
    np.testing.assert_array_equal(t_obj, t_off)

    lines[len(lines) - 2] = "f 3 4 x 7"
    (tmp_path / "bad.obj").write_text("\n".join(lines) + "\n")
    with pytest.raises(SceneError, match=rf"bad\.obj: malformed OBJ file, line {len(lines) - 1}: "
                                         r"vertex index 'x' is not allowed"):
        sssphere.load_mesh(tmp_path / "bad.obj")

def _ply(fmt, verts, faces, vtype="float", itype="int"):
    head = (f"ply\nformat {fmt} 1.0\ncomment ours\nelement vertex {len(verts)}\n"
            f"property {vtype} x\nproperty {vtype} y\nproperty {vtype} z\n"
            f"element face {len(faces)}\nproperty list uchar {itype} vertex_indices\nend_header\n")
    if fmt == "ascii":
        body = "".join(" ".join(map(str, v)) + "\n" for v in verts)
        body += "".join(f"{len(f)} " + " ".join(map(str, f)) + "\n" for f in faces)
        return head.encode() + body.encode()
    order = "<" if fmt == "binary_little_endian" else ">"
    body = b"".join(np.array(v, dtype=order + "f4").tobytes() for v in verts)
    body += b"".join(bytes([len(f)]) + np.array(f, dtype=order + "i4").tobytes() for f in faces)
    return head.encode() + body


@pytest.mark.parametrize("fmt", ["ascii", "binary_little_endian", "binary_big_endian"])
def test_our_ply_and_off_readers_read_what_cgals_did(tmp_path, fmt):
    """PLY and OFF are read by our own readers (CGAL's crashed on malformed files): every
    encoding and the format's alternative type names give the cube the OFF file gives."""
    _write_off(tmp_path / "cube.off", CUBE_V, CUBE_F)
    expected = sssphere.load_mesh(tmp_path / "cube.off")
    (tmp_path / "cube.ply").write_bytes(_ply(fmt, CUBE_V, CUBE_F))
    for got in (sssphere.load_mesh(tmp_path / "cube.ply"),):
        np.testing.assert_array_equal(got[0], expected[0])
        np.testing.assert_array_equal(got[1], expected[1])
    (tmp_path / "named.ply").write_bytes(_ply(fmt, CUBE_V, CUBE_F, "float32", "int32"))
    np.testing.assert_array_equal(sssphere.load_mesh(tmp_path / "named.ply")[1], expected[1])


_PLY_TETRA = ("ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
              "property float z\nelement face 4\nproperty list uchar int vertex_indices\n"
              "end_header\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n")
_TETRA_V = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)]
_STL_TETRA = "solid t\n" + "".join(
    " facet normal 0 0 0\n  outer loop\n"
    + "".join("   vertex %g %g %g\n" % _TETRA_V[i] for i in f)
    + "  endloop\n endfacet\n"
    for f in [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)]) + "endsolid t\n"


def test_the_tetrahedra_the_malformed_files_start_from_load(tmp_path):
    """The files the next test breaks load as written, in either case of the keywords, and
    an STL file may hold more than one solid."""
    (tmp_path / "t.ply").write_text(_PLY_TETRA)
    (tmp_path / "t.stl").write_text(_STL_TETRA)
    (tmp_path / "upper.stl").write_text(_STL_TETRA.upper())
    (tmp_path / "two.stl").write_text(_STL_TETRA + "solid empty\nendsolid empty\n")
    tetra = sssphere.load_mesh(tmp_path / "t.ply")
    assert tetra[1].shape == (4, 3)
    for name in ("t.stl", "upper.stl", "two.stl"):
        got = sssphere.load_mesh(tmp_path / name)
        np.testing.assert_array_equal(np.sort(got[0], axis=0), np.sort(tetra[0], axis=0))
        assert got[1].shape == (4, 3)


@pytest.mark.parametrize(
    "name, text, expected",
    [
        ("neg.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n-3 0 1 2\n",
         "line 6: face 0 needs its vertex count (0 to 65536)"),
        ("short.off", "OFF\n8 6 0\n0 0 0\n", "names 8 vertices and 6 faces but has 1 lines"),
        ("idx.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 x\n", "vertex index 'x'"),
        ("4d.off", "4OFF\n1 0 0\n0 0 0 0\n", "OFF variant '4OFF' is not supported"),
        ("type.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty int33 x\nend_header\n1\n",
         "line 4: unknown property type"),
        ("end.ply", "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\n"
         "property float z\nend_header\n0 0 0\n1 1\n", "the file ends in element 'vertex' 1"),
        ("list.ply", "ply\nformat ascii 1.0\nelement face 1\nproperty list uchar int vertex_indices\n"
         "end_header\n3 0 1 -2\n", "vertex index -2 is not allowed"),
        ("noxyz.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nend_header\n0\n",
         "needs the scalar properties x, y and z"),
        # An index past the vertices, and header counts that do not match the body: they
        # were named by face only, or as "face 0 has 1 vertices", far from the cause.
        ("range.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n",
         "line 6: face 0: vertex index 3 but the file has 3 vertices"),
        ("over.ply", _PLY_TETRA.replace("vertex 4", "vertex 5"),
         "line 14: element 'vertex' 4 ends before its line does"),
        ("under.ply", _PLY_TETRA.replace("vertex 4", "vertex 3"),
         "line 13: element 'face' 0 ends before its line does"),
        ("faces.ply", _PLY_TETRA.replace("face 4", "face 3"),
         "line 17: values after the last element"),
        ("word.ply", _PLY_TETRA.replace("\n0 0 1\n", "\n0 0 z\n"),
         "line 13: element 'vertex' 3: 'z' is not a number"),
        # STL: ours reads it (CGAL's said "malformed .stl file" and no more)
        ("cut.stl", _STL_TETRA[:_STL_TETRA.index("endloop", 200)],
         "it ends inside the facet begun on line 16 (expected 'vertex X Y Z' or 'endloop'): "
         "truncated?"),
        ("end.stl", _STL_TETRA.replace("endsolid t\n", ""),
         "it ends inside the solid begun on line 1 (expected 'facet' or 'endsolid')"),
        ("word.stl", _STL_TETRA.replace("endloop", "endlop", 1),
         "line 7: expected 'vertex X Y Z' or 'endloop', got 'endlop'"),
        ("nan.stl", _STL_TETRA.replace("vertex 0 0 1", "vertex 0 0 nan", 1),
         "line 13: a vertex is not finite"),
        ("two.stl", _STL_TETRA.replace("endloop", "vertex 1 1\nendloop", 1),
         "line 7: a vertex needs three numbers x y z"),
        ("tiny.stl", "hello", "5 bytes, neither ASCII (which starts with 'solid') nor binary"),
    ],
)
def test_malformed_ply_and_off_files_get_a_line_or_element_named(tmp_path, name, text, expected):
    (tmp_path / name).write_text(text)
    with pytest.raises(SceneError, match=re.escape(expected)):
        sssphere.load_mesh(tmp_path / name)


@pytest.mark.parametrize(
    "kwargs, expected",
    [
        ({"spp": 0}, "spp must be an integer >= 1"),
        ({"spp": 2.5}, "spp must be an integer"),
        ({"seed": -1}, "seed must be an integer from 0 to 2\\^63 - 1"),
        ({"threads": -2}, "threads must be"),
        ({"integrator": "mc"}, "integrator 'mc' is not allowed \\(allowed: 'pt', 'st'\\)"),
        # st's options given to pt would change nothing: refused, not ignored
        ({"integrator": "pt", "step_nee": "event"},
         "step_nee 'event' is an option of integrator 'st' \\(the integrator is 'pt'\\)"),
        ({"integrator": "pt", "sphere_sampler": "walk"}, "sphere_sampler 'walk' is an option of integrator 'st'"),
        ({"integrator": "pt", "models": "models"}, "models is an option of integrator 'st'"),
        ({"sphere_threshold": 2.0}, "sphere_threshold is an option of integrator 'st' \\(the integrator is 'pt'\\)"),
    ],
)
def test_bad_render_arguments(small_scene, kwargs, expected):
    scene = sssphere.load_scene(small_scene)
    with pytest.raises(SceneError, match=expected):
        sssphere.render(scene, **kwargs)


@pytest.mark.parametrize(
    "kwargs, expected",
    [
        ({"seed": -1}, "seed must be an integer from 0 to 2\\^63 - 1, got -1"),
        ({"seed": 2.5}, "seed must be an integer from 0 to 2\\^63 - 1, got 2.5"),
        ({"threads": -3}, "threads must be an integer from 0 to 4096"),
        ({"seed": None}, "seed must be an integer from 0 to 2\\^63 - 1, got None"),
        ({"samples": 0}, "aov samples must be an integer from 1 to 2147483647, got 0"),
        ({"samples": True}, "aov samples must be an integer from 1 to 2147483647, got True"),
        ({"samples": 1 << 40}, "aov samples must be an integer from 1 to 2147483647, got 1099"),
    ],
)
def test_bad_first_hit_aov_arguments(small_scene, kwargs, expected):
    """first_hit_aovs takes seed and threads as a render does (it raised pybind's TypeError
    for a negative seed and took threads=-3)."""
    scene = sssphere.load_scene(small_scene)
    with pytest.raises(SceneError, match=expected):
        sssphere.first_hit_aovs(scene, **kwargs)


def test_bad_image_paths(tmp_path):
    import numpy as np

    img = np.zeros((2, 2, 3), np.float32)
    with pytest.raises(SceneError, match=r"unsupported image format '\.jpg'"):
        sssphere.write_image(tmp_path / "a.jpg", img)
    with pytest.raises(SceneError, match="does not exist"):
        sssphere.write_image(tmp_path / "no" / "a.exr", img)
    with pytest.raises(SceneError, match="shape"):
        sssphere.write_image(tmp_path / "a.exr", np.zeros((2, 2, 2), np.float32))
    # 8-bit pixels would be taken as radiance 0-255, a white image: refused
    for dtype in (np.uint8, np.int64, bool):
        with pytest.raises(SceneError, match=f"a.png: image of dtype {np.dtype(dtype)} is "
                                             "not allowed"):
            sssphere.write_image(tmp_path / "a.png", np.zeros((2, 2, 3), dtype))
    assert not (tmp_path / "a.png").exists()
    # NaN came out black in a PNG, silently (a review); an EXR keeps it
    nan = np.zeros((2, 3, 3), np.float32)
    nan[1, 2, 0] = np.nan
    with pytest.raises(SceneError, match=r"a.png: image holds 1 non-finite value\(s\) \(first "
                                         r"nan at pixel \(2, 1\)\)"):
        sssphere.write_image(tmp_path / "a.png", nan)
    sssphere.write_image(tmp_path / "a.exr", nan)


# ---------------------------------------------------------------------------------------------
# Input that used to crash, hang or pass silently


def test_deeply_nested_json_is_refused_not_a_crash(tmp_path):
    (tmp_path / "deep.json").write_text("[" * 100_000 + "]" * 100_000)
    with pytest.raises(SceneError, match=r"deep.json: \[0\]\[0\].*JSON nested deeper than 64 levels"):
        sssphere.load_scene(tmp_path / "deep.json")
    deep = []
    for _ in range(100_000):
        deep = [deep]
    with pytest.raises(SceneError, match="nested too deeply"):
        sssphere.load_scene({"camera": deep})


def test_negative_zero_coefficients_read_as_zero():
    """-0.0 passes every ">= 0" check, but its reciprocal is -inf: read as given it made
    flights of -inf (a vacuum sphere in a furnace came out 0.25 instead of 1; sigma_t -0.0
    under a point light crashed in Embree). It reads as 0."""
    furnace = {"camera": {"origin": [0, 0, 4], "target": [0, 0, 0], "fov": 30, "width": 8, "height": 8},
               "shapes": [{"sphere": {"center": [0, 0, 0], "radius": 1},
                           "medium": {"sigma_s": -0.0, "sigma_a": [-0.0, 0, 0]}}],
               "lights": [{"type": "environment", "radiance": 1}]}
    img = sssphere.render(furnace, "pt", spp=4, seed=1)
    assert np.all(np.abs(img - 1) < 1e-5), f"a vacuum sphere in a furnace: {img.min()} .. {img.max()}"

    def lit(sigma_t):
        scene = copy.deepcopy(furnace)
        scene["shapes"][0]["medium"] = {"sigma_t": sigma_t, "albedo": 0.9}
        scene["lights"] = [{"type": "point", "position": [3, 3, 3], "intensity": 20}]
        return sssphere.render(scene, "pt", spp=4, seed=1)

    assert np.array_equal(lit(-0.0), lit(0.0))
    assert np.array_equal(lit([-0.0, 1, 1]), lit([0.0, 1, 1]))


def test_radiometric_values_up_to_their_limit_are_taken(small_scene):
    """The range is checked on the file's number: 1e30 itself was refused (as a float it is
    1.0000000150e30), with a message that said only "each channel >= 0"."""
    small_scene["lights"] = [{"type": "point", "position": [3, 3, 3], "intensity": 1e30}]
    sssphere.load_scene(small_scene)
    small_scene["lights"][0]["intensity"] = [1, 1.01e30, 1]
    with pytest.raises(SceneError, match=r"lights\[0\]\.intensity: value .* \(allowed: each channel in \[0, 1e30\]\)"):
        sssphere.load_scene(small_scene)


def test_distance_queries_refuse_points_that_are_not_finite(small_scene):
    """exact_distance trapped on NaN (SIGFPE in CGAL) and the grid queries read out of
    bounds for points 1e8 away (a float past INT_MAX converted to int): the process died."""
    scene = sssphere.load_scene(small_scene)
    far = np.array([[1e8, 0, 0], [-3e9, 0, 0], [1e30, 0, 0]])
    assert np.all(scene.distance_lower_bound(0, far) == 0)
    assert not np.any(scene.grid_inside(0, far))
    assert np.all(scene.exact_distance(0, far[:2]) > 1e7)
    for bad in ([np.nan, 0, 0], [0, np.inf, 0], [1e39, 0, 0]):
        for query in (scene.exact_distance, scene.distance_lower_bound, scene.grid_inside):
            with pytest.raises(SceneError, match=r"points\[0\] = .* is not finite"):
                query(0, np.array([bad]))


def test_a_dielectric_of_index_1_is_no_interface(small_scene):
    """ior exactly 1 made the rough BSDF's half vector wi + wo vanish: NaN pixels. Between
    equal indices there is no interface at any roughness: the index-matched boundary."""
    def render(boundary):
        scene = copy.deepcopy(small_scene)
        scene["shapes"][0]["boundary"] = boundary
        return sssphere.render(scene, "pt", spp=4, seed=3)

    matched = render({"type": "index_matched"})
    for roughness in (0, 1e-4, 0.2):
        img = render({"type": "dielectric", "ior": 1.0, "roughness": roughness})
        assert np.array_equal(img, matched), f"roughness {roughness}"
    for ior in (0.989, 1.011):  # just past where the boundary is index-matched (below)
        for roughness in (1e-4, 0.2):
            img = render({"type": "dielectric", "ior": ior, "roughness": roughness})
            assert np.isfinite(img).all(), f"ior {ior}, roughness {roughness}"


def test_a_dielectric_within_a_hundredth_of_index_1_is_no_interface(small_scene):
    """An outside sweep found a ball behind a dielectric of ior 1.0001 black under a point
    light (0 against 0.042 index-matched at 1024 spp), and 60 % dark at 1.01: the lobe through
    which the interface passes the light is |ior - 1| times its alpha wide, and no light
    sample found it. Within 0.01 of 1 the boundary is index-matched (dielectric.h says why);
    beyond, it is an interface again."""
    def render(boundary):
        scene = copy.deepcopy(small_scene)
        scene["shapes"][0]["boundary"] = boundary
        scene["lights"] = [{"type": "point", "position": [2, 3, 2], "intensity": 20}]
        return sssphere.render(scene, "pt", spp=4, seed=3)

    matched = render({"type": "index_matched"})
    assert matched.mean() > 0
    for ior in (0.99, 0.9999, 1.0001, 1.01):
        for roughness in (0, 0.3):
            # The move is said, naming the field and the value.
            with pytest.warns(sssphere.SceneWarning,
                              match=rf"shapes\[0\]\.boundary\.ior: {ior} is within 0\.01 of 1"):
                img = render({"type": "dielectric", "ior": ior, "roughness": roughness})
            assert np.array_equal(img, matched), f"ior {ior}, roughness {roughness}"
    with warnings.catch_warnings():  # no interface asked for, or a real one: nothing to say
        warnings.simplefilter("error")
        assert np.array_equal(render({"type": "dielectric", "ior": 1}), matched)
        assert not np.array_equal(render({"type": "dielectric", "ior": 1.011}), matched)


def test_a_key_given_twice_is_refused(tmp_path, small_scene):
    text = json.dumps(small_scene).replace('"spp": 4', '"spp": 4, "spp": 8')
    (tmp_path / "dup.json").write_text(text)
    with pytest.raises(SceneError, match=r"dup.json: render.spp: key 'spp' appears twice in one object"):
        sssphere.load_scene(tmp_path / "dup.json")


def test_a_scene_file_not_in_utf8_is_placed_as_the_cpp_parser_places_it(tmp_path, small_scene):
    """A Latin-1 scene file: Python's codec said only a byte position ('utf-8' codec can't
    decode byte 0xe8 in position 146); the parser names the line, column and field, in both
    command lines and with --set (a review)."""
    small_scene["shapes"][0]["name"] = "caf\xe9"
    (tmp_path / "latin.json").write_bytes(json.dumps(small_scene, ensure_ascii=False)
                                          .encode("latin-1"))
    expected = r"latin.json: malformed JSON at shapes\[0\]\.name: parse error at line 1, column \d+"
    with pytest.raises(SceneError, match=expected):
        sssphere.load_scene(tmp_path / "latin.json")
    with pytest.raises(SceneError, match=expected):
        load_scene_with(tmp_path / "latin.json", ["render.seed=5"])


def test_a_byte_order_mark_is_read_as_the_cpp_parser_reads_it(tmp_path, small_scene):
    """A scene file saved with a UTF-8 BOM (Windows editors write one) loads as it does in
    `sssphere-render`: one leading BOM is skipped (Python's json refused it, with a
    JSONDecodeError instead of a SceneError); a second is malformed JSON, as in C++."""
    from sssphere.mitsuba import export_mitsuba

    bom = b"\xef\xbb\xbf"
    (tmp_path / "bom.json").write_bytes(bom + json.dumps(small_scene).encode())
    expected = sssphere.render(sssphere.load_scene(small_scene), spp=1)
    scene = sssphere.load_scene(tmp_path / "bom.json")
    assert scene.to_dict() == small_scene
    np.testing.assert_array_equal(sssphere.render(scene, spp=1), expected)
    edited = load_scene_with(tmp_path / "bom.json", ["render.seed=5"])  # as --set reads it
    assert edited.render.seed == 5
    (tmp_path / "two.json").write_bytes(2 * bom + json.dumps(small_scene).encode())
    with pytest.raises(SceneError, match="two.json: malformed JSON"):
        sssphere.load_scene(tmp_path / "two.json")
    # export-mitsuba read the file with Python's json before our parser: a JSONDecodeError
    (tmp_path / "bad.json").write_text('{"camera": {"origin": [0, 0, 1],}')
    with pytest.raises(SceneError, match="bad.json: malformed JSON"):
        export_mitsuba(tmp_path / "bad.json", tmp_path / "out.xml")


def test_inputs_that_are_not_regular_files_are_refused(tmp_path, small_scene):
    fifo = tmp_path / "fifo.obj"
    os.mkfifo(fifo)
    small_scene["shapes"][0] = {"mesh": str(fifo), "medium": {"sigma_t": 1, "albedo": 0.5}}
    with pytest.raises(SceneError, match=r"fifo.obj: is not a regular file .* a mesh file must be a regular"):
        sssphere.load_scene(small_scene)
    os.mkfifo(tmp_path / "scene.json")
    with pytest.raises(SceneError, match="scene.json: is not a regular file"):
        sssphere.load_scene(tmp_path / "scene.json")
    with pytest.raises(SceneError, match="x.exr: is not a regular file"):
        os.mkfifo(tmp_path / "x.exr")
        sssphere.read_image(tmp_path / "x.exr")


def test_outputs_are_replaced_whole(tmp_path):
    from sssphere._files import atomic_output

    out = tmp_path / "image.exr"
    sssphere.write_image(out, np.ones((4, 4, 3)))
    sssphere.write_image(out, np.full((4, 4, 3), 2.0))
    assert sssphere.read_image(out).max() == 2.0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["image.exr"]  # no temporary left
    # A write that fails half-way leaves the previous file as it was
    target = tmp_path / "walks.npz"
    target.write_bytes(b"previous")
    with pytest.raises(RuntimeError), atomic_output(target) as tmp:
        tmp.write_bytes(b"half")
        raise RuntimeError("interrupted")
    assert target.read_bytes() == b"previous"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["image.exr", "walks.npz"]


_WRITE_UNDER_A_SIZE_LIMIT = """
import resource, signal, sys
import numpy as np
import sssphere
signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # a write past the limit fails with EFBIG
resource.setrlimit(resource.RLIMIT_FSIZE, (200, 200))
try:
    sssphere.write_image(sys.argv[1], np.random.default_rng(1).random((64, 64, 3)))
except sssphere.SceneError as e:
    print(e)
"""


@pytest.mark.parametrize("name", ["image.png", "image.exr"])
def test_a_write_that_fails_for_want_of_room_is_an_error_and_keeps_the_old_image(tmp_path, name):
    """A disk that fills up while an image is written: the writer is told (here by a file
    size limit, EFBIG, which a full disk's ENOSPC reaches the same way), says so, and the
    previous image is left whole. OpenImageIO's own file writes used to lose that error: a
    PNG came out empty and the command said it wrote it."""
    out = tmp_path / name
    sssphere.write_image(out, np.full((2, 2, 3), 0.25))  # 200 bytes hold this one
    before = out.read_bytes()
    r = subprocess.run([sys.executable, "-c", _WRITE_UNDER_A_SIZE_LIMIT, str(out)],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    assert f"{out}: cannot write image: File too large" in r.stdout, (r.stdout, r.stderr)
    assert out.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == [name]  # no temporary left


def test_an_output_that_is_a_pipe_or_device_is_refused(tmp_path):
    """The image is written to a new file renamed into place: over a FIFO, or through a
    link to a device (/dev/null), that would replace the pipe or the device by a file."""
    img = np.zeros((2, 2, 3))
    os.mkfifo(tmp_path / "pipe.exr")
    os.symlink(os.devnull, tmp_path / "null.png")
    for name in ("pipe.exr", "null.png"):
        with pytest.raises(SceneError, match=f"{name}: is a device, pipe or socket, not a file"):
            sssphere.write_image(tmp_path / name, img)
    assert (tmp_path / "pipe.exr").is_fifo() and os.path.exists(os.devnull)


def test_a_read_only_image_is_refused_even_for_root(tmp_path):
    """A file made read-only is refused, not replaced (docs/reliability.md); access(W_OK)
    passes every file for root, which replaced it (a review, as root)."""
    out = tmp_path / "kept.png"
    sssphere.write_image(out, np.zeros((2, 2, 3)))
    before = out.read_bytes()
    out.chmod(0o444)
    with pytest.raises(SceneError, match="kept.png: is read-only"):
        sssphere.write_image(out, np.ones((2, 2, 3)))
    assert out.read_bytes() == before and out.stat().st_mode & 0o777 == 0o444


def test_an_image_written_over_another_keeps_its_permissions_and_any_name_fits(tmp_path):
    out = tmp_path / "private.exr"
    sssphere.write_image(out, np.zeros((2, 2, 3)))
    out.chmod(0o600)
    sssphere.write_image(out, np.ones((2, 2, 3)))
    assert out.stat().st_mode & 0o777 == 0o600 and sssphere.read_image(out).min() == 1.0
    # the temporary file's name is not built from the output's, so a name of 255 bytes
    # (NAME_MAX) is no more refused than it would be by `touch`
    long = tmp_path / ("a" * 251 + ".png")
    sssphere.write_image(long, np.zeros((2, 2, 3)))
    assert long.exists()
    (tmp_path / "adir").mkdir()
    with pytest.raises(SceneError, match="adir: is a directory"):
        sssphere.write_image(tmp_path / "adir", np.zeros((2, 2, 3)))


_LOAD_UNDER_A_MEMORY_LIMIT = """
import resource, sys
import sssphere
resource.setrlimit(resource.RLIMIT_AS, (4 << 30, 4 << 30))
try:
    sssphere.load_scene(sys.argv[1])
except sssphere.SceneError as e:
    print(e)
"""


@pytest.mark.parametrize("big", ["mesh", "scene"])
def test_an_input_file_too_large_for_memory_is_named(tmp_path, big):
    """A mesh or scene file larger than the memory there is (here an 8 GiB sparse file under
    a 4 GiB address-space limit) is refused naming the file and its size: it was
    std::bad_alloc, or a MemoryError traceback, naming nothing."""
    scene = {"camera": {"origin": [0, 0, 4], "target": [0, 0, 0], "fov": 30, "width": 8,
                        "height": 8},
             "shapes": [{"mesh": "big.obj", "medium": {"sigma_t": 5, "albedo": 0.9, "g": 0},
                         "boundary": {"type": "index_matched"}}],
             "lights": [{"type": "environment", "radiance": [1, 1, 1]}]}
    (tmp_path / "s.json").write_text(json.dumps(scene))
    name = "big.obj" if big == "mesh" else "s.json"
    with open(tmp_path / name, "ab") as f:
        f.truncate(8 << 30)
    r = subprocess.run([sys.executable, "-c", _LOAD_UNDER_A_MEMORY_LIMIT, str(tmp_path / "s.json")],
                       capture_output=True, text=True, timeout=300)
    what = "mesh file" if big == "mesh" else "scene file"
    assert r.returncode == 0 and f"{name}: {what} of {8 << 30} bytes does not fit in memory" in r.stdout, (
        r.stdout, r.stderr)


def test_a_null_where_an_object_belongs_is_said_once(small_scene):
    """'got null null' named the type and then the value of a null."""
    small_scene["render"] = None
    with pytest.raises(SceneError, match=r"^<dict>: render: expected an object, got null$"):
        sssphere.load_scene(small_scene)
    small_scene["render"] = "fast"
    with pytest.raises(SceneError, match=r'render: expected an object, got a string "fast"$'):
        sssphere.load_scene(small_scene)


def test_a_loop_of_symbolic_links_is_named(tmp_path, small_scene):
    """A mesh or scene file that is a loop of links was said not to exist."""
    os.symlink(tmp_path / "b.obj", tmp_path / "a.obj")
    os.symlink(tmp_path / "a.obj", tmp_path / "b.obj")
    del small_scene["shapes"][0]["sphere"]
    small_scene["shapes"][0]["mesh"] = str(tmp_path / "a.obj")
    with pytest.raises(SceneError, match="a.obj: is a loop of symbolic links, not a mesh file"):
        sssphere.load_scene(small_scene)
    os.symlink(tmp_path / "d.json", tmp_path / "c.json")
    os.symlink(tmp_path / "c.json", tmp_path / "d.json")
    with pytest.raises(SceneError, match="c.json: is a loop of symbolic links, not a scene file"):
        sssphere.load_scene(tmp_path / "c.json")


def test_a_tiny_direction_is_a_direction(small_scene):
    """A directional light's direction (or the camera's up) is refused only when zero: one
    of [1e-30, 0, 0] was refused as "not a non-zero vector" (its float length underflows; a
    review). It is the direction [1, 0, 0]."""
    def with_direction(d):
        scene = json.loads(json.dumps(small_scene))
        scene["lights"] = [{"type": "directional", "direction": d, "irradiance": 2}]
        scene["camera"]["up"] = [0, 1e-30, 0]
        return sssphere.render(sssphere.load_scene(scene), spp=2)

    np.testing.assert_array_equal(with_direction([-1e-30, -1e-31, 0]), with_direction([-1, -0.1, 0]))
    assert error_of({**small_scene, "lights": [{"type": "directional", "direction": [0, 0, 0],
                                                "irradiance": 1}]}).endswith(
        "lights[0].direction: value [0,0,0] is not allowed (allowed: a non-zero vector)")


def _l_prism_obj(path, start: int) -> None:
    """An L-shaped prism (the unit square's [0, 2]^2 less [1, 2]^2, 1 high) whose two
    hexagon caps list their corners from corner `start`; the four side walls as quads."""
    ring = [(0, 0), (2, 0), (2, 1), (1, 1), (1, 2), (0, 2)]
    ring = ring[start:] + ring[:start]
    v = [(x, y, 0) for x, y in ring] + [(x, y, 1) for x, y in ring]
    n = len(ring)
    faces = [list(range(n, 0, -1)), [n + 1 + i for i in range(n)]]  # bottom down, top up
    faces += [[i + 1, (i + 1) % n + 1, (i + 1) % n + n + 1, i + n + 1] for i in range(n)]
    path.write_text("".join(f"v {x} {y} {z}\n" for x, y, z in v) +
                    "".join("f " + " ".join(map(str, f)) + "\n" for f in faces))


@pytest.mark.parametrize("start", range(6))
def test_a_concave_face_is_triangulated_inside_itself(tmp_path, start):
    """A concave hexagon fanned from one of its convex corners folded triangles over the
    notch it does not cover (medium rendered where there is none; a review). From every
    starting corner its triangles now tile it: they lie in it and their areas add up to
    its area."""
    _l_prism_obj(tmp_path / "l.obj", start)
    v, t = sssphere.load_mesh(tmp_path / "l.obj")
    cap = t[np.all(v[t][:, :, 2] == 1, axis=1)]
    assert len(cap) == 4, cap  # a hexagon in four triangles
    p = v[cap][:, :, :2].astype(np.float64)
    e1, e2 = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]
    area = 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])
    assert area.sum() == pytest.approx(3.0), area
    centroids = p.mean(axis=1)
    assert not np.any((centroids[:, 0] > 1) & (centroids[:, 1] > 1)), centroids  # the notch


def test_faces_with_a_corner_repeated_or_on_an_edge_are_read_and_bad_ones_named(tmp_path):
    """Exporters write a triangle as the quad 'f 1 4 3 3', and a face may have a corner in
    the middle of an edge (a T-junction): both were refused as a 'degenerate triangle N' of
    the fan, numbered after triangulation. A face reversed and given twice is one face. A
    face with no area is named by its number and corners."""
    v = CUBE_V + [(0.5, 0, 0)]  # 8: the middle of the edge 0-1
    faces = [f for f in CUBE_F if f not in ((0, 1, 5, 4), (0, 3, 2, 1), (0, 4, 7, 3))]
    faces += [(0, 8, 1, 5, 4), (8, 0, 3, 2, 1)]  # 5 corners, one on a straight edge
    faces += [(0, 4, 3), (4, 7, 3, 3)]  # the face 0-4-7-3 as two triangles, one a quad
    _write_off(tmp_path / "t.off", v, faces + [(6, 7, 3, 2)])  # 2-3-7-6 again, reversed
    vt, t = sssphere.load_mesh(tmp_path / "t.off")
    a, b, c = vt[t[:, 0]], vt[t[:, 1]], vt[t[:, 2]]
    assert np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6 == pytest.approx(1.0)
    _write_off(tmp_path / "d.off", CUBE_V, CUBE_F[:-1] + [(0, 4, 7, 3), (0, 4, 4)])
    with pytest.raises(SceneError, match=r"d\.off: face 6 \(corners \(0, 0, 0\), \(0, 0, 1\), "
                                         r"\(0, 0, 1\)\) is degenerate"):
        sssphere.load_mesh(tmp_path / "d.off")


def test_defects_at_nearly_the_same_place_print_apart(tmp_path):
    """Edge coordinates had six digits: two open edges 1e-13 apart printed alike. They get
    the shortest decimal that reads back as the coordinate."""
    v = CUBE_V + [(1, 1 + 1e-13, 1)]  # 8: beside vertex 6, which one face uses instead
    faces = [tuple(8 if i == 6 and f == (1, 2, 6, 5) else i for i in f) for f in CUBE_F]
    _write_off(tmp_path / "n.off", v, faces)
    with pytest.raises(SceneError, match=r"\(1, 1\.0000000000001, 1\)"):
        sssphere.load_mesh(tmp_path / "n.off")


def test_a_vertex_no_face_uses_does_not_move_the_mesh(tmp_path):
    """The mesh is kept relative to the centre of its vertices' bounds in float: an unused
    vertex 3e7 away moved a cube by 0.15, one 1e10 away collapsed it to 'no volume'."""
    shifted = [(x + 0.3, y + 0.3, z + 0.3) for x, y, z in CUBE_V]
    for far in (3e7, 1e10, 1e30):
        _write_off(tmp_path / "u.off", shifted + [(far, 0, 0)], CUBE_F)
        v, _ = sssphere.load_mesh(tmp_path / "u.off")
        np.testing.assert_array_equal(v.min(axis=0), np.float32(0.3))
        np.testing.assert_array_equal(v.max(axis=0), np.float32(1.3))


@pytest.mark.parametrize("fmt", ["off", "ply"])
def test_a_byte_order_mark_before_an_off_or_ply_header_is_skipped(tmp_path, fmt):
    _write_off(tmp_path / "c.off", CUBE_V, CUBE_F)
    if fmt == "off":
        text = (tmp_path / "c.off").read_text()
    else:
        text = ("ply\nformat ascii 1.0\nelement vertex 8\nproperty float x\nproperty float y\n"
                "property float z\nelement face 6\nproperty list uchar int vertex_indices\n"
                "end_header\n" + "".join(" ".join(map(str, p)) + "\n" for p in CUBE_V) +
                "".join(f"4 {' '.join(map(str, f))}\n" for f in CUBE_F))
    (tmp_path / f"bom.{fmt}").write_bytes(b"\xef\xbb\xbf" + text.encode())
    v, t = sssphere.load_mesh(tmp_path / f"bom.{fmt}")
    assert len(v) == 8 and len(t) == 12


def test_a_medium_its_transform_or_float_rounding_flattens_is_refused(small_scene):
    """The 'encloses no volume' check ran on the file's mesh only: a scale of 1e-50 on one
    axis, or a plate 1e-8 thick that the render frame's float rounding flattens, made a
    medium with no inside, and the grid's inside test looped for ever (a hang that Ctrl-C
    could not stop; a review)."""
    box = {"vertices": CUBE_V, "faces": CUBE_F, "medium": {"sigma_t": 1, "albedo": 0.5}}
    for scale in ([1, 1, 1e-50], [1e-50, 1, 1]):
        scene = copy.deepcopy(small_scene)
        scene["shapes"] = [dict(box, transform={"scale": scale})]
        msg = error_of(scene)
        assert "shapes[0]" in msg and "after its transform" in msg and "volume 0" in msg, msg
    scene = copy.deepcopy(small_scene)
    scene["shapes"].append(dict(box, transform={"scale": [1, 1, 1e-8], "translate": [0, 0, 0.5]},
                                name="plate"))
    scene["shapes"][0]["sphere"]["center"] = [0, 0, -3]
    msg = error_of(scene)
    assert "shapes[1] ('plate'), after its transform" in msg, msg


def test_a_far_camera_is_refused_not_an_embree_abort(small_scene):
    """A camera ray that misses the shapes starts at the camera, and Embree aborts the
    process on an origin past 1.8e18 (exit 134, the Python interpreter with it). A camera
    1e20 away also read 'camera.up is parallel to the viewing direction' (its direction's
    float length overflowed)."""
    for origin, target in (([0, 0, 1e19], [0, 0, 2e19]), ([0, 0, 1e20], [0, 0, 0])):
        scene = copy.deepcopy(small_scene)
        scene["camera"].update(origin=origin, target=target)
        msg = error_of(scene)
        assert "camera.origin: lies 1e+" in msg and "at most 1e+17" in msg, msg
    scene = copy.deepcopy(small_scene)
    scene["camera"].update(origin=[0, 0, 1e16], target=[0, 0, 2e16])  # within: renders
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # far from the shapes, as said
        image = sssphere.render(sssphere.load_scene(scene), spp=1)
    assert np.all(np.isfinite(image))
