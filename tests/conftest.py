"""Shared fixtures: small scenes as dicts, so each test says what it renders."""

import copy
import json
import os
from pathlib import Path

import pytest


SMALL_SCENE = {
    "camera": {"origin": [0, 0, 4], "target": [0, 0, 0], "up": [0, 1, 0], "fov": 30,
               "width": 24, "height": 16},
    "shapes": [
        {"name": "ball", "sphere": {"center": [0, 0, 0], "radius": 1, "subdivisions": 3},
         "medium": {"sigma_t": [5, 5, 5], "albedo": [0.95, 0.9, 0.8], "g": 0.3},
         "boundary": {"type": "index_matched"}}
    ],
    "lights": [
        {"type": "point", "position": [3, 3, 3], "intensity": [10, 10, 10]},
        {"type": "environment", "radiance": [0.1, 0.1, 0.1]},
    ],
    "render": {"spp": 4, "seed": 1},
}


@pytest.fixture
def small_scene():
    """A fresh deep copy of a 24x16 sphere scene (edit freely)."""
    return copy.deepcopy(SMALL_SCENE)


@pytest.fixture
def ctrl_c_while_training(monkeypatch):
    """Call with a model's name (e.g. "PathGen"): from then on, training that model raises
    KeyboardInterrupt as Ctrl-C would, and every other model trains as usual."""
    from sssphere.learn import train as train_module

    real = train_module.train_cvae

    def interrupt_at(name: str) -> None:
        def train_cvae(spec, *args, **kwargs):
            if spec.name == name:
                raise KeyboardInterrupt
            return real(spec, *args, **kwargs)

        monkeypatch.setattr(train_module, "train_cvae", train_cvae)

    return interrupt_at


@pytest.fixture
def models_with(tmp_path):
    """Call with training ranges, e.g. g=[-0.2, 0.2]: a copy of the sphere-step models (the
    shipped ones, or $SSSPHERE_MODELS) claiming those ranges, for media they were not
    trained for. Returns its directory."""
    from sssphere.model import DEFAULT_MODELS

    made = []

    def make(**ranges) -> Path:
        made.append(ranges)
        out = tmp_path / f"models-{len(made)}"
        out.mkdir()
        source = Path(os.environ.get("SSSPHERE_MODELS") or DEFAULT_MODELS)
        for name in ("lengthgen", "pathgen", "eventgen"):
            d = json.loads((source / f"{name}.json").read_text())
            d["training"].update(ranges)
            (out / f"{name}.json").write_text(json.dumps(d))
        return out

    return make
