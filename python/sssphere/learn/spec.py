"""What the three models are (paper Table 1, docs/model-format.md) and the encodings of their
variables. NumPy only: shared by the trainer, the exporter and the NumPy decoder.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

FORMAT = "sssphere-cvae-decoder"
FORMAT_VERSION = 1
NOTATION_VERSION = 1

ENCODING_KINDS = ("affine", "log", "logit")
_ENCODING_DEFAULTS = {
    "affine": {"a": 1.0, "b": 0.0},
    "log": {"a": 1.0, "b": 0.0, "s": 1.0, "c": 0.0},
    "logit": {"a": 1.0, "b": 0.0, "lo": -1.0, "hi": 1.0, "eps": 0.0},
}


def round9(x: float) -> float:
    """x rounded to 9 significant digits: the value a model file stores and reads back."""
    return float(f"{float(x):.9g}")


@dataclass(frozen=True)
class Encoding:
    """docs/model-format.md: e(x) = a·x + b (``affine``), a·ln(s·x + c) + b (``log``) or
    a·ln((x − lo + eps) / (hi − x + eps)) + b (``logit``)."""

    kind: str
    a: float = 1.0
    b: float = 0.0
    s: float = 1.0
    c: float = 0.0
    lo: float = -1.0
    hi: float = 1.0
    eps: float = 0.0

    def __post_init__(self):
        if self.kind not in ENCODING_KINDS:
            raise ValueError(f"unknown encoding kind {self.kind!r} "
                             f"(allowed: {', '.join(ENCODING_KINDS)})")
        for name in ("a", "b", "s", "c", "lo", "hi", "eps"):
            if not math.isfinite(getattr(self, name)):
                raise ValueError(f"encoding parameter {name} must be finite")
        if self.a == 0 or (self.kind == "log" and self.s == 0):
            raise ValueError("encoding parameters a and s must be non-zero")
        if self.kind != "log" and (self.s != 1.0 or self.c != 0.0):
            raise ValueError(f"a {self.kind} encoding has no parameters s, c")
        if self.kind != "logit" and (self.lo != -1.0 or self.hi != 1.0 or self.eps != 0.0):
            raise ValueError(f"a {self.kind} encoding has no parameters lo, hi, eps")
        if self.kind == "logit" and not (self.lo < self.hi and self.eps >= 0):
            raise ValueError("a logit encoding needs lo < hi and eps >= 0")

    # -- NumPy maps (float64) ------------------------------------------------------------
    def in_domain(self, x: np.ndarray) -> np.ndarray:
        """True where x may be encoded (finite, and s·x + c > 0 for ``log``)."""
        x = np.asarray(x, dtype=np.float64)
        ok = np.isfinite(x)
        if self.kind == "log":
            ok &= self.s * x + self.c > 0
        elif self.kind == "logit":
            ok &= (x - self.lo + self.eps > 0) & (self.hi - x + self.eps > 0)
        return ok

    def encode(self, x) -> np.ndarray:
        x = np.asarray(x, dtype=np.float64)
        if self.kind == "affine":
            return self.a * x + self.b
        with np.errstate(divide="ignore", invalid="ignore"):
            if self.kind == "log":
                return self.a * np.log(self.s * x + self.c) + self.b
            ratio = np.log(x - self.lo + self.eps) - np.log(self.hi - x + self.eps)
            return self.a * ratio + self.b

    def decode(self, e) -> np.ndarray:
        e = np.asarray(e, dtype=np.float64)
        if self.kind == "affine":
            return (e - self.b) / self.a
        if self.kind == "log":
            with np.errstate(over="ignore"):
                return (np.exp((e - self.b) / self.a) - self.c) / self.s
        # lo − eps + (hi − lo + 2 eps)·sigmoid((e − b)/a), sigmoid(t) = 1/(1 + e^{−t})
        t = (e - self.b) / self.a
        with np.errstate(over="ignore"):
            sig = 1.0 / (1.0 + np.exp(-t))
        return self.lo - self.eps + (self.hi - self.lo + 2.0 * self.eps) * sig

    def standardized(self, x: np.ndarray) -> "Encoding":
        """The same map followed by the affine map that gives the encoded sample x zero mean
        and unit variance (parameters rounded to 9 digits, as stored)."""
        e = self.encode(x)
        mean, std = float(np.mean(e)), float(np.std(e))
        # Relative: the std of one value repeated is rounding noise (~1e-16), not a spread.
        if not (math.isfinite(mean) and std > 1e-12 * max(1.0, abs(mean))):
            raise ValueError("cannot standardize an encoding on constant or non-finite data")
        a = round9(self.a / std)
        b = round9((self.b - mean) / std)
        return Encoding(self.kind, a, b, self.s, self.c, self.lo, self.hi, self.eps)

    # -- JSON ----------------------------------------------------------------------------
    def to_json(self) -> dict:
        out = {"kind": self.kind, "a": round9(self.a), "b": round9(self.b)}
        if self.kind == "log":
            out.update(s=round9(self.s), c=round9(self.c))
        elif self.kind == "logit":
            out.update(lo=round9(self.lo), hi=round9(self.hi), eps=round9(self.eps))
        return out

    @staticmethod
    def from_json(obj) -> "Encoding":
        if not isinstance(obj, dict) or "kind" not in obj:
            raise ValueError("an encoding must be an object with a 'kind'")
        kind = obj["kind"]
        if kind not in ENCODING_KINDS:
            raise ValueError(f"unknown encoding kind {kind!r} "
                             f"(allowed: {', '.join(ENCODING_KINDS)})")
        params = dict(_ENCODING_DEFAULTS[kind])
        for key, value in obj.items():
            if key == "kind":
                continue
            if key not in params:
                raise ValueError(f"unknown parameter {key!r} of a {kind!r} encoding")
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise ValueError(f"encoding parameter {key!r} must be a number")
            params[key] = float(value)
        return Encoding(kind, **params)


@dataclass(frozen=True)
class ModelSpec:
    """One CVAE: its conditions and outputs (in order), latent size and hidden width."""

    name: str  # "LengthGen", ...
    file_stem: str  # "lengthgen", ...
    conditions: tuple[str, ...]
    outputs: tuple[str, ...]
    latent_dim: int
    width: int
    depth: int = 2  # hidden layers

    @property
    def input_width(self) -> int:
        """len(conditions) + latent_dim rounded up to a multiple of 4."""
        return -(-(len(self.conditions) + self.latent_dim) // 4) * 4


# Paper Table 1: depth 2, widths 8 / 16 / 16, latent 2 / 5 / 5.
LENGTHGEN = ModelSpec("LengthGen", "lengthgen", ("sigma", "g"), ("N",), latent_dim=2, width=8)
PATHGEN = ModelSpec("PathGen", "pathgen", ("sigma", "g", "N"), ("cos_theta", "alpha", "beta"),
                    latent_dim=5, width=16)
EVENTGEN = ModelSpec("EventGen", "eventgen",
                     ("sigma", "g", "phi", "N", "cos_theta", "alpha", "beta"),
                     ("X_x", "X_y", "X_z", "W_x", "W_y", "W_z"), latent_dim=5, width=16)
SPECS = (LENGTHGEN, PATHGEN, EVENTGEN)
# Steps in a sphere cut by a plane (docs/learning.md, "Learned cut sphere steps"; issue 26).
# h is the plane's distance from the centre in radii, mu0 the arriving direction's cosine to
# the plane's normal. The exit point seen from the centre is (sin, 0, cos_p) turned by
# cos_psi about +z (mirrored to y >= 0: the problem is symmetric in y); the exit direction
# is alpha t + beta b + sqrt(1 - alpha^2 - beta^2) n in the exit surface's frame
# (sssphere.learn.cut.exit_frame).
CUT_LENGTHGEN = ModelSpec("CutLengthGen", "cutlengthgen", ("sigma", "g", "h", "mu0"), ("N",),
                          latent_dim=2, width=16)
CUT_PATHGEN = ModelSpec("CutPathGen", "cutpathgen", ("sigma", "g", "h", "mu0", "N"),
                        ("cos_p", "cos_psi", "alpha", "beta"), latent_dim=5, width=32)
CUT_SPECS = (CUT_LENGTHGEN, CUT_PATHGEN)
SPECS_BY_NAME = {s.name: s for s in SPECS + CUT_SPECS}

# The fixed part of each variable's encoding (before standardization). ε keeps the logs
# finite at the ends of the ranges and sets the finest scale they resolve.
COS_THETA_EPS = 1e-4
DIRECTION_EPS = 1e-3  # alpha, beta
PHI_EPS = 1e-6
SIGMA_C = 0.5
_COMMON = {
    "sigma": Encoding("log", s=1.0, c=SIGMA_C),  # ln(σ + 0.5): σ = 0 allowed
    "g": Encoding("log", s=-1.0, c=1.0),  # ln(1 − g): ln σ + ln(1 − g) = ln of the reduced σ
    "phi": Encoding("log", s=-1.0, c=1.0 + PHI_EPS),  # ln(1 − φ + ε)
    "N": Encoding("log", s=1.0, c=-1.0),  # ln(N − 1): N ≥ 2 (N = 1 is outside the domain)
    # X, W: affine. i.i.d. Gaussian components, normalized, are uniform on the sphere, so the
    # decoder's Gaussian followed by W ← W/|W| is a projected normal, the natural family for W
    # (a logit encoding of W's components was much worse).
    **{f"{v}_{k}": Encoding("affine") for v in "XW" for k in "xyz"},
    # Cut sphere conditions: h in (0, 1], mu0 in [-1, 1] through logits (ε = 1e-3).
    "h": Encoding("logit", lo=0.0, hi=1.0, eps=1e-3),
    "mu0": Encoding("logit", eps=1e-3),
    "cos_p": Encoding("logit", eps=COS_THETA_EPS),
    "cos_psi": Encoding("logit", eps=DIRECTION_EPS),
}
# The shipped choice: bounded variables through `logit` (docs/model-format.md). A uniform
# variable on [−1, 1] becomes logistic (nearly Gaussian), a peak at an end is stretched.
BASE_ENCODINGS = {
    **_COMMON,
    "cos_theta": Encoding("logit", eps=COS_THETA_EPS),
    "alpha": Encoding("logit", eps=DIRECTION_EPS),
    "beta": Encoding("logit", eps=DIRECTION_EPS),
}
# The same with the first version's kinds only (affine, log): measurably worse PathGen
# (docs/learning.md), kept for readers that do not know `logit`.
PLAIN_ENCODINGS = {
    **_COMMON,
    "cos_theta": Encoding("log", s=-1.0, c=1.0 + COS_THETA_EPS),  # ln(1 − cos θ + ε)
    "alpha": Encoding("affine"),
    "beta": Encoding("affine"),
}
ENCODING_SETS = {"logit": BASE_ENCODINGS, "plain": PLAIN_ENCODINGS}
