"""Writes the fuzz targets' seed corpora, tests/fuzz/corpus/<target>/, and the libFuzzer
dictionaries of the JSON targets, tests/fuzz/<target>.dict (docs/fuzzing.md).

    .venv/bin/python scripts/make_fuzz_corpus.py

Seeds are small on purpose (a few KB each): the scenes of scenes/ with their meshes replaced
by the two the scene target provides (cube.obj, tetra.off), scenes that use every light,
boundary and render field, tiny closed meshes in every format and encoding the readers
accept, the shipped decoders of models/, and tiny images (EXR and PNG through sssphere.write_image,
more PNG colour types written here). Run it again after changing the formats; the
output is deterministic.
"""

import json
import shutil
import struct
import tempfile
import zlib
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
OUT = REPO / "tests" / "fuzz" / "corpus"

# A tetrahedron and a cube, outward-facing, 0-based.
TETRA_V = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)]
TETRA_F = [(0, 2, 1), (0, 1, 3), (1, 2, 3), (0, 3, 2)]
CUBE_V = [(x, y, z) for z in (-1, 1) for y in (-1, 1) for x in (-1, 1)]
CUBE_F = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]


def triangles(faces):
    return [(f[0], f[i], f[i + 1]) for f in faces for i in range(1, len(f) - 1)]


def write(target, name, data):
    d = OUT / target
    d.mkdir(parents=True, exist_ok=True)
    (d / name).write_bytes(data if isinstance(data, bytes) else data.encode())


def obj(vs, fs, extra=""):
    lines = [f"v {x} {y} {z}" for x, y, z in vs] + ([extra] if extra else [])
    lines += ["f " + " ".join(str(i + 1) for i in f) for f in fs]
    return "\n".join(lines) + "\n"


def off(vs, fs, header="OFF"):
    lines = [header, f"{len(vs)} {len(fs)} 0"] + [f"{x} {y} {z}" for x, y, z in vs]
    lines += [f"{len(f)} " + " ".join(map(str, f)) for f in fs]
    return "\n".join(lines) + "\n"


def ply_ascii(vs, fs, extra_vertex_props=False):
    props = "property float x\nproperty float y\nproperty float z\n"
    if extra_vertex_props:
        props += "property float nx\nproperty uchar red\n"
    head = (f"ply\nformat ascii 1.0\ncomment seed\nelement vertex {len(vs)}\n{props}"
            f"element face {len(fs)}\nproperty list uchar int vertex_indices\nend_header\n")
    body = [" ".join(map(str, v)) + (" 0.5 7" if extra_vertex_props else "") for v in vs]
    body += [f"{len(f)} " + " ".join(map(str, f)) for f in fs]
    return head + "\n".join(body) + "\n"


def ply_binary(vs, fs, endian, vtype="float", itype="int"):
    fmt = {"little": "<", "big": ">"}[endian]
    vcode, icode = {"float": "f", "double": "d"}[vtype], {"int": "i", "uint": "I"}[itype]
    head = (f"ply\nformat binary_{endian}_endian 1.0\nelement vertex {len(vs)}\n"
            f"property {vtype} x\nproperty {vtype} y\nproperty {vtype} z\n"
            f"element face {len(fs)}\nproperty list uchar {itype} vertex_indices\n"
            "end_header\n").encode()
    body = b"".join(struct.pack(fmt + 3 * vcode, *v) for v in vs)
    body += b"".join(struct.pack(fmt + "B" + len(f) * icode, len(f), *f) for f in fs)
    return head + body


def stl_ascii(vs, fs):
    lines = ["solid seed"]
    for t in triangles(fs):
        lines += ["  facet normal 0 0 0", "    outer loop"]
        lines += [f"      vertex {vs[i][0]} {vs[i][1]} {vs[i][2]}" for i in t]
        lines += ["    endloop", "  endfacet"]
    return "\n".join(lines + ["endsolid seed"]) + "\n"


def stl_binary(vs, fs):
    tris = triangles(fs)
    data = b"seed".ljust(80, b" ") + struct.pack("<I", len(tris))
    for t in tris:
        data += struct.pack("<3f", 0, 0, 0)
        data += b"".join(struct.pack("<3f", *vs[i]) for i in t) + b"\0\0"
    return data


def png(width, height, color_type, bit_depth, rows, palette=None):
    def chunk(kind, payload):
        return (struct.pack(">I", len(payload)) + kind + payload
                + struct.pack(">I", zlib.crc32(kind + payload) & 0xFFFFFFFF))

    head = struct.pack(">IIBBBBB", width, height, bit_depth, color_type, 0, 0, 0)
    raw = b"".join(b"\0" + r for r in rows)
    data = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", head)
    if palette is not None:
        data += chunk(b"PLTE", palette)
    return data + chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b"")


def scenes():
    def with_small_meshes(scene):
        for i, s in enumerate(scene["shapes"]):
            if "mesh" in s:
                s["mesh"] = ["cube.obj", "tetra.off"][i % 2]
        return scene

    for path in sorted((REPO / "scenes").glob("*.json")):
        scene = with_small_meshes(json.loads(path.read_text()))
        write("scene", path.name, json.dumps(scene, indent=1))
    medium = {"sigma_t": [10, 20, 30], "albedo": [0.9, 0.8, 0.7], "g": 0.3}
    full = {
        "camera": {"origin": [0, 0, 5], "target": [0, 0, 0], "up": [0, 1, 0], "fov": 40,
                   "width": 8, "height": 6},
        "shapes": [
            {"name": "a", "mesh": "cube.obj", "normalize": True,
             "transform": {"scale": [1, 2, 0.5], "rotate_deg": [10, 20, 30],
                           "translate": [0.5, 0, 0]},
             "medium": medium, "boundary": {"type": "dielectric", "ior": 1.33}},
            {"mesh": "tetra.off", "transform": {"scale": 0.5, "translate": [3, 0, 0]},
             "medium": medium, "boundary": {"type": "index_matched"}},
            {"sphere": {"center": [-3, 0, 0], "radius": 0.5, "subdivisions": 1},
             "medium": medium},
        ],
        "lights": [
            {"type": "point", "position": [1, 2, 3], "intensity": [1, 1, 1]},
            {"type": "directional", "direction": [0, -1, 0], "irradiance": [2, 2, 2]},
            {"type": "area", "corner": [-1, 3, -1], "edge1": [2, 0, 0], "edge2": [0, 0, 2],
             "radiance": [3, 3, 3]},
            {"type": "environment", "radiance": [0.1, 0.1, 0.1]},
        ],
        "render": {"integrator": "st", "spp": 2, "seed": 7, "max_bounces": -1,
                   "grid_resolution": 16, "sphere_threshold": 0.01, "models": "models"},
    }
    write("scene", "full.json", json.dumps(full, indent=1))
    minimal = {"camera": full["camera"], "shapes": [{"sphere": {"center": [0, 0, 0],
                                                                 "radius": 1,
                                                                 "subdivisions": 0},
                                                      "medium": medium}]}
    write("scene", "minimal.json", json.dumps(minimal))
    return [full, minimal]


def meshes():
    for name, vs, fs in (("tetra", TETRA_V, TETRA_F), ("cube", CUBE_V, CUBE_F)):
        write("mesh_obj", f"{name}.obj", obj(vs, fs))
        write("mesh_off", f"{name}.off", off(vs, fs))
        write("mesh_ply", f"{name}_ascii.ply", ply_ascii(vs, fs))
        write("mesh_ply", f"{name}_le.ply", ply_binary(vs, fs, "little"))
        write("mesh_stl", f"{name}_ascii.stl", stl_ascii(vs, fs))
        write("mesh_stl", f"{name}_binary.stl", stl_binary(vs, fs))
    # Variants: OBJ with normals, texture coordinates, groups and v/vt/vn faces; OFF with
    # colours; PLY big-endian, double and unsigned, with extra properties.
    extra = "# comment\no cube\ng side\nvn 0 0 1\nvt 0.5 0.5\nusemtl none\ns off"
    write("mesh_obj", "cube_extra.obj", obj(CUBE_V, CUBE_F, extra))
    slashed = "\n".join(f"v {x} {y} {z}" for x, y, z in TETRA_V) + "\nvt 0 0\nvn 0 0 1\n"
    slashed += "\n".join("f " + " ".join(f"{i + 1}/1/1" for i in f) for f in TETRA_F)
    write("mesh_obj", "tetra_slashes.obj", slashed + "\n")
    coff = off(TETRA_V, TETRA_F, "COFF").replace("\n0 0 0\n", "\n0 0 0 255 0 0 255\n")
    write("mesh_off", "tetra_coff.off", coff)
    write("mesh_ply", "tetra_be.ply", ply_binary(TETRA_V, TETRA_F, "big", "double", "uint"))
    write("mesh_ply", "tetra_props.ply", ply_ascii(TETRA_V, TETRA_F, True))


def models():
    for path in sorted((REPO / "models").glob("*gen.json")):
        shutil.copy(path, OUT / "model" / path.name)


def images():
    import sssphere  # the dev environment's module writes the EXR seeds

    # Named <name>_exr and <name>_png: .gitignore ignores *.exr and *.png, and the targets
    # write each input to a file of their own extension anyway.
    rng = np.random.default_rng(0)
    with tempfile.TemporaryDirectory() as tmp:
        for channels in (1, 3):
            img = rng.random((3, 4, channels), dtype=np.float32)
            for ext in ("exr", "png"):
                path = Path(tmp) / f"c{channels}.{ext}"
                sssphere.write_image(path, img)
                write(f"image_{ext}", f"c{channels}_{ext}", path.read_bytes())
    w, h = 3, 2
    write("image_png", "gray8_png", png(w, h, 0, 8, [bytes(range(w))] * h))
    write("image_png", "gray16_png", png(w, h, 0, 16, [bytes(2 * w)] * h))
    write("image_png", "gray_alpha_png", png(w, h, 4, 8, [bytes(2 * w)] * h))
    write("image_png", "rgb16_png", png(w, h, 2, 16, [bytes(6 * w)] * h))
    write("image_png", "palette_png",
          png(w, h, 3, 8, [bytes([0, 1, 0])] * h, palette=bytes([255, 0, 0, 0, 0, 255])))
    write("image_png", "gray1_png", png(8, 2, 0, 1, [b"\xa5"] * 2))


def dictionary(name, docs, extra=()):
    """A libFuzzer dictionary: JSON punctuation and literals, every key and string value
    of the seed documents `docs`."""
    words = {"{", "}", "[", "]", ":", ",", '"', "true", "false", "null", "-1", "0", "1e999",
             "1e-999", "-0", "0.5", "NaN", *extra}

    def walk(v):
        if isinstance(v, dict):
            for k, x in v.items():
                words.add(f'"{k}"')
                walk(x)
        elif isinstance(v, list):
            for x in v:
                walk(x)
        elif isinstance(v, str) and len(v) <= 24 and " " not in v:
            words.add(f'"{v}"')

    for d in docs:
        walk(d)
    lines = [f'"{w.replace(chr(92), chr(92) * 2).replace(chr(34), chr(92) + chr(34))}"'
             for w in sorted(words)]
    (REPO / "tests" / "fuzz" / f"{name}.dict").write_text("\n".join(lines) + "\n")


def main():
    if OUT.exists():
        shutil.rmtree(OUT)
    (OUT / "model").mkdir(parents=True)
    generated = scenes()
    meshes()
    models()
    images()
    seed_scenes = [json.loads(p.read_text()) for p in sorted((OUT / "scene").iterdir())]
    dictionary("scene", seed_scenes + generated, ["cube.obj", "tetra.off"])
    seed_models = [json.loads(p.read_text()) for p in sorted((OUT / "model").iterdir())]
    dictionary("model", seed_models, ["affine", "log", "logit", "identity", "softplus"])
    total = sum(p.stat().st_size for p in OUT.rglob("*") if p.is_file())
    print(f"{OUT.relative_to(REPO)}: {sum(1 for p in OUT.rglob('*') if p.is_file())} "
          f"files, {total / 1024:.0f} KiB")


if __name__ == "__main__":
    main()
