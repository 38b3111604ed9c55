"""A plain NumPy simulation of the canonical sphere problem (docs/notation.md, "The canonical sphere problem").

It is the test oracle for the C++ generator `sssphere.sphere_walks` (same signature, same
keys) and the training-data source of the learning tests; `reference_cut_sphere_walks` is the
oracle of `sssphere.walks.cut_sphere_walks` (the sphere cut by a plane, "The cut sphere
problem"). Written for clarity first: all walks
advance together one scattering event per loop iteration, and finished walks are dropped from
the working arrays so that long walks do not drag the short ones along.
"""

from __future__ import annotations

import numpy as np

HG_ISOTROPIC_G = 1e-3  # |g| below this is sampled isotropically (notation.md, kHgIsotropicG)


def _per_walk(value, n: int, name: str) -> np.ndarray:
    arr = np.asarray(value, dtype=np.float64)
    if arr.ndim == 0:
        return np.full(n, float(arr))
    if arr.shape != (n,):
        raise ValueError(f"{name} must be a scalar or have shape ({n},), got {arr.shape}")
    return arr.copy()


def hg_sample_cos(g: np.ndarray, xi: np.ndarray) -> np.ndarray:
    """cos θ = ω·ω′ sampled from Henyey–Greenstein by inversion (notation.md), clamped."""
    iso = np.abs(g) < HG_ISOTROPIC_G
    gs = np.where(iso, 0.5, g)  # any value away from 0 for the lanes computed but not used
    frac = (1.0 - gs * gs) / (1.0 - gs + 2.0 * gs * xi)
    cos = (1.0 + gs * gs - frac * frac) / (2.0 * gs)
    return np.clip(np.where(iso, 1.0 - 2.0 * xi, cos), -1.0, 1.0)


def _scatter(d: np.ndarray, g: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """New unit directions around the unit directions d (n, 3), HG in cos, uniform azimuth."""
    n = d.shape[0]
    cos = hg_sample_cos(g, rng.random(n))
    sin = np.sqrt(np.maximum(0.0, 1.0 - cos * cos))
    phi = 2.0 * np.pi * rng.random(n)
    # An orthonormal frame (s, t, d) around d (Duff et al. 2017, "Building an Orthonormal
    # Basis, Revisited").
    x, y, z = d[:, 0], d[:, 1], d[:, 2]
    sign = np.where(z >= 0.0, 1.0, -1.0)
    a = -1.0 / (sign + z)
    b = x * y * a
    s = np.stack([1.0 + sign * x * x * a, sign * b, -sign * x], axis=1)
    t = np.stack([b, sign + y * y * a, -y], axis=1)
    out = (sin * np.cos(phi))[:, None] * s + (sin * np.sin(phi))[:, None] * t + cos[:, None] * d
    return out / np.linalg.norm(out, axis=1, keepdims=True)


def _walks(sigma, g, albedo, n: int, seed: int, h, mu0):
    """The walks of both problems in their common frame: the sphere cut by the plane z = h
    (h >= 1: whole), the photon arriving at the centre along (√(1 − μ0²), 0, μ0). Returns N,
    whether the walk left through the plane, the exit point and direction, X and W."""
    n = int(n)
    sigma = _per_walk(sigma, n, "sigma")
    g = _per_walk(g, n, "g")
    albedo = _per_walk(albedo, n, "albedo")
    h = _per_walk(h, n, "h")
    mu0 = _per_walk(mu0, n, "mu0")
    if np.any(~(h > 0)):
        raise ValueError("h must be > 0")
    if np.any(~(np.abs(mu0) <= 1)):
        raise ValueError("mu0 must lie in [-1, 1]")
    if np.any(~np.isfinite(sigma)) or np.any(sigma < 0):
        raise ValueError("sigma must be finite and >= 0")
    if np.any(~(np.abs(g) < 1)):
        raise ValueError("g must lie in (-1, 1)")
    if np.any(~((albedo >= 0) & (albedo <= 1))):
        raise ValueError("albedo must lie in [0, 1]")
    rng = np.random.default_rng(seed)

    N_out = np.ones(n, dtype=np.int64)
    exit_pos = np.zeros((n, 3))
    exit_dir = np.zeros((n, 3))
    through_out = np.zeros(n, dtype=bool)
    arrive = np.stack([np.sqrt(np.maximum(0.0, 1.0 - mu0 * mu0)), np.zeros(n), mu0], axis=1)
    X_out = np.zeros((n, 3))
    W_out = arrive.copy()

    # Working state of the walks still inside. Event 1 is at the centre with arrival +z;
    # the reservoir holds it with weight sum S = φ^0 (weights are φ^k / φ, which does not
    # change the choice and stays finite for φ = 0: 0**0 = 1).
    idx = np.arange(n)
    pos = np.zeros((n, 3))
    d = _scatter(arrive, g, rng)
    count = np.ones(n, dtype=np.int64)
    w_k = np.ones(n)  # φ^(k-1) for the current event k
    w_sum = np.ones(n)  # Σ_{j≤k} φ^(j-1)
    res_X = np.zeros((n, 3))
    res_W = arrive.copy()
    sig, gg, phi, hh = sigma, g, albedo, h

    with np.errstate(divide="ignore"):
        while idx.size:
            m = idx.size
            # Free flight: t = -ln(1 - ξ)/σ (σ = 0: infinite).
            t = -np.log1p(-rng.random(m)) / sig
            # Distance to the sphere along d from pos (|pos| < 1): the positive root of
            # |pos + s d| = 1.
            pd = np.einsum("ij,ij->i", pos, d)
            pp = np.einsum("ij,ij->i", pos, pos)
            s_ball = -pd + np.sqrt(np.maximum(0.0, pd * pd + 1.0 - pp))
            # And to the plane z = h, moving up (the cut sphere; h >= 1: never first).
            up = d[:, 2] > 0.0
            s_plane = np.where(up, (hh - pos[:, 2]) / np.where(up, d[:, 2], 1.0), np.inf)
            plane = s_plane < s_ball
            s_exit = np.minimum(s_ball, s_plane)
            leaves = t >= s_exit
            if np.any(leaves):
                j = idx[leaves]
                p_exit = pos[leaves] + s_exit[leaves, None] * d[leaves]
                on_plane = plane[leaves]
                through_out[j] = on_plane
                p_exit[on_plane, 2] = hh[leaves][on_plane]
                ball = ~on_plane
                p_exit[ball] /= np.linalg.norm(p_exit[ball], axis=1, keepdims=True)
                exit_pos[j] = p_exit
                exit_dir[j] = d[leaves]
                N_out[j] = count[leaves]
                X_out[j] = res_X[leaves]
                W_out[j] = res_W[leaves]
                keep = ~leaves
                idx, pos, d, t = idx[keep], pos[keep], d[keep], t[keep]
                count, w_k, w_sum = count[keep], w_k[keep], w_sum[keep]
                res_X, res_W = res_X[keep], res_W[keep]
                sig, gg, phi, hh = sig[keep], gg[keep], phi[keep], hh[keep]
                if not idx.size:
                    break
            # A scattering event inside: event k = count + 1, arriving along d.
            pos = pos + t[:, None] * d
            count = count + 1
            w_k = w_k * phi
            w_sum = w_sum + w_k
            take = rng.random(idx.size) * w_sum < w_k  # probability w_k / w_sum
            res_X[take] = pos[take]
            res_W[take] = d[take]
            d = _scatter(d, gg, rng)

    return N_out, through_out, exit_pos, exit_dir, X_out, W_out


def reference_sphere_walks(sigma, g, albedo, n: int, seed: int = 0) -> dict:
    """Simulate n walks of the canonical sphere problem.

    Parameters
    ----------
    sigma, g, albedo : float or array of shape (n,)
        Optical radius σ = σt·r (≥ 0), HG anisotropy (|g| < 1) and single-scattering albedo
        φ ∈ [0, 1] (it only weights the choice of the representative event).
    n : int
        Number of walks.
    seed : int
        Seed of the NumPy generator; the result is a deterministic function of the arguments.

    Returns
    -------
    dict with
        ``N`` (n,) int64: scattering events, N ≥ 1 (the first is at the centre);
        ``cos_theta``, ``alpha``, ``beta`` (n,) float64: exit point x̂ = (sin θ, 0, cos θ) and
        exit direction ω = α b + β t + √(1 − α² − β²) n in the exit frame
        (n = x̂, b = ŷ, t = (cos θ, 0, −sin θ));
        ``X``, ``W`` (n, 3) float64: the representative event, chosen among events 1..N with
        probability φ^k / Σ_j φ^j, its position and the direction arriving at it, in the exit
        frame (event 1: X = 0, W = +z).
    """
    N_out, _, exit_pos, exit_dir, X_out, W_out = _walks(sigma, g, albedo, n, seed, 2.0, 1.0)
    # The exit frame: rotate about z by -ψ, ψ the azimuth of the exit point, so that the exit
    # point lies in the half-plane y = 0, x ≥ 0 (at the poles ψ = atan2(0, ±0), fixed).
    psi = np.arctan2(exit_pos[:, 1], exit_pos[:, 0])
    c, s = np.cos(psi), np.sin(psi)

    def rotate(v: np.ndarray) -> np.ndarray:
        return np.stack([c * v[:, 0] + s * v[:, 1], -s * v[:, 0] + c * v[:, 1], v[:, 2]], axis=1)

    x_hat = rotate(exit_pos)
    cos_theta = np.clip(x_hat[:, 2], -1.0, 1.0)
    sin_theta = np.hypot(exit_pos[:, 0], exit_pos[:, 1])  # = x_hat[:, 0] up to rounding
    omega = rotate(exit_dir)
    alpha = omega[:, 1]
    beta = omega[:, 0] * cos_theta - omega[:, 2] * sin_theta
    # N = 1 leaves radially (from the centre): α = β = 0 exactly, not rounding noise around it.
    radial = N_out == 1
    alpha[radial] = 0.0
    beta[radial] = 0.0
    return {
        "N": N_out,
        "cos_theta": cos_theta,
        "alpha": alpha,
        "beta": beta,
        "X": rotate(X_out),
        "W": rotate(W_out),
    }


def reference_cut_sphere_walks(sigma, g, h, mu0, albedo, n: int, seed: int = 0) -> dict:
    """Simulate n walks of the cut sphere problem (docs/notation.md, "The cut sphere problem"):
    the oracle of `sssphere.walks.cut_sphere_walks` (same keys, float64), in the walk's frame
    (the plane z = h, the arriving direction (√(1 − μ0²), 0, μ0))."""
    N, through, exit_pos, exit_dir, X, W = _walks(sigma, g, albedo, n, seed, h, mu0)
    return {"N": N, "through_plane": through.astype(np.uint8), "exit_pos": exit_pos,
            "exit_dir": exit_dir, "X": X, "W": W}
