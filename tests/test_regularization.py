"""Path regularization of smooth dielectric boundaries (docs/notation.md, "Regularization"):
a smooth interface lets point and directional lights through as a rough one of alpha
`regularization` would, at the vertices where paths meet it, while the paths themselves go
on as on the smooth interface."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

import sssphere

from render_stats import block_z, mean_z

Z_MAX = 4.0  # per image mean; blocks: a chi-square test and a Bonferroni bound at P_BLOCKS
P_BLOCKS = 1e-4


def _ball(boundary: dict, albedo: float, sigma_t: float, res: int = 32) -> dict:
    """A unit ball lit by one point light and nothing else."""
    return {
        "camera": {"origin": [0, 0, 4], "target": [0, 0, 0], "up": [0, 1, 0], "fov": 32,
                   "width": res, "height": res},
        "shapes": [{"name": "ball", "sphere": {"center": [0, 0, 0], "radius": 1, "subdivisions": 4},
                    "medium": {"sigma_t": sigma_t, "albedo": albedo, "g": 0.3},
                    "boundary": {"type": "dielectric", "ior": 1.5, **boundary}}],
        "lights": [{"type": "point", "position": [1.5, 2, 3], "intensity": [20, 20, 20]}],
        "render": {"grid_resolution": 32},
    }


def _assert_same_expectation(a, b, what: str) -> None:
    """The two renders' image means (|z| < Z_MAX per channel) and 4x4-block means (per
    channel, a chi-square test of their z-scores and a Bonferroni bound on max |z|, each at
    P_BLOCKS) agree within their variance estimates."""
    z = mean_z(a, b)
    assert np.all(np.abs(z) < Z_MAX), f"{what}: image means differ, z {z}"
    for c, zc in enumerate(block_z(a, b)):
        assert zc.size >= 8, (what, c)
        chi2 = float((zc ** 2).sum())
        assert stats.chi2.sf(chi2, zc.size) > P_BLOCKS, f"{what}, channel {c}: chi2 {chi2:.1f}"
        assert np.abs(zc).max() < stats.norm.isf(P_BLOCKS / (2 * zc.size)), \
            f"{what}, channel {c}: max |z| {np.abs(zc).max():.2f}"


@pytest.mark.parametrize("integrator,backend", [("pt", "cpu"), ("st", "cpu"), ("pt", "vulkan")])
def test_a_regularized_vertex_is_the_rough_vertex(integrator, backend):
    """Where a path's only light is what its first boundary vertex samples (a black,
    absorbing ball under a point light: reflection off it is all there is), a smooth
    interface regularized with alpha and a rough one of alpha give the same image in
    expectation: the vertex evaluates the same BSDF. Each render's own variance estimate
    bounds the difference."""
    alpha = 0.15
    kw = dict(integrator=integrator, backend=backend, spp=256)
    smooth = sssphere.render_full(_ball({"regularization": alpha}, 0.0, 20.0), seed=1, **kw)
    rough = sssphere.render_full(_ball({"roughness": alpha}, 0.0, 20.0), seed=2, **kw)
    assert smooth.image.max() > 0.05  # the highlight is there
    _assert_same_expectation(smooth, rough, f"{integrator} {backend}")


@pytest.mark.parametrize("integrator", ["pt", "st"])
def test_point_light_reaches_the_inside_only_when_regularized(integrator):
    """Under a point light alone, a scattering ball behind a smooth interface is black
    without regularization (no path can reach a delta light through it), and lit with it:
    paths meeting the interface from inside sample the light through it."""
    kw = dict(integrator=integrator, spp=16, seed=3)
    dark = sssphere.render_full(_ball({"regularization": 0}, 0.9, 5.0), **kw)
    assert not dark.image.any()
    lit = sssphere.render_full(_ball({"regularization": 0.1}, 0.9, 5.0), **kw)
    assert np.all(np.isfinite(lit.image))
    # pixels whose camera rays miss the highlight's lobe still see light from inside: the
    # darker half of the ball (left of the centre, the light is at upper right)
    left = lit.image[8:24, 4:14]
    assert (left > 0).mean() > 0.5


@pytest.mark.parametrize("integrator,backend", [("pt", "cpu"), ("st", "cpu"), ("pt", "vulkan")])
def test_a_rough_interface_below_the_regularization_passes_delta_light_through_its_lobe(
        integrator, backend):
    """A rough interface less rough than its regularization passes point and directional
    light through the regularization's lobe, as the smooth one does: else the variance
    grew as 1/alpha^2 (a user review: at alpha 1e-3, 1,024 spp gave a tenth of the image
    the nearby alphas give; the median 32-spp image mean was 0.15 of the mean). On the black
    ball, where the first vertex's light is all there is, alpha 0.03 under regularization
    0.15 is the smooth interface regularized with 0.15 in expectation; with its own lobe its
    highlight was 25x as peaked (the block test fails)."""
    kw = dict(integrator=integrator, backend=backend, spp=256)
    smooth = sssphere.render_full(_ball({"regularization": 0.15}, 0.0, 20.0), seed=1, **kw)
    faint = sssphere.render_full(_ball({"roughness": 0.03, "regularization": 0.15}, 0.0, 20.0),
                                 seed=2, **kw)
    assert smooth.image.max() > 0.05
    _assert_same_expectation(smooth, faint, f"{integrator} {backend}")
