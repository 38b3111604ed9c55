"""sssphere.ScatteringModel: loading decoder files (docs/model-format.md), sampling sphere steps,
and the two C++ decoders (scalar reference, SIMD) against a plain numpy evaluation of the file.

The model files are written here, with random weights of paper Table 1's shapes, by a small
numpy writer of the contract format: nothing depends on a trained model.
"""

import json
import math

import numpy as np
import pytest

import sssphere
from sssphere import ScatteringModel
from sssphere import model as model_module

# name, conditions, outputs, latent_dim, hidden width (two hidden layers): paper Table 1.
SHAPES = {
    "LengthGen": (["sigma", "g"], ["N"], 2, 8),
    "PathGen": (["sigma", "g", "N"], ["cos_theta", "alpha", "beta"], 5, 16),
    "EventGen": (["sigma", "g", "phi", "N", "cos_theta", "alpha", "beta"],
                 ["X_x", "X_y", "X_z", "W_x", "W_y", "W_z"], 5, 16),
}
ENCODINGS = {
    "sigma": {"kind": "log", "a": 0.5, "b": -1.0, "c": 1.0},      # ln(1 + sigma)
    "g": {"kind": "affine", "a": 2.0},
    "phi": {"kind": "log", "s": -1.0, "c": 1.001},                # ln(1 - phi + 1e-3)
    "N": {"kind": "log", "a": 0.5},                               # ln(N) / 2
}
TRAINING = {"sigma": [0, 200], "g": [-0.95, 0.95], "phi": [0, 1], "samples": 0, "seed": 0}


def f9(x):
    """A float32 written with 9 significant digits (reads back exactly)."""
    return float(f"{np.float32(x):.9g}")


def decoder_dict(name, rng, weight_scale=1.0, logvar_bias=-2.0):
    """A model-format dict with random weights for decoder `name`."""
    conditions, outputs, latent, width = SHAPES[name]
    input_width = (len(conditions) + latent + 3) // 4 * 4
    widths = [input_width, width, width, 2 * len(outputs)]
    layers = []
    for i in range(3):
        fan_in, fan_out = widths[i], widths[i + 1]
        a = weight_scale * math.sqrt(3.0 / fan_in)
        w = rng.uniform(-a, a, size=(fan_out, fan_in)).astype(np.float32)
        b = rng.uniform(-0.5, 0.5, size=fan_out).astype(np.float32)
        if i == 2:
            b[: len(outputs)] = [0.5 * math.log(10.0) if o == "N" else 0.0 for o in outputs]
            b[len(outputs):] = logvar_bias
        layers.append({"in": fan_in, "out": fan_out, "activation": "identity" if i == 2 else "softplus",
                       "weight": [[f9(v) for v in row] for row in w], "bias": [f9(v) for v in b]})
    return {
        "format": "sssphere-cvae-decoder",
        "format_version": 1,
        "notation_version": 1,
        "name": name,
        "conditions": [{"name": c, "encode": ENCODINGS.get(c, {"kind": "affine"})} for c in conditions],
        "latent_dim": latent,
        "input_width": input_width,
        "layers": layers,
        "outputs": [{"name": o, "encode": ENCODINGS.get(o, {"kind": "affine"})} for o in outputs],
        "training": dict(TRAINING),
        "metrics": {"latent_dims_used": latent},
    }


def write_models(directory, seed=0, **kwargs):
    rng = np.random.default_rng(seed)
    directory.mkdir(parents=True, exist_ok=True)
    dicts = {}
    for name in SHAPES:
        d = decoder_dict(name, rng, **kwargs)
        (directory / f"{name.lower()}.json").write_text(json.dumps(d))
        dicts[name] = d
    return dicts


def numpy_forward(d, x):
    """mean, logvar of decoder dict `d` for inputs x (batch, input_width), in float64."""
    h = np.asarray(x, dtype=np.float64)
    for layer in d["layers"]:
        h = h @ np.asarray(layer["weight"], dtype=np.float64).T + np.asarray(layer["bias"])
        if layer["activation"] == "softplus":
            h = np.where(h > 20, h, np.log1p(np.exp(np.minimum(h, 20))))
    n = len(d["outputs"])
    return h[:, :n], h[:, n:]


def rel_err(a, b):
    """Symmetric relative error per output column, judged against the larger of the two values
    and the column's root-mean-square (a value that cancels to ~0 is judged on the scale of
    its column)."""
    a, b = np.asarray(a, np.float64), np.asarray(b, np.float64)
    scale = np.maximum(np.maximum(np.abs(a), np.abs(b)), np.sqrt(np.mean(b * b, axis=0)))
    return float(np.max(np.abs(a - b) / scale))


@pytest.fixture
def models(tmp_path):
    dicts = write_models(tmp_path / "models")
    return ScatteringModel.load(tmp_path / "models"), dicts


# ---- loading --------------------------------------------------------------------------------

def test_load_and_repr(models):
    model, _ = models
    assert isinstance(model, sssphere.ScatteringModel)
    assert model.sigma_range == (0.0, 200.0)
    assert model.input_width("LengthGen") == 4
    assert model.input_width("pathgen") == 8
    assert model.input_width("EventGen") == 12
    assert "LengthGen, PathGen, EventGen" in repr(model)


def test_default_directory_missing_is_a_clear_error(tmp_path, monkeypatch):
    monkeypatch.setattr(model_module, "DEFAULT_MODELS", tmp_path / "models")
    with pytest.raises(ValueError, match="no models directory"):
        ScatteringModel.load()
    write_models(tmp_path / "models")
    assert ScatteringModel.load().path == str(tmp_path / "models")


def test_default_directory_is_the_repository_models():
    # In a source checkout the package's models are the repository's (a wheel, and the
    # sanitizer build's package root, link or copy them into the package)
    assert model_module.DEFAULT_MODELS.resolve() == (
        __import__("pathlib").Path(__file__).resolve().parents[1] / "models")


def load_error(directory):
    with pytest.raises(ValueError) as info:
        ScatteringModel.load(directory)
    return str(info.value)


def test_load_errors(tmp_path):
    assert "not a directory" in load_error(tmp_path / "nowhere")
    d = tmp_path / "m"
    dicts = write_models(d)
    (d / "eventgen.json").unlink()
    msg = load_error(d)
    assert "eventgen.json" in msg and "cannot open" in msg

    def broken(edit, text=None):
        dd = dict(json.loads(json.dumps(dicts["EventGen"])))
        edit(dd)
        (d / "eventgen.json").write_text(text(dd) if text else json.dumps(dd))
        return load_error(d)

    msg = broken(lambda e: e.update(format_version=2))
    assert "eventgen.json" in msg and "format_version 2" in msg and "format_version 1" in msg
    assert "sssphere-cvae-decoder" in broken(lambda e: e.update(format="onnx"))
    assert "unknown key 'dropout'" in broken(lambda e: e.update(dropout=0.1))
    assert "layers[1].in" in broken(lambda e: e["layers"][1].update({"in": 15}))
    assert "input_width" in broken(lambda e: e.update(input_width=16))
    assert "not a finite float32" in broken(lambda e: e["layers"][0]["bias"].__setitem__(0, 1e39))
    # json.dumps writes NaN, which is not JSON.
    assert "must be finite" in broken(lambda e: e["layers"][0]["bias"].__setitem__(0, math.nan))
    assert "malformed JSON" in broken(lambda e: None, text=lambda e: json.dumps(e)[:-10])
    assert "unknown encoding kind \"sqrt\"" in broken(
        lambda e: e["conditions"][0].update(encode={"kind": "sqrt"}))
    assert "where EventGen was expected" in broken(lambda e: e.update(name="PathGen"))


# ---- sampling -------------------------------------------------------------------------------

def test_sample_keys_shapes_and_invariants(models):
    model, _ = models
    n = 20000
    rng = np.random.default_rng(3)
    out = model.sample(sigma_t=rng.uniform(0, 60, n), g=rng.uniform(-0.9, 0.9, n),
                       albedo=rng.uniform(0, 1, n), n=n, seed=7)
    assert set(out) == {"N", "cos_theta", "alpha", "beta", "X", "W"}
    assert out["N"].dtype == np.int64 and out["N"].shape == (n,)
    for k in ("cos_theta", "alpha", "beta"):
        assert out[k].dtype == np.float32 and out[k].shape == (n,)
    for k in ("X", "W"):
        assert out[k].dtype == np.float32 and out[k].shape == (n, 3)
    for k, v in out.items():
        assert np.all(np.isfinite(v)), k
    assert out["N"].min() >= 1
    assert np.all(np.abs(out["cos_theta"]) <= 1)
    a, b = out["alpha"].astype(np.float64), out["beta"].astype(np.float64)
    assert np.all(a * a + b * b <= 1 + 1e-6)
    assert np.all(np.linalg.norm(out["X"].astype(np.float64), axis=1) <= 1 + 1e-6)
    assert np.allclose(np.linalg.norm(out["W"].astype(np.float64), axis=1), 1, atol=1e-5)
    # N = 1: exact single scattering, nothing else moves.
    one = out["N"] == 1
    assert one.any() and (~one).any()
    assert np.all(out["alpha"][one] == 0) and np.all(out["beta"][one] == 0)
    assert np.all(out["X"][one] == 0) and np.all(out["W"][one] == [0, 0, 1])


def test_post_processing_holds_for_wild_networks(tmp_path):
    """Large weights and variances: raw outputs far outside every range get clamped."""
    write_models(tmp_path / "m", weight_scale=8.0, logvar_bias=3.0)
    model = ScatteringModel.load(tmp_path / "m")
    out = model.sample(sigma_t=50.0, g=0.5, albedo=0.8, n=5000, seed=1)
    a, b = out["alpha"].astype(np.float64), out["beta"].astype(np.float64)
    assert np.all(a * a + b * b <= 1 + 1e-6)
    assert np.mean(np.abs(a * a + b * b - 1) < 1e-5) > 0.05  # scaled onto the circle
    assert np.mean(np.abs(out["cos_theta"]) == 1) > 0.05      # clamped
    assert np.all(np.linalg.norm(out["X"].astype(np.float64), axis=1) <= 1 + 1e-6)
    assert np.allclose(np.linalg.norm(out["W"].astype(np.float64), axis=1), 1, atol=1e-5)
    assert out["N"].min() >= 2  # sigma = 50: N = 1 has probability e^-50


@pytest.mark.parametrize("sigma", [0.1, 0.7, 2.0])
def test_single_scattering_probability_is_exp_minus_sigma(models, sigma):
    model, _ = models
    n = 40000
    out = model.sample(sigma_t=sigma, g=0.3, albedo=0.5, n=n, seed=11)
    p = math.exp(-sigma)
    assert abs(np.mean(out["N"] == 1) - p) < 4.5 * math.sqrt(p * (1 - p) / n)


def test_reproducible_and_independent_of_threads(models):
    model, _ = models
    args = dict(sigma_t=np.linspace(0, 30, 3001), g=0.2, albedo=0.9, n=3001)
    a = model.sample(**args, seed=5, threads=1)
    b = model.sample(**args, seed=5, threads=3)
    c = model.sample(**args, seed=6)
    for k in a:
        np.testing.assert_array_equal(a[k], b[k])
    assert not np.array_equal(a["cos_theta"], c["cos_theta"])


def test_scalar_and_simd_sampling_agree(models):
    model, _ = models
    n = 4000
    s = np.linspace(0.5, 80, n, dtype=np.float32)
    g = np.full(n, 0.4, np.float32)
    phi = np.full(n, 0.7, np.float32)
    a = model._core.sample(s, g, phi, n, 3, 0, True, "scalar")
    b = model._core.sample(s, g, phi, n, 3, 0, True, "simd")
    same_n = a["N"] == b["N"]
    assert np.mean(same_n) > 0.998
    for k in ("cos_theta", "alpha", "beta", "X", "W"):
        np.testing.assert_allclose(a[k][same_n], b[k][same_n], atol=1e-4, err_msg=k)


def test_every_simd_target_can_be_pinned_and_samples_alike(models):
    """Pinning a target (for benchmarks of other CPUs) switches the decoders the sampler
    uses; every target samples the same law (the scalar one above within rounding)."""
    model, _ = models
    targets = ScatteringModel.simd_targets()
    default = ScatteringModel.simd_default_target()
    assert targets and default in targets and ScatteringModel.simd_target() == default
    n = 2000
    args = dict(sigma_t=np.linspace(0.5, 80, n), g=0.4, albedo=0.7, n=n, seed=3)
    try:
        runs = {}
        for t in targets:
            ScatteringModel.use_simd_target(t)
            assert ScatteringModel.simd_target() == t
            runs[t] = model.sample(**args)
        with pytest.raises(ValueError, match="SIMD target 'NOSUCH' is not available here"):
            ScatteringModel.use_simd_target("NOSUCH")
    finally:
        ScatteringModel.use_simd_target("")
    assert ScatteringModel.simd_target() == default
    a = runs[targets[0]]
    for t in targets[1:]:
        b = runs[t]
        same_n = a["N"] == b["N"]
        assert np.mean(same_n) > 0.998, t
        for k in ("cos_theta", "alpha", "beta", "X", "W"):
            np.testing.assert_allclose(a[k][same_n], b[k][same_n], atol=1e-4, err_msg=f"{t} {k}")


@pytest.mark.parametrize(
    "kwargs, expected",
    [
        (dict(sigma_t=-1.0), "sigma_t[0] = -1.0 is not allowed"),
        (dict(sigma_t=math.nan), "sigma_t[0] = nan is not a finite number"),
        (dict(sigma_t=math.inf), "not a finite number"),
        # named sigma_t, as here (it was the decoders' "sigma[0]")
        (dict(sigma_t=250.0), "sigma_t[0] = 250 is outside the models' training range [0, 200]"),
        (dict(g=1.0), "g[0] = 1.0 is not allowed (allowed: -1 < g < 1)"),
        (dict(g=-0.97), "outside the training range [-0.95, 0.95]"),
        (dict(albedo=1.5), "albedo[0] = 1.5 is not allowed"),
        (dict(albedo=-0.1), "albedo[0]"),
        (dict(n=0), "n must be an integer from 1 to 2**31 - 1, got 0"),
        (dict(n=2.5), "n must be an integer from 1"),
        (dict(n=True), "n must be an integer from 1"),
        (dict(n=10**13), "n must be an integer from 1 to 2**31 - 1, got 10000000000000"),
        (dict(sigma_t=[1.0, 2.0]), "sigma_t must be a number or an array of shape (4,)"),
        (dict(g=np.zeros((4, 1))), "g must be a number or an array of shape (4,)"),
        (dict(albedo="dark"), "albedo must be a number or a 1-D array"),
        (dict(seed=-1), "seed must be an integer"),
        (dict(threads=5000), "threads must be an integer from 0 to 4096 (0 or None = all cores)"),
        (dict(threads=-1), "threads must be an integer from 0 to 4096"),
    ],
)
def test_bad_sample_arguments(models, kwargs, expected):
    model, _ = models
    args = dict(sigma_t=1.0, g=0.0, albedo=0.5, n=4, seed=0)
    args.update(kwargs)
    with pytest.raises(ValueError) as info:
        model.sample(**args)
    assert expected in str(info.value), str(info.value)


def test_sample_takes_threads_0_as_all_cores_as_renders_do(models):
    model, _ = models
    a = model.sample(sigma_t=5.0, g=0.3, albedo=0.9, n=64, seed=3, threads=0)
    b = model.sample(sigma_t=5.0, g=0.3, albedo=0.9, n=64, seed=3)
    np.testing.assert_array_equal(a["N"], b["N"])
    np.testing.assert_array_equal(a["X"], b["X"])


def test_bad_value_in_an_array_is_named_by_index(models):
    model, _ = models
    with pytest.raises(ValueError, match=r"sigma_t\[2\] = 300 is outside the models. training range"):
        model.sample(sigma_t=np.array([1.0, 2.0, 300.0]), g=0.0, albedo=0.5, n=3)


# ---- the decoders ---------------------------------------------------------------------------

@pytest.mark.parametrize("name", list(SHAPES))
@pytest.mark.parametrize("scale", [1.0, 5.0])
def test_evaluate_matches_numpy_and_scalar_matches_simd(tmp_path, name, scale):
    dicts = write_models(tmp_path / "m", seed=2, weight_scale=scale)
    model = ScatteringModel.load(tmp_path / "m")
    d = dicts[name]
    x = np.random.default_rng(4).uniform(-3, 3, size=(3000, d["input_width"])).astype(np.float32)
    mean_s, logvar_s = model.evaluate(name, x, impl="scalar")
    mean_v, logvar_v = model.evaluate(name, x, impl="simd")
    mean_n, logvar_n = numpy_forward(d, x)
    n_out = len(d["outputs"])
    assert mean_s.shape == mean_v.shape == (3000, n_out) and mean_v.dtype == np.float32
    assert rel_err(mean_v, mean_s) < 1e-5 and rel_err(logvar_v, logvar_s) < 1e-5
    assert rel_err(mean_s, mean_n) < 1e-5 and rel_err(logvar_s, logvar_n) < 1e-5
    assert rel_err(mean_v, mean_n) < 1e-5 and rel_err(logvar_v, logvar_n) < 1e-5


def test_evaluate_errors(models):
    model, _ = models
    with pytest.raises(ValueError, match=r"x must have shape \(batch, 8\) for PathGen"):
        model.evaluate("PathGen", np.zeros((3, 4), np.float32))
    with pytest.raises(ValueError, match="no decoder named 'SizeGen'"):
        model.evaluate("SizeGen", np.zeros((3, 4), np.float32))
    with pytest.raises(ValueError, match="impl 'gpu' is not allowed"):
        model.evaluate("LengthGen", np.zeros((3, 4), np.float32), impl="gpu")
    x = np.zeros((4, 8), np.float32)
    x[2, 5] = np.nan  # gave finite means and log-variances (a review)
    with pytest.raises(ValueError, match=r"x\[2, 5\] = nan is not allowed \(allowed: finite inputs\)"):
        model.evaluate("PathGen", x)
