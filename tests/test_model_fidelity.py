"""The shipped models (models/) against ground-truth sphere walks on the paper's grid.

The full report (10,000 samples per cell, all metrics, figures) is `sssphere eval`, written to
models/README.md. This test guards against regressions: in every cell of σ ∈ {1, 4, 20, 100}
× g ∈ {−0.7, 0, 0.4, 0.9} the two-sample KS statistic of log N and of cos θ must stay below
REGRESSION_KS = 0.1. With 5,000 samples a side the KS statistic of two samples of the *same*
distribution exceeds 0.04 with probability ~1e-3, so a model at the aim (0.05) passes with a
wide margin and one at 0.1 fails.
"""

from pathlib import Path

import numpy as np
import pytest

import sssphere
from sssphere.learn import evaluate

MODELS = Path(__file__).resolve().parents[1] / "models"


@pytest.fixture(scope="module")
def cells():
    model = sssphere.ScatteringModel.load(MODELS)
    return evaluate.evaluate(lambda s, g, a, n, seed: model.sample(s, g, a, n, seed=seed),
                             samples=5000, seed=100)


def test_every_cell_stays_below_the_regression_limit(cells):
    bad = [(c.sigma, c.g, name, round(c.ks[name], 3)) for c in cells
           for name in ("log_N", "cos_theta") if c.ks[name] > evaluate.REGRESSION_KS]
    assert not bad, f"cells past KS {evaluate.REGRESSION_KS}: {bad}"


def test_exit_directions_stay_below_the_regression_limit(cells):
    # PathGen's other outputs, held to the same limit. (EventGen's X and W are not gated: their
    # marginals miss by KS 0.1-0.25 today, a known weakness stated in models/README.md.)
    bad = [(c.sigma, c.g, name, round(c.ks[name], 3)) for c in cells
           for name in ("alpha", "beta") if c.ks[name] > evaluate.REGRESSION_KS]
    assert not bad, bad


def test_the_model_card_reports_the_current_models():
    card = (MODELS / "README.md").read_text()
    assert "<!-- eval:begin -->" in card and "| σ | g |" in card
    report = MODELS / "eval.json"
    assert report.exists()
    assert np.isfinite([v for c in __import__("json").loads(report.read_text())["cells"]
                        for v in c["ks"].values()]).all()


# PathGen's forward-memory tilt (models/tilt.json; docs/sphere-tracing.md, "The forward-memory
# tilt"). At nodes of the table the tilted steps must keep the walks' share of the entering
# direction: the means of cos θ and of the exit direction's z within five standard errors of
# the difference (this test's samples, new seeds, and the calibration's walks, whose means the
# table was fitted to). The decoders alone miss both by more in these cells (the test can fail).
TILT_CELLS = [(28.0, 0.95), (42.0, 0.9), (28.0, 0.65), (9.0, 0.95)]


@pytest.mark.parametrize("sigma,g", TILT_CELLS)
def test_the_tilt_gives_the_walks_forward_memory(sigma, g):
    from sssphere.learn import tilt

    table = tilt.read(MODELS / "tilt.json")
    node = next(c for c in table["calibration"]["cells"] if (c["sigma"], c["g"]) == (sigma, g))
    n_model, n_walks = 400_000, 200_000
    walks = tilt.moments(sssphere.sphere_walks(sigma, g, 0.9999, n_walks, seed=901))
    tilted = tilt.moments(sssphere.ScatteringModel.load(MODELS).sample(
        sigma_t=sigma, g=g, albedo=0.9999, n=n_model, seed=902))
    plain = tilt.moments(sssphere.ScatteringModel.load(MODELS, tilt=False).sample(
        sigma_t=sigma, g=g, albedo=0.9999, n=n_model, seed=902))
    plain_z = []
    for v, square in (("mu", "mumu"), ("wz", "wzwz")):
        var = walks[square] - walks[v] ** 2
        se = np.sqrt(var / walks["n"] + var / tilted["n"] + var / node["walks"]["n"])
        assert abs(tilted[v] - walks[v]) < 5 * se, \
            f"{v}: tilted {tilted[v]:+.4f}, walks {walks[v]:+.4f}, 5 se {5 * se:.4f}"
        plain_z.append(abs(plain[v] - walks[v]) / se)
    assert max(plain_z) > 5, f"the decoders alone already agree here (z {plain_z})"


def test_the_numpy_reference_sampler_takes_the_tilt_too():
    """SphereSampler (learn/numpy_decoder.py) reads tilt.json and keeps steps as the renderer
    does: its mean cos θ is the C++ sampler's within five standard errors, and without the
    tilt it is the decoders' own."""
    from sssphere.learn.numpy_decoder import SphereSampler

    sigma, g, n = 42.0, 0.9, 100_000
    cpp = sssphere.ScatteringModel.load(MODELS).sample(sigma_t=sigma, g=g, albedo=0.99, n=n, seed=5)
    plain = sssphere.ScatteringModel.load(MODELS, tilt=False).sample(sigma_t=sigma, g=g, albedo=0.99,
                                                                       n=n, seed=5)
    for tilted, want in ((True, cpp), (False, plain)):
        ref = SphereSampler.from_dir(MODELS, events=False, tilt=tilted).sample(
            sigma, g, 0.99, n, np.random.default_rng(6))
        a, b = ref["cos_theta"], want["cos_theta"].astype(np.float64)
        se = np.hypot(a.std(), b.std()) / np.sqrt(n)
        assert abs(a.mean() - b.mean()) < 5 * se, (tilted, a.mean(), b.mean())
    assert abs(cpp["cos_theta"].mean() - plain["cos_theta"].mean()) > 5 * se
