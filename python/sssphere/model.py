"""The learned sphere step: LengthGen, PathGen and EventGen (docs/model-format.md).

    model = sssphere.ScatteringModel.load()            # the repository's models/ directory
    steps = model.sample(sigma_t=5.0, g=0.3, albedo=0.9, n=100_000, seed=1)
    steps["N"], steps["cos_theta"], steps["X"]         # numpy arrays, one entry per step

Everything is in the canonical exit frame of docs/notation.md: a unit sphere, the photon
entering at its centre travelling +z, so ``sigma_t`` here is the optical radius σt·r.
"""

from __future__ import annotations

import numbers
import os
from pathlib import Path
from typing import Union

import numpy as np

from sssphere import _core

# The shipped models: installed with the package (sssphere/models/, a regular install), or
# models/ at the root of the repository this package lives in (an editable install).
_PACKAGED_MODELS = Path(__file__).resolve().parent / "models"
DEFAULT_MODELS = (_PACKAGED_MODELS if (_PACKAGED_MODELS / "lengthgen.json").is_file()
                  else Path(__file__).resolve().parents[2] / "models")

ArrayLike = Union[float, np.ndarray, list]


def _per_sample(value: ArrayLike, name: str, n: int) -> np.ndarray:
    """A float32 array of length n from a scalar or a length-n 1-D array."""
    try:
        a = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a number or a 1-D array of numbers, got {value!r}") from None
    if a.ndim == 0:
        a = np.full(n, a)
    elif a.ndim != 1 or a.shape[0] != n:
        raise ValueError(f"{name} must be a number or an array of shape ({n},), got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        i = int(np.flatnonzero(~np.isfinite(a))[0])
        raise ValueError(f"{name}[{i}] = {a[i]} is not a finite number")
    return a.astype(np.float32)


def _first_bad(mask: np.ndarray) -> int:
    return int(np.flatnonzero(mask)[0])


class ScatteringModel:
    """The three decoders of one model directory and the sphere-step sampler built on them."""

    def __init__(self, core: _core.ScatteringModel):
        self._core = core

    @classmethod
    def load(cls, path: Union[str, os.PathLike, None] = None, tilt: bool = True) -> ScatteringModel:
        """Load ``lengthgen.json``, ``pathgen.json`` and ``eventgen.json`` from a directory.

        Parameters
        ----------
        path : the model directory (default: the repository's ``models/``).
        tilt : also load ``tilt.json``, PathGen's forward-memory tilt, if the directory has
            one (docs/sphere-tracing.md, "The forward-memory tilt"). ``False`` gives the
            decoders' own steps (what ``sssphere calibrate-tilt`` measures).

        Raises
        ------
        ValueError naming the directory or file and what is wrong (missing file, malformed
        JSON, another format or format_version, inconsistent shapes, non-finite numbers, ...).
        """
        if path is None:
            path = DEFAULT_MODELS
            if not path.is_dir():
                raise ValueError(
                    f"{path}: no models directory here (the default, models/ at the root of the "
                    "repository): train and export the decoders first, or pass the directory "
                    "that holds lengthgen.json, pathgen.json and eventgen.json")
        path = Path(path)
        if not path.is_dir():
            raise ValueError(f"{path}: not a directory (expected lengthgen.json, pathgen.json, "
                             "eventgen.json)")
        return cls(_core.ScatteringModel.load(str(path), bool(tilt)))

    @property
    def path(self) -> str:
        """The directory the model was loaded from."""
        return self._core.path

    @property
    def tilted(self) -> bool:
        """Whether the steps carry PathGen's forward-memory tilt (``tilt.json`` was loaded)."""
        return self._core.tilted

    @property
    def sigma_range(self) -> tuple[float, float]:
        """The optical radii (σt·r) every decoder was trained on: the renderer keeps within it."""
        return self._core.sigma_range

    def sample(self, sigma_t: ArrayLike, g: ArrayLike, albedo: ArrayLike, n: int, seed: int = 0,
               threads: int | None = None) -> dict[str, np.ndarray]:
        """Sample n sphere steps (the first scattering event at the centre counts: N >= 1).

        Parameters
        ----------
        sigma_t : optical radius σt·r of the sphere, >= 0 and within ``sigma_range``;
            a number or an array of shape (n,).
        g : Henyey-Greenstein anisotropy, |g| < 1 (and within the training range);
            a number or an array of shape (n,).
        albedo : single-scattering albedo φ in [0, 1] (it selects the representative event
            X, W); a number or an array of shape (n,).
        n : number of steps, >= 1.
        seed : step i uses the random stream (seed, i): the result does not depend on
            ``threads``.
        threads : worker threads, 0 to 4096 (0 or None, the default: all cores).

        Returns
        -------
        dict of numpy arrays: ``N`` (n,) int64, ``cos_theta``, ``alpha``, ``beta`` (n,)
        float32, ``X`` (n, 3) and ``W`` (n, 3) float32, in the exit frame.
        """
        if isinstance(n, bool) or not isinstance(n, numbers.Integral) or not 1 <= n < 2**31:
            # the cap of sphere_walks: a sample's results take 40 bytes, 2^31 of them 80 GiB
            # (10^13 raised numpy's MemoryError "72.8 TiB", naming nothing)
            raise ValueError(f"n must be an integer from 1 to 2**31 - 1, got {n!r}")
        n = int(n)
        if isinstance(seed, bool) or not isinstance(seed, numbers.Integral) or not 0 <= seed < 2**64:
            raise ValueError(f"seed must be an integer in [0, 2**64), got {seed!r}")
        if threads is None:
            threads = 0
        elif (isinstance(threads, bool) or not isinstance(threads, numbers.Integral)
              or not 0 <= threads <= 4096):  # as a render takes them
            raise ValueError(f"threads must be an integer from 0 to 4096 (0 or None = all "
                             f"cores), got {threads!r}")
        s = _per_sample(sigma_t, "sigma_t", n)
        gg = _per_sample(g, "g", n)
        phi = _per_sample(albedo, "albedo", n)
        if np.any(s < 0):
            i = _first_bad(s < 0)
            raise ValueError(f"sigma_t[{i}] = {s[i]} is not allowed (allowed: sigma_t >= 0)")
        lo, hi = self.sigma_range
        if np.any((s < lo) | (s > hi)):  # named as here, not as the decoders' "sigma"
            i = _first_bad((s < lo) | (s > hi))
            raise ValueError(f"sigma_t[{i}] = {float(s[i]):.7g} is outside the models' training range "
                             f"[{lo:g}, {hi:g}] (sigma_range); the renderer shrinks the sphere "
                             "to stay within it")
        if np.any(np.abs(gg) >= 1):
            i = _first_bad(np.abs(gg) >= 1)
            raise ValueError(f"g[{i}] = {gg[i]} is not allowed (allowed: -1 < g < 1)")
        if np.any((phi < 0) | (phi > 1)):
            i = _first_bad((phi < 0) | (phi > 1))
            raise ValueError(f"albedo[{i}] = {phi[i]} is not allowed (allowed: 0 <= albedo <= 1)")
        return self._core.sample(s, gg, phi, n, int(seed), int(threads))

    def evaluate(self, model_name: str, x: np.ndarray, impl: str = "simd") -> tuple[np.ndarray, np.ndarray]:
        """The raw network of one decoder: (mean, logvar), each (batch, outputs) float32, for
        x of shape (batch, input_width) (encoded conditions, latent z, zero padding).

        ``impl`` is ``"simd"`` (the renderer's decoder) or ``"scalar"`` (the reference); both
        exist for parity tests.
        """
        x = np.ascontiguousarray(x, dtype=np.float32)
        if not np.isfinite(x).all():  # NaN in gave finite numbers out (a review)
            bad = np.argwhere(~np.isfinite(x))[0]
            raise ValueError(f"x[{bad[0]}, {bad[1]}] = {x[tuple(bad)]} is not allowed "
                             "(allowed: finite inputs)")
        return self._core.evaluate(model_name, x, impl)

    def input_width(self, model_name: str) -> int:
        """The input width of decoder ``model_name`` (LengthGen, PathGen or EventGen)."""
        return self._core.input_width(model_name)

    @staticmethod
    def simd_targets() -> list[str]:
        """The SIMD targets of the decoders that this CPU can run, best first ("AVX3" is
        AVX-512, then "AVX2", "SSE4", ...)."""
        return list(_core.ScatteringModel.simd_targets())

    @staticmethod
    def simd_target() -> str:
        """The SIMD target the decoders run on now."""
        return _core.ScatteringModel.simd_target

    @staticmethod
    def simd_default_target() -> str:
        """The SIMD target the decoders run on unless pinned: the best this CPU has, except
        "AVX2" where that is AVX-512 on Intel's family 6, model 85 (Skylake-SP, Cascade
        Lake, Cooper Lake), whose clock drops after 512-bit arithmetic and slows the rest of
        a render more than the wider vectors gain (bench/README.md, "Which CPU")."""
        return _core.ScatteringModel.simd_default_target()

    @staticmethod
    def use_simd_target(name: str = "") -> None:
        """Pin the decoders (in renders too) to one of ``simd_targets()``; ``""`` returns to
        ``simd_default_target()``. For benchmarks of other CPUs' instruction sets: it is global
        to the process, so call it only while nothing renders or samples. Raises ValueError
        naming the target when this CPU or build does not have it."""
        if not isinstance(name, str):
            raise ValueError(f"name must be a string, got {name!r}")
        _core.ScatteringModel.use_simd_target(name)

    def __repr__(self) -> str:
        return repr(self._core)
