"""The learning pipeline (python/sssphere/learn/) and its oracle, the NumPy reference walker
(tests/reference_walks.py): walker facts that need no simulation, the training-data loader,
a few-second training run, decoder parity (PyTorch / onnxruntime / NumPy), file round trips and
the errors for bad files and inputs."""

import json
import math
import os
import shlex
import sys

from pathlib import Path

import numpy as np
import onnxruntime as ort
import pytest
import torch

import sssphere

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from reference_walks import hg_sample_cos, reference_sphere_walks  # noqa: E402

from sssphere.cli import main as cli_main  # noqa: E402
from sssphere.learn import data as learn_data  # noqa: E402
from sssphere.learn.data import DataError, generate_training_data, load_training_data  # noqa: E402
from sssphere.learn.export import CheckpointError, export_checkpoint, load_checkpoint  # noqa: E402
from sssphere.learn.numpy_decoder import (ModelFileError, SphereSampler,  # noqa: E402
                                          load_decoder, postprocess)
from sssphere.learn.spec import PATHGEN, SPECS, Encoding  # noqa: E402
from sssphere.learn.train import TrainConfig, fit_encodings, train  # noqa: E402

STEMS = [s.file_stem for s in SPECS]


def binomial_ok(k: int, n: int, p: float, z: float = 4.5) -> bool:
    return abs(k - n * p) <= z * math.sqrt(n * p * (1 - p)) + 1


def hg_cdf(g: float, mu: np.ndarray) -> np.ndarray:
    """P(cos θ ≤ mu) for HG(g), from ∫ρ dω = ½ ∫ (1−g²)/(1+g²−2g t)^{3/2} dt."""
    return (1 - g * g) / (2 * g) * (1 / np.sqrt(1 + g * g - 2 * g * mu) - 1 / (1 + g))


# ----------------------------------------------------------------------------------------
# The reference walker
# ----------------------------------------------------------------------------------------
@pytest.mark.parametrize("sigma, g", [(0.3, 0.0), (1.0, 0.9), (2.5, -0.7), (6.0, 0.4)])
def test_walker_single_scattering_probability_is_exp_minus_sigma(sigma, g):
    n = 40_000
    w = reference_sphere_walks(sigma, g, 0.9, n, seed=11)
    assert w["N"].dtype == np.int64 and w["N"].min() >= 1
    assert binomial_ok(int((w["N"] == 1).sum()), n, math.exp(-sigma))


def test_walker_geometry_holds_for_every_walk():
    n = 20_000
    rng = np.random.default_rng(5)
    sigma = rng.uniform(0, 30, n)
    g = rng.uniform(-0.95, 0.95, n)
    phi = rng.uniform(0, 1, n)
    w = reference_sphere_walks(sigma, g, phi, n, seed=3)
    assert set(w) == {"N", "cos_theta", "alpha", "beta", "X", "W"}
    assert w["X"].shape == (n, 3) and w["W"].shape == (n, 3) and w["cos_theta"].shape == (n,)
    # The exit point x̂ = (sin θ, 0, cos θ) is a unit vector with sin θ ≥ 0.
    assert np.all(np.abs(w["cos_theta"]) <= 1)
    x_hat = np.stack([np.sqrt(1 - w["cos_theta"] ** 2), 0 * w["cos_theta"], w["cos_theta"]], 1)
    np.testing.assert_allclose(np.linalg.norm(x_hat, axis=1), 1, atol=1e-12)
    assert np.all(w["alpha"] ** 2 + w["beta"] ** 2 <= 1 + 1e-12)
    assert np.all(np.linalg.norm(w["X"], axis=1) <= 1 + 1e-12)
    np.testing.assert_allclose(np.linalg.norm(w["W"], axis=1), 1, atol=1e-12)
    # The exit direction leaves the sphere: ω·n = √(1 − α² − β²) ≥ 0 is implied, so a walk
    # that ended with N = 1 left along its first direction, radially: α = β = 0.
    one = w["N"] == 1
    assert one.any()
    np.testing.assert_array_equal(w["alpha"][one], 0)
    np.testing.assert_array_equal(w["beta"][one], 0)
    np.testing.assert_array_equal(w["X"][one], 0)
    np.testing.assert_array_equal(w["W"][one], np.tile([0, 0, 1], (one.sum(), 1)))
    # σ = 0: every walk leaves after the first event.
    assert np.all(reference_sphere_walks(0.0, 0.3, 1.0, 100, seed=1)["N"] == 1)


@pytest.mark.parametrize("g", [-0.7, 0.0, 0.9])
def test_walker_single_scattering_exit_follows_hg(g):
    # With N = 1 the exit point is the first HG direction: cos θ ~ HG(g) exactly.
    w = reference_sphere_walks(0.2, g, 1.0, 20_000, seed=7)
    c = np.sort(w["cos_theta"][w["N"] == 1])
    cdf = hg_cdf(g, c) if abs(g) > 1e-3 else (c + 1) / 2
    d = np.max(np.abs(np.arange(1, c.size + 1) / c.size - cdf))
    assert d < 1.63 / math.sqrt(c.size) + 1e-3  # Kolmogorov 1 % level
    # ... and the sampler itself matches its CDF.
    xi = np.random.default_rng(2).random(20_000)
    c2 = np.sort(hg_sample_cos(np.full(xi.size, g), xi))
    cdf2 = hg_cdf(g, c2) if abs(g) > 1e-3 else (c2 + 1) / 2
    assert np.max(np.abs(np.arange(1, c2.size + 1) / c2.size - cdf2)) < 1.63 / math.sqrt(c2.size)


def test_walker_representative_event_weights():
    n = 30_000
    # φ = 0: only event 1 has weight (φ^k / Σ φ^j → 1 for k = 1).
    w = reference_sphere_walks(3.0, 0.2, 0.0, n, seed=4)
    np.testing.assert_array_equal(w["X"], 0)
    np.testing.assert_array_equal(w["W"], np.tile([0, 0, 1], (n, 1)))
    # φ = 1: uniform over the N events, so P(event 1 | N) = 1/N and E[N · 1{event 1}] = 1.
    w = reference_sphere_walks(3.0, 0.2, 1.0, n, seed=5)
    first = np.all(w["X"] == 0, axis=1)
    v = w["N"] * first
    assert abs(v.mean() - 1) < 4.5 * v.std() / math.sqrt(n)
    # General φ: P(event 1 | N) = φ / Σ_{j≤N} φ^j = (1 − φ) / (1 − φ^N).
    phi = 0.7
    w = reference_sphere_walks(3.0, 0.2, phi, n, seed=6)
    first = np.all(w["X"] == 0, axis=1)
    p1 = (1 - phi) / (1 - phi ** w["N"].astype(float))
    r = first - p1
    assert abs(r.mean()) < 4.5 * r.std() / math.sqrt(n)


def test_walker_is_deterministic_and_checks_its_arguments():
    a = reference_sphere_walks([1.0, 5.0, 9.0], 0.5, [0.1, 0.5, 0.9], 3, seed=9)
    b = reference_sphere_walks(np.array([1.0, 5.0, 9.0]), 0.5, [0.1, 0.5, 0.9], 3, seed=9)
    for k in a:
        np.testing.assert_array_equal(a[k], b[k])
    with pytest.raises(ValueError, match="sigma must be a scalar or have shape"):
        reference_sphere_walks([1.0, 2.0], 0.0, 0.5, 3)
    with pytest.raises(ValueError, match="g must lie in"):
        reference_sphere_walks(1.0, 1.0, 0.5, 3)
    with pytest.raises(ValueError, match="sigma must be finite"):
        reference_sphere_walks(-1.0, 0.0, 0.5, 3)


# ----------------------------------------------------------------------------------------
# Training data
# ----------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def tiny_data(tmp_path_factory):
    """6000 reference walks over σ ∈ [0, 20] (fast to simulate), as a training-data file."""
    path = tmp_path_factory.mktemp("data") / "walks.npz"
    generate_training_data(path, 6000, reference_sphere_walks, seed=1, sigma_max=20.0,
                           chunk=3000)
    return path


def test_training_data_round_trip(tiny_data):
    d = load_training_data(tiny_data)
    assert len(d) == 6000 and d.N.dtype == np.int64 and d.X.shape == (6000, 3)
    assert 0 <= d.sigma.min() and d.sigma.max() <= 20 and np.abs(d.g).max() <= 0.95
    assert d.meta["seed"] == 1 and d.meta["sigma_range"] == [0.0, 20.0]
    # The same seed gives the same file contents.
    again = generate_training_data(tiny_data.parent / "again.npz", 6000, reference_sphere_walks,
                                   seed=1, sigma_max=20.0, chunk=3000)
    np.testing.assert_array_equal(again.X, d.X)
    np.testing.assert_array_equal(again.sigma, d.sigma)


def _write_npz(path, arrays):
    np.savez(path, **arrays)
    return path


@pytest.mark.parametrize(
    "edit, message",
    [
        (lambda a: a.pop("W"), "missing array(s) W"),
        (lambda a: a.update(extra=np.zeros(3)), "unknown array(s) extra"),
        (lambda a: a.update(X=a["X"][:, :2]), "X has shape (50, 2), expected (50, 3)"),
        (lambda a: a.update(alpha=a["alpha"][:-1]), "alpha has shape (49,), expected (50,)"),
        (lambda a: a.update(N=a["N"].astype(float)), "N must hold integers"),
        (lambda a: a["sigma"].__setitem__(3, np.nan), "sigma has 1 non-finite value(s)"),
        (lambda a: a["g"].__setitem__(0, 1.0), "|g| < 1 fails for 1 walk(s), first at index 0"),
        (lambda a: a["phi"].__setitem__(7, 1.5), "0 <= phi <= 1 fails"),
        (lambda a: a["W"].__setitem__(2, [0, 0, 2]), "|W| = 1 fails"),
        (lambda a: a.update(meta=np.array("{not json")), "meta is not a JSON string"),
    ],
)
def test_training_data_errors_name_the_file_and_problem(tmp_path, edit, message):
    w = reference_sphere_walks(2.0, 0.3, 0.9, 50, seed=2)
    arrays = {"sigma": np.full(50, 2.0), "g": np.full(50, 0.3), "phi": np.full(50, 0.9), **w}
    edit(arrays)
    path = _write_npz(tmp_path / "bad.npz", arrays)
    with pytest.raises(DataError) as e:
        load_training_data(path)
    assert str(path) in str(e.value) and message in str(e.value)


def test_training_data_missing_or_corrupt_file(tmp_path):
    with pytest.raises(DataError, match="none.npz: training-data file does not exist"):
        load_training_data(tmp_path / "none.npz")
    (tmp_path / "junk.npz").write_bytes(b"not a zip file at all")
    with pytest.raises(DataError, match="junk.npz: not a .npz file \\(not a zip archive") as e:
        load_training_data(tmp_path / "junk.npz")
    assert "pickle" not in str(e.value)  # np.load's word for it
    np.save(tmp_path / "one.npy", np.zeros(3))
    with pytest.raises(DataError, match="one.npy: not a .npz file \\(a single .npy array"):
        load_training_data(tmp_path / "one.npy")
    (tmp_path / "cut.npz").write_bytes(b"PK\x03\x04 and then nothing")
    with pytest.raises(DataError, match="cut.npz: not a readable .npz file"):
        load_training_data(tmp_path / "cut.npz")


@pytest.mark.parametrize("enc", [Encoding("affine", a=2.0, b=-1.0),
                                 Encoding("log", a=0.5, b=0.2, s=-1.0, c=1.0001),
                                 Encoding("logit", a=0.8, b=0.1, lo=-1.0, hi=1.0, eps=1e-4)])
def test_encodings_invert_and_round_trip(enc):
    x = np.linspace(-0.999, 0.999, 101)
    np.testing.assert_allclose(enc.decode(enc.encode(x)), x, rtol=0, atol=1e-12)
    assert Encoding.from_json(json.loads(json.dumps(enc.to_json()))) == enc
    if enc.kind != "affine":
        assert not enc.in_domain(np.array([5.0])).any()
    if enc.kind == "logit":
        # The inverse maps the whole line into (lo − ε, hi + ε) without overflow.
        y = enc.decode(np.array([-1e6, 0.0, 1e6]))
        assert np.all(np.isfinite(y)) and y[0] >= -1 - 1e-4 and y[2] <= 1 + 1e-4


def test_encoding_json_errors():
    with pytest.raises(ValueError, match="unknown parameter 'c' of a 'affine' encoding"):
        Encoding.from_json({"kind": "affine", "c": 1})
    with pytest.raises(ValueError, match="unknown encoding kind 'sqrt'"):
        Encoding.from_json({"kind": "sqrt"})
    with pytest.raises(ValueError, match="must be a number"):
        Encoding.from_json({"kind": "log", "a": "1"})
    with pytest.raises(ValueError, match="lo < hi"):
        Encoding.from_json({"kind": "logit", "lo": 1, "hi": -1})


def test_plain_encoding_set_uses_only_the_first_kinds(tiny_data):
    # For readers that know affine and log only; the shipped set uses logit for cos θ, α, β.
    d = load_training_data(tiny_data)
    d = d.subset(d.N >= 2)
    plain = fit_encodings(PATHGEN, d, np.random.default_rng(0), "plain")
    assert {e.kind for e in plain.values()} <= {"affine", "log"}
    shipped = fit_encodings(PATHGEN, d, np.random.default_rng(0))
    assert shipped["cos_theta"].kind == "logit"
    # Standardized: the encoded training values have mean 0 and variance 1.
    e = shipped["cos_theta"].encode(d.cos_theta)
    assert abs(e.mean()) < 1e-6 and abs(e.std() - 1) < 1e-6


# ----------------------------------------------------------------------------------------
# Training, export and the decoders
# ----------------------------------------------------------------------------------------
SMOKE_CONFIG = TrainConfig(batch_size=512, lr_warmup_steps=10)


@pytest.fixture(scope="module")
def trained(tiny_data, tmp_path_factory):
    out = tmp_path_factory.mktemp("models")
    result = train(tiny_data, out, epochs=3, seed=0, progress=False, config=SMOKE_CONFIG)
    return out, result


def test_training_writes_all_files_with_metrics(tiny_data, trained):
    out, result = trained
    names = sorted(os.listdir(out))
    assert names == sorted([f"{s}.{e}" for s in STEMS for e in ("json", "onnx")]
                           + ["cvae_checkpoint.pt"])
    d = load_training_data(tiny_data)
    rows = {"LengthGen": d.N >= 2, "PathGen": d.N >= 2,
            "EventGen": (d.N >= 2) & np.any(d.X != 0, axis=1)}  # EventGen: events k >= 2
    for spec in SPECS:
        r = result[spec.name]
        assert r["steps"] > 0 and r["epochs_completed"] == 3 and not r["stopped_by_time_limit"]
        assert all(np.isfinite(r["train_loss_per_epoch"]))
        # Training does something: the loss of the last epoch is below the first's.
        assert r["train_loss_per_epoch"][-1] < r["train_loss_per_epoch"][0]
        obj = json.loads((out / f"{spec.file_stem}.json").read_text())
        m = obj["metrics"]
        assert len(m["kl_per_latent_dim"]) == spec.latent_dim
        assert m["latent_dims_active"] == sum(k > 0.01 for k in m["kl_per_latent_dim"])
        t = obj["training"]
        assert t["sigma"] == [0.0, 20.0] and t["g"] == [-0.95, 0.95] and t["seed"] == 0
        assert t["n_samples"] + t["n_validation"] == int(rows[spec.name].sum())


@pytest.mark.parametrize("stem", STEMS)
def test_decoder_parity_torch_onnxruntime_numpy(trained, stem):
    out, _ = trained
    dec = load_decoder(out / f"{stem}.json")
    model = load_checkpoint(out / "cvae_checkpoint.pt")[dec.name][0]
    rng = np.random.default_rng(3)
    x = np.zeros((257, dec.input_width), dtype=np.float32)
    used = len(dec.condition_names) + dec.latent_dim
    x[:, :used] = 2.0 * rng.standard_normal((257, used))  # padding stays zero
    mean_np, logvar_np = dec.evaluate(x)
    with torch.no_grad():
        mean_t, logvar_t = model.decoder(torch.from_numpy(x))
    # The file depends on the weights, not on where the code that made it lives.
    assert str(Path(sssphere.__file__).parent).encode() not in (out / f"{stem}.onnx").read_bytes()
    sess = ort.InferenceSession(str(out / f"{stem}.onnx"), providers=["CPUExecutionProvider"])
    assert [i.name for i in sess.get_inputs()] == ["x"]
    assert [o.name for o in sess.get_outputs()] == ["mean", "logvar"]
    mean_o, logvar_o = sess.run(["mean", "logvar"], {"x": x})
    k = len(dec.output_names)
    assert mean_np.shape == (257, k) and logvar_o.shape == (257, k)

    def rel(a, b):  # outputs are standardized: 1 is their natural scale
        return np.max(np.abs(a - b) / np.maximum(np.maximum(np.abs(a), np.abs(b)), 1.0))

    for a, b in [(mean_np, mean_t.numpy()), (mean_np, mean_o), (mean_o, mean_t.numpy()),
                 (logvar_np, logvar_t.numpy()), (logvar_np, logvar_o), (logvar_o, logvar_t.numpy())]:
        assert rel(a, b) <= 1e-5
    # The C++ decoders the renderer uses: the scalar reference and the SIMD one.
    cpp = sssphere.ScatteringModel.load(out)
    for impl in ("scalar", "simd"):
        mean_c, logvar_c = cpp.evaluate(dec.name, x, impl=impl)
        assert rel(mean_c, mean_t.numpy()) <= 1e-5 and rel(logvar_c, logvar_t.numpy()) <= 1e-5


SHIPPED = Path(__file__).resolve().parents[1] / "models"


@pytest.mark.parametrize("stem", STEMS)
def test_shipped_decoders_agree_across_onnxruntime_numpy_and_cpp(stem):
    """The shipped files: ONNX (onnxruntime) = JSON (NumPy) = C++ scalar = C++ SIMD, 1e-5."""
    dec = load_decoder(SHIPPED / f"{stem}.json")
    rng = np.random.default_rng(5)
    x = np.zeros((513, dec.input_width), dtype=np.float32)
    used = len(dec.condition_names) + dec.latent_dim
    x[:, :used] = 2.0 * rng.standard_normal((513, used))
    mean_np, logvar_np = dec.evaluate(x)
    sess = ort.InferenceSession(str(SHIPPED / f"{stem}.onnx"), providers=["CPUExecutionProvider"])
    mean_o, logvar_o = sess.run(["mean", "logvar"], {"x": x})
    cpp = sssphere.ScatteringModel.load(SHIPPED)
    (mean_s, logvar_s), (mean_v, logvar_v) = (cpp.evaluate(dec.name, x, impl=i) for i in ("scalar", "simd"))

    def rel(a, b):
        return np.max(np.abs(a - b) / np.maximum(np.maximum(np.abs(a), np.abs(b)), 1.0))

    for ref, others in ((mean_np, (mean_o, mean_s, mean_v)), (logvar_np, (logvar_o, logvar_s, logvar_v))):
        for o in others:
            assert rel(ref, o) <= 1e-5


def test_json_round_trip_is_exact(trained, tmp_path):
    out, _ = trained
    ck = load_checkpoint(out / "cvae_checkpoint.pt")
    for spec in SPECS:
        obj = json.loads((out / f"{spec.file_stem}.json").read_text())
        layers = ck[spec.name][0].decoder.linear_layers()
        assert len(obj["layers"]) == spec.depth + 1 == len(layers)
        for entry, layer in zip(obj["layers"], layers):
            np.testing.assert_array_equal(np.asarray(entry["weight"], np.float32),
                                          layer.weight.detach().numpy())
            np.testing.assert_array_equal(np.asarray(entry["bias"], np.float32),
                                          layer.bias.detach().numpy())
        # 9 significant digits at most, on every number of the file.
        text = (out / f"{spec.file_stem}.json").read_text()
        for token in text.replace(",", " ").replace("[", " ").replace("]", " ").split():
            if token[0].isdigit() or token[0] == "-":
                mantissa = token.lstrip("-").split("e")[0].replace(".", "").lstrip("0")
                assert len(mantissa) <= 9, token
        # Encodings read back are the ones written.
        for item in obj["conditions"] + obj["outputs"]:
            assert Encoding.from_json(item["encode"]).to_json() == item["encode"]
    # Re-exporting the checkpoint gives the same JSON, byte for byte.
    export_checkpoint(out / "cvae_checkpoint.pt", tmp_path)
    for stem in STEMS:
        assert (tmp_path / f"{stem}.json").read_text() == (out / f"{stem}.json").read_text()


def test_training_is_deterministic(tiny_data, trained, tmp_path):
    out, _ = trained
    train(tiny_data, tmp_path, epochs=3, seed=0, progress=False, config=SMOKE_CONFIG,
          models=("LengthGen",))
    assert (tmp_path / "lengthgen.json").read_text() == (out / "lengthgen.json").read_text()
    train(tiny_data, tmp_path, epochs=3, seed=1, progress=False, config=SMOKE_CONFIG,
          models=("LengthGen",))
    assert (tmp_path / "lengthgen.json").read_text() != (out / "lengthgen.json").read_text()


def test_samples_obey_the_post_processing_rules(trained):
    out, _ = trained
    rng = np.random.default_rng(8)
    n = 4000
    length = load_decoder(out / "lengthgen.json").sample({"sigma": rng.uniform(0, 20, n),
                                                          "g": 0.5}, rng)
    assert length["N"].dtype == np.int64 and length["N"].min() >= 2
    sampler = SphereSampler.from_dir(out)
    sigma = 1.5
    w = sampler.sample(sigma, -0.3, 0.95, n, rng)
    assert set(w) == {"N", "cos_theta", "alpha", "beta", "X", "W"}
    # N = 1 is sampled exactly with probability e^{-σ}, never by the network.
    assert binomial_ok(int((w["N"] == 1).sum()), n, math.exp(-sigma))
    assert np.all(np.abs(w["cos_theta"]) <= 1)
    assert np.all(np.hypot(w["alpha"], w["beta"]) <= 1 + 1e-12)
    # The first event is the representative one with probability (1 − φ)/(1 − φ^N), drawn
    # exactly: for φ = 1 that is 1/N, so E[N · 1{X = 0}] = 1 over the walks with N ≥ 2 ...
    w1 = sampler.sample(sigma, -0.3, 1.0, n, rng)
    many = w1["N"] >= 2
    v = w1["N"][many] * np.all(w1["X"][many] == 0, axis=1)
    assert abs(v.mean() - 1) < 4.5 * v.std() / math.sqrt(v.size)
    assert np.all(np.all(w1["X"][~many] == 0, axis=1))
    # ... and for φ = 0 it is always the first event.
    w0 = sampler.sample(sigma, -0.3, 0.0, 200, rng)
    np.testing.assert_array_equal(w0["X"], 0)
    np.testing.assert_array_equal(w0["W"], np.tile([0, 0, 1], (200, 1)))
    assert np.all(np.linalg.norm(w["X"], axis=1) <= 1 + 1e-12)
    np.testing.assert_allclose(np.linalg.norm(w["W"], axis=1), 1, atol=1e-12)
    # The rules themselves, on values that need them.
    p = postprocess({"N": np.array([-3.0, 2.7, 7.2]), "cos_theta": np.array([1.5, -2.0, 0.3]),
                     "alpha": np.array([3.0, 0.0, 0.1]), "beta": np.array([4.0, 0.0, 0.2]),
                     "X_x": np.array([2.0, 0, 0]), "X_y": np.zeros(3), "X_z": np.zeros(3),
                     "W_x": np.zeros(3), "W_y": np.array([0.0, 2.0, 0]), "W_z": np.zeros(3)})
    np.testing.assert_array_equal(p["N"], [2, 2, 7])
    np.testing.assert_array_equal(p["cos_theta"], [1.0, -1.0, 0.3])
    np.testing.assert_allclose([p["alpha"][0], p["beta"][0]], [0.6, 0.8])
    assert p["X_x"][0] == 1.0 and p["W_z"][0] == 1.0 and p["W_y"][1] == 1.0


# ----------------------------------------------------------------------------------------
# Errors
# ----------------------------------------------------------------------------------------
def _edited_model(trained, tmp_path, edit):
    obj = json.loads((trained[0] / "pathgen.json").read_text())
    edit(obj)
    path = tmp_path / "pathgen.json"
    path.write_text(json.dumps(obj))
    return path


@pytest.mark.parametrize(
    "edit, message",
    [
        (lambda o: o.update(format_version=2),
         "format_version is 2; this reader understands format_version 1 only"),
        (lambda o: o.update(format="other"), "format is 'other', expected 'sssphere-cvae-decoder'"),
        (lambda o: o.update(extra=1), "unknown field(s) extra"),
        (lambda o: o.pop("layers"), "missing field(s) layers"),
        (lambda o: o.update(input_width=12), "input_width is 12, expected 8"),
        (lambda o: o["layers"][1]["weight"].pop(), "layers[1].weight has shape (15, 16), expected (16, 16)"),
        (lambda o: o["layers"][0].update(activation="relu"), "layers[0].activation is 'relu'"),
        (lambda o: o["outputs"][0]["encode"].update(kind="sqrt"), "unknown encoding kind 'sqrt'"),
        (lambda o: o["conditions"].reverse(), "PathGen conditions are ['N', 'g', 'sigma']"),
        (lambda o: o["training"].update(sigma=[5]), "training.sigma must be a range"),
    ],
)
def test_model_file_errors_name_the_file_and_problem(trained, tmp_path, edit, message):
    path = _edited_model(trained, tmp_path, edit)
    with pytest.raises(ModelFileError) as e:
        load_decoder(path)
    assert str(path) in str(e.value) and message in str(e.value)


def test_missing_and_corrupt_model_files(tmp_path):
    with pytest.raises(ModelFileError, match="none.json: model file does not exist"):
        load_decoder(tmp_path / "none.json")
    (tmp_path / "bad.json").write_text('{"format": "sssphere-cvae-decoder", ')
    with pytest.raises(ModelFileError, match="bad.json: not valid JSON"):
        load_decoder(tmp_path / "bad.json")
    with pytest.raises(CheckpointError, match="none.pt: checkpoint does not exist"):
        load_checkpoint(tmp_path / "none.pt")
    (tmp_path / "bad.pt").write_bytes(b"junk")
    with pytest.raises(CheckpointError, match="bad.pt: not a readable checkpoint"):
        load_checkpoint(tmp_path / "bad.pt")


def test_checkpoints_of_another_structure_are_named_not_tracebacks(trained, tmp_path):
    """A checkpoint torch reads but whose models are not the ones this version builds (other
    layer widths, a missing table or encoding) raised torch's RuntimeError or a bare
    KeyError (a review); each is a CheckpointError naming the file and the model."""
    out, _ = trained
    blob = torch.load(out / "cvae_checkpoint.pt", weights_only=True)
    swapped = {**blob, "models": {**blob["models"], "LengthGen": {
        **blob["models"]["LengthGen"], "state_dict": blob["models"]["PathGen"]["state_dict"]}}}
    no_enc = {**blob, "models": {**blob["models"], "PathGen": {
        **blob["models"]["PathGen"], "encodings": {
            k: v for k, v in blob["models"]["PathGen"]["encodings"].items() if k != "cos_theta"}}}}
    cases = {"swapped.pt": (swapped, "model LengthGen: not the LengthGen this version builds "
                            "(RuntimeError: Error(s) in loading state_dict for CVAE: size mismatch"),
             "tableless.pt": ({k: v for k, v in blob.items() if k != "models"},
                              "the checkpoint holds no models"),
             "no_enc.pt": (no_enc, "model PathGen: not the PathGen this version builds "
                           "(KeyError: 'no encoding of cos_theta')")}
    for name, (content, message) in cases.items():
        torch.save(content, tmp_path / name)
        with pytest.raises(CheckpointError) as e:
            load_checkpoint(tmp_path / name)
        assert f"{name}: {message}" in str(e.value), str(e.value)


def test_training_that_could_not_finish_is_refused_before_it_starts(tiny_data, tmp_path,
                                                                    monkeypatch):
    """What a review found told late or not at all: data without a walk EventGen can learn
    from was refused after LengthGen and PathGen had trained (minutes, lost); a time limit
    too short for one step wrote untrained models and exited 0; epochs=1.5 trained one
    epoch; a seed past about 10^14 overflowed torch's. `sssphere datagen -o` naming a
    directory failed after simulating every walk."""
    from sssphere.learn import train as train_module

    d = dict(np.load(tiny_data))
    d["X"] = np.zeros_like(d["X"])  # no representative event k >= 2 anywhere
    np.savez(tmp_path / "no_events.npz", **d)
    monkeypatch.setattr(train_module, "train_cvae", lambda *a, **k: pytest.fail("trained"))
    with pytest.raises(ValueError, match="no_events.npz: fewer than 2 walks to train EventGen"):
        train(tmp_path / "no_events.npz", tmp_path / "m", epochs=1, progress=False)
    for epochs in (1.5, True, 0):
        with pytest.raises(ValueError, match="epochs"):
            train(tiny_data, tmp_path / "m", epochs=epochs, progress=False)
    monkeypatch.undo()
    with pytest.raises(ValueError, match="ended before its first training step; nothing"):
        train(tiny_data, tmp_path / "m", epochs=1, max_minutes=1e-9, progress=False)
    assert not (tmp_path / "m").exists()
    train(tiny_data, tmp_path / "m", epochs=1, seed=2**64 - 1, progress=False,
          models=("LengthGen",), config=SMOKE_CONFIG)
    (tmp_path / "walks.npz").mkdir()
    assert cli_main(["datagen", "--samples", "100000000", "-o", str(tmp_path / "walks.npz"),
                     "--quiet"]) == 1  # at once: 10^8 walks would take minutes


def test_eval_refuses_models_whose_ranges_miss_its_grid_before_evaluating(models_with, tmp_path,
                                                                          capsys):
    """Models trained on sigma_t <= 50 evaluated 12 of the 16 cells of the fixed grid, then
    died with a traceback at sigma_t = 100 (a review). The grid is checked first."""
    models = models_with(sigma=[0.0, 50.0])
    assert cli_main(["eval", "--models", str(models), "--samples", "100", "--no-plots",
                     "--out", str(tmp_path / "ev"), "--quiet"]) == 1
    err = capsys.readouterr().err
    assert "lies outside these models' training ranges: sigma_t[0] = 100 is outside" in err, err
    assert not any((tmp_path / "ev").iterdir())


@pytest.mark.parametrize(
    "conditions, message",
    [
        ({"sigma": 25.0, "g": 0.0, "N": 5}, "condition sigma = 25.0 is outside the training range"),
        ({"sigma": 5.0, "g": 0.99, "N": 5}, "condition g = 0.99 is outside the training range"),
        ({"sigma": 5.0, "g": 0.0, "N": 1}, "condition N = 1.0 is outside the domain of its log"),
        ({"sigma": np.nan, "g": 0.0, "N": 3}, "condition sigma = nan is outside the domain"),
        ({"sigma": 5.0, "g": 0.0}, "missing ['N']"),
        ({"sigma": [1.0, 2.0], "g": [0.1, 0.2, 0.3], "N": 3}, "do not broadcast"),
        (np.zeros((4, 2)), "conditions must have shape (batch, 3)"),
    ],
)
def test_bad_decoder_inputs_are_refused(trained, conditions, message):
    dec = load_decoder(trained[0] / "pathgen.json")
    with pytest.raises(ValueError) as e:
        dec.sample(conditions, np.random.default_rng(0))
    assert message in str(e.value)
    with pytest.raises(ValueError, match=r"x must have shape \(batch, 8\), got \(3, 7\)"):
        dec.evaluate(np.zeros((3, 7)))


# ----------------------------------------------------------------------------------------
# Command line
# ----------------------------------------------------------------------------------------
def test_cli_train_and_export(tiny_data, tmp_path, capsys):
    code = cli_main(["train", str(tiny_data), "-o", str(tmp_path / "m"), "--epochs", "1",
                     "--seed", "2"])
    err = capsys.readouterr().err
    assert code == 0, err
    assert "LengthGen" in err and "latent KL per dim" in err and "wrote" in err
    assert json.loads((tmp_path / "m" / "eventgen.json").read_text())["training"]["seed"] == 2
    code = cli_main(["export", str(tmp_path / "m" / "cvae_checkpoint.pt"), "-o", str(tmp_path / "e")])
    assert code == 0
    assert (tmp_path / "e" / "pathgen.json").read_text() == (tmp_path / "m" / "pathgen.json").read_text()
    assert (tmp_path / "e" / "pathgen.onnx").is_file()
    # --models: PathGen alone, again with seed 2, gives the same file; the others stay.
    # A tilt fitted to the PathGen replaced is moved aside, and the command says so.
    before = (tmp_path / "m" / "eventgen.json").read_bytes()
    (tmp_path / "m" / "pathgen.json").unlink()
    (tmp_path / "m" / "tilt.json").write_text('{"format": "sssphere-step-tilt"}')
    capsys.readouterr()
    code = cli_main(["train", str(tiny_data), "-o", str(tmp_path / "m"), "--epochs", "1",
                     "--seed", "2", "--models", "PathGen", "--quiet"])
    assert code == 0
    assert (tmp_path / "e" / "pathgen.json").read_text() == (tmp_path / "m" / "pathgen.json").read_text()
    assert (tmp_path / "m" / "eventgen.json").read_bytes() == before
    assert not (tmp_path / "m" / "tilt.json").exists()
    assert (tmp_path / "m" / "tilt.json.stale").read_text() == '{"format": "sssphere-step-tilt"}'
    assert "fitted to the models this run replaced; moved to tilt.json.stale" in capsys.readouterr().err


def test_cli_learn_errors_are_clear(tmp_path, capsys):
    assert cli_main(["train", str(tmp_path / "none.npz"), "-o", str(tmp_path / "m")]) == 1
    assert "none.npz: training-data file does not exist" in capsys.readouterr().err
    assert cli_main(["export", str(tmp_path / "none.pt"), "-o", str(tmp_path / "m")]) == 1
    assert "none.pt: checkpoint does not exist" in capsys.readouterr().err
    # a directory named as the file was said not to exist (a review)
    assert cli_main(["train", str(tmp_path), "-o", str(tmp_path / "m")]) == 1
    assert f"{tmp_path}: is a directory, not a training-data file" in capsys.readouterr().err
    assert cli_main(["export", str(tmp_path), "-o", str(tmp_path / "m")]) == 1
    assert f"{tmp_path}: is a directory, not a checkpoint" in capsys.readouterr().err
    with pytest.raises(ModelFileError, match="is a directory, not a model file"):
        load_decoder(tmp_path)
    with pytest.raises(SystemExit):
        cli_main(["train", str(tmp_path / "x.npz"), "-o", str(tmp_path), "--max-minutes", "0"])
    assert "must be a positive number" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        cli_main(["train", str(tmp_path / "x.npz"), "-o", str(tmp_path), "--models", "PathGen,Foo"])
    assert "expected model names from LengthGen,PathGen,EventGen" in capsys.readouterr().err


def test_sample_conditions_cover_the_ranges():
    c = learn_data.sample_conditions(100_000, np.random.default_rng(0), sigma_max=200.0)
    assert 0 <= c["sigma"].min() < 0.05 and 190 < c["sigma"].max() <= 200
    assert -0.95 <= c["g"].min() < -0.94 and 0.94 < c["g"].max() <= 0.95
    assert 0 <= c["phi"].min() and c["phi"].max() <= 1
    # ln(σ + 0.5) uniform: about a third of the walks at σ ∈ [1, 10].
    frac = np.mean((c["sigma"] >= 1) & (c["sigma"] <= 10))
    expected = math.log(10.5 / 1.5) / math.log(200.5 / 0.5)
    assert abs(frac - expected) < 0.01


# ----------------------------------------------------------------------------------------
# Sweep findings: all-or-nothing outputs, bad data and settings told up front
# ----------------------------------------------------------------------------------------
def _old_models(out):
    """out with stand-in model files, as a previous run left them; returns their contents."""
    out.mkdir(exist_ok=True)
    for name in ("lengthgen.json", "pathgen.json", "cvae_checkpoint.pt"):
        (out / name).write_text(f"old {name}\n")
    return {p.name: p.read_bytes() for p in out.iterdir()}


def test_interrupted_train_leaves_the_output_directory_unchanged(tiny_data, tmp_path, capsys,
                                                                 ctrl_c_while_training):
    # LengthGen finishes, then Ctrl-C during PathGen: LengthGen's files must not be moved
    # into place beside the old PathGen (a mixed set).
    ctrl_c_while_training("PathGen")
    before = _old_models(tmp_path / "m")
    code = cli_main(["train", str(tiny_data), "-o", str(tmp_path / "m"), "--epochs", "1",
                     "--quiet"])
    assert code == 130
    err = capsys.readouterr().err
    assert f"interrupted: wrote nothing to {tmp_path / 'm'}" in err
    assert {p.name: p.read_bytes() for p in (tmp_path / "m").iterdir()} == before
    # The finished LengthGen is kept beside it (Ctrl-C lost minutes of training: a review),
    # and the command that completes that set is said; it does.
    partial = tmp_path / "m.partial"
    assert sorted(p.name for p in partial.iterdir()) == ["cvae_checkpoint.pt", "lengthgen.json",
                                                        "lengthgen.onnx"]
    hint = shlex.join(["sssphere", "train", str(tiny_data), "-o", str(partial), "--models",
                       "PathGen,EventGen"])
    assert f"kept the finished LengthGen in {partial}; {hint} trains the rest" in err, err
    # A directory the run created is gone again.
    assert cli_main(["train", str(tiny_data), "-o", str(tmp_path / "new"), "--epochs", "1",
                     "--quiet"]) == 130
    assert not (tmp_path / "new").exists()
    ctrl_c_while_training("none")  # train the rest into the partial set: a whole set
    assert cli_main(["train", str(tiny_data), "-o", str(partial), "--epochs", "1", "--quiet",
                     "--models", "PathGen,EventGen"]) == 0
    sssphere.ScatteringModel.load(partial)


def test_interrupted_train_into_the_current_directory_keeps_its_models(
        tiny_data, tmp_path, capsys, ctrl_c_while_training, monkeypatch):
    """`-o .` has no name to add ".partial" to: the interrupt became "PosixPath('.') has an
    empty name", status 1, and the finished model was lost (a review). The command said to
    finish the set is quoted for the shell (a path with a space broke it)."""
    here = tmp_path / "sp ace"
    here.mkdir()
    monkeypatch.chdir(here)
    ctrl_c_while_training("PathGen")
    assert cli_main(["train", str(tiny_data), "-o", ".", "--epochs", "1", "--quiet"]) == 130
    err = capsys.readouterr().err
    partial = tmp_path / "sp ace.partial"
    assert (partial / "lengthgen.json").is_file(), err
    assert f"-o '{partial}' --models PathGen,EventGen trains the rest" in err, err


def test_export_of_non_finite_weights_names_the_layer_and_writes_nothing(trained, tmp_path,
                                                                         capsys):
    from sssphere.learn.export import save_checkpoint

    models = load_checkpoint(trained[0] / "cvae_checkpoint.pt")
    with torch.no_grad():
        models["EventGen"][0].decoder.hidden[1].bias[3] = float("nan")
    save_checkpoint(tmp_path / "nan.pt", models)
    before = _old_models(tmp_path / "out")
    code = cli_main(["export", str(tmp_path / "nan.pt"), "-o", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert code == 1 and len(err.strip().splitlines()) == 1, err
    assert "nan.pt: model EventGen: layers[1].bias holds 1 non-finite value(s) (first nan)" in err
    assert {p.name: p.read_bytes() for p in (tmp_path / "out").iterdir()} == before


def test_training_refuses_data_from_one_medium(tiny_data, tmp_path):
    d = load_training_data(tiny_data)
    d.sigma[:] = np.float32(10.0)
    path = tmp_path / "one_sigma.npz"
    learn_data.save_training_data(path, d)
    with pytest.raises(DataError) as e:
        train(path, tmp_path / "m", epochs=1, progress=False, config=SMOKE_CONFIG)
    msg = str(e.value)
    assert str(path) in msg and "sigma is constant" in msg and "span a range of media" in msg
    assert not (tmp_path / "m").exists()  # refused before any output


def _arrays_with_meta(meta, n=50):
    rng = np.random.default_rng(0)
    w = rng.normal(size=(n, 3))
    return {"sigma": rng.uniform(0, 5, n), "g": rng.uniform(-0.5, 0.5, n),
            "phi": rng.uniform(0, 1, n), "N": np.full(n, 3), "cos_theta": np.zeros(n),
            "alpha": np.zeros(n), "beta": np.zeros(n), "X": np.zeros((n, 3)),
            "W": w / np.linalg.norm(w, axis=1, keepdims=True),
            "meta": np.array(json.dumps(meta))}


@pytest.mark.parametrize(
    "meta, message",
    [
        ({"g_range": [-2, 2]}, "meta g_range = [-2, 2] is not allowed (allowed: [lo, hi], "
                               "finite numbers with lo < hi, within (-1.0, 1.0))"),
        ({"g_range": [float("nan"), 0.9]}, "meta g_range = [nan, 0.9] is not allowed"),
        ({"sigma_range": [10, 0]}, "meta sigma_range = [10, 0] is not allowed"),
        ({"phi_range": "0 to 1"}, "meta phi_range = '0 to 1' is not allowed"),
        ({"phi_range": [0, 1.5]}, "meta phi_range = [0, 1.5] is not allowed"),
        ({"sigma_max": -1}, "meta sigma_max = -1 is not allowed (allowed: a finite number > 0)"),
        ({"g_max": 1.5}, "meta g_max = 1.5 is not allowed (allowed: a number in (0, 1))"),
        ({"g_range": [-0.1, 0.1]}, "meta g_range = [-0.1, 0.1] does not hold the data's g"),
        ({"sigma_max": 2}, "meta sigma_max = 2 does not hold the data's sigma"),
    ],
)
def test_meta_ranges_are_checked(meta, message):
    with pytest.raises(DataError) as e:
        learn_data.validate_arrays(_arrays_with_meta(meta), "w.npz")
    assert str(e.value).startswith("w.npz: ") and message in str(e.value)


def test_good_meta_ranges_are_accepted():
    meta = {"sigma_range": [0, 200], "g_range": [-0.95, 0.95], "phi_range": [0, 1],
            "sigma_max": 200, "g_max": 0.95, "other": "free-form"}
    assert learn_data.validate_arrays(_arrays_with_meta(meta)).meta == meta


@pytest.mark.parametrize(
    "field, value, allowed",
    [
        ("batch_size", -5, "an integer >= 1"),
        ("batch_size", 0, "an integer >= 1"),
        ("val_fraction", 2, "0 <= val_fraction < 1"),
        ("kl_warmup", -1, "a fraction of training, 0 to 1"),
        ("free_bits", -1, "a number >= 0 (nats)"),
        ("threads", 0, "an integer >= 1"),
        ("lr", float("nan"), "a number > 0"),
        ("epochs", 1.5, "an integer >= 1"),
        ("encodings", "fancy", "logit, plain"),
    ],
)
def test_train_config_is_checked(field, value, allowed):
    with pytest.raises(ValueError) as e:
        TrainConfig(**{field: value})
    assert str(e.value) == f"TrainConfig.{field} = {value!r} is not allowed (allowed: {allowed})"


def test_datagen_meta_records_the_requested_count_when_interrupted(tmp_path, monkeypatch):
    from sssphere.learn import datagen as datagen_mod

    real, calls = datagen_mod.sphere_walks, []

    def stop_second_chunk(*args, **kwargs):
        calls.append(1)
        if len(calls) == 2:
            raise KeyboardInterrupt
        return real(*args, **kwargs)

    monkeypatch.setattr(datagen_mod, "sphere_walks", stop_second_chunk)
    data, interrupted, _ = datagen_mod.datagen(12_000, tmp_path / "w.npz", seed=3, threads=1)
    assert interrupted and len(data["N"]) == 10_000
    meta = load_training_data(tmp_path / "w.npz").meta
    assert (meta["samples"], meta["requested_samples"], meta["interrupted"]) == (10_000, 12_000,
                                                                                 True)
    monkeypatch.setattr(datagen_mod, "sphere_walks", real)
    datagen_mod.datagen(20, tmp_path / "v.npz", seed=3, threads=1)
    meta = load_training_data(tmp_path / "v.npz").meta
    assert (meta["samples"], meta["requested_samples"], meta["interrupted"]) == (20, 20, False)


def test_model_card_with_unbalanced_markers_is_refused(tmp_path):
    from sssphere.learn import evaluate

    card = tmp_path / "README.md"
    text = "# My models\n\n<!-- eval:begin -->\nold table\n\n## Notes kept here\n"
    card.write_text(text)
    with pytest.raises(ValueError, match=f"{card}: the eval markers are unbalanced"):
        evaluate.update_model_card(card, "| new |")
    assert card.read_text() == text
    card.write_text("# Mine\n\n<!-- eval:begin -->\nold\n<!-- eval:end -->\n\nkept\n")
    evaluate.update_model_card(card, "| new |")
    assert card.read_text() == "# Mine\n\n<!-- eval:begin -->\n| new |\n<!-- eval:end -->\n\nkept\n"
    fresh = tmp_path / "user" / "README.md"
    fresh.parent.mkdir()
    evaluate.update_model_card(fresh, "| t |")
    assert fresh.read_text().startswith("# Models in user\n")


@pytest.mark.parametrize(
    "g, albedo, message",
    [
        (0.0, np.nan, "phi[0] = nan is not allowed (allowed: 0 <= phi <= 1)"),
        (0.0, -0.5, "phi[0] = -0.5 is not allowed (allowed: 0 <= phi <= 1)"),
        (0.0, [0.5, 0.5, 1.5], "phi[2] = 1.5 is not allowed (allowed: 0 <= phi <= 1)"),
        (1.0, 0.5, "g[0] = 1 is not allowed (allowed: -1 < g < 1)"),
        (np.nan, 0.5, "g[0] = nan is not allowed (allowed: -1 < g < 1)"),
    ],
)
def test_sphere_sampler_checks_g_and_albedo(trained, g, albedo, message):
    sampler = SphereSampler.from_dir(trained[0])
    with pytest.raises(ValueError) as e:
        sampler.sample(5.0, g, albedo, 3, np.random.default_rng(0))
    assert str(e.value) == message


def test_eval_finds_the_shipped_models_from_anywhere(tmp_path, capsys, monkeypatch):
    from sssphere.model import DEFAULT_MODELS

    code = cli_main(["eval", "--models", str(tmp_path / "none"), "--quiet", "--no-plots"])
    err = capsys.readouterr().err
    assert code == 1 and len(err.strip().splitlines()) == 1
    assert f"{tmp_path / 'none'}: models directory does not exist" in err
    monkeypatch.chdir(tmp_path)  # no models/ here: the default is the shipped models
    before = sorted(p.name for p in DEFAULT_MODELS.iterdir())
    code = cli_main(["eval", "--samples", "30", "--quiet", "--no-plots"])
    assert code == 0, capsys.readouterr().err
    # the results go here, not into the shipped (in a wheel: the installed) models
    report = json.loads((tmp_path / "eval.json").read_text())
    assert report["models"] == str(DEFAULT_MODELS)
    assert (report["decoder"], report["seed"]) == ("cpp", 0)  # what repeats it (a review)
    assert sorted(p.name for p in DEFAULT_MODELS.iterdir()) == before
    # --out is made if missing, as train's --output is; a file there is refused
    code = cli_main(["eval", "--samples", "30", "--quiet", "--no-plots",
                     "--out", str(tmp_path / "runs" / "a"), "--seed", "7", "--decoder", "numpy"])
    assert code == 0, capsys.readouterr().err
    report = json.loads((tmp_path / "runs" / "a" / "eval.json").read_text())
    assert (report["decoder"], report["seed"]) == ("numpy", 7)
    code = cli_main(["eval", "--quiet", "--no-plots", "--out", "eval.json"])
    assert code == 1
    assert "eval.json: is a file, not an output directory" in \
        capsys.readouterr().err


def test_bad_outputs_are_told_before_any_work(tiny_data, trained, tmp_path, capsys,
                                              monkeypatch):
    from sssphere.learn import train as train_mod

    def no_training(*args, **kwargs):
        raise AssertionError("trained before checking the output directory")

    monkeypatch.setattr(train_mod, "train_cvae", no_training)
    (tmp_path / "m" / "lengthgen.json").mkdir(parents=True)
    assert cli_main(["train", str(tiny_data), "-o", str(tmp_path / "m"), "--quiet"]) == 1
    assert (f"{tmp_path / 'm' / 'lengthgen.json'}: is a directory or other non-file where the "
            "output file lengthgen.json is to be written") in capsys.readouterr().err
    (tmp_path / "f").write_text("a file")
    assert cli_main(["export", str(trained[0] / "cvae_checkpoint.pt"), "-o",
                     str(tmp_path / "f")]) == 1
    assert f"{tmp_path / 'f'}: is a file, not a directory" in capsys.readouterr().err
    assert cli_main(["datagen", "--samples", "5", "-o", str(tmp_path / "f" / "x.npz")]) == 1
    err = capsys.readouterr().err
    assert f"output directory '{tmp_path / 'f'}' is not a directory" in err
    assert "%|" not in err, err  # refused before any work: no progress bar above the error


def test_a_signal_while_the_files_move_into_place_is_held_until_all_are_there(
        trained, tmp_path, capsys, monkeypatch):
    import signal

    from sssphere.learn import export as export_mod

    real_replace, moved = os.replace, []

    def replace_then_interrupt(src, dst):
        if Path(dst).parent == tmp_path / "out":  # a move into place
            if not moved:
                os.kill(os.getpid(), signal.SIGINT)  # held: the handlers are swapped during the moves
            moved.append(Path(dst).name)
        real_replace(src, dst)

    monkeypatch.setattr(export_mod.os, "replace", replace_then_interrupt)
    _old_models(tmp_path / "out")
    code = cli_main(["export", str(trained[0] / "cvae_checkpoint.pt"), "-o",
                     str(tmp_path / "out")])
    monkeypatch.undo()
    assert code == 130
    assert f"interrupted after all files were written to {tmp_path / 'out'}" in (
        capsys.readouterr().err)
    assert moved == [f"{s}.{e}" for s in STEMS for e in ("json", "onnx")]
    for stem in STEMS:
        assert ((tmp_path / "out" / f"{stem}.json").read_text()
                == (trained[0] / f"{stem}.json").read_text())
