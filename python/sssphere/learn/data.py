"""Training data: walks of the canonical sphere problem with their conditions, in one `.npz`.

A training-data file holds, for n walks (docs/learning.md):

========== ========= ===================================================================
key        shape     meaning
========== ========= ===================================================================
sigma      (n,)      optical radius σ = σt·r ≥ 0
g          (n,)      HG anisotropy, |g| < 1
phi        (n,)      albedo φ ∈ [0, 1] (chooses the representative event)
N          (n,)      integer number of scattering events, ≥ 1
cos_theta  (n,)      exit point x̂ = (sin θ, 0, cos θ) in the exit frame
alpha      (n,)      exit direction ω·b
beta       (n,)      exit direction ω·t
X          (n, 3)    representative event: position (|X| ≤ 1)
W          (n, 3)    representative event: arriving direction (unit)
meta       ()        optional: a JSON string describing how the file was made
========== ========= ===================================================================

``meta`` may hold ``sigma_range``, ``g_range``, ``phi_range`` ([lo, hi]) or ``sigma_max``
(σ ∈ [0, sigma_max]) and ``g_max`` (|g| ≤ g_max): the ranges the conditions were drawn from,
which the model files then record as their training ranges (otherwise the data's min and max
are recorded). They must be finite, lo < hi, inside the variable's domain (σ ≥ 0,
−1 < g < 1, 0 ≤ φ ≤ 1) and hold the data's own values.

Any other key is an error. `load_training_data` checks all of this and names the file and the
problem. `sample_conditions` and `generate_training_data` make such a file from any walker with
the signature of `sssphere.sphere_walks`.
"""

from __future__ import annotations

import json
import math
import zipfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from sssphere._files import atomic_output, missing_input

VECTOR_KEYS = ("sigma", "g", "phi", "N", "cos_theta", "alpha", "beta")
MATRIX_KEYS = ("X", "W")
REQUIRED_KEYS = VECTOR_KEYS + MATRIX_KEYS
OPTIONAL_KEYS = ("meta",)
WALK_KEYS = ("N", "cos_theta", "alpha", "beta", "X", "W")

# Tolerance of the range checks on stored float values (rounding of unit vectors).
_TOL = 1e-5


class DataError(ValueError):
    """A training-data file is missing, unreadable or inconsistent."""


@dataclass
class TrainingData:
    """The arrays of a training-data file (float64, N int64) and where they came from."""

    sigma: np.ndarray
    g: np.ndarray
    phi: np.ndarray
    N: np.ndarray
    cos_theta: np.ndarray
    alpha: np.ndarray
    beta: np.ndarray
    X: np.ndarray
    W: np.ndarray
    path: str = ""
    meta: dict = field(default_factory=dict)

    def __len__(self) -> int:
        return int(self.N.shape[0])

    def subset(self, mask: np.ndarray) -> "TrainingData":
        """The walks where mask is true (or at the given indices)."""
        return TrainingData(**{k: getattr(self, k)[mask] for k in REQUIRED_KEYS},
                            path=self.path, meta=self.meta)

    def __repr__(self) -> str:
        return f"TrainingData({len(self)} walks from {self.path or '<memory>'})"


def _fail(path, message: str):
    raise DataError(f"{path}: {message}")


def validate_arrays(arrays: dict, path="<memory>") -> TrainingData:
    """Check keys, shapes, dtypes and ranges of training-data arrays; return TrainingData."""
    missing = [k for k in REQUIRED_KEYS if k not in arrays]
    if missing:
        _fail(path, f"missing array(s) {', '.join(missing)} (a training-data file needs "
                    f"{', '.join(REQUIRED_KEYS)})")
    unknown = sorted(set(arrays) - set(REQUIRED_KEYS) - set(OPTIONAL_KEYS))
    if unknown:
        _fail(path, f"unknown array(s) {', '.join(unknown)} (allowed: "
                    f"{', '.join(REQUIRED_KEYS + OPTIONAL_KEYS)})")
    n = np.shape(arrays["N"])[0] if np.ndim(arrays["N"]) == 1 else None
    if n is None:
        _fail(path, f"N must be one-dimensional, got shape {np.shape(arrays['N'])}")
    if n == 0:
        _fail(path, "holds no walks")
    out = {}
    for key in REQUIRED_KEYS:
        arr = np.asarray(arrays[key])
        want = (n,) if key in VECTOR_KEYS else (n, 3)
        if arr.shape != want:
            _fail(path, f"{key} has shape {arr.shape}, expected {want} (n = {n} walks, from N)")
        if key == "N":
            if not np.issubdtype(arr.dtype, np.integer):
                _fail(path, f"N must hold integers, got dtype {arr.dtype}")
            out[key] = arr.astype(np.int64)
            continue
        if not (np.issubdtype(arr.dtype, np.floating) or np.issubdtype(arr.dtype, np.integer)):
            _fail(path, f"{key} must hold numbers, got dtype {arr.dtype}")
        arr = arr.astype(np.float64)
        bad = ~np.isfinite(arr)
        if bad.any():
            _fail(path, f"{key} has {int(bad.sum())} non-finite value(s)")
        out[key] = arr

    def check(ok: np.ndarray, what: str):
        if not ok.all():
            i = int(np.flatnonzero(~ok)[0])
            _fail(path, f"{what} fails for {int((~ok).sum())} walk(s), first at index {i}")

    check(out["sigma"] >= 0, "sigma >= 0")
    check(np.abs(out["g"]) < 1, "|g| < 1")
    check((out["phi"] >= 0) & (out["phi"] <= 1), "0 <= phi <= 1")
    check(out["N"] >= 1, "N >= 1")
    check(np.abs(out["cos_theta"]) <= 1 + _TOL, "|cos_theta| <= 1")
    check(out["alpha"] ** 2 + out["beta"] ** 2 <= 1 + _TOL, "alpha^2 + beta^2 <= 1")
    check(np.linalg.norm(out["X"], axis=1) <= 1 + _TOL, "|X| <= 1")
    check(np.abs(np.linalg.norm(out["W"], axis=1) - 1) <= _TOL, "|W| = 1")
    meta = {}
    if "meta" in arrays:
        try:
            meta = json.loads(str(np.asarray(arrays["meta"])[()]))
        except (json.JSONDecodeError, TypeError) as e:
            _fail(path, f"meta is not a JSON string ({e})")
        if not isinstance(meta, dict):
            _fail(path, "meta must be a JSON object")
    validate_meta(meta, out, path)
    return TrainingData(**out, path=str(path), meta=meta)


# The ranges a meta may give, as (key, variable, smallest lo, largest hi, whether the ends
# are allowed): the model files record them as their training ranges, and the renderer
# trusts those, so they must be values the medium can take.
_META_RANGES = (("sigma_range", "sigma", 0.0, math.inf, True),
                ("g_range", "g", -1.0, 1.0, False),
                ("phi_range", "phi", 0.0, 1.0, True))
_META_MAXIMA = (("sigma_max", "sigma", "a finite number > 0"),
                ("g_max", "g", "a number in (0, 1)"))


def validate_meta(meta: dict, arrays: dict, path="<memory>") -> None:
    """Check the ranges a meta gives (module docstring): finite numbers, lo < hi, inside the
    variable's domain, and holding the data's own values (arrays: key → float64 array)."""
    def number(v) -> bool:
        return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)

    def covers(key, var, lo, hi):
        v = arrays[var]
        tol = _TOL * max(1.0, abs(lo), abs(hi))  # float32 rounding of the stored values
        if v.min() < lo - tol or v.max() > hi + tol:
            _fail(path, f"meta {key} = {meta[key]!r} does not hold the data's {var}, which "
                        f"ranges from {float(v.min()):.9g} to {float(v.max()):.9g}")

    for key, var, lo_min, hi_max, closed in _META_RANGES:
        if key not in meta:
            continue
        r = meta[key]
        inside = "[{}, {}]" if closed else "({}, {})"
        allowed = (f"[lo, hi], finite numbers with lo < hi, within "
                   f"{inside.format(lo_min, 'inf' if hi_max == math.inf else hi_max)}")
        if not (isinstance(r, list) and len(r) == 2 and all(number(x) for x in r)
                and r[0] < r[1]):
            _fail(path, f"meta {key} = {r!r} is not allowed (allowed: {allowed})")
        ok = (r[0] >= lo_min and r[1] <= hi_max) if closed else (r[0] > lo_min and r[1] < hi_max)
        if not ok:
            _fail(path, f"meta {key} = {r!r} is not allowed (allowed: {allowed})")
        covers(key, var, r[0], r[1])
    for key, var, allowed in _META_MAXIMA:
        if key not in meta:
            continue
        m = meta[key]
        ok = number(m) and m > 0 and (var != "g" or m < 1)
        if not ok:
            _fail(path, f"meta {key} = {m!r} is not allowed (allowed: {allowed})")
        covers(key, var, 0.0 if var == "sigma" else -m, m)


def load_training_data(path) -> TrainingData:
    """Load and validate a training-data `.npz` (see the module docstring).

    Raises
    ------
    DataError
        naming the file and the problem: missing file, not an npz, missing or unknown arrays,
        wrong shapes or dtypes, non-finite or out-of-range values.
    """
    path = Path(path)
    if not path.is_file():
        _fail(path, missing_input(path, "training-data file"))
    try:
        with open(path, "rb") as f:
            head = f.read(6)
    except OSError as e:
        _fail(path, f"cannot read the training-data file ({e.strerror or e})")
    if not head.startswith((b"PK\x03\x04", b"PK\x05\x06")):  # np.load would speak of pickles
        what = "a single .npy array" if head.startswith(b"\x93NUMPY") else "not a zip archive"
        _fail(path, f"not a .npz file ({what}; expected the .npz archive of arrays that "
                    "`sssphere datagen` writes)")
    try:
        # np.load given the path leaves it open when the archive is broken (a ResourceWarning)
        with open(path, "rb") as f, np.load(f, allow_pickle=False) as npz:
            arrays = {k: npz[k] for k in npz.files}
    except (zipfile.BadZipFile, OSError, ValueError, EOFError) as e:
        _fail(path, f"not a readable .npz file ({type(e).__name__}: {e})")
    return validate_arrays(arrays, path)


def save_training_data(path, data: dict | TrainingData, meta: dict | None = None) -> None:
    """Write arrays (validated first) as an uncompressed `.npz`."""
    if isinstance(data, TrainingData):
        arrays = {k: getattr(data, k) for k in REQUIRED_KEYS}
        meta = data.meta if meta is None else meta
    else:
        arrays = dict(data)
    checked = validate_arrays(arrays, path)
    if meta:
        validate_meta(meta, {k: getattr(checked, k) for k in VECTOR_KEYS}, path)
        arrays["meta"] = np.array(json.dumps(meta))
    path = Path(path)
    if path.suffix != ".npz":  # as np.savez names it
        path = path.with_name(path.name + ".npz")
    with atomic_output(path) as tmp, open(tmp, "wb") as f:
        np.savez(f, **arrays)


def sample_conditions(n: int, rng: np.random.Generator, sigma_max: float = 200.0,
                      g_max: float = 0.95, phi_min_absorption: float = 1e-6) -> dict:
    """Draw (σ, g, φ) for n walks, covering the training ranges where they matter.

    - σ ∈ [0, σ_max] with ln(σ + 0.5) uniform: as many walks per octave at σ ≈ 1–10, where
      the paper's models erred, as at σ ≈ 100 (and far cheaper walks).
    - g = g_max · sin(π u / 2), u ~ U[−1, 1]: denser towards |g| = g_max.
    - 1 − φ log-uniform on [phi_min_absorption, 1]: every order of magnitude of absorption
      (the renderer's albedos are often 0.99–0.99999).
    """
    c = 0.5
    sigma = np.exp(rng.uniform(math.log(c), math.log(sigma_max + c), n)) - c
    sigma = np.clip(sigma, 0.0, sigma_max)
    g = g_max * np.sin(0.5 * np.pi * rng.uniform(-1.0, 1.0, n))
    phi = 1.0 - np.exp(rng.uniform(math.log(phi_min_absorption), 0.0, n))
    return {"sigma": sigma, "g": g, "phi": np.clip(phi, 0.0, 1.0)}


def generate_training_data(path, n: int, walker: Callable, seed: int = 0,
                           sigma_max: float = 200.0, g_max: float = 0.95,
                           chunk: int = 50_000, progress: Callable[[float], object] | None = None
                           ) -> TrainingData:
    """Simulate n walks with ``walker(sigma, g, albedo, n, seed)`` (the signature of
    `sssphere.sphere_walks`) at conditions from `sample_conditions`, and write them to path.

    Chunk i uses walker seed ``seed * 1_000_003 + i``; the conditions come from
    ``numpy.random.default_rng(seed)``. Deterministic for a deterministic walker.
    """
    rng = np.random.default_rng(seed)
    cond = sample_conditions(n, rng, sigma_max=sigma_max, g_max=g_max)
    parts = []
    for i, start in enumerate(range(0, n, chunk)):
        sl = slice(start, min(n, start + chunk))
        w = walker(cond["sigma"][sl], cond["g"][sl], cond["phi"][sl], sl.stop - sl.start,
                   seed=seed * 1_000_003 + i)
        parts.append({k: np.asarray(w[k]) for k in WALK_KEYS})
        if progress is not None:
            progress(sl.stop / n)
    arrays = dict(cond)
    for k in WALK_KEYS:
        arrays[k] = np.concatenate([p[k] for p in parts])
    meta = {"generator": getattr(walker, "__qualname__", str(walker)), "seed": seed, "n": n,
            "sigma_range": [0.0, float(sigma_max)], "g_range": [-float(g_max), float(g_max)],
            "phi_range": [0.0, 1.0]}
    save_training_data(path, arrays, meta=meta)
    return validate_arrays(arrays, path)
