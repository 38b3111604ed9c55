"""A NumPy reference decoder for the model files of docs/model-format.md.

    dec = load_decoder("models/pathgen.json")
    mean, logvar = dec.evaluate(x)                         # x: (batch, dec.input_width)
    out = dec.sample({"sigma": s, "g": g, "N": n}, rng)    # dict of post-processed outputs

    sampler = SphereSampler.from_dir("models/")
    walks = sampler.sample(sigma=20.0, g=0.4, albedo=0.99, n=10_000, rng=rng)

`SphereSampler.sample` returns the keys of `sssphere.sphere_walks` (N, cos_theta, alpha, beta,
X, W): N = 1 sampled exactly with probability e^{−σ}, the networks for N ≥ 2; the
representative event is the first one (X = 0, W = +z) with its exact probability
(1 − φ)/(1 − φ^N), EventGen's otherwise. The network is
evaluated in float32 like PyTorch, onnxruntime and the C++ decoders; encodings and
post-processing in float64.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from sssphere._files import missing_input
from sssphere.learn.spec import (FORMAT, FORMAT_VERSION, NOTATION_VERSION, SPECS_BY_NAME,
                                 Encoding)

TOP_LEVEL_KEYS = {"format", "format_version", "notation_version", "name", "conditions",
                  "latent_dim", "input_width", "layers", "outputs", "training", "metrics"}
OPTIONAL_TOP_LEVEL_KEYS = {"metrics"}
LAYER_KEYS = {"in", "out", "activation", "weight", "bias"}
RANGED_CONDITIONS = ("sigma", "g", "phi", "h", "mu0")  # checked against training[...] = [lo, hi]


class ModelFileError(ValueError):
    """A model file is missing, unreadable, of another format or version, or inconsistent."""


def _softplus(x: np.ndarray) -> np.ndarray:
    return np.logaddexp(np.float32(0.0), x)


class NumpyDecoder:
    """One decoder read from a model file (validated against the contract)."""

    def __init__(self, obj: dict, path: str = "<memory>"):
        self.path = str(path)
        self._validate(obj)
        self.name = obj["name"]
        self.spec = SPECS_BY_NAME[self.name]
        self.condition_names = [c["name"] for c in obj["conditions"]]
        self.output_names = [o["name"] for o in obj["outputs"]]
        self.condition_encodings = [Encoding.from_json(c["encode"]) for c in obj["conditions"]]
        self.output_encodings = [Encoding.from_json(o["encode"]) for o in obj["outputs"]]
        self.latent_dim = int(obj["latent_dim"])
        self.input_width = int(obj["input_width"])
        self.weights = [np.asarray(layer["weight"], dtype=np.float32) for layer in obj["layers"]]
        self.biases = [np.asarray(layer["bias"], dtype=np.float32) for layer in obj["layers"]]
        self.activations = [layer["activation"] for layer in obj["layers"]]
        self.training = obj["training"]
        self.metrics = obj.get("metrics", {})
        self.ranges = {k: (float(self.training[k][0]), float(self.training[k][1]))
                       for k in RANGED_CONDITIONS if k in self.condition_names}

    def __repr__(self) -> str:
        sizes = " → ".join([str(self.input_width)] + [str(w.shape[0]) for w in self.weights])
        return f"NumpyDecoder({self.name}: {sizes}, latent {self.latent_dim}, {self.path})"

    # -- validation ----------------------------------------------------------------------
    def _fail(self, message: str):
        raise ModelFileError(f"{self.path}: {message}")

    def _validate(self, obj) -> None:
        if not isinstance(obj, dict):
            self._fail("the top level must be a JSON object")
        fmt = obj.get("format")
        if fmt != FORMAT:
            self._fail(f"format is {fmt!r}, expected {FORMAT!r}")
        ver = obj.get("format_version")
        if ver != FORMAT_VERSION:
            self._fail(f"format_version is {ver!r}; this reader understands format_version "
                       f"{FORMAT_VERSION} only")
        if obj.get("notation_version") != NOTATION_VERSION:
            self._fail(f"notation_version is {obj.get('notation_version')!r}; expected "
                       f"{NOTATION_VERSION}")
        missing = sorted(TOP_LEVEL_KEYS - OPTIONAL_TOP_LEVEL_KEYS - set(obj))
        if missing:
            self._fail(f"missing field(s) {', '.join(missing)}")
        unknown = sorted(set(obj) - TOP_LEVEL_KEYS)
        if unknown:
            self._fail(f"unknown field(s) {', '.join(unknown)}")
        spec = SPECS_BY_NAME.get(obj["name"])
        if spec is None:
            self._fail(f"unknown model name {obj['name']!r} (allowed: {', '.join(SPECS_BY_NAME)})")
        for field, want in (("conditions", spec.conditions), ("outputs", spec.outputs)):
            items = obj[field]
            if not isinstance(items, list) or not all(isinstance(i, dict) for i in items):
                self._fail(f"{field} must be a list of objects")
            names = tuple(i.get("name") for i in items)
            if names != want:
                self._fail(f"{spec.name} {field} are {list(names)}, expected {list(want)}")
            for item in items:
                if set(item) != {"name", "encode"}:
                    self._fail(f"{field} entry {item.get('name')!r} must have exactly 'name' and "
                               f"'encode'")
                try:
                    Encoding.from_json(item["encode"])
                except ValueError as e:
                    self._fail(f"encoding of {item['name']!r}: {e}")
        latent = obj["latent_dim"]
        if not isinstance(latent, int) or isinstance(latent, bool) or latent < 1:
            self._fail(f"latent_dim must be a positive integer, got {latent!r}")
        width = obj["input_width"]
        expected_width = -(-(len(spec.conditions) + latent) // 4) * 4
        if width != expected_width:
            self._fail(f"input_width is {width!r}, expected {expected_width} "
                       f"(len(conditions) + latent_dim rounded up to a multiple of 4)")
        layers = obj["layers"]
        if not isinstance(layers, list) or not layers:
            self._fail("layers must be a non-empty list")
        n_in = width
        for i, layer in enumerate(layers):
            where = f"layers[{i}]"
            if not isinstance(layer, dict) or set(layer) != LAYER_KEYS:
                self._fail(f"{where} must have exactly the fields in, out, activation, weight, "
                           f"bias")
            if layer["in"] != n_in:
                self._fail(f"{where}.in is {layer['in']!r}, expected {n_in}")
            n_out = layer["out"]
            if not isinstance(n_out, int) or isinstance(n_out, bool) or n_out < 1:
                self._fail(f"{where}.out must be a positive integer")
            last = i == len(layers) - 1
            want_act = "identity" if last else "softplus"
            if layer["activation"] != want_act:
                self._fail(f"{where}.activation is {layer['activation']!r}, expected {want_act!r}")
            try:
                w = np.asarray(layer["weight"], dtype=np.float64)
                b = np.asarray(layer["bias"], dtype=np.float64)
            except (ValueError, TypeError):
                self._fail(f"{where}: weight and bias must be (nested) lists of numbers")
            if w.shape != (n_out, n_in):
                self._fail(f"{where}.weight has shape {w.shape}, expected ({n_out}, {n_in}) "
                           f"(out rows of in numbers)")
            if b.shape != (n_out,):
                self._fail(f"{where}.bias has shape {b.shape}, expected ({n_out},)")
            if not (np.all(np.isfinite(w)) and np.all(np.isfinite(b))):
                self._fail(f"{where} has non-finite numbers")
            n_in = n_out
        if n_in != 2 * len(spec.outputs):
            self._fail(f"the last layer has {n_in} outputs, expected 2 x {len(spec.outputs)} "
                       f"(means, then log-variances)")
        training = obj["training"]
        if not isinstance(training, dict):
            self._fail("training must be an object")
        for key in RANGED_CONDITIONS:
            if key in spec.conditions:
                r = training.get(key)
                if (not isinstance(r, list) or len(r) != 2
                        or not all(isinstance(v, (int, float)) and math.isfinite(v) for v in r)
                        or r[0] > r[1]):
                    self._fail(f"training.{key} must be a range [lo, hi], got {r!r}")
        if "metrics" in obj and not isinstance(obj["metrics"], dict):
            self._fail("metrics must be an object")

    # -- evaluation ----------------------------------------------------------------------
    def evaluate(self, x) -> tuple[np.ndarray, np.ndarray]:
        """The network on encoded input vectors.

        Parameters
        ----------
        x : array (batch, input_width): [encoded conditions, z, zeros].

        Returns
        -------
        mean, logvar : float32 arrays (batch, len(outputs)) of the encoded outputs.
        """
        x = np.asarray(x, dtype=np.float32)
        if x.ndim != 2 or x.shape[1] != self.input_width:
            raise ValueError(f"{self.name}: x must have shape (batch, {self.input_width}), "
                             f"got {x.shape}")
        h = x
        for w, b, act in zip(self.weights, self.biases, self.activations):
            h = h @ w.T + b
            if act == "softplus":
                h = _softplus(h)
        k = len(self.output_names)
        return h[:, :k], h[:, k:]

    def encode_conditions(self, conditions) -> np.ndarray:
        """Encoded conditions (batch, len(conditions)), float64, after checking them.

        conditions: a mapping name → scalar or (batch,) array (broadcast together), or an array
        (batch, len(conditions)) in the order of the file. Raises ValueError for a wrong shape,
        a non-finite value, a value outside the domain of its encoding, outside the training
        range (σ, g, φ) or N < 2.
        """
        names = self.condition_names
        if isinstance(conditions, dict):
            missing = [n for n in names if n not in conditions]
            unknown = [n for n in conditions if n not in names]
            if missing or unknown:
                raise ValueError(f"{self.name} conditions are {names}; missing {missing}, "
                                 f"unknown {unknown}")
            try:
                cols = np.broadcast_arrays(*[np.asarray(conditions[n], dtype=np.float64)
                                             for n in names])
            except ValueError:
                shapes = [np.shape(conditions[n]) for n in names]
                raise ValueError(f"{self.name}: condition shapes {shapes} do not broadcast") from None
            cols = [np.atleast_1d(c) for c in cols]
            if cols[0].ndim != 1:
                raise ValueError(f"{self.name}: conditions must be scalars or 1-D arrays, got "
                                 f"shape {cols[0].shape}")
            c = np.stack(cols, axis=1)
        else:
            c = np.asarray(conditions, dtype=np.float64)
            if c.ndim != 2 or c.shape[1] != len(names):
                raise ValueError(f"{self.name}: conditions must have shape (batch, {len(names)}) "
                                 f"({', '.join(names)}), got {c.shape}")
        out = np.empty_like(c)
        for j, (name, enc) in enumerate(zip(names, self.condition_encodings)):
            col = c[:, j]
            bad = ~enc.in_domain(col)
            if bad.any():
                raise ValueError(f"{self.name}: condition {name} = {float(col[bad][0])!r} is "
                                 f"outside the domain of its {enc.kind} encoding")
            if name in self.ranges:
                lo, hi = self.ranges[name]
                bad = (col < lo) | (col > hi)
                if bad.any():
                    raise ValueError(f"{self.name}: condition {name} = {float(col[bad][0])!r} is "
                                     f"outside the training range [{lo}, {hi}] of {self.path}")
            if name == "N" and np.any(col < 2):
                raise ValueError(f"{self.name}: condition N must be >= 2 (N = 1 is sampled "
                                 f"exactly, not by the networks)")
            out[:, j] = enc.encode(col)
        return out

    def sample(self, conditions, rng: np.random.Generator) -> dict:
        """Draw one output per row of conditions (see `encode_conditions`).

        Draws z ~ N(0, I) (batch, latent_dim) and then ε ~ N(0, I) (batch, len(outputs)) from
        rng, in that order; u = μ + e^{ℓ/2} ε; inverse encodings; post-processing of
        docs/model-format.md. Returns a dict output name → (batch,) array (N as int64).
        """
        c = self.encode_conditions(conditions)
        batch = c.shape[0]
        x = np.zeros((batch, self.input_width), dtype=np.float32)
        x[:, : c.shape[1]] = c
        n_c = c.shape[1]
        x[:, n_c: n_c + self.latent_dim] = rng.standard_normal((batch, self.latent_dim))
        mean, logvar = self.evaluate(x)
        eps = rng.standard_normal(mean.shape)
        u = mean.astype(np.float64) + np.exp(0.5 * logvar.astype(np.float64)) * eps
        values = {n: e.decode(u[:, i]) for i, (n, e) in enumerate(zip(self.output_names,
                                                                        self.output_encodings))}
        return postprocess(values)


def postprocess(values: dict) -> dict:
    """The post-processing rules of docs/model-format.md, for whichever outputs are present."""
    out = dict(values)
    if "N" in out:
        x = np.nan_to_num(out["N"], nan=2.0, posinf=np.iinfo(np.int64).max / 2)
        out["N"] = np.maximum(2, np.floor(np.minimum(x, 2.0 ** 62))).astype(np.int64)
    if "cos_theta" in out:
        out["cos_theta"] = np.clip(out["cos_theta"], -1.0, 1.0)
    if "alpha" in out and "beta" in out:
        a, b = out["alpha"], out["beta"]
        r = np.hypot(a, b)
        scale = np.where(r > 1.0, 1.0 / np.where(r > 1.0, r, 1.0), 1.0)
        out["alpha"], out["beta"] = a * scale, b * scale
    if "X_x" in out:
        X = np.stack([out["X_x"], out["X_y"], out["X_z"]], axis=1)
        r = np.linalg.norm(X, axis=1, keepdims=True)
        X = np.where(r > 1.0, X / np.where(r > 1.0, r, 1.0), X)
        out["X_x"], out["X_y"], out["X_z"] = X[:, 0], X[:, 1], X[:, 2]
    if "W_x" in out:
        W = np.stack([out["W_x"], out["W_y"], out["W_z"]], axis=1)
        r = np.linalg.norm(W, axis=1, keepdims=True)
        W = np.where(r > 0, W / np.where(r > 0, r, 1.0), np.array([0.0, 0.0, 1.0]))
        out["W_x"], out["W_y"], out["W_z"] = W[:, 0], W[:, 1], W[:, 2]
    return out


def load_decoder(path) -> NumpyDecoder:
    """Read and validate a model file; ModelFileError names the file and the problem."""
    path = Path(path)
    if not path.is_file():
        raise ModelFileError(f"{path}: {missing_input(path, 'model file')}")
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as e:
        raise ModelFileError(f"{path}: cannot read the model file ({e})") from None
    try:
        obj = json.loads(text)
    except json.JSONDecodeError as e:
        raise ModelFileError(f"{path}: not valid JSON ({e})") from None
    return NumpyDecoder(obj, path)


def _hg_sample_cos(g: np.ndarray, xi: np.ndarray) -> np.ndarray:
    """HG cos θ by inversion (docs/notation.md), isotropic for |g| < 1e-3."""
    iso = np.abs(g) < 1e-3
    gs = np.where(iso, 0.5, g)
    frac = (1.0 - gs * gs) / (1.0 - gs + 2.0 * gs * xi)
    cos = (1.0 + gs * gs - frac * frac) / (2.0 * gs)
    return np.clip(np.where(iso, 1.0 - 2.0 * xi, cos), -1.0, 1.0)


class SphereSampler:
    """A whole sphere step from the three decoders: N = 1 exactly, LengthGen, PathGen and
    (optionally) EventGen for N ≥ 2."""

    def __init__(self, lengthgen: NumpyDecoder, pathgen: NumpyDecoder,
                 eventgen: NumpyDecoder | None = None, tilt: dict | None = None):
        for dec, name in ((lengthgen, "LengthGen"), (pathgen, "PathGen"), (eventgen, "EventGen")):
            if dec is not None and dec.name != name:
                raise ValueError(f"{dec.path} holds {dec.name}, expected {name}")
        self.lengthgen, self.pathgen, self.eventgen = lengthgen, pathgen, eventgen
        self.tilt = tilt  # PathGen's forward-memory tilt (learn/tilt.py), or None

    @classmethod
    def from_dir(cls, directory, events: bool = True, tilt: bool = True) -> "SphereSampler":
        """The decoders of a model directory, and its tilt.json if it has one and `tilt`."""
        from sssphere.learn import tilt as tilt_file

        d = Path(directory)
        t = tilt_file.read(d / "tilt.json") if tilt and (d / "tilt.json").exists() else None
        return cls(load_decoder(d / "lengthgen.json"), load_decoder(d / "pathgen.json"),
                   load_decoder(d / "eventgen.json") if events else None, t)

    def sample(self, sigma, g, albedo, n: int, rng: np.random.Generator) -> dict:
        """n sphere steps; sigma, g, albedo scalars or (n,) arrays. Keys as
        `sssphere.sphere_walks` (X, W are X = 0, W = +z if there is no EventGen)."""
        sigma, g, albedo = (np.broadcast_to(np.asarray(v, dtype=np.float64), (n,)).copy()
                            for v in (sigma, g, albedo))
        # As the C++ ScatteringModel.sample checks them (a NaN albedo gave X = 0 everywhere).
        for name, bad, allowed in (
                ("sigma", ~(np.isfinite(sigma) & (sigma >= 0)), "sigma >= 0"),
                ("g", ~(np.abs(g) < 1), "-1 < g < 1"),
                ("phi", ~((albedo >= 0) & (albedo <= 1)), "0 <= phi <= 1")):
            if bad.any():
                i = int(np.flatnonzero(bad)[0])
                v = {"sigma": sigma, "g": g, "phi": albedo}[name][i]
                raise ValueError(f"{name}[{i}] = {v:g} is not allowed (allowed: {allowed})")
        one = rng.random(n) < np.exp(-sigma)  # P(N = 1) = e^{-σ}
        N = np.ones(n, dtype=np.int64)
        cos_theta = _hg_sample_cos(g, rng.random(n))
        alpha, beta = np.zeros(n), np.zeros(n)
        X = np.zeros((n, 3))
        W = np.tile([0.0, 0.0, 1.0], (n, 1))
        m = ~one
        if m.any():
            from sssphere.learn import tilt as tilt_file

            draw = np.flatnonzero(m)
            if self.tilt is not None:
                ta, tb = tilt_file.coefficients(self.tilt, sigma[draw], g[draw])
            for k in range(tilt_file.MAX_DRAWS if self.tilt is not None else 1):
                N[draw] = self.lengthgen.sample({"sigma": sigma[draw], "g": g[draw]}, rng)["N"]
                p = self.pathgen.sample({"sigma": sigma[draw], "g": g[draw], "N": N[draw]}, rng)
                cos_theta[draw], alpha[draw], beta[draw] = p["cos_theta"], p["alpha"], p["beta"]
                if self.tilt is None or k + 1 == tilt_file.MAX_DRAWS:
                    break
                # the tilt keeps a step with its acceptance and draws the others again
                again = rng.random(draw.size) >= tilt_file.acceptance(
                    cos_theta[draw], alpha[draw], beta[draw], ta, tb)
                draw, ta, tb = draw[again], ta[again], tb[again]
                if draw.size == 0:
                    break
            if self.eventgen is not None:
                # The first event is the representative one with probability
                # φ / Σ_{j≤N} φ^j = (1 − φ)/(1 − φ^N) (1/N for φ = 1): X = 0, W = +z exactly.
                # EventGen models the events k ≥ 2 (docs/model-format.md).
                phi, n_m = albedo[m], N[m].astype(np.float64)
                with np.errstate(divide="ignore", invalid="ignore"):
                    p_first = np.where(phi >= 1.0, 1.0 / n_m,
                                       (1.0 - phi) / -np.expm1(n_m * np.log(phi)))
                p_first = np.where(phi <= 0.0, 1.0, p_first)
                later = np.flatnonzero(m)[rng.random(n_m.size) >= p_first]
                if later.size:
                    e = self.eventgen.sample({"sigma": sigma[later], "g": g[later],
                                              "phi": albedo[later], "N": N[later],
                                              "cos_theta": cos_theta[later],
                                              "alpha": alpha[later], "beta": beta[later]}, rng)
                    X[later] = np.stack([e["X_x"], e["X_y"], e["X_z"]], axis=1)
                    W[later] = np.stack([e["W_x"], e["W_y"], e["W_z"]], axis=1)
        return {"N": N, "cos_theta": cos_theta, "alpha": alpha, "beta": beta, "X": X, "W": W}
