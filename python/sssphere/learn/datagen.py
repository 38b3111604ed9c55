"""Training data for the learned models: sphere walks over a documented sampling of (σ, g, φ).

The parameter sampling (also in docs/learning.md, "Training data"). Each sample draws, from
one NumPy generator seeded by ``seed``:

* σ (optical radius σt·r) from a mixture over [0, SIGMA_MAX]:
  10 % uniform on [0, 1], 50 % log-uniform on [1, 10] (where the paper's models failed:
  single and multiple scattering both matter), 40 % log-uniform on [10, SIGMA_MAX];
* g from a mixture over [−G_MAX, G_MAX]: 60 % uniform, 40 % strong anisotropy with |g|
  uniform on [0.6, G_MAX] and a random sign;
* φ from a mixture over [0, 1]: 30 % uniform, 60 % 1 − 10^(−u) with u uniform on [1, 5]
  (the albedos of real translucent materials, 0.9 to 0.99999), 10 % exactly 1.

Sample i is the walk ``sphere_walks(σ_i, g_i, φ_i, seed=seed, first_index=i)``, so a data set
is reproducible from (requested_samples, seed) whatever the thread count or chunking. The
draws depend on the requested count (each mixture draws all n values at once), so a file cut
short by Ctrl-C (meta ``"interrupted": true``) holds the first ``samples`` walks of the
requested_samples run, not the file a run of ``samples`` would make.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Callable, Optional

import numpy as np

from sssphere.learn.data import save_training_data
from sssphere.walks import sphere_walks

SIGMA_MAX = 200.0
G_MAX = 0.95
FORMAT_VERSION = 1  # of the parameter sampling below


def sample_parameters(n: int, seed: int = 0) -> dict:
    """(σ, g, φ) for n training walks, per the mixtures in the module docstring (float32)."""
    rng = np.random.default_rng([seed, 0x5353])
    u = rng.random(n)
    sigma = np.where(
        u < 0.1,
        rng.random(n),
        np.where(u < 0.6, 10.0 ** rng.random(n), 10.0 * (SIGMA_MAX / 10.0) ** rng.random(n)),
    )
    v = rng.random(n)
    strong = np.where(rng.random(n) < 0.5, -1.0, 1.0) * (0.6 + (G_MAX - 0.6) * rng.random(n))
    g = np.where(v < 0.6, G_MAX * (2.0 * rng.random(n) - 1.0), strong)
    w = rng.random(n)
    phi = np.where(w < 0.3, rng.random(n), np.where(w < 0.9, 1.0 - 10.0 ** -(1.0 + 4.0 * rng.random(n)), 1.0))
    return {
        "sigma": np.clip(sigma, 0.0, SIGMA_MAX).astype(np.float32),
        "g": np.clip(g, -G_MAX, G_MAX).astype(np.float32),
        "phi": np.clip(phi, 0.0, 1.0).astype(np.float32),
    }


def generate(
    samples: int,
    seed: int = 0,
    threads: Optional[int] = None,
    chunk: int = 10_000,  # walks per call: about 0.7 s on 2 cores, so Ctrl-C and SIGTERM stop soon
    progress: Optional[Callable[[float], object]] = None,
    ray_address: Optional[str] = None,
) -> tuple[dict, bool]:
    """Simulate the walks for ``samples`` parameter draws.

    Returns (data, interrupted): data holds ``sigma``, ``g``, ``phi`` and the keys of
    ``sphere_walks``; on Ctrl-C it holds the chunks finished so far and interrupted is True.
    With ``ray_address`` the chunks are tasks on that Ray cluster (sssphere.cluster.walks):
    the same walks, bit for bit.
    """
    params = sample_parameters(samples, seed)
    parts: list[dict] = []
    done = 0
    interrupted = False
    if ray_address is not None:
        from sssphere.cluster import walks

        parts, interrupted = walks(params["sigma"], params["g"], params["phi"], samples, seed,
                                   0, ray_address, progress=progress)
        done = sum(len(p["N"]) for p in parts)
    try:
        while done < samples and ray_address is None:
            m = min(chunk, samples - done)
            sl = slice(done, done + m)
            walk = sphere_walks(params["sigma"][sl], params["g"][sl], params["phi"][sl], m,
                                seed=seed, threads=threads, first_index=done)
            parts.append(walk)
            done += m
            if progress is not None:
                progress(done / samples)
    except KeyboardInterrupt:
        interrupted = True
    data = {k: v[:done] for k, v in params.items()}
    for key in ("N", "cos_theta", "alpha", "beta", "X", "W"):
        data[key] = (np.concatenate([p[key] for p in parts]) if parts
                     else np.zeros((0, 3) if key in ("X", "W") else 0))
    return data, interrupted


def save(path: str | Path, data: dict, seed: int, seconds: float,
         requested: Optional[int] = None, interrupted: bool = False) -> None:
    """Write an .npz training file (sssphere.learn.data) with how it was made in ``meta``:
    ``requested_samples`` (what the parameters were drawn for; with the seed it reproduces
    the file) and ``interrupted``, beside the ``samples`` it holds."""
    samples = int(len(data["N"]))
    meta = {"generator": "sssphere.learn.datagen", "version": FORMAT_VERSION, "seed": seed,
            "samples": samples,
            "requested_samples": int(samples if requested is None else requested),
            "interrupted": bool(interrupted), "seconds": round(seconds, 3),
            "sigma_max": SIGMA_MAX, "g_max": G_MAX, "sigma_range": [0.0, SIGMA_MAX],
            "g_range": [-G_MAX, G_MAX], "phi_range": [0.0, 1.0]}
    save_training_data(path, data, meta=meta)


def datagen(samples: int, output: str | Path, seed: int = 0, threads: Optional[int] = None,
            progress: Optional[Callable[[float], object]] = None,
            ray_address: Optional[str] = None) -> tuple[dict, bool, float]:
    """Generate and save; returns (data, interrupted, seconds). Interrupted before any walk
    finished, it writes nothing (an existing file stays as it was). ``ray_address``: on
    that Ray cluster (generate)."""
    out = Path(output)
    if out.suffix != ".npz":
        raise ValueError(f"{out}: the training data file must end in .npz")
    if out.parent != Path("") and not out.parent.is_dir():
        what = "is not a directory" if out.parent.exists() else "does not exist"
        raise ValueError(f"{out}: output directory {str(out.parent)!r} {what}")
    if out.is_dir():  # told now, not after the walks (minutes) at the final rename
        raise ValueError(f"{out}: is a directory, not a file to write the training data to")
    t0 = time.monotonic()
    data, interrupted = generate(samples, seed, threads, progress=progress,
                                 ray_address=ray_address)
    seconds = time.monotonic() - t0
    if len(data["N"]) or not interrupted:
        save(out, data, seed, seconds, requested=samples, interrupted=interrupted)
    return data, interrupted, seconds
