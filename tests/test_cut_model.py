"""The learned cut sphere step (python/sssphere/learn/cut.py; issue 26): the exact first flight,
the exit geometry, training and decoder parity (PyTorch → ONNX → onnxruntime = NumPy), the
shipped models' fidelity against `cut_sphere_walks`, and the errors for bad input."""

from pathlib import Path

import numpy as np
import onnxruntime as ort
import pytest
from scipy import stats

from sssphere.learn.cut import (CONDITION_RANGES, CUT_METRICS, CutData, CutSampler, evaluate_cut,
                                generate_cut_data, region_exit, sample_cut_conditions,
                                train_cut)
from sssphere.learn.numpy_decoder import load_decoder
from sssphere.learn.spec import CUT_SPECS
from sssphere.walks import cut_sphere_walks

SHIPPED = Path(__file__).resolve().parent.parent / "models" / "cut"


class _TruthTail:
    """Stand-ins for CutLengthGen and CutPathGen that return true walks with N >= 2 of one
    cell, N first and then that same walk's exit in the networks' variables: with them the
    sampler must reproduce `cut_sphere_walks` exactly in distribution, which tests its exact
    first flight, the exit parametrization (frame, mirror) and the geometry after it."""

    def __init__(self, sigma, g, h, mu0, n, seed):
        w = cut_sphere_walks(sigma, g, h, mu0, 1.0, n, seed=seed)
        keep = w["N"] >= 2
        self.N = w["N"][keep]
        pos = w["exit_pos"][keep].astype(np.float64)
        self.P = pos / np.linalg.norm(pos, axis=1, keepdims=True)
        self.D = w["exit_dir"][keep].astype(np.float64)
        k = len(self.N)
        self.data = CutData(*(np.full(k, v, dtype=np.float64) for v in (sigma, g, h, mu0)),
                            N=self.N, P=self.P, D=self.D)
        self.next, self.taken = 0, None

    def lengthgen(self):
        tail = self

        class LengthGen:
            name, path = "CutLengthGen", "<truth>"

            def sample(self, cond, rng):
                k = len(cond["sigma"])
                tail.taken = np.arange(tail.next, tail.next + k)
                tail.next += k
                return {"N": tail.N[tail.taken]}
        return LengthGen()

    def pathgen(self):
        tail = self

        class PathGen:
            name, path = "CutPathGen", "<truth>"

            def sample(self, cond, rng):
                assert np.array_equal(cond["N"], tail.N[tail.taken])
                d = tail.data.subset(tail.taken)
                return {"cos_p": d.cos_p, "cos_psi": d.cos_psi, "alpha": d.alpha,
                        "beta": d.beta}
        return PathGen()


@pytest.mark.parametrize("sigma, g, h, mu0", [(0.7, 0.0, 0.3, 1.0), (3.0, 0.8, 0.15, -0.5),
                                              (2.0, -0.6, 0.6, 0.2), (1.2, 0.95, 0.05, 0.9)])
def test_exact_first_flight_with_a_true_tail_reproduces_the_walks(sigma, g, h, mu0):
    n = 20_000
    tail = _TruthTail(sigma, g, h, mu0, 4 * n, seed=3)
    sampler = CutSampler(tail.lengthgen(), tail.pathgen())
    got = sampler.sample(sigma, g, h, mu0, n, np.random.default_rng(9))
    want = cut_sphere_walks(sigma, g, h, mu0, 1.0, n, seed=21)
    want = {**want, "exit_pos": want["exit_pos"].astype(np.float64),
            "exit_dir": want["exit_dir"].astype(np.float64)}
    # P(N = 1) is a binomial proportion: the two shares agree within 5 standard errors.
    p1, q1 = (got["N"] == 1).mean(), (want["N"] == 1).mean()
    assert abs(p1 - q1) <= 5 * np.sqrt((p1 * (1 - p1) + q1 * (1 - q1)) / n) + 1e-9
    for name, f in CUT_METRICS.items():
        a, b = np.round(f(got), 5), np.round(f(want), 5)
        assert stats.ks_2samp(a, b).pvalue > 1e-4, name


def test_region_exit_is_always_a_valid_exit():
    rng = np.random.default_rng(4)
    n = 50_000
    P = rng.standard_normal((n, 3))
    P /= np.linalg.norm(P, axis=1, keepdims=True)
    D = rng.standard_normal((n, 3))
    D /= np.linalg.norm(D, axis=1, keepdims=True)
    h = rng.uniform(0.01, 1.0, n)
    e = region_exit(P, D, h)
    pos, d, plane = e["exit_pos"], e["exit_dir"], e["through_plane"] == 1
    r = np.linalg.norm(pos, axis=1)
    assert np.allclose(pos[plane, 2], h[plane]) and np.all(r[plane] <= 1 + 1e-12)
    assert np.allclose(r[~plane], 1.0) and np.all(pos[~plane, 2] <= h[~plane] + 1e-12)
    # The exit point lies in direction P, and the direction is a unit vector leaving the region.
    assert np.allclose(pos / r[:, None], P)
    assert np.allclose(np.linalg.norm(d, axis=1), 1.0)
    normal = np.where(plane[:, None], [[0.0, 0.0, 1.0]], pos)
    assert np.all(np.sum(d * normal, axis=1) >= -1e-12)


def test_conditions_cover_their_ranges():
    c = sample_cut_conditions(100_000, seed=1)
    for name, (lo, hi) in CONDITION_RANGES.items():
        v = c[name]
        assert v.min() >= np.float32(lo) and v.max() <= np.float32(hi), name
        assert v.min() < lo + 0.05 * (hi - lo) and v.max() > hi - 0.05 * (hi - lo), name


@pytest.fixture(scope="module")
def tiny_cut_models(tmp_path_factory):
    out = tmp_path_factory.mktemp("cut")
    data = generate_cut_data(20_000, seed=2)
    report = train_cut(data, out, epochs=1, progress=False)
    return out, report


def test_training_interrupted_leaves_the_output_as_it_was(tmp_path, ctrl_c_while_training):
    """train_cut wrote each model as it finished: Ctrl-C while CutPathGen trained left a new
    CutLengthGen beside an old CutPathGen. Now both go in together, or neither."""
    for name in ("cutlengthgen.json", "cutpathgen.json"):
        (tmp_path / name).write_text("old")
    ctrl_c_while_training("CutPathGen")
    with pytest.raises(KeyboardInterrupt):
        train_cut(generate_cut_data(5_000, seed=4), tmp_path, epochs=1, progress=False)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cutlengthgen.json", "cutpathgen.json"]
    assert all((tmp_path / n).read_text() == "old" for n in ("cutlengthgen.json",
                                                               "cutpathgen.json"))


@pytest.mark.parametrize("argv, message", [
    (["train", "-o", "OUT", "--walks", "0"], "argument --walks: must be an integer >= 1, got '0'"),
    (["train", "-o", "OUT", "--epochs", "x"], "argument --epochs: must be an integer >= 1, got 'x'"),
    (["eval", "MISSING"], "MISSING/cutlengthgen.json: model file does not exist"),
    (["eval", str(SHIPPED), "--samples", "-1"], "argument --samples: must be an integer >= 1"),
])
def test_cut_command_line_names_bad_input_without_a_traceback(tmp_path, capsys, argv, message):
    from sssphere.learn.cut import main

    argv = [a.replace("OUT", str(tmp_path / "out")).replace("MISSING", str(tmp_path / "none"))
            for a in argv]
    message = message.replace("MISSING", str(tmp_path / "none"))
    try:
        status = main(argv)
    except SystemExit as e:  # argparse's usage errors
        status = e.code
    err = capsys.readouterr().err
    assert status == 2 and message in err and "Traceback" not in err, err
    assert not (tmp_path / "out").exists()


def test_training_writes_models_that_agree_across_torch_onnxruntime_numpy(tiny_cut_models):
    out, report = tiny_cut_models
    assert set(report) >= {"CutLengthGen", "CutPathGen", "files"}
    rng = np.random.default_rng(0)
    for spec in CUT_SPECS:
        dec = load_decoder(out / f"{spec.file_stem}.json")
        assert dec.name == spec.name and dec.condition_names == list(spec.conditions)
        x = rng.standard_normal((257, spec.input_width)).astype(np.float32)
        x[:, len(spec.conditions) + spec.latent_dim:] = 0.0
        mean, logvar = dec.evaluate(x)
        sess = ort.InferenceSession(str(out / f"{spec.file_stem}.onnx"),
                                    providers=["CPUExecutionProvider"])
        m2, l2 = sess.run(["mean", "logvar"], {"x": x})
        np.testing.assert_allclose(m2, mean, rtol=1e-5, atol=1e-5)
        np.testing.assert_allclose(l2, logvar, rtol=1e-5, atol=1e-5)


def test_sampled_steps_are_valid_exits(tiny_cut_models):
    sampler = CutSampler.from_dir(tiny_cut_models[0])
    rng = np.random.default_rng(1)
    n = 5000
    h = rng.uniform(0.01, 1.0, n)
    s = sampler.sample(rng.uniform(0.5, 32, n), rng.uniform(-0.95, 0.95, n), h,
                       rng.uniform(-1, 1, n), n, rng)
    assert s["N"].min() >= 1 and np.all(np.isfinite(s["exit_pos"]))
    plane = s["through_plane"] == 1
    assert np.allclose(s["exit_pos"][plane, 2], h[plane])
    assert np.allclose(np.linalg.norm(s["exit_pos"][~plane], axis=1), 1.0)


@pytest.mark.parametrize("field, value", [("sigma", 40.0), ("g", 0.99), ("h", 0.0),
                                          ("mu0", 1.5), ("h", float("nan"))])
def test_sampler_refuses_conditions_outside_the_training_ranges(tiny_cut_models, field, value):
    sampler = CutSampler.from_dir(tiny_cut_models[0])
    cond = {"sigma": 4.0, "g": 0.5, "h": 0.3, "mu0": 0.0, field: value}
    with pytest.raises(ValueError, match=field):
        sampler.sample(**cond, n=10, rng=np.random.default_rng(0))


def test_sampler_refuses_a_directory_without_cut_models(tmp_path):
    with pytest.raises(ValueError, match="cutlengthgen.json"):
        CutSampler.from_dir(tmp_path)


# ----------------------------------------------------------------------------------------
# The renderer's cut steps (render option cut_models)
# ----------------------------------------------------------------------------------------
def _dense_sphere(sigma_t=(30.0, 40.0, 60.0)):
    return {
        "camera": {"origin": [0, 0, 4], "target": [0, 0, 0], "fov": 35, "width": 16,
                   "height": 16},
        "shapes": [{"name": "ball", "sphere": {"center": [0, 0, 0], "radius": 1.0},
                    "medium": {"sigma_t": list(sigma_t), "albedo": [0.95, 0.9, 0.97],
                               "g": 0.6},
                    "boundary": {"type": "dielectric", "ior": 1.5}}],
        "lights": [{"type": "environment", "radiance": 1.0}],
    }


def test_render_with_cut_steps_takes_them_and_stays_finite():
    import sssphere
    scene = sssphere.load_scene(_dense_sphere())
    kw = dict(integrator="st", spp=16, seed=1, threads=2, sphere_threshold=6.0)
    plain = sssphere.render_full(scene, **kw)
    cut = sssphere.render_full(scene, cut_models=SHIPPED, **kw)
    assert np.isfinite(cut.image).all()
    assert cut.options["cut_models"] == str(SHIPPED)
    # The cut steps stand for most of the ordinary events near the surface.
    assert cut.mean_events_per_path < 0.75 * plain.mean_events_per_path


@pytest.mark.parametrize("kw, message", [
    ({"integrator": "pt"}, "cut_models is an option of integrator 'st'"),
    ({"integrator": "pt", "backend": "vulkan"}, "cut_models is an option of integrator 'st'"),
])
def test_cut_models_refused_where_they_do_not_apply(kw, message):
    import sssphere
    with pytest.raises(Exception, match=message):
        sssphere.render_full(_dense_sphere(), spp=1, cut_models=SHIPPED, **kw)


def test_cut_models_missing_file_is_named(tmp_path):
    import sssphere
    with pytest.raises(Exception, match="cutlengthgen.json"):
        sssphere.render_full(_dense_sphere(), integrator="st", spp=1, cut_models=tmp_path)
    # a directory that is not there is named as one, as --models names it (a review)
    with pytest.raises(sssphere.SceneError, match=r"none: not a directory \(expected cutlengthgen.json"):
        sssphere.render_full(_dense_sphere(), integrator="st", spp=1, cut_models=tmp_path / "none")


# ----------------------------------------------------------------------------------------
# The shipped models (models/cut)
# ----------------------------------------------------------------------------------------
@pytest.mark.parametrize("stem", [s.file_stem for s in CUT_SPECS])
def test_shipped_cut_decoders_agree_across_onnxruntime_and_numpy(stem):
    dec = load_decoder(SHIPPED / f"{stem}.json")
    rng = np.random.default_rng(3)
    x = rng.standard_normal((500, dec.input_width)).astype(np.float32)
    x[:, len(dec.condition_names) + dec.latent_dim:] = 0.0
    mean, logvar = dec.evaluate(x)
    sess = ort.InferenceSession(str(SHIPPED / f"{stem}.onnx"), providers=["CPUExecutionProvider"])
    m2, l2 = sess.run(["mean", "logvar"], {"x": x})
    np.testing.assert_allclose(m2, mean, rtol=1e-5, atol=1e-5)
    np.testing.assert_allclose(l2, logvar, rtol=1e-5, atol=1e-5)


def test_shipped_cut_models_have_not_regressed():
    from sssphere.learn.cut import REGRESSION_KS, REGRESSION_PLANE
    cells = evaluate_cut(CutSampler.from_dir(SHIPPED), samples=4000, seed=1,
                         sigmas=(2.0, 12.0), gs=(0.0, 0.9), hs=(0.05, 0.3), mu0s=(-1.0, 1.0))
    for c in cells:
        where = f"sigma {c['sigma']} g {c['g']} h {c['h']} mu0 {c['mu0']}"
        for name, ks in c["ks"].items():
            assert ks < REGRESSION_KS, f"{name} KS {ks:.3f} at {where}"
        assert abs(c["plane_model"] - c["plane_truth"]) < REGRESSION_PLANE, where


@pytest.mark.parametrize("sigma, g, h, mu0", [(2.0, 0.0, 0.05, -1.0), (6.0, 0.9, 0.3, 0.0),
                                              (12.0, 0.5, 0.7, 1.0), (24.0, 0.9, 0.3, -1.0)])
def test_cpp_sampler_draws_what_the_numpy_sampler_draws(sigma, g, h, mu0):
    """The renderer's sampler (C++, float encodings on lanes) and the NumPy reference
    sampler on the shipped models: the same distribution (KS per variable, p > 1e-4, and the
    through-plane shares within 5 standard errors)."""
    from sssphere import _core
    n = 20_000
    cpp = _core.cut_steps(str(SHIPPED), sigma, g, h, mu0, n, seed=4)
    cpp = {**cpp, "exit_pos": cpp["exit_pos"].astype(np.float64),
           "exit_dir": cpp["exit_dir"].astype(np.float64)}
    ref = CutSampler.from_dir(SHIPPED).sample(sigma, g, h, mu0, n, np.random.default_rng(8))
    for name, f in CUT_METRICS.items():
        a, b = np.round(f(cpp), 5), np.round(f(ref), 5)
        assert stats.ks_2samp(a, b).pvalue > 1e-4, name
    p, q = cpp["through_plane"].mean(), ref["through_plane"].mean()
    assert abs(p - q) <= 5 * np.sqrt((p * (1 - p) + q * (1 - q)) / n) + 1e-9
