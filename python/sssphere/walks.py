"""Ground truth for the learned models: random walks in the canonical unit sphere.

See docs/notation.md ("The canonical sphere problem"): a photon starts at the centre travelling
+z, scatters there (the first event counts) and alternates Henyey-Greenstein scattering with
exponential flights of optical radius ``sigma_t`` until it leaves the sphere. ``cut_sphere_walks``
is the same walk in the sphere cut by a plane ("The cut sphere problem"), the ground truth for a
step near a flat boundary (issue 26; its models: `sssphere.learn.cut`).
"""

from __future__ import annotations

import time
from typing import Optional, Union

import numpy as np

from sssphere import _core

#: Largest optical radius accepted: the mean number of events grows as sigma_t² (1 − g) / 2.
MAX_SIGMA_T = 1000.0

ArrayLike = Union[float, np.ndarray, list]


def _param(name: str, value: ArrayLike, n: int, lo: float, hi: float, closed_hi: bool) -> np.ndarray:
    a = np.asarray(value, dtype=np.float64)
    if a.ndim > 1 or (a.ndim == 1 and a.shape[0] != n):
        raise ValueError(f"{name} must be a scalar or an array of length n = {n}, got shape {a.shape}")
    a = a.reshape(-1)
    bad = ~np.isfinite(a) | (a < lo) | ((a > hi) if closed_hi else (a >= hi))
    if name == "g":
        bad |= a <= -1.0
    if bad.any():
        i = int(np.argmax(bad))
        allowed = f"{lo} <= {name} {'<=' if closed_hi else '<'} {hi}"
        if name == "g":
            allowed = "-1 < g < 1"
        raise ValueError(f"{name}[{i}] = {a[i].item()!r} is out of range (allowed: {allowed})")
    return a.astype(np.float32)


# The largest value of each integer argument: seeds and indices are 64-bit in C++ (the
# streams are numbered by them); a walk's results take 64 bytes, so 2^31 walks are 128 GiB.
_MOST = {"seed": 2**64 - 1, "first_index": 2**64 - 1, "n": 2**31 - 1, "threads": 4096}


def _count(name: str, v, lo: int) -> int:
    """An integer argument from lo to _MOST[name] (threads: 0 = all cores)."""
    hi = _MOST[name]
    if (isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < lo
            or v > hi):
        note = " (0 = all cores)" if name == "threads" else ""
        shown = "2^64 - 1" if hi == 2**64 - 1 else f"{hi:,}"
        raise ValueError(f"{name} must be an integer from {lo} to {shown}{note}, got {v!r}")
    return int(v)


def sphere_walks(
    sigma_t: ArrayLike,
    g: ArrayLike,
    albedo: ArrayLike,
    n: int,
    seed: int = 0,
    threads: Optional[int] = None,
    first_index: int = 0,
    ray_address: Optional[str] = None,
) -> dict:
    """Simulate ``n`` walks in the unit sphere (C++, multithreaded).

    Parameters
    ----------
    sigma_t, g, albedo : float or (n,) arrays
        Optical radius σ = σt·r in [0, 1000], HG anisotropy in (−1, 1), albedo φ in [0, 1].
    n : int >= 1
    seed : int >= 0
        Walk i uses the random stream (seed, first_index + i): results do not depend on
        ``threads`` or on how a large set is split into calls.
    threads : int, optional
        Worker threads (None or 0: all cores).
    ray_address : str, optional
        Simulate on this Ray cluster (``"auto"``, ``"HOST:PORT"``; docs/cluster.md), in
        tasks of ``sssphere.cluster.WALK_CHUNK`` walks of one thread each: the same walks,
        bit for bit. Ctrl-C cancels the tasks and raises KeyboardInterrupt.

    Returns
    -------
    dict of numpy arrays, in the exit frame:
        ``N`` (n,) int64 >= 1 scattering events (the centre counts),
        ``cos_theta`` (n,) exit point's z, ``alpha``, ``beta`` (n,) exit direction along b and t,
        ``X`` (n, 3) representative event position, ``W`` (n, 3) direction arriving at it.
    """
    n = _count("n", n, 1)
    seed, first_index = _count("seed", seed, 0), _count("first_index", first_index, 0)
    if first_index + n - 1 > _MOST["first_index"]:
        raise ValueError(f"first_index + n - 1 = {first_index + n - 1} is past 2^64 - 1 (the "
                         "walks' stream numbers)")
    threads = _count("threads", 0 if threads is None else threads, 0)
    s = _param("sigma_t", sigma_t, n, 0.0, MAX_SIGMA_T, True)
    gg = _param("g", g, n, -1.0, 1.0, False)
    a = _param("albedo", albedo, n, 0.0, 1.0, True)
    if ray_address is not None:
        from sssphere.cluster import walks

        parts, interrupted = walks(s, gg, a, n, seed, first_index, ray_address)
        if interrupted:
            raise KeyboardInterrupt
        return {key: np.concatenate([p[key] for p in parts]) for key in parts[0]}
    return _in_parts(lambda k, i, *x: _core.sphere_walks(*x, k, seed, first_index + i, threads),
                     n, s, gg, a)


# Calls of C++ walks take about _PART_SECONDS each, between which Python sees Ctrl-C: a call
# of millions of dense walks ran for minutes deaf to it, and 65,536 walks at sigma_t = 1000
# (about 6 ms each on a thread) for six minutes. The first call takes _FIRST_PART walks and
# each next one as many as the last call's pace fits in _PART_SECONDS, at most 4 times as
# many (the parameters may get denser along the arrays).
_PART_SECONDS = 0.25
_FIRST_PART = 64
_MOST_PART = 1 << 20


def _in_parts(simulate, n: int, *arrays: np.ndarray) -> dict:
    """simulate(k, i, parts of arrays) for walks i .. i + k - 1 over the n walks, in calls
    of about _PART_SECONDS each; the results concatenated. Walk i's stream is (seed,
    first_index + i) however the walks are split, so the results do not depend on it."""
    parts, i, size = [], 0, _FIRST_PART
    while i < n:
        k = min(size, n - i)
        start = time.perf_counter()
        parts.append(simulate(k, i, *(x if x.shape[0] == 1 else x[i:i + k] for x in arrays)))
        took = time.perf_counter() - start
        i += k
        size = int(min(4 * k, _MOST_PART, max(1.0, k * _PART_SECONDS / max(took, 1e-9))))
    if len(parts) == 1:
        return parts[0]
    return {key: np.concatenate([p[key] for p in parts]) for key in parts[0]}


def cut_sphere_walks(
    sigma_t: ArrayLike,
    g: ArrayLike,
    h: ArrayLike,
    mu0: ArrayLike,
    albedo: ArrayLike,
    n: int,
    seed: int = 0,
    threads: Optional[int] = None,
    first_index: int = 0,
) -> dict:
    """Simulate ``n`` walks in the unit sphere cut by the plane z = h (C++, multithreaded).

    The medium is the part z < h. The photon arrived at the centre travelling
    (sqrt(1 − mu0²), 0, mu0) and scatters there (the first event counts); it walks until a
    flight leaves the region, through the plane (the boundary) or through the cap.

    Parameters
    ----------
    sigma_t, g, albedo : float or (n,) arrays
        As for :func:`sphere_walks`.
    h : float or (n,) array
        The plane's distance from the centre in radii, > 0 (h >= 1: no cut).
    mu0 : float or (n,) array
        Cosine between the arriving direction and the plane's normal +z, in [−1, 1].
    n, seed, threads, first_index
        As for :func:`sphere_walks` (the same random streams).

    Returns
    -------
    dict of numpy arrays, in the walk's frame (the plane's normal +z, the arriving direction
    in the x-z plane): ``N`` (n,) int64 >= 1, ``through_plane`` (n,) uint8 (1: left through
    the plane), ``exit_pos`` and ``exit_dir`` (n, 3), ``X`` and ``W`` (n, 3) the
    representative event and the direction arriving at it.
    """
    n = _count("n", n, 1)
    seed, first_index = _count("seed", seed, 0), _count("first_index", first_index, 0)
    threads = _count("threads", 0 if threads is None else threads, 0)
    s = _param("sigma_t", sigma_t, n, 0.0, MAX_SIGMA_T, True)
    gg = _param("g", g, n, -1.0, 1.0, False)
    hh = _param("h", h, n, 0.0, np.inf, False)
    if (hh <= 0).any():
        i = int(np.argmax(hh <= 0))
        raise ValueError(f"h[{i}] = {hh[i].item()!r} is out of range (allowed: h > 0)")
    m0 = _param("mu0", mu0, n, -1.0, 1.0, True)
    a = _param("albedo", albedo, n, 0.0, 1.0, True)
    return _in_parts(lambda k, i, *x: _core.cut_sphere_walks(*x, k, seed, first_index + i,
                                                             threads),
                     n, s, gg, hh, m0, a)
