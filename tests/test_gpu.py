"""The GPU path (backend "vulkan", cpp/gpu/) against the CPU's.

Each part of the shaders is compared with an independent implementation of the same thing:

* the BVH's closest hits (trace_rays.comp) with Embree's (embreex) on random rays;
* the GLSL decoders (sample_steps.comp) with the scalar C++ reference and the SIMD decoder on
  the same random streams, and the step's N = 1 branch with its known law;
* renders ("pt" and "st") with the CPU's by z-tests on image means, block means and mean path
  lengths; a furnace scene whose image is known exactly;
* the rules of the backend (what it refuses, with which message), determinism, record_paths.

Sample k of pixel (x, y) draws from the same stream on both backends, but float rounding makes
paths diverge, so renders are compared statistically, with different seeds (independent
estimates), never pixel by pixel.

Everything runs on Mesa's lavapipe (a CPU Vulkan driver) in CI, so the images are tiny. The
module is skipped only where no Vulkan device can be opened (or the build has no GPU path).
"""

from __future__ import annotations

import functools
import json
import math
from pathlib import Path

import numpy as np
import pytest

import sssphere
from sssphere import SceneError, _core
from sssphere.model import DEFAULT_MODELS

from render_stats import block_z, mean_z

_AVAILABLE, _DEVICE, _SOFTWARE = _core.gpu_status()  # (available, device or reason, software)
if not _AVAILABLE:
    pytest.skip(f"no Vulkan device: {_DEVICE}", allow_module_level=True)

REPO = Path(__file__).resolve().parents[1]
BUNNY = "/usr/share/glmark2/models/bunny.obj"

AREA = {"type": "area", "corner": [-1.5, 2.5, 1.5], "edge1": [0, 0, -3.0], "edge2": [3.0, 0, 0],
        "radiance": [1.5, 1.5, 1.5]}
ENV = {"type": "environment", "radiance": [0.3, 0.2, 0.1]}
DIELECTRIC = {"type": "dielectric", "ior": 1.5}
ROUGH_DIELECTRIC = {"type": "dielectric", "ior": 1.5, "roughness": 0.2}
INDEX_MATCHED = {"type": "index_matched"}

# Two-sided tolerance on a z-score of an image mean or a mean path length (p ~ 6e-5 each).
Z_MAX = 4.0



def _models(integrator: str, model_dir: str):
    """`models` for a render with `integrator`: an option of "st" alone."""
    return model_dir if integrator == "st" else None


def _render_gpu(scene, integrator, spp, seed, progress=None, batch=0, lanes=0, **options):
    """The binding's render on the Vulkan backend, with the benchmark knobs (dispatch batch,
    lanes) the public API does not offer."""
    return _core.render(scene, "", progress, {}, gpu_batch=batch, gpu_lanes=lanes, backend="vulkan",
                        integrator=integrator, spp=spp, seed=seed, **options)

def bunny_scene(res=(24, 16), sigma_t=50.0, albedo=(0.99, 0.95, 0.9), g=0.9,
                boundary=DIELECTRIC, lights=None) -> dict:
    """scenes/bunny.json (normalized bunny, area light + environment) at res = (width,
    height) pixels (not square, so that a swapped axis shows)."""
    d = json.loads((REPO / "scenes" / "bunny.json").read_text())
    d["camera"].update(width=res[0], height=res[1])
    d["shapes"][0]["mesh"] = BUNNY
    d["shapes"][0]["medium"].update(sigma_t=sigma_t, albedo=list(albedo), g=g)
    d["shapes"][0]["boundary"] = dict(boundary)
    d["lights"] = [AREA, ENV] if lights is None else lights
    d["render"] = {"grid_resolution": 32}
    return d


def sphere_scene(res=(16, 16), sigma_t=30.0, albedo=(0.99, 0.95, 0.9), g=0.5,
                 boundary=DIELECTRIC, lights=None) -> dict:
    """scenes/sphere.json (a unit sphere) at res = (width, height) pixels, lit by an area
    light above it and the environment."""
    d = json.loads((REPO / "scenes" / "sphere.json").read_text())
    d["camera"].update(width=res[0], height=res[1])
    d["shapes"][0]["sphere"]["subdivisions"] = 3
    d["shapes"][0]["medium"].update(sigma_t=sigma_t, albedo=list(albedo), g=g)
    d["shapes"][0]["boundary"] = dict(boundary)
    d["lights"] = [AREA, ENV] if lights is None else lights
    d["render"] = {"grid_resolution": 32}
    return d


def sphere_on_floor_scene(boundary=INDEX_MATCHED, lights=None) -> dict:
    """sphere_scene seen from above, the sphere resting over an opaque diffuse floor (an open
    mesh, scenes/meshes/floor.obj) that fills the lower half of the image; a point light
    besides the area light and the environment."""
    d = sphere_scene(sigma_t=30.0, g=0.5, boundary=boundary, lights=lights)
    d["camera"].update(origin=[0, 2.0, 4.0])
    d["shapes"].append({"mesh": str(REPO / "scenes" / "meshes" / "floor.obj"),
                        "transform": {"scale": 8, "translate": [0, -1.02, 0]},
                        "surface": {"type": "diffuse", "reflectance": [0.7, 0.6, 0.5]}})
    if lights is None:
        d["lights"].append({"type": "point", "position": [2, 2, -1], "intensity": [8, 8, 8]})
    return d


@functools.lru_cache(maxsize=None)
def _sky_map() -> str:
    """scenes/make_sky.py's sky (a 64 x 32 map with a small bright sun) in a file of its
    own, written once per test session."""
    import sys
    import tempfile

    sys.path.insert(0, str(REPO / "scenes"))
    import make_sky

    path = Path(tempfile.mkdtemp(prefix="sssphere-gpu-test-")) / "sky.exr"
    sssphere.write_image(path, make_sky.sky(64, 40, 70, sun_radiance=300.0, sun_radius_deg=4))
    return str(path)


# ---------------------------------------------------------------------------------------------
# BVH: closest hits against Embree.


def _quad_triangles(light):
    """The two triangles of an area light's quad, as the scene meshes it (CCW about
    edge1 x edge2, its emitting side)."""
    c, e1, e2 = (np.asarray(light[k], np.float64) for k in ("corner", "edge1", "edge2"))
    return np.array([[c, c + e1, c + e1 + e2], [c, c + e1 + e2, c + e2]])


@pytest.fixture(scope="module")
def bvh_scene():
    """A transformed bunny, a small sphere beside it and an area light: meshes 0, 1, 2."""
    d = {
        "camera": {"origin": [0, 0.1, 2.6], "target": [0, 0, 0], "fov": 30, "width": 4,
                   "height": 4},
        "shapes": [
            {"name": "bunny", "mesh": BUNNY, "normalize": True,
             "transform": {"scale": 0.8, "rotate_deg": [10, 30, -5], "translate": [0.1, -0.05, 0]},
             "medium": {"sigma_t": 10, "albedo": 0.9}, "boundary": DIELECTRIC},
            {"name": "ball", "sphere": {"center": [0.9, 0.5, -0.6], "radius": 0.25,
                                        "subdivisions": 2},
             "medium": {"sigma_t": 10, "albedo": 0.9}},
        ],
        "lights": [AREA, ENV],
        "render": {"grid_resolution": 16},
    }
    scene = sssphere.load_scene(d)
    triangles = []
    for i in range(scene.num_shapes):
        v, f = scene.shape_mesh(i)  # after normalize and transform
        triangles.append(np.asarray(v, np.float64)[np.asarray(f, np.int64)])
    triangles.append(_quad_triangles(AREA))
    return scene, triangles


def _random_rays(triangles, n, rng):
    """Rays of three kinds, n // 3 each (the rest of the first kind): from a sphere of radius 3
    around the bunny towards random points of its bounds; from that sphere in uniformly random
    directions (many miss everything); from random points inside the bunny's bounds (inside
    or outside the mesh) in random directions, as rays from inside a medium."""
    pts = triangles[0].reshape(-1, 3)
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    centre = 0.5 * (lo + hi)

    def unit(k):
        u = rng.normal(size=(k, 3))
        return u / np.linalg.norm(u, axis=1, keepdims=True)

    k = n // 3
    outside = centre + 3.0 * unit(n - k)
    towards = rng.uniform(lo, hi, size=(n - 2 * k, 3)) - outside[: n - 2 * k]
    towards /= np.linalg.norm(towards, axis=1, keepdims=True)
    origins = np.concatenate([outside, rng.uniform(lo, hi, size=(k, 3))])
    directions = np.concatenate([towards, unit(n - k)])
    return origins.astype(np.float32), directions.astype(np.float32)


def _embree_closest(triangles, origins, directions):
    """(t or -1, mesh index, unit geometric normal) of Embree's closest hits."""
    from embreex import rtcore_scene
    from embreex.mesh_construction import TriangleMesh

    es = rtcore_scene.EmbreeScene()
    for tri in triangles:  # geometry ids 0, 1, ... in this order
        TriangleMesh(es, np.ascontiguousarray(tri, np.float32))
    r = es.run(origins, directions, output=1)
    hit = r["geomID"] >= 0
    t = np.where(hit, r["tfar"], -1.0)
    ng = np.asarray(r["Ng"], np.float64)
    norm = np.linalg.norm(ng, axis=1, keepdims=True)
    normal = np.divide(ng, norm, out=np.zeros_like(ng), where=norm > 0)
    return t, r["geomID"], normal


def test_bvh_closest_hits_agree_with_embree(bvh_scene):
    """Every ray's closest hit (or miss), its distance, mesh and outward normal.

    Both sides intersect float32 triangles, Embree with its watertight test, the shader with
    Moller-Trumbore: a ray that grazes a shared edge or a silhouette within rounding can hit
    on one side and miss (or pass to the next surface) on the other. 1e-3 of the rays may
    disagree for that reason; none did when this was written. Elsewhere t agrees to float
    rounding (relative 1e-4) and the normals to 1e-3 (float32 cross products of the small,
    thin triangles of the bunny; a wrong or flipped normal is off by O(1))."""
    scene, triangles = bvh_scene
    rng = np.random.default_rng(20240601)
    n = 6000
    origins, directions = _random_rays(triangles, n, rng)
    gpu = _core.gpu_trace_rays(scene, origins, directions, 100.0)
    assert gpu.shape == (n, 4) and gpu.dtype == np.float32
    t_ref, mesh_ref, normal_ref = _embree_closest(triangles, origins, directions)

    gpu_t = gpu[:, 0].astype(np.float64)
    gpu_mesh = gpu[:, 1].view(np.uint32).astype(np.int64)
    hit_ref, hit_gpu = t_ref >= 0, gpu_t >= 0
    both = hit_ref & hit_gpu
    same = np.zeros(n, bool)
    same[both] = (gpu_mesh[both] == mesh_ref[both]) & (
        np.abs(gpu_t[both] - t_ref[both]) <= 1e-4 * t_ref[both])
    same |= ~hit_ref & ~hit_gpu
    bad = np.flatnonzero(~same)
    assert bad.size <= 1e-3 * n, (
        f"{bad.size} of {n} rays disagree with Embree; first: "
        + "; ".join(f"ray {i}: gpu t {gpu_t[i]:.6g} mesh {gpu_mesh[i]}, embree t {t_ref[i]:.6g} "
                    f"mesh {mesh_ref[i]}" for i in bad[:5]))
    # The rays exercise every kind of outcome.
    for m in range(len(triangles)):
        assert np.count_nonzero(same & hit_ref & (mesh_ref == m)) >= 20, m
    assert np.count_nonzero(same & ~hit_ref) >= 200
    # Normals (x and y returned) of the agreeing hits: outward, unit.
    ok = same & hit_ref
    err = np.abs(gpu[ok, 2:4] - normal_ref[ok, :2]).max(axis=1)
    assert err.max() <= 1e-3, f"normal off by {err.max():.3g} at ray {np.flatnonzero(ok)[err.argmax()]}"


def test_bvh_respects_tfar(bvh_scene):
    """With tfar = 2.5 a ray reports its closest hit when that is nearer, and a miss when it
    is farther (rays whose hit lies within rounding of tfar are left out)."""
    scene, triangles = bvh_scene
    rng = np.random.default_rng(7)
    origins, directions = _random_rays(triangles, 3000, rng)
    tfar = 2.5
    gpu = _core.gpu_trace_rays(scene, origins, directions, tfar)
    t_ref, mesh_ref, _ = _embree_closest(triangles, origins, directions)
    clear = (t_ref < 0) | (np.abs(t_ref - tfar) > 1e-4 * tfar)
    nearer = clear & (t_ref >= 0) & (t_ref < tfar)
    farther = clear & ~nearer
    assert nearer.sum() >= 500 and (farther & (t_ref >= 0)).sum() >= 500
    wrong_side = np.count_nonzero(nearer & (gpu[:, 0] < 0)) + np.count_nonzero(farther & (gpu[:, 0] >= 0))
    assert wrong_side <= 1e-3 * len(t_ref), wrong_side
    hits = nearer & (gpu[:, 0] >= 0)
    assert np.all(gpu[hits, 0] < tfar)
    # atol: the origins are rounded to float once more when moved into the scene's render
    # frame (a few 1e-8 at these coordinates), which a hit a few 1e-6 away sees relatively.
    np.testing.assert_allclose(gpu[hits, 0], t_ref[hits], rtol=1e-4, atol=1e-6)


# ---------------------------------------------------------------------------------------------
# Decoders: the GLSL sphere step against the C++ ones.


@pytest.fixture(scope="module")
def model_dir() -> str:
    return str(DEFAULT_MODELS)


@pytest.fixture(scope="module")
def step_inputs():
    """A few thousand (sigma, g) spanning the renderer's range: sigma log-uniform in
    [0.5, 200] (from mostly N = 1 to ~1e5 events), g uniform in [-0.9, 0.9]."""
    rng = np.random.default_rng(11)
    n = 4000
    sigma = np.exp(rng.uniform(math.log(0.5), math.log(200.0), n)).astype(np.float32)
    g = rng.uniform(-0.9, 0.9, n).astype(np.float32)
    return sigma, g


@pytest.fixture(scope="module")
def gpu_steps(model_dir, step_inputs):
    sigma, g = step_inputs
    return _core.gpu_sample_steps(model_dir, sigma, g, 1234)


def _same_n(gpu_n_float, cpu_n):
    """The GPU's N (floats) as integers and where they equal the CPU's: N is the floor of a
    decoded float, and exp/log rounding can move it across an integer, so up to 1 % of the
    items may differ, by one."""
    gpu_n = gpu_n_float.astype(np.int64)
    assert np.all(gpu_n_float == gpu_n), "N is not an integer"
    agree = gpu_n == cpu_n
    assert agree.mean() >= 0.99, f"N agrees for {agree.mean():.4f} of the items"
    off = np.abs(gpu_n - cpu_n)[~agree]
    assert np.all(off == 1), f"N differs by {off.max()} (not a rounding flip of floor)"
    return gpu_n, agree


@pytest.mark.parametrize("impl", ["scalar", "simd"])
def test_gpu_decoders_match_cpu_on_the_same_streams(model_dir, step_inputs, gpu_steps, impl):
    """Step i from Rng(1234, i) on both sides: the same N (floor of a decoded float: exp/log
    rounding can move it across an integer, so up to 1 % of the items may differ by one), and
    where N agrees the same exit (cos_theta, alpha, beta) to 1e-3 (float rounding through two
    small networks; a wrong weight, encoding or latent order is off by O(0.1))."""
    sigma, g = step_inputs
    n = sigma.size
    model = sssphere.ScatteringModel.load(model_dir)
    # Without phi the GPU draws no event (EventGen's normals would follow LengthGen's and
    # PathGen's on the stream), so the CPU leaves it out too.
    cpu = model._core.sample(sigma, g, np.ones(n, np.float32), n, 1234, 1, event=False,
                             impl=impl)
    assert gpu_steps.shape == (n, 12) and gpu_steps.dtype == np.float32
    assert not gpu_steps[:, 4:7].any() and np.all(gpu_steps[:, 8:11] == [0, 0, 1])
    gpu_n, agree = _same_n(gpu_steps[:, 0], cpu["N"])
    # Both branches are exercised: N = 1 (no network) and the networks.
    assert 100 <= np.count_nonzero(agree & (gpu_n == 1)) <= n - 1000
    assert np.count_nonzero(gpu_n >= 100) >= 1000
    for k, name in enumerate(["cos_theta", "alpha", "beta"], start=1):
        err = np.abs(gpu_steps[agree, k].astype(np.float64) - cpu[name][agree])
        i = int(np.flatnonzero(agree)[err.argmax()])
        assert err.max() <= 1e-3, (f"{name}: |gpu - cpu| = {err.max():.3g} at sigma {sigma[i]}, "
                                   f"g {g[i]}, N {gpu_n[i]}")
    # The exit stays on the unit disc and cos_theta in [-1, 1].
    assert np.all(np.abs(gpu_steps[:, 1]) <= 1)
    assert np.all(gpu_steps[:, 2] ** 2 + gpu_steps[:, 3] ** 2 <= 1)


@pytest.mark.parametrize("impl", ["scalar", "simd"])
def test_gpu_eventgen_matches_cpu_on_the_same_streams(model_dir, step_inputs, impl):
    """With the albedo phi (1 - phi log-uniform in [5e-5, 0.1]) both sides also draw the
    representative event from Rng(1234, i): the same choice of the first event (the centre,
    X = 0, W = +z; a uniform against (1 - phi) / (1 - phi^N), computed with log1p and expm1
    on both), and where N and that choice agree the same X and W to 1e-3 (a wrong weight,
    encoding, condition or latent order is off by O(0.1)). LengthGen and PathGen are
    unchanged by the event (their normals come first)."""
    sigma, g = step_inputs
    n = sigma.size
    rng = np.random.default_rng(12)
    phi = (1 - np.exp(rng.uniform(math.log(5e-5), math.log(0.1), n))).astype(np.float32)
    gpu = _core.gpu_sample_steps(model_dir, sigma, g, 1234, phi)
    model = sssphere.ScatteringModel.load(model_dir)
    cpu = model._core.sample(sigma, g, phi, n, 1234, 1, event=True, impl=impl)
    gpu_n = gpu[:, 0].astype(np.int64)
    agree = gpu_n == cpu["N"]
    assert agree.mean() >= 0.99, f"N agrees for {agree.mean():.4f} of the items"
    X, W = gpu[:, 4:7].astype(np.float64), gpu[:, 8:11].astype(np.float64)
    first_gpu = np.all(X == 0, axis=1) & np.all(W == [0, 0, 1], axis=1)
    first_cpu = np.all(cpu["X"] == 0, axis=1) & np.all(cpu["W"] == [0, 0, 1], axis=1)
    same_choice = first_gpu == first_cpu
    assert same_choice[agree].mean() >= 0.99, same_choice[agree].mean()
    # Both kinds of event occur: the centre, and EventGen's away from it.
    networks = agree & (gpu_n >= 2) & same_choice
    assert 100 <= np.count_nonzero(networks & first_gpu) <= np.count_nonzero(networks) - 1000
    ok = networks & ~first_gpu
    for name, got in (("X", X), ("W", W)):
        err = np.abs(got[ok] - cpu[name][ok]).max(axis=1)
        i = int(np.flatnonzero(ok)[err.argmax()])
        assert err.max() <= 1e-3, (f"{name}: |gpu - cpu| = {err.max():.3g} at sigma {sigma[i]}, "
                                   f"g {g[i]}, phi {phi[i]}, N {gpu_n[i]}")
    assert np.all(np.linalg.norm(X, axis=1) <= 1 + 1e-6)
    np.testing.assert_allclose(np.linalg.norm(W, axis=1), 1, atol=1e-6)
    without = _core.gpu_sample_steps(model_dir, sigma, g, 1234)
    np.testing.assert_array_equal(without[:, :4], gpu[:, :4])


def test_gpu_single_event_steps_follow_their_law(model_dir):
    """N = 1 with probability e^{-sigma} (binomial, |z| < 4 per sigma), and then the photon
    leaves along its first Henyey-Greenstein direction: cos_theta has the HG law for g
    (Kolmogorov-Smirnov, p > 1e-3)."""
    from scipy import stats

    g = 0.6
    per = 4000
    levels = np.array([0.5, 1.0, 2.0], np.float32)
    sigma = np.repeat(levels, per)
    out = _core.gpu_sample_steps(model_dir, sigma, np.full(sigma.size, g, np.float32), 99)
    single = out[:, 0] == 1
    for s in levels:
        k = np.count_nonzero(single[sigma == s])
        p = math.exp(-float(s))
        z = (k - per * p) / math.sqrt(per * p * (1 - p))
        assert abs(z) < Z_MAX, f"sigma {s}: {k} of {per} steps with N = 1, expected {per * p:.0f}"

    def hg_cdf(x):
        x = np.clip(x, -1.0, 1.0)
        return (1 - g * g) / (2 * g) * (1 / np.sqrt(1 + g * g - 2 * g * x) - 1 / (1 + g))

    cos_theta = out[single, 1].astype(np.float64)
    assert cos_theta.size > 3000
    p_value = stats.kstest(cos_theta, hg_cdf).pvalue
    assert p_value > 1e-3, f"cos_theta of N = 1 steps is not HG({g}): KS p = {p_value:.2g}"


# ---------------------------------------------------------------------------------------------
# Renders: the GPU against the CPU.


CUT_MODELS = str(REPO / "models" / "cut")


# (sigma, g, h, mu0, whether the exact N = 1 branch is common): a plane close ahead of the
# photon makes it so (e^-(sigma h / mu0) of the first flights reach it), one behind it or
# none (h = 1) leaves the networks nearly every step.
CUT_CASES = [(6.0, 0.9, 0.08, 0.2, True), (6.0, 0.0, 0.15, 0.3, True), (12.0, 0.5, 0.2, 0.9, True),
             (24.0, 0.9, 0.1, 0.7, True), (6.0, 0.9, 1.0, -1.0, False), (24.0, 0.9, 0.3, -0.5, False)]


@pytest.mark.parametrize("sigma, g, h, mu0, exact_too", CUT_CASES)
def test_gpu_cut_steps_match_cpu_on_the_same_streams(sigma, g, h, mu0, exact_too):
    """Cut step i from Rng(5, i) on both sides (cut_model.glsl and CutStepModel on lanes):
    the same N (floor of a decoded float: up to 1 % of the steps may differ by one, a
    rounding flip), and where N agrees the same side of exit (plane or cap) and the same exit
    point and direction to 1e-3 in the walk's frame (float rounding through two networks; a
    wrong weight, encoding or normal's place is off by O(0.1)). The networks are exercised
    in every case, the exact first flight (N = 1) where exact_too."""
    n = 3000
    full = [np.full(n, v, np.float32) for v in (sigma, g, h, mu0)]
    gpu = _core.gpu_sample_cut_steps(CUT_MODELS, *full, 5)
    cpu = _core.cut_steps(CUT_MODELS, sigma, g, h, mu0, n, seed=5)
    assert gpu.shape == (n, 12) and gpu.dtype == np.float32
    gpu_n, agree = _same_n(gpu[:, 0], cpu["N"])
    assert np.count_nonzero(agree & (gpu_n >= 2)) >= 500
    if exact_too:
        assert np.count_nonzero(agree & (gpu_n == 1)) >= 50
    plane = gpu[:, 1] == 1
    assert np.all(plane[agree] == cpu["through_plane"][agree].astype(bool))
    for name, cols in (("exit_pos", slice(4, 7)), ("exit_dir", slice(8, 11))):
        err = np.abs(gpu[agree, cols].astype(np.float64) - cpu[name][agree]).max(axis=1)
        i = int(np.flatnonzero(agree)[err.argmax()])
        assert err.max() <= 1e-3, f"{name}: |gpu - cpu| = {err.max():.3g} at step {i}, N {gpu_n[i]}"
    # The exit is on the region's boundary and leaves it: on the plane z = h with D.z >= 0,
    # or on the cap (unit length) with D . P >= 0.
    pos, d = gpu[:, 4:7].astype(np.float64), gpu[:, 8:11].astype(np.float64)
    np.testing.assert_allclose(np.linalg.norm(d, axis=1), 1, atol=1e-5)
    np.testing.assert_allclose(pos[plane, 2], h, atol=1e-6)
    assert np.all(d[plane, 2] >= 0)
    np.testing.assert_allclose(np.linalg.norm(pos[~plane], axis=1), 1, atol=1e-5)
    assert np.all(np.einsum("ij,ij->i", pos[~plane], d[~plane]) >= -1e-6)


def test_gpu_cut_steps_refuse_inputs_outside_the_training_ranges():
    with pytest.raises(ValueError, match="outside the training range"):
        _core.gpu_sample_cut_steps(CUT_MODELS, *[np.full(4, v, np.float32) for v in (6.0, 0.9, 0.5, 1.5)], 5)
    with pytest.raises(ValueError, match="one length"):
        _core.gpu_sample_cut_steps(CUT_MODELS, *[np.full(k, 0.5, np.float32) for k in (4, 4, 4, 3)], 5)


def _count_z(a, b, counts):
    """z-score of the difference of the mean per-path count (`counts`: "path_events" or
    "path_steps") of two renders, from their recorded paths. The standard error uses the
    spread over all paths of the image, which includes the spread between pixels: it
    overstates the error of a mean over equal samples per pixel, so the test is conservative."""
    x, y = (np.asarray(getattr(r, counts), np.float64).ravel() for r in (a, b))
    se2 = x.var(ddof=1) / x.size + y.var(ddof=1) / y.size
    diff = x.mean() - y.mean()
    if se2 == 0:
        return 0.0 if diff == 0 else math.inf
    return diff / math.sqrt(se2)


# p-value below which the block tests fail: 16 comparisons x 3 channels x 2 tests on a device
# whose rounding gives other paths than this one's (the seeds are fixed, the paths are not)
# stay below a 1 % chance of a false failure.
P_BLOCKS = 1e-4


def assert_renders_agree(cpu, gpu, what):
    """Image means per channel (|z| < Z_MAX); 4x4-block means per channel, by a chi-square
    test of their z-scores and a Bonferroni bound on max |z| (p = P_BLOCKS each: channels are
    tested separately, as in a grey medium they carry the same samples); the mean ordinary
    events and sphere steps per path (|z| < Z_MAX)."""
    from scipy import stats

    z = mean_z(cpu, gpu)
    assert np.all(np.abs(z) < Z_MAX), f"{what}: image means differ, z per channel {z}"
    for c, zc in enumerate(block_z(cpu, gpu)):
        n = zc.size
        assert n >= 8, (what, c, n)
        chi2 = float((zc ** 2).sum())
        assert stats.chi2.sf(chi2, n) > P_BLOCKS, \
            f"{what}, channel {c}: chi2 {chi2:.1f} over {n} blocks"
        assert np.abs(zc).max() < stats.norm.isf(P_BLOCKS / (2 * n)), \
            f"{what}, channel {c}: max |z| {np.abs(zc).max():.2f}"
    z_events = _count_z(cpu, gpu, "path_events")
    assert abs(z_events) < Z_MAX, (f"{what}: events per path {cpu.mean_events_per_path:.3f} (cpu) "
                                   f"vs {gpu.mean_events_per_path:.3f} (gpu), z {z_events:.2f}")
    z_steps = _count_z(cpu, gpu, "path_steps")
    assert abs(z_steps) < Z_MAX, (f"{what}: sphere steps per path "
                                  f"{cpu.mean_sphere_steps_per_path:.4f} (cpu) vs "
                                  f"{gpu.mean_sphere_steps_per_path:.4f} (gpu), z {z_steps:.2f}")


RENDER_CASES = {
    # The scene of scenes/bunny.json, less dense, at 24x16 pixels: dielectric, so the GPU's
    # estimator (no light sampling) is the CPU's with NEE (nee=True on both).
    "bunny_dielectric": (lambda: bunny_scene(sigma_t=50.0, g=0.9), True),
    # Chromatic extinction: pt with spectral MIS, st one channel per path (weight 3); many
    # sphere steps (sigma*r ~ 20-40).
    "sphere_dielectric_chromatic": (
        lambda: sphere_scene(sigma_t=[20.0, 30.0, 40.0], albedo=(0.99, 0.98, 0.97), g=0.5), True),
    # Channels ten times apart: st goes on in one channel where a step fits half the densest
    # (spectral_switch_extinction), and a thin channel picked there scatters instead.
    "sphere_dielectric_channels_far_apart": (
        lambda: sphere_scene(sigma_t=[8.0, 30.0, 80.0], albedo=(0.99, 0.98, 0.97), g=0.5), True),
    # Index-matched, without and with light sampling (area light and environment, MIS).
    "sphere_index_matched": (lambda: sphere_scene(sigma_t=30.0, g=0.7, boundary=INDEX_MATCHED),
                             False),
    "sphere_index_matched_nee": (
        lambda: sphere_scene(sigma_t=30.0, g=0.7, boundary=INDEX_MATCHED), True),
    # Shadow rays that leave and re-enter the medium (the ears and the body), chromatic
    # extinction: pt with spectral MIS, its shadow roulette by the smallest sigma_t.
    "bunny_index_matched_nee": (
        lambda: bunny_scene(sigma_t=[60.0, 80.0, 100.0], boundary=INDEX_MATCHED), True),
    # An opaque diffuse floor (light sampling and MIS at its points, shadow rays it blocks)
    # under an index-matched and under a dielectric medium.
    "floor_index_matched_nee": (lambda: sphere_on_floor_scene(), True),
    "floor_dielectric_nee": (
        lambda: sphere_on_floor_scene(boundary={**DIELECTRIC, "regularization": 0}), True),
    # A smooth dielectric regularized (alpha 0.1: a wide lobe, little noise): the point light
    # sampled at its boundary vertices, the area light and environment not.
    "floor_regularized_dielectric_nee": (
        lambda: sphere_on_floor_scene(boundary={**DIELECTRIC, "regularization": 0.1}), True),
    # A rough dielectric: light sampling at boundary vertices from both sides (point, area
    # and environment lights, MIS with the sampled lobe), over the floor.
    "floor_rough_dielectric_nee": (
        lambda: sphere_on_floor_scene(boundary=ROUGH_DIELECTRIC), True),
    # An environment map (its importance sampling, the table the shaders read), turned.
    "floor_environment_map_nee": (lambda: sphere_on_floor_scene(lights=[
        {"type": "environment", "map": _sky_map(), "scale": 0.8, "rotate_deg": [0, 30, 0]}]),
        True),
    # Dense: sigma*r up to 300, beyond the models' range (200), so steps are clipped to it.
    "sphere_dense": (lambda: sphere_scene(sigma_t=300.0, albedo=(0.99, 0.98, 0.95), g=0.7), True),
}


def _render_pair(scene, spp=128, **kw):
    """A CPU and a GPU render of `scene` with independent seeds, every path recorded."""
    cpu = sssphere.render_full(scene, spp=spp, seed=1, record_paths=True, **kw)
    gpu = sssphere.render_full(scene, spp=spp, seed=2, record_paths=True, backend="vulkan", **kw)
    assert gpu.backend == "vulkan" and cpu.backend == "cpu"
    assert gpu.image.shape == cpu.image.shape and gpu.events.shape == cpu.events.shape
    assert np.all(gpu.samples == spp) and not gpu.interrupted
    assert np.all(np.isfinite(gpu.image)) and np.all(gpu.image >= 0)
    return cpu, gpu


@pytest.mark.parametrize("integrator", ["pt", "st"])
@pytest.mark.parametrize("case", list(RENDER_CASES))
def test_gpu_render_agrees_with_cpu(case, integrator, model_dir):
    """CPU and GPU renders of one scene with independent seeds agree (assert_renders_agree):
    image means, block means, mean events and sphere steps per path."""
    make, nee = RENDER_CASES[case]
    scene = sssphere.load_scene(make())
    cpu, gpu = _render_pair(scene, integrator=integrator, nee=nee, models=_models(integrator, model_dir))
    if integrator == "st":
        assert gpu.mean_sphere_steps_per_path > 0.05, gpu.mean_sphere_steps_per_path
    else:
        assert gpu.mean_sphere_steps_per_path == 0 and not gpu.path_steps.any()
    assert_renders_agree(cpu, gpu, f"{case} {integrator}")


@pytest.mark.parametrize("boundary", [INDEX_MATCHED, DIELECTRIC], ids=["index_matched",
                                                                    "dielectric"])
def test_gpu_point_light_inside_a_medium_agrees_with_cpu(boundary):
    """A point light inside the medium, the only light: the shadow-ray roulette's bound is
    the distance to it where that is nearer than the grid's bound (direct_light on both
    backends; without it almost no shadow ray reached the light). Behind glass the events
    sample it too (Scene::medium_samples_lights: the baked shape's surface.z), at 1 / 1.5^2
    of its intensity (Scene::light_scale: the baked light's value)."""
    scene = sssphere.load_scene(sphere_scene(
        res=(32, 32), sigma_t=15.0, albedo=(0.95, 0.9, 0.85), g=0.0, boundary=boundary,
        lights=[{"type": "point", "position": [0.2, 0.1, 0.0], "intensity": [4, 4, 4]}]))
    cpu, gpu = _render_pair(scene, integrator="pt", nee=True)
    assert cpu.image.mean() > 1e-3, cpu.image.mean()  # the light is seen
    assert_renders_agree(cpu, gpu, f"point light inside, {boundary['type']}")


CUT_RENDER_CASES = {
    # Dielectric boundaries (the media whose events sample no light: they take cut steps),
    # grey and chromatic (one channel per path from the first step on, weight 3).
    "bunny_dielectric": lambda: bunny_scene(sigma_t=50.0, g=0.9),
    "sphere_dielectric_chromatic": lambda: sphere_scene(sigma_t=[20.0, 30.0, 40.0],
                                                        albedo=(0.99, 0.98, 0.97), g=0.5),
}


@pytest.mark.parametrize("case", list(CUT_RENDER_CASES))
def test_gpu_cut_steps_render_agrees_with_cpu(case, model_dir):
    """"st" with cut_models on both backends (render.glsl's cut_certificate and
    path_cut_step against PathTracer's): the renders agree as above, steps per path included,
    and the cut steps are taken: a path takes more steps than without them."""
    scene = sssphere.load_scene(CUT_RENDER_CASES[case]())
    cpu, gpu = _render_pair(scene, integrator="st", nee=True, models=model_dir,
                            cut_models=CUT_MODELS)
    assert_renders_agree(cpu, gpu, f"{case} st with cut steps")
    spheres_only = sssphere.render_full(scene, spp=32, seed=3, integrator="st", nee=True,
                                        models=model_dir, backend="vulkan")
    assert gpu.mean_sphere_steps_per_path > 1.5 * spheres_only.mean_sphere_steps_per_path, \
        (gpu.mean_sphere_steps_per_path, spheres_only.mean_sphere_steps_per_path)


@pytest.mark.parametrize("max_bounces", [0, 2])
def test_gpu_max_bounces_agrees_with_cpu(max_bounces):
    """max_bounces counts scattering events the same way on both backends: the images agree,
    and the longest path has the same count: max_bounces (the collision past it ends the
    path without scattering, and is not counted)."""
    scene = sssphere.load_scene(sphere_scene(sigma_t=30.0, g=0.7, boundary=INDEX_MATCHED))
    cpu, gpu = _render_pair(scene, integrator="pt", nee=False, max_bounces=max_bounces)
    assert_renders_agree(cpu, gpu, f"max_bounces {max_bounces}")
    assert gpu.path_events.max() == cpu.path_events.max() == max_bounces


def test_camera_samples_use_the_cpus_streams():
    """Sample k of pixel (x, y) draws from the CPU's stream Rng(seed, y * width + x, k).

    A one-pixel-high image across the tilted lower edge of an area light (the medium is
    behind the camera): each sample sees the light or nothing, decided by its film jitter
    alone, so every pixel counts the samples whose jitter falls above the edge. With the CPU's
    seed the GPU must count the same in (nearly) every pixel: only a sample within rounding
    of the edge can flip. With another seed most pixels differ."""
    d = {
        "camera": {"origin": [0, 0, 0], "target": [0, 1, 0], "up": [0, 0, 1], "fov": 10,
                   "width": 48, "height": 1},
        "shapes": [{"name": "behind", "sphere": {"center": [0, -5, 0], "radius": 0.5,
                                                 "subdivisions": 1},
                    "medium": {"sigma_t": 1, "albedo": 0.5}, "boundary": DIELECTRIC}],
        "lights": [{"type": "area", "corner": [-5, 1, -0.03], "edge1": [10, 0, 0.06],
                    "edge2": [0, 0, 1], "radiance": [1, 1, 1]}],
    }
    scene = sssphere.load_scene(d)
    cpu = sssphere.render_full(scene, spp=16, seed=9)
    partial = (cpu.image[..., 0] > 0) & (cpu.image[..., 0] < 1)
    assert partial.mean() > 0.9  # the edge crosses the pixels
    same = sssphere.render_full(scene, spp=16, seed=9, backend="vulkan")
    other = sssphere.render_full(scene, spp=16, seed=10, backend="vulkan")
    assert (same.image == cpu.image).all(axis=2).mean() >= 0.95
    assert (other.image == cpu.image).all(axis=2).mean() <= 0.5


@pytest.mark.parametrize("integrator", ["pt", "st"])
def test_gpu_furnace(integrator, model_dir):
    """Albedo 1 under a constant environment: every path leaves the medium with throughput 1
    (no absorption, so no roulette), so every pixel is the environment's radiance exactly,
    with zero variance, however many events or sphere steps the path took."""
    env = {"type": "environment", "radiance": [0.5, 0.25, 1.0]}
    scene = sssphere.load_scene(bunny_scene(sigma_t=50.0, albedo=(1, 1, 1), g=0.7, lights=[env]))
    r = sssphere.render_full(scene, integrator=integrator, spp=8, seed=3, backend="vulkan",
                             models=_models(integrator, model_dir))
    np.testing.assert_array_equal(r.image, np.broadcast_to(np.float32(env["radiance"]), r.image.shape))
    assert not r.variance.any()
    assert r.mean_events_per_path > 1
    if integrator == "st":
        assert r.mean_sphere_steps_per_path > 0.05


# ---------------------------------------------------------------------------------------------
# What the backend refuses.


POINT = {"type": "point", "position": [2, 3, 2.5], "intensity": [12, 10, 12]}
DIRECTIONAL = {"type": "directional", "direction": [-0.3, -1, -0.2], "irradiance": [0.8, 1.0, 1.5]}


@pytest.mark.parametrize("integrator", ["pt", "st"])
def test_gpu_delta_lights_agree_with_cpu(integrator, model_dir):
    """Point and directional lights, seen only by light sampling, beside an area light and the
    environment (one light chosen per event, MIS for the two that paths also hit), in an
    index-matched medium with a chromatic albedo: "pt" with NEE agrees with the CPU's, and so
    does "st", whose balls keep clear of the boundary and the point light (SphereTracing::
    clearance, the GPU's step_radius)."""
    scene = sssphere.load_scene(sphere_scene(sigma_t=30.0, g=0.7, boundary=INDEX_MATCHED,
                                             lights=[POINT, AREA, DIRECTIONAL, ENV]))
    cpu, gpu = _render_pair(scene, integrator=integrator, nee=True,
                            models=_models(integrator, model_dir))
    if integrator == "st":
        assert gpu.mean_sphere_steps_per_path > 0.05, gpu.mean_sphere_steps_per_path
    assert_renders_agree(cpu, gpu, f"delta lights, {integrator}")
    # The test has power: those lights add much light (without NEE, which misses them, the
    # image is darker by many standard errors in every channel).
    dark = sssphere.render_full(scene, integrator=integrator, spp=128, seed=3, nee=False,
                                backend="vulkan", models=_models(integrator, model_dir))
    z = mean_z(gpu, dark)
    assert np.all(z > 3 * Z_MAX), z


def test_gpu_clearance_with_chromatic_extinction_and_a_light_inside_agrees_with_cpu(model_dir):
    """The clearance of st's steps (SphereTracing::step_radius, render.glsl's step_radius):
    chromatic extinction (measured in spectral_switch_extinction, here the smallest channel's,
    before the one carried is picked, then in that one's)
    and a point light inside the medium, which the balls keep clear of, beside a directional
    light and the environment."""
    inside = {"type": "point", "position": [0.45, 0, 0], "intensity": [2, 2, 2]}
    scene = sssphere.load_scene(sphere_scene(sigma_t=[40.0, 50.0, 65.0], albedo=(0.995, 0.99, 0.98),
                                             g=0.5, boundary=INDEX_MATCHED,
                                             lights=[inside, DIRECTIONAL, ENV]))
    cpu, gpu = _render_pair(scene, integrator="st", nee=True, models=model_dir)
    assert gpu.mean_sphere_steps_per_path > 0.05, gpu.mean_sphere_steps_per_path
    assert_renders_agree(cpu, gpu, "clearance, chromatic, light inside")


def test_too_many_lights_are_refused():
    lights = [dict(AREA, corner=[-1.5, 2.5 + 0.01 * i, 1.5]) for i in range(17)]
    scene = sssphere.load_scene(sphere_scene(res=(4, 4), lights=lights))
    with pytest.raises(SceneError, match=r"17 lights; the GPU path renders at most 16"):
        sssphere.render_full(scene, spp=1, backend="vulkan")


@pytest.mark.parametrize("kwargs, expected", [
    ({"backend": "cuda"}, r"backend 'cuda' is not allowed \(allowed: 'cpu', 'vulkan'\)"),
    ({"backend": "vulkan", "integrator": "st", "sphere_sampler": "walk"},
     r"sphere_sampler 'walk' is CPU-only"),
    ({"backend": "vulkan", "threads": 2}, r"threads=2 is CPU-only"),
    ({"backend": "vulkan", "integrator": "st", "step_nee": "event"},
     r"step_nee 'event' is CPU-only"),
    # with pt it is wrong on either backend (it said "CPU-only", as if pt took it there)
    ({"backend": "vulkan", "integrator": "pt", "step_nee": "event"},
     r"step_nee 'event' is an option of integrator 'st' \(the integrator is 'pt'\)"),
    ({"backend": "vulkan", "integrator": "st", "max_bounces": 3}, r"max_bounces 3 is not supported "
     r"by integrator 'st' \(allowed: -1\)"),
    # 16 pixels at 2^23 + 1 spp: 16 paths more than record_paths holds (2^27).
    ({"backend": "vulkan", "spp": (1 << 23) + 1, "record_paths": True},
     r"record_paths keeps at most 2\^27 paths; 8388609 spp x 16 pixels are more"),
])
def test_bad_arguments(kwargs, expected):
    scene = sssphere.load_scene(sphere_scene(res=(4, 4)))
    kwargs.setdefault("spp", 1)
    with pytest.raises(SceneError, match=expected):
        sssphere.render_full(scene, **kwargs)


# ---------------------------------------------------------------------------------------------
# Determinism and the result's fields.


def test_gpu_dispatches_start_at_one_sample_and_grow_at_most_fourfold():
    """Without a fixed batch the first dispatch renders one sample per pixel and each later
    one at most four times the last, so progress and Ctrl-C are answered soon on a slow
    device; a callback that stops after the first dispatch keeps exactly its samples."""
    scene = sssphere.load_scene(sphere_scene(res=(16, 16), sigma_t=30.0))
    spp = 64
    seen = []

    def record(fraction):
        seen.append(round(fraction * spp))
        return True

    r = _render_gpu(scene, "pt", spp, 3, progress=record)
    assert not r["cancelled"]
    assert seen[0] == 0 and seen[1] == 1 and seen[-1] == spp
    sizes = np.diff(seen)
    assert np.all(sizes >= 1) and np.all(sizes[1:] <= 4 * sizes[:-1]), seen

    calls = []
    stopped = _render_gpu(scene, "pt", spp, 3, progress=lambda f: calls.append(f) or len(calls) < 2)
    assert stopped["cancelled"]
    np.testing.assert_array_equal(stopped["samples"], 1)


def test_gpu_time_limit_stops_between_dispatches_with_the_spp_reached():
    """A time limit ends a GPU render between dispatches (every dispatch covers every pixel,
    so the samples stay uniform); the image is that of a render of the spp reached."""
    scene = sssphere.load_scene(sphere_scene(res=(16, 16), sigma_t=30.0))
    r = sssphere.render_full(scene, backend="vulkan", time_limit=0.5, seed=7)
    assert r.time_limit_reached and not r.interrupted
    assert 1 <= r.spp < 1 << 24 and np.all(r.samples == r.spp)
    assert r.seconds < 30
    full = sssphere.render_full(scene, backend="vulkan", spp=r.spp, seed=7)
    np.testing.assert_array_equal(r.image, full.image)


@pytest.mark.parametrize("integrator", ["pt", "st"])
def test_gpu_render_is_deterministic(integrator, model_dir):
    """The same seed gives the same image whatever the batching of samples into dispatches
    (sample k of a pixel has its own stream); another seed gives another image."""
    scene = sssphere.load_scene(sphere_scene(res=(12, 8), sigma_t=30.0))
    kw = dict(integrator=integrator, spp=6, backend="vulkan", models=_models(integrator, model_dir))
    a = sssphere.render_full(scene, seed=5, **kw)
    b = sssphere.render_full(scene, seed=5, **kw)
    c = sssphere.render_full(scene, seed=6, **kw)
    np.testing.assert_array_equal(a.image, b.image)
    np.testing.assert_array_equal(a.events, b.events)
    np.testing.assert_array_equal(a.sphere_steps, b.sphere_steps)
    assert not np.array_equal(a.image, c.image)
    # Two samples per dispatch instead of all six at once.
    batched = _render_gpu(scene, integrator, 6, 5, models=_models(integrator, model_dir), batch=2)
    np.testing.assert_array_equal(batched["image"], a.image)
    np.testing.assert_array_equal(batched["events"], a.events)
    # 100 lanes for the 576 paths: a lane renders every 100th path, starting the next when
    # one ends (path regeneration; "st" batches steps among the lanes still running).
    for lanes in (100, 576 + 64):
        regenerated = _render_gpu(scene, integrator, 6, 5, models=_models(integrator, model_dir),
                                  record_paths=True,
                                  lanes=lanes)
        np.testing.assert_array_equal(regenerated["image"], a.image)
        np.testing.assert_array_equal(regenerated["events"], a.events)
        np.testing.assert_array_equal(regenerated["sphere_steps"], a.sphere_steps)


def test_the_grid_only_saves_work_in_pt():
    """pt's paths do not depend on the distance grid: it only tells which flights cannot
    reach the boundary (and a collision inside the ball certified at its flight's start
    takes that ball, shrunk by the flight, without a query). Grids of 3, 48 and 160 cells
    give the same image, event for event (ctest PathTracer.TheGridOnlySavesWork)."""
    first = None
    for res in (3, 48, 160):
        d = sphere_scene(res=(12, 12), sigma_t=40.0, albedo=(0.98,) * 3, g=0.5)
        d["render"] = {"grid_resolution": res}
        r = sssphere.render_full(sssphere.load_scene(d), spp=4, seed=1, backend="vulkan")
        assert r.mean_events_per_path > 10, r.mean_events_per_path
        if first is None:
            first = r
        else:
            np.testing.assert_array_equal(r.image, first.image, err_msg=f"grid of {res} cells")
            np.testing.assert_array_equal(r.events, first.events, err_msg=f"grid of {res} cells")


def test_st_without_possible_steps_is_pt(model_dir):
    """Where the grid's bound times sigma_t stays under the threshold everywhere, "st"
    takes no step and renders pt's paths exactly (the renderer then runs the pt kernel)."""
    scene = sssphere.load_scene(sphere_scene(res=(12, 8), sigma_t=5.0))  # unit sphere: sigma_t r <= 5
    kw = dict(spp=4, seed=2, backend="vulkan")
    st = sssphere.render_full(scene, integrator="st", models=model_dir, **kw)
    pt = sssphere.render_full(scene, integrator="pt", **kw)
    assert st.mean_sphere_steps_per_path == 0 and st.mean_events_per_path > 0.5
    np.testing.assert_array_equal(st.image, pt.image)
    np.testing.assert_array_equal(st.events, pt.events)


def test_paths_that_do_not_end_fail_the_render():
    """Every path's result carries a mark the host checks. Mesa's lavapipe silently ends all
    loops of a shader invocation after 65535 iterations; one lane rendering all 1024 paths
    of a dense medium in one dispatch (~240,000 scattering events) needs more, and the
    render must then fail by name, not return the paths it finished. On a GPU (no such
    limit) the same render equals the default one."""
    scene = sssphere.load_scene(sphere_scene(res=(8, 8), sigma_t=300.0, albedo=(0.999,) * 3))
    args = (scene, "pt", 16, 1)
    if _SOFTWARE:
        with pytest.raises(SceneError, match=r"of 1024 paths did not end on the Vulkan device "
                                             r".*65535 iterations.*backend 'cpu'"):
            _render_gpu(*args, batch=16, lanes=1)
    else:
        np.testing.assert_array_equal(_render_gpu(*args, batch=16, lanes=1)["image"],
                                      _render_gpu(*args)["image"])


def test_gpu_record_paths(model_dir):
    scene = sssphere.load_scene(sphere_scene(res=(12, 8), sigma_t=30.0, boundary=INDEX_MATCHED))
    assert sssphere.render_full(scene, spp=2, nee=False, backend="vulkan").path_events is None
    r = sssphere.render_full(scene, integrator="st", spp=6, seed=3, nee=False, backend="vulkan",
                             record_paths=True, models=model_dir)
    assert r.path_events.shape == r.path_steps.shape == (6, 8, 12)  # (spp, height, width)
    assert r.path_events.dtype == r.path_steps.dtype == np.uint32
    np.testing.assert_allclose(r.path_events.mean(axis=0), r.events, rtol=1e-6)
    np.testing.assert_allclose(r.path_steps.mean(axis=0), r.sphere_steps, rtol=1e-6)
    assert r.path_events.mean() == pytest.approx(r.mean_events_per_path, rel=1e-12)
    assert r.path_steps.mean() == pytest.approx(r.mean_sphere_steps_per_path, rel=1e-12)
    assert r.path_steps.any() and r.path_events.any()
    # Paths differ: the samples of the centre pixel are not copies of each other.
    assert len(np.unique(r.path_events[:, 4, 6])) > 1
    # The same paths with and without recording.
    plain = sssphere.render_full(scene, integrator="st", spp=6, seed=3, nee=False,
                                 backend="vulkan", models=model_dir)
    np.testing.assert_array_equal(plain.image, r.image)
    # Where it ran.
    assert r.backend == "vulkan" and r.device == _DEVICE
    assert r.gpu_seconds is not None and 0 < r.gpu_seconds


def test_gpu_st_renders_a_medium_the_models_were_not_trained_for_without_steps(models_with):
    """As on the CPU (test_st.py): g outside the models' range is no error; the medium takes
    no steps (pt's image, bit for bit) and the render warns, naming the shape."""
    edited = models_with(g=[-0.4, 0.4])
    scene = json.loads((REPO / "scenes" / "sphere.json").read_text())
    scene["camera"].update(width=8, height=8)
    scene["shapes"][0]["medium"].update(sigma_t=100.0, albedo=[0.99, 0.95, 0.9], g=0.5)
    scene["shapes"][0]["sphere"]["subdivisions"] = 3
    scene["render"] = {"grid_resolution": 32}
    scene = sssphere.load_scene(scene)
    with pytest.warns(sssphere.SceneWarning, match=r"shapes\[0\] \('sphere'\): integrator 'st' "
                      r"takes no sphere steps in this medium.*g = 0.5 is outside"):
        st = sssphere.render_full(scene, integrator="st", models=edited, spp=4, seed=2,
                                  backend="vulkan")
    assert st.mean_sphere_steps_per_path == 0
    pt = sssphere.render_full(scene, integrator="pt", spp=4, seed=2, backend="vulkan")
    np.testing.assert_array_equal(st.image, pt.image)
    trained = sssphere.render_full(scene, integrator="st", spp=4, seed=2, backend="vulkan")
    assert trained.mean_sphere_steps_per_path > 0
