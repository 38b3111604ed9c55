"""Statistical comparison of our renders with Mitsuba 3's (block means, chi-square and
Bonferroni z tests). The scene translation itself is sssphere.mitsuba."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Iterable, Sequence

import numpy as np

from sssphere.mitsuba import (RR_DEPTH, VARIANT, import_mitsuba, load_mitsuba_scene,  # noqa: F401
                              mitsuba_scene_dict, write_ply)


def render_mitsuba(mi_scene, spp: int, seed: int) -> np.ndarray:
    """One Mitsuba render: (height, width, 3) float64 mean radiance."""
    import mitsuba as mi

    img = mi.render(mi_scene, spp=int(spp), seed=int(seed))
    return np.array(img, dtype=np.float64)[:, :, :3]


@dataclass
class SeedStack:
    """K independent Mitsuba renders: their mean and the variance of that mean per pixel."""

    mean: np.ndarray        # (H, W, 3)
    var_of_mean: np.ndarray  # (H, W, 3): per-pixel sample variance over the K renders / K
    renders: np.ndarray     # (K, H, W, 3)
    seconds: float


def render_mitsuba_seeds(mi_scene, spp: int, seeds: Iterable[int]) -> SeedStack:
    import time

    t0 = time.perf_counter()
    renders = np.stack([render_mitsuba(mi_scene, spp, s) for s in seeds])
    seconds = time.perf_counter() - t0
    k = renders.shape[0]
    if k < 2:
        raise ValueError("need at least two seeds for a variance estimate")
    return SeedStack(
        mean=renders.mean(axis=0),
        var_of_mean=renders.var(axis=0, ddof=1) / k,
        renders=renders,
        seconds=seconds,
    )


def block_mean(img: np.ndarray, b: int) -> np.ndarray:
    """Mean over b x b pixel blocks of an (H, W, C) image (H, W multiples of b)."""
    h, w, c = img.shape
    if h % b or w % b:
        raise ValueError(f"image {h}x{w} is not a multiple of the block size {b}")
    return img.reshape(h // b, b, w // b, b, c).mean(axis=(1, 3))


def block_var_of_mean(var: np.ndarray, b: int) -> np.ndarray:
    """Variance of a block mean from independent per-pixel variances of the pixel means."""
    return block_mean(var, b) / (b * b)


@dataclass
class Comparison:
    """Block-mean comparison of two images with independent noise.

    The channels of one image are correlated (with grey sigma_t they share every path), so the
    chi-square test runs per channel, each at alpha / channels; the |z| test is Bonferroni over
    all blocks and channels (valid under any dependence). Both hold the family-wise false-alarm
    rate at about alpha when the images agree and the variance estimates are right.
    """

    z: np.ndarray             # (by, bx, 3), NaN where both variances are zero
    chi2: np.ndarray          # (3,) per channel, sum of z^2 over blocks with variance
    dof: np.ndarray           # (3,) blocks with variance per channel
    chi2_p: np.ndarray        # (3,) chi-square survival function per channel
    max_abs_z: float
    bonferroni_z: float       # |z| threshold for family-wise alpha over all blocks x channels
    alpha: float
    zero_var_max_abs_diff: float  # largest |difference| among blocks where both variances are 0
    mean_ours: np.ndarray     # (3,) image means
    mean_theirs: np.ndarray
    rel_diff_mean: np.ndarray  # (3,) (ours - theirs) / theirs
    rel_diff_mean_sigma: np.ndarray  # (3,) one standard deviation of rel_diff_mean

    @property
    def chi2_ok(self) -> bool:
        return bool(np.all(self.chi2_p > self.alpha / len(self.chi2_p)))

    @property
    def z_ok(self) -> bool:
        return self.max_abs_z < self.bonferroni_z

    @property
    def ok(self) -> bool:
        return self.chi2_ok and self.z_ok

    def summary(self) -> str:
        def fmt(a, nd=3):
            return "[" + ", ".join(f"{x:.{nd}g}" for x in np.asarray(a).ravel()) + "]"

        return (
            f"chi2 per channel {fmt(self.chi2, 4)} on {fmt(self.dof)} blocks, p = {fmt(self.chi2_p)} "
            f"(limit alpha/3 = {self.alpha / len(self.chi2_p):.3g}); max |z| = {self.max_abs_z:.2f} "
            f"(Bonferroni limit {self.bonferroni_z:.2f} for alpha = {self.alpha:g}); image means "
            f"ours {fmt(self.mean_ours, 5)} mitsuba {fmt(self.mean_theirs, 5)}; relative difference "
            f"{fmt(100 * self.rel_diff_mean, 2)} % (one sigma {fmt(100 * self.rel_diff_mean_sigma, 2)} %)"
        )


def compare(
    ours: np.ndarray,
    ours_var: np.ndarray,
    theirs: np.ndarray,
    theirs_var: np.ndarray,
    block: int,
    alpha: float = 1e-3,
) -> Comparison:
    """z-scores of b x b block means; per-channel chi-square and Bonferroni |z| tests."""
    from scipy import stats

    ours = np.asarray(ours, dtype=np.float64)
    theirs = np.asarray(theirs, dtype=np.float64)
    ours_var = np.asarray(ours_var, dtype=np.float64)
    theirs_var = np.asarray(theirs_var, dtype=np.float64)
    a, va = block_mean(ours, block), block_var_of_mean(ours_var, block)
    b, vb = block_mean(theirs, block), block_var_of_mean(theirs_var, block)
    var = va + vb
    live = var > 0
    z = np.full(a.shape, np.nan)
    z[live] = (a[live] - b[live]) / np.sqrt(var[live])
    nch = a.shape[2]
    z2 = np.where(live, np.nan_to_num(z) ** 2, 0.0)
    chi2 = z2.sum(axis=(0, 1))
    dof = live.sum(axis=(0, 1))
    p = np.array([stats.chi2.sf(chi2[c], dof[c]) if dof[c] else 1.0 for c in range(nch)])
    n_tests = max(int(live.sum()), 1)
    bonf = float(stats.norm.isf(alpha / (2 * n_tests)))
    dead = ~live
    zero_diff = float(np.max(np.abs(a[dead] - b[dead]))) if dead.any() else 0.0
    n_pix = ours.shape[0] * ours.shape[1]
    m_a, m_b = ours.mean(axis=(0, 1)), theirs.mean(axis=(0, 1))
    v_mean = (ours_var.sum(axis=(0, 1)) + theirs_var.sum(axis=(0, 1))) / n_pix**2
    safe_b = np.where(m_b != 0, m_b, 1.0)
    rel = np.where(m_b != 0, (m_a - m_b) / safe_b, 0.0)
    rel_sigma = np.where(m_b != 0, np.sqrt(v_mean) / np.abs(safe_b), 0.0)
    return Comparison(
        z=z, chi2=chi2, dof=dof, chi2_p=p,
        max_abs_z=float(np.max(np.abs(z[live]))) if live.any() else 0.0,
        bonferroni_z=bonf, alpha=alpha, zero_var_max_abs_diff=zero_diff,
        mean_ours=m_a, mean_theirs=m_b, rel_diff_mean=rel, rel_diff_mean_sigma=rel_sigma,
    )


@dataclass
class AgreementRun:
    comparison: Comparison
    ours_seconds: float
    mitsuba_seconds: float
    ours_events_per_path: float


def compare_with_mitsuba(
    scene_dict: dict,
    our_spp: int,
    mitsuba_spp: int,
    mitsuba_seeds: Sequence[int],
    block: int,
    our_seed: int = 0,
    alpha: float = 1e-3,
    mitsuba_scene_dict_override: dict | None = None,
) -> AgreementRun:
    """Render `scene_dict` with our PT (one render, its own variance estimate) and with
    Mitsuba (one render per seed; the variance of their mean from the spread between seeds)
    and compare block means. `mitsuba_scene_dict_override`, if given, is the sssphere-format
    scene that Mitsuba renders instead (for negative checks: a deliberately different scene)."""
    import tempfile

    import sssphere

    ours_scene = sssphere.load_scene(scene_dict)
    r = sssphere.render_full(ours_scene, spp=our_spp, seed=our_seed, threads=0)
    mi_src = scene_dict if mitsuba_scene_dict_override is None else mitsuba_scene_dict_override
    mesh_scene = ours_scene if mi_src is scene_dict else sssphere.load_scene(mi_src)
    with tempfile.TemporaryDirectory(prefix="sssphere-mitsuba-") as tmp:
        mi_scene = load_mitsuba_scene(mi_src, mesh_scene, tmp, mitsuba_spp)
        stack = render_mitsuba_seeds(mi_scene, mitsuba_spp, mitsuba_seeds)
        del mi_scene
    cmp = compare(r.image, r.variance, stack.mean, stack.var_of_mean, block, alpha=alpha)
    return AgreementRun(cmp, r.seconds, stack.seconds, r.mean_events_per_path)
