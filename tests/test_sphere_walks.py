"""The ground-truth sphere-walk generator (sssphere.sphere_walks) against facts that need no
simulation, and against an independent NumPy implementation (tests/reference_walks.py)."""

import numpy as np
import pytest
from scipy import stats

import sssphere
from sssphere import _core
from reference_walks import reference_cut_sphere_walks, reference_sphere_walks

KEYS = ("N", "cos_theta", "alpha", "beta", "X", "W")


def hg_cdf(c, g):
    """CDF of cos θ under Henyey–Greenstein."""
    if abs(g) < 1e-3:
        return 0.5 * (1 + c)
    return (1 - g * g) / (2 * g) * (1 / np.sqrt(1 + g * g - 2 * g * c) - 1 / (1 + g))


@pytest.mark.parametrize("sigma", [0.5, 2.0, 6.0])
def test_single_event_probability_is_exp_minus_sigma(sigma):
    n = 100_000
    N = sssphere.sphere_walks(sigma, 0.0, 1.0, n, seed=3)["N"]
    p = np.exp(-sigma)
    assert abs(np.mean(N == 1) - p) <= 4.5 * np.sqrt(p * (1 - p) / n)


@pytest.mark.parametrize("g", [-0.7, 0.0, 0.9])
def test_vanishing_sigma_exits_along_the_first_hg_direction(g):
    d = sssphere.sphere_walks(1e-6, g, 0.5, 50_000, seed=1)
    assert np.all(d["N"] == 1)
    assert np.all(np.abs(d["alpha"]) < 1e-3) and np.all(np.abs(d["beta"]) < 1e-3)
    assert np.all(d["X"] == 0) and np.all(d["W"] == [0, 0, 1])
    assert stats.kstest(d["cos_theta"], lambda c: hg_cdf(c, g)).pvalue > 1e-4


@pytest.mark.parametrize("g", [-0.5, 0.0, 0.5])
def test_diffusion_limit_mean_events(g):
    # Diffusion: E[N] = σ²(1 − g)/2 (1 + O(1/σ')) with σ' = σ(1 − g); the leading correction
    # is the extrapolated boundary, 2 × 0.7104/σ' (measured here: 1.3–1.9/σ').
    sigma, n = 100.0, 20_000
    N = sssphere.sphere_walks(sigma, g, 1.0, n, seed=5, threads=2)["N"].astype(np.float64)
    scale = sigma * sigma * (1 - g) / 2
    ratio, se = N.mean() / scale, N.std() / np.sqrt(n) / scale
    sigma_prime = sigma * (1 - g)
    assert -4 * se <= ratio - 1 <= 2.5 / sigma_prime + 4 * se


def test_outputs_are_well_formed():
    n = 20_000
    d = sssphere.sphere_walks(np.linspace(0, 30, n), np.linspace(-0.9, 0.9, n), 0.95, n, seed=2)
    assert set(d) == set(KEYS)
    assert d["N"].dtype == np.int64 and d["N"].shape == (n,)
    assert d["X"].shape == (n, 3) and d["W"].shape == (n, 3)
    assert np.all(d["N"] >= 1)
    assert np.all(np.abs(d["cos_theta"]) <= 1)
    assert np.all(d["alpha"] ** 2 + d["beta"] ** 2 <= 1)
    assert np.all(np.linalg.norm(d["X"], axis=1) <= 1 + 1e-6)
    np.testing.assert_allclose(np.linalg.norm(d["W"], axis=1), 1, atol=1e-5)


def test_reproducible_for_any_thread_count_and_split():
    args = (15.0, 0.3, 0.99, 4000)
    a = sssphere.sphere_walks(*args, seed=9, threads=1)
    b = sssphere.sphere_walks(*args, seed=9, threads=2)
    tail = sssphere.sphere_walks(15.0, 0.3, 0.99, 1000, seed=9, first_index=3000)
    c = sssphere.sphere_walks(*args, seed=10)
    for k in KEYS:
        np.testing.assert_array_equal(a[k], b[k])
        np.testing.assert_array_equal(a[k][3000:], tail[k])
    assert not np.array_equal(a["N"], c["N"])


@pytest.mark.parametrize("sigma,g,albedo", [(4.0, 0.4, 0.9), (10.0, -0.7, 0.99), (1.5, 0.9, 1.0)])
def test_agrees_with_the_numpy_reference(sigma, g, albedo):
    n = 20_000
    ours = sssphere.sphere_walks(sigma, g, albedo, n, seed=11)
    ref = reference_sphere_walks(sigma, g, albedo, n, seed=12)
    columns = {
        "N": lambda d: d["N"],
        "cos_theta": lambda d: d["cos_theta"],
        "alpha": lambda d: d["alpha"],
        "beta": lambda d: d["beta"],
        "|X|": lambda d: np.linalg.norm(d["X"], axis=1),
        "X_z": lambda d: d["X"][:, 2],
        "W_z": lambda d: d["W"][:, 2],
        "W_x": lambda d: d["W"][:, 0],
    }
    # Two-sample KS per column; 8 columns × 3 cases at family-wise level ~1e-3. Values are
    # rounded to 1e-6 so that the atoms (α = β = 0 and X = 0 for N = 1) are not split by
    # rounding noise of either implementation.
    for name, f in columns.items():
        p = stats.ks_2samp(np.round(f(ours), 6), np.round(f(ref), 6)).pvalue
        assert p > 1e-3 / 24, f"{name}: KS p-value {p:.2e}"


@pytest.mark.parametrize(
    "kwargs,match",
    [
        (dict(sigma_t=-1.0), "sigma_t"),
        (dict(sigma_t=float("nan")), "sigma_t"),
        (dict(sigma_t=5000.0), "sigma_t"),
        (dict(g=1.0), "g"),
        (dict(g=-1.0), "g"),
        (dict(albedo=1.5), "albedo"),
        (dict(sigma_t=np.ones(3)), "length n"),
        (dict(g=np.zeros((10, 1))), "length n"),
        (dict(n=0), "n must be"),
        (dict(n=2.5), "n must be"),
        (dict(seed=-1), "seed"),
        (dict(threads=-2), "threads"),
    ],
)
def test_bad_input_is_named(kwargs, match):
    args = dict(sigma_t=1.0, g=0.0, albedo=1.0, n=10)
    args.update(kwargs)
    with pytest.raises(ValueError, match=match):
        sssphere.sphere_walks(**args)


# The cut sphere problem (docs/notation.md): the sphere cut by the plane z = h.


@pytest.mark.parametrize("sigma,g,h,mu0,albedo", [(6.0, 0.9, 0.2, 1.0, 0.99),
                                                 (10.0, 0.5, 0.5, -0.5, 0.9),
                                                 (3.0, 0.0, 0.1, 0.3, 1.0)])
def test_cut_walks_agree_with_the_numpy_reference(sigma, g, h, mu0, albedo):
    from sssphere.walks import cut_sphere_walks

    n = 20_000
    ours = cut_sphere_walks(sigma, g, h, mu0, albedo, n, seed=11)
    ref = reference_cut_sphere_walks(sigma, g, h, mu0, albedo, n, seed=12)
    columns = {"N": lambda d: d["N"], "through_plane": lambda d: d["through_plane"]}
    for k in range(3):
        columns[f"exit_pos[{k}]"] = lambda d, k=k: d["exit_pos"][:, k]
        columns[f"exit_dir[{k}]"] = lambda d, k=k: d["exit_dir"][:, k]
    columns["|X|"] = lambda d: np.linalg.norm(d["X"], axis=1)
    columns["W_z"] = lambda d: d["W"][:, 2]
    # Two-sample KS per column (10 columns x 3 cases at family-wise level ~1e-3); rounded to
    # 1e-6 so that the atoms (the plane z = h, X = 0) are not split by rounding noise.
    for name, f in columns.items():
        a, b = (np.round(np.asarray(f(d), np.float64), 6) for d in (ours, ref))
        p = stats.ks_2samp(a, b).pvalue
        assert p > 1e-3 / 30, f"{name}: KS p-value {p:.2e}"
    # Both ways out occur, and the exits are on the surface they name.
    plane = ours["through_plane"].astype(bool)
    assert 0.02 < plane.mean() < 0.98
    np.testing.assert_array_equal(ours["exit_pos"][plane, 2], np.float32(h))
    np.testing.assert_allclose(np.linalg.norm(ours["exit_pos"][~plane], axis=1), 1.0, atol=1e-5)


@pytest.mark.parametrize(
    "kwargs,match",
    [
        (dict(h=0.0), "h"),
        (dict(h=float("nan")), "h"),
        (dict(mu0=1.5), "mu0"),
        (dict(albedo=-0.1), "albedo"),
        (dict(sigma_t=2000.0), "sigma_t"),
        (dict(h=np.ones(3)), "length n"),
        (dict(n=0), "n must be"),
    ],
)
def test_cut_walks_bad_input_is_named(kwargs, match):
    from sssphere.walks import cut_sphere_walks

    args = dict(sigma_t=1.0, g=0.0, h=0.5, mu0=1.0, albedo=1.0, n=10)
    args.update(kwargs)
    with pytest.raises(ValueError, match=match):
        cut_sphere_walks(**args)


@pytest.mark.parametrize(
    "kwargs,match",
    [
        (dict(seed=2**64), r"seed must be an integer from 0 to 2\^64 - 1, got 18446744073709551616"),
        (dict(first_index=2**64), r"first_index must be an integer from 0 to 2\^64 - 1"),
        (dict(n=2**62), "n must be an integer from 1 to 2,147,483,647"),
        (dict(threads=5000), r"threads must be an integer from 0 to 4,096 \(0 = all cores\)"),
        (dict(first_index=2**64 - 2), r"first_index \+ n - 1 = 18446744073709551616 is past 2\^64 - 1"),
    ],
)
def test_walk_counts_and_seeds_past_their_range_are_named(kwargs, match):
    """Past 64 bits a seed was pybind11's list of overloads; a count of 2^62 walks was
    std::vector's own message. Each is now refused naming the argument and its range."""
    args = dict(sigma_t=5.0, g=0.3, albedo=0.9, n=3)
    args.update(kwargs)
    with pytest.raises(ValueError, match=match):
        sssphere.sphere_walks(**args)
    assert sssphere.sphere_walks(5.0, 0.3, 0.9, 3, seed=2**64 - 1)["N"].min() >= 1


def test_a_large_call_is_made_in_parts_with_the_same_walks(monkeypatch):
    """sphere_walks and cut_sphere_walks call C++ in parts of about a quarter of a second
    (so that Ctrl-C is seen between them; 65,536 walks at sigma_t = 1000 were one call of six
    minutes); walk i keeps its stream (seed, first_index + i), so the parts give the walks
    of one call."""
    from sssphere import walks

    rng = np.random.default_rng(5)
    n = 1000
    sigma = rng.uniform(0.5, 20, n).astype(np.float32)
    calls = []
    whole_call = _core.sphere_walks
    monkeypatch.setattr(walks._core, "sphere_walks",
                        lambda *a: calls.append(a[3]) or whole_call(*a))
    monkeypatch.setattr(walks, "_FIRST_PART", 8)
    monkeypatch.setattr(walks, "_PART_SECONDS", 1e-6)  # 8 walks, then one per call
    # per-walk arrays are split; a number serves every part
    for kind, sigma_t in (("array", sigma), ("number", 5.0)):
        s = np.broadcast_to(np.float32(sigma_t), n) if kind == "number" else sigma
        whole = whole_call(np.ascontiguousarray(s), np.full(n, 0.3, np.float32),
                           np.full(n, 0.9, np.float32), n, 11, 7, 0)
        calls.clear()
        parted = walks.sphere_walks(sigma_t, 0.3, 0.9, n, seed=11, first_index=7)
        assert len(calls) > 10 and sum(calls) == n, calls
        for key in whole:
            np.testing.assert_array_equal(parted[key], whole[key], err_msg=f"{kind} {key}")
    cut_parted = walks.cut_sphere_walks(sigma[:200], 0.3, 0.4, -0.2, 0.9, 200, seed=3)
    monkeypatch.setattr(walks, "_FIRST_PART", 200)  # one call
    cut_whole = walks.cut_sphere_walks(sigma[:200], 0.3, 0.4, -0.2, 0.9, 200, seed=3)
    for key in cut_whole:
        np.testing.assert_array_equal(cut_parted[key], cut_whole[key], err_msg=f"cut {key}")
