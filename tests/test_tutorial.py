"""docs/tutorial.md runs: its python blocks, in order, in one namespace, in a fresh
directory (the files it writes land there)."""

import re
from pathlib import Path

import numpy as np
import pytest

import sssphere

TUTORIAL = Path(__file__).resolve().parents[1] / "docs" / "tutorial.md"


def test_the_tutorial_runs_and_makes_a_denoised_marble_bunny(tmp_path, monkeypatch, capsys):
    pytest.importorskip("pyoidn", reason="the tutorial's step 5 needs the denoise extra")
    blocks = re.findall(r"```python\n(.*?)```", TUTORIAL.read_text(), re.S)
    assert len(blocks) == 5, "one block per step"
    monkeypatch.chdir(tmp_path)
    namespace: dict = {}
    for block in blocks:
        exec(compile(block, str(TUTORIAL), "exec"), namespace)  # noqa: S102 (our own doc)
    out = capsys.readouterr().out
    assert "shape 'bunny': medium" in out and "sphere steps" in out
    result = namespace["result"]
    assert result.denoised is not None and result.spp == 16
    assert (tmp_path / "bunny_marble.png").is_file()
    layers = sssphere.read_layers(tmp_path / "bunny_marble.exr")
    assert {"", "noisy", "albedo", "normal", "depth"} <= set(layers)
    np.testing.assert_array_equal(layers[""], result.denoised)
    # The bunny is there, in marble's near-white colour, and the picture is lit.
    bunny = layers["albedo"][..., 0] > 0.9
    assert bunny.mean() > 0.05
    assert np.all(np.isfinite(result.denoised)) and result.denoised[bunny].mean() > 0.05
    assert namespace["scene"].rebuilt == []
