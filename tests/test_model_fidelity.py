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
