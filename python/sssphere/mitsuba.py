"""Mitsuba 3 scenes from sssphere scenes: the same meshes, media, camera and lights, so that
both renderers can be compared on any scene (our tests do; so can users).

    import json, sssphere, sssphere.mitsuba
    scene_dict = json.load(open("scenes/sphere.json"))
    scene = sssphere.load_scene(scene_dict, base_dir="scenes")
    mi_scene = sssphere.mitsuba.load_mitsuba_scene(scene_dict, scene, "/tmp", spp=64)

Needs the ``mitsuba`` package (the ``test`` and ``bench`` extras install it).

The translation keeps everything that matters for an unbiased comparison identical:
* geometry: Mitsuba gets *our* triangle mesh (``Scene.shape_mesh(i)``, world space,
  counter-clockwise = outward) as a PLY file with ``face_normals`` (no smooth shading
  normals, which would change refraction at a dielectric boundary);
* boundary: ``null`` BSDF for index-matched shapes, ``dielectric`` (int_ior, ext_ior = 1)
  otherwise; the medium is the shape's ``interior`` (homogeneous, ``sigma_t`` as an unbounded
  sRGB spectrum since it exceeds 1, ``albedo`` rgb, ``hg`` phase);
* opaque surfaces: each surface type writes its own BSDF (``mitsuba`` in
  cpp/render/surfaces/<type>.h): ``diffuse`` as ``twosided`` ``diffuse`` (ours reflects on
  both sides of an open mesh), with no interior medium;
* camera: ``perspective`` with ``look_at(origin, target, up)``, ``fov_axis = 'y'`` (our fov is
  vertical), ``hdrfilm`` with a ``box`` filter (each sample lands in one pixel, uniform jitter);
  Mitsuba's images are not mirrored against ours (checked in the tests with an asymmetric scene);
* lights: each light type translates itself (``mitsuba`` in cpp/render/lights/<type>.h):
  ``point`` (intensity), ``directional`` (irradiance, direction = direction of travel),
  ``constant`` environment (radiance), an environment map as ``envmap`` (the same file, its
  ``scale``, ``to_world`` the rotation: our map convention is Mitsuba's), and an area light
  as a ``rectangle`` whose ``to_world`` maps [-1, 1]^2 onto corner + [0, 1] edge1 + [0, 1] edge2 with local +z onto
  normalize(cross(edge1, edge2)) -- Mitsuba's area emitter emits towards its normal, one-sided,
  as ours does; its BSDF is black (ours absorbs everything that hits the quad);
* integrator: ``volpath`` with ``max_depth = -1`` and a huge ``rr_depth`` (Mitsuba's default
  Russian roulette from depth 5 is unbiased but has enormous variance in dense media).

Known limitation of the peer (measured with Mitsuba 3.9.1, scalar_rgb): at a null interface
Mitsuba continues the ray from ``si.spawn_ray``, offset along the normal by
``(1 + max|p|) * RayEpsilon`` (RayEpsilon = 8.94e-5; 1.3e-4 at |p| = 0.45). That skips a thin layer
of medium at every crossing, and Mitsuba's images of dense media come out dark, by roughly
``0.35 * sigma_t * offset`` (a sphere of radius 0.45, sigma_t = 30, albedo 0.9-0.95: 0.15 % at
unit scale; the same scene shrunk 10x: 0.4-0.9 %; shrunk 100x: 6-11 %; grown 10x: no detectable
difference). Our renderer's image is the same at all these scales. Compare at scales where
``sigma_t * offset`` is small, or expect Mitsuba to be dark by about that much.
"""

from __future__ import annotations

import json
import os
from typing import Sequence

import numpy as np

from . import _core

VARIANT = "scalar_rgb"
RR_DEPTH = 100000


def import_mitsuba(variant: str = VARIANT):
    """Import Mitsuba with `variant` selected (the variant is process-wide)."""
    import mitsuba as mi

    if mi.variant() != variant:
        mi.set_variant(variant)
    mi.set_log_level(mi.LogLevel.Warn)
    return mi


def write_ply(path: str | os.PathLike, vertices: np.ndarray, triangles: np.ndarray) -> None:
    """Binary little-endian PLY with float32 positions and uint32 triangle indices."""
    v = np.ascontiguousarray(vertices, dtype="<f4").reshape(-1, 3)
    t = np.ascontiguousarray(triangles, dtype="<u4").reshape(-1, 3)
    header = (
        "ply\nformat binary_little_endian 1.0\n"
        f"element vertex {len(v)}\nproperty float x\nproperty float y\nproperty float z\n"
        f"element face {len(t)}\nproperty list uchar uint vertex_indices\nend_header\n"
    ).encode("ascii")
    faces = np.empty(len(t), dtype=[("n", "u1"), ("i", "<u4", (3,))])
    faces["n"] = 3
    faces["i"] = t
    with open(path, "wb") as f:
        f.write(header)
        f.write(v.tobytes())
        f.write(faces.tobytes())


def _unbounded(mi, rgb: Sequence[float]) -> dict:
    return {"type": "srgb", "color": mi.ScalarColor3f(*map(float, rgb)), "unbounded": True}


def _rgb(mi, rgb: Sequence[float]) -> dict:
    return {"type": "rgb", "value": mi.ScalarColor3f(*map(float, rgb))}


def _from_markers(mi, value):
    """Mitsuba's types in a plain dict from the C++ light types' translations: {"$rgb": ...}
    becomes an unbounded sRGB colour and {"$matrix": rows} a transform."""
    if isinstance(value, dict):
        if set(value) == {"$rgb"}:
            return _unbounded(mi, value["$rgb"])
        if set(value) == {"$matrix"}:
            return mi.ScalarTransform4f(value["$matrix"])
        return {k: _from_markers(mi, v) for k, v in value.items()}
    if isinstance(value, list):
        return [_from_markers(mi, v) for v in value]
    return value


def mitsuba_scene_dict(
    scene_dict: dict,
    our_scene,
    mesh_dir: str | os.PathLike,
    spp: int,
    seed: int = 0,
    rr_depth: int = RR_DEPTH,
    max_depth: int = -1,
    variant: str = VARIANT,
) -> dict:
    """Translate an sssphere scene dict (plus its loaded Scene, for the meshes) to a Mitsuba
    `load_dict` dict. Meshes are written as PLY files into `mesh_dir`."""
    mi = import_mitsuba(variant)
    cam = scene_dict["camera"]
    out: dict = {
        "type": "scene",
        "integrator": {"type": "volpath", "max_depth": int(max_depth), "rr_depth": int(rr_depth)},
        "sensor": {
            "type": "perspective",
            "fov": float(cam["fov"]),
            "fov_axis": "y",
            "to_world": mi.ScalarTransform4f().look_at(
                origin=[float(x) for x in cam["origin"]],
                target=[float(x) for x in cam["target"]],
                up=[float(x) for x in cam.get("up", [0, 1, 0])],
            ),
            "sampler": {"type": "independent", "sample_count": int(spp), "seed": int(seed)},
            "film": {
                "type": "hdrfilm",
                "width": int(cam["width"]),
                "height": int(cam["height"]),
                "rfilter": {"type": "box"},
                "pixel_format": "rgb",
                "component_format": "float32",
            },
        },
    }
    for i, shape in enumerate(scene_dict["shapes"]):
        verts, tris = our_scene.shape_mesh(i)
        ply = os.path.join(os.fspath(mesh_dir), f"shape{i}.ply")
        write_ply(ply, verts, tris)
        if "surface" in shape:
            # An opaque surface: its type writes its BSDF (render/surfaces/<type>.h).
            out[f"shape{i}"] = {
                "type": "ply",
                "filename": ply,
                "face_normals": True,
                "bsdf": _from_markers(
                    mi, json.loads(_core.surface_to_mitsuba(json.dumps(shape["surface"])))
                ),
            }
            continue
        med = shape["medium"]
        # However the medium is stated (sigma_t + albedo, sigma_s + sigma_a, a preset).
        coefficients = _core.medium_coefficients(json.dumps(med))
        # Each boundary type writes its own BSDF (render/boundaries/<type>.h).
        boundary = shape.get("boundary", {"type": "index_matched"})
        bsdf = _from_markers(mi, json.loads(_core.boundary_to_mitsuba(json.dumps(boundary))))
        out[f"shape{i}"] = {
            "type": "ply",
            "filename": ply,
            "face_normals": True,
            "bsdf": bsdf,
            "interior": {
                "type": "homogeneous",
                "sigma_t": _unbounded(mi, coefficients["sigma_t"]),
                "albedo": _rgb(mi, coefficients["albedo"]),
                # Each phase function type writes its own (render/phase/<type>.h).
                "phase": json.loads(_core.phase_to_mitsuba(json.dumps(med))),
            },
        }
    for j, light in enumerate(scene_dict.get("lights", [])):
        if "map" in light:  # an environment map: its file, found as our scene found it
            light = dict(light, map=os.path.join(our_scene.base_dir, light["map"]))
        # Each light type writes its own translation (render/lights/<type>.h).
        out[f"light{j}"] = _from_markers(mi, json.loads(_core.light_to_mitsuba(json.dumps(light))))
    return out


def load_mitsuba_scene(scene_dict: dict, our_scene, mesh_dir, spp: int, **kw):
    mi = import_mitsuba(kw.get("variant", VARIANT))
    return mi.load_dict(mitsuba_scene_dict(scene_dict, our_scene, mesh_dir, spp, **kw))


# The XML tag of each plugin type the translation writes (Mitsuba's object classes).
_XML_TAGS = {
    "scene": "scene", "volpath": "integrator", "volpathmis": "integrator",
    "perspective": "sensor", "independent": "sampler", "hdrfilm": "film", "box": "rfilter",
    "ply": "shape", "rectangle": "shape", "null": "bsdf", "dielectric": "bsdf",
    "roughdielectric": "bsdf", "diffuse": "bsdf", "twosided": "bsdf", "homogeneous": "medium",
    "hg": "phase", "isotropic": "phase", "point": "emitter", "directional": "emitter",
    "constant": "emitter", "envmap": "emitter", "area": "emitter", "srgb": "texture",
}


def _xml_value(name: str, value, pad: str) -> list[str]:
    from xml.sax.saxutils import quoteattr

    def numbers(v) -> str:
        return ", ".join(repr(float(x)) for x in v)

    if isinstance(value, dict):
        kind = value["type"]
        if kind == "rgb":  # an RGB texture, written as Mitsuba's <rgb> shorthand
            return [f'{pad}<rgb name={quoteattr(name)} value="{numbers(value["value"])}"/>']
        tag = _XML_TAGS.get(kind)
        if tag is None:
            raise ValueError(f"no XML tag known for Mitsuba plugin type {kind!r}")
        head = f'{pad}<{tag} type={quoteattr(kind)}'
        head += ">" if tag in ("scene",) else f" name={quoteattr(name)}>"
        lines = [head if tag != "scene" else f'{pad}<scene version="3.0.0">']
        for k, v in value.items():
            if k != "type":
                lines += _xml_value(k, v, pad + "    ")
        return lines + [f"{pad}</{tag}>"]
    n = quoteattr(name)
    if isinstance(value, bool):
        return [f'{pad}<boolean name={n} value="{str(value).lower()}"/>']
    if isinstance(value, int):
        return [f'{pad}<integer name={n} value="{value}"/>']
    if isinstance(value, float):
        return [f'{pad}<float name={n} value="{value!r}"/>']
    if isinstance(value, str):
        return [f"{pad}<string name={n} value={quoteattr(value)}/>"]
    if isinstance(value, (list, tuple)) and len(value) == 3:
        return [f'{pad}<vector name={n} value="{numbers(value)}"/>']
    kind = type(value).__name__
    if "Transform" in kind:
        m = np.array(value.matrix, dtype=np.float64).reshape(4, 4)
        return [f"{pad}<transform name={n}>",
                f'{pad}    <matrix value="{" ".join(repr(float(x)) for x in m.ravel())}"/>',
                f"{pad}</transform>"]
    if "Color" in kind:
        return [f'{pad}<rgb name={n} value="{numbers(list(value))}"/>']
    raise ValueError(f"cannot write {name} = {value!r} ({kind}) as Mitsuba XML")


def chromatic_extinction(scene) -> bool:
    """Whether some medium of a loaded scene has a sigma_t that differs between channels."""
    for i in range(scene.num_shapes):
        info = scene.shape_info(i)
        if info["kind"] == "medium" and len(set(info["sigma_t"])) > 1:
            return True
    return False


def export_mitsuba(scene_path: str | os.PathLike, xml_path: str | os.PathLike, spp: int = 64,
                   seed: int = 0, integrator: str | None = None) -> list[str]:
    """Write the Mitsuba 3 scene equivalent to an sssphere scene file: ``xml_path`` and, in
    the folder ``<xml stem>_meshes`` beside it, each shape's triangle mesh as PLY (ours, in
    world space, as the tests compare them). Paths in the XML are relative to it, so the
    two can move together; ``mitsuba out.xml`` or ``mi.load_file`` renders it. Mitsuba runs
    with max_depth -1 and rr_depth 100000 (an unbiased estimate comparable with ours).
    ``integrator``: ``"volpath"`` or ``"volpathmis"``; by default ``volpathmis`` where a
    medium's sigma_t differs between channels (volpath samples distances with one channel
    and weights the others by ratios: its estimate there is heavy-tailed, far from converged
    at thousands of samples), else ``volpath``. A scene's ``render.max_bounces`` is not
    exported (a SceneWarning says so): Mitsuba's max_depth counts every interaction, ours
    scattering events. Returns the files written."""
    import warnings

    from sssphere.scene import SceneError, SceneWarning, load_scene

    scene_path, xml_path = os.fspath(scene_path), os.fspath(xml_path)
    ours = load_scene(scene_path)  # a bad file gets the parser's SceneError
    bounces = ours.to_dict().get("render", {}).get("max_bounces", -1)
    if bounces >= 0:
        warnings.warn(f"{scene_path}: render.max_bounces {bounces} is not exported: Mitsuba's "
                      "max_depth counts every interaction (surfaces, refractions, index-matched "
                      "crossings), ours the scattering events; the XML renders every bounce "
                      "(max_depth -1)", SceneWarning, stacklevel=2)
    for i in range(ours.num_shapes):
        info = ours.shape_info(i)
        sigma_t = list(info["sigma_t"]) if info["kind"] == "medium" else []
        if 0 in sigma_t and max(sigma_t) > 0:
            warnings.warn(f"{scene_path}: shapes[{i}] ('{info['name']}'): sigma_t "
                          f"{[float(x) for x in sigma_t]} has a channel of 0, which Mitsuba "
                          "3 does not render right (volpath gives NaN, volpathmis darkens the "
                          "other channels: measured 2026-11-30); the XML keeps it, give the "
                          "channel a small sigma_t (1e-3) to compare", SceneWarning,
                          stacklevel=2)
    if integrator is None:
        integrator = "volpathmis" if chromatic_extinction(ours) else "volpath"
    scene_dict = ours.to_dict()
    xml_dir = os.path.dirname(os.path.abspath(xml_path))
    stem = os.path.splitext(os.path.basename(xml_path))[0]
    mesh_dir = os.path.join(xml_dir, f"{stem}_meshes")
    try:
        os.makedirs(mesh_dir, exist_ok=True)
    except OSError as e:  # a raw "[Errno 2] ... '/proc/m_meshes'" before (a review)
        raise SceneError(f"{xml_path}: cannot make the meshes' directory {mesh_dir} "
                         f"({e.strerror})") from None
    d = mitsuba_scene_dict(scene_dict, ours, mesh_dir, spp=spp, seed=seed)
    d["integrator"]["type"] = integrator
    written = [xml_path]
    for value in d.values():  # file names relative to the XML
        if isinstance(value, dict) and "filename" in value:
            if value["type"] == "ply":
                written.append(value["filename"])
            value["filename"] = os.path.relpath(os.path.abspath(value["filename"]), xml_dir)
    text = "\n".join(['<?xml version="1.0" encoding="utf-8"?>',
                      f"<!-- Mitsuba 3 scene written by sssphere from {scene_path} -->",
                      *_xml_value("", d, "")]) + "\n"
    with open(xml_path, "w", encoding="utf-8") as f:
        f.write(text)
    return written
