"""Shared fixtures: small scenes as dicts, so each test says what it renders."""

import copy

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
