"""Paper mode: IGWO over the Levy moment sums of eq. (29), checked against the direct WLS path."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxgwo import _gwo as G
from jaxgwo._cost import CiferObjective
from jaxgwo._models import PaperModel, ParameterMap, QuarticModel
from jaxgwo._plants import R50Plant, r50_frequency_response
from jaxgwo._paper_mode import (
    MomentObjective,
    hurwitz_stable_quartic,
    identify_paper_mode,
    wls_moment_weights,
)
from jaxgwo._spectral import FrequencyResponse
from jaxgwo._transfer import paper_model_response
from jaxgwo._wls import levy_fit, levy_fit_response, levy_moments, solve_levy_moments

TRUTH = jnp.array([500.0, 0.1, 150.0, 40.0, 0.7])  # K, tau, M, omega_s, zeta_s
W = jnp.geomspace(1.0, 60.0, 200)
SMALL = dict(wolves=10, iterations=30)  # compiles once for every run below


def _quartic_map():
    return ParameterMap(kind="quartic", log=(False,) * 5, signs=(1.0,) * 5)


@pytest.fixture(scope="module")
def noise_free():
    return FrequencyResponse.from_complex(W, paper_model_response(TRUTH, W), coherence=None)


@pytest.fixture(scope="module")
def noisy():
    """3 % complex noise, coherence in [0.4, 1] so that some points fail the 0.6 mask."""
    rng = np.random.default_rng(3)
    h = np.asarray(paper_model_response(TRUTH, W))
    h = h * (1.0 + 0.03 * (rng.standard_normal(h.size) + 1j * rng.standard_normal(h.size)))
    coh = rng.uniform(0.4, 1.0, h.size)
    return FrequencyResponse.from_complex(W, jnp.asarray(h), coherence=jnp.asarray(coh))


@pytest.fixture(scope="module")
def r50_runs():
    """The R-50's analytic roll response: the paper model cannot fit it exactly, and its
    WLS start (J = 137.6) is far from the best J (123.4), so the search must move.  Same
    shapes as the noise-free run, so one compilation serves both."""
    h = r50_frequency_response(R50Plant.default(), W)[:, 0, 0]
    response = FrequencyResponse.from_complex(W, h)
    return tuple(identify_paper_mode(response, key=jax.random.key(k), **SMALL) for k in (0, 0, 1))


def test_hurwitz_test_matches_numpy_roots():
    rng = np.random.default_rng(0)
    a = rng.lognormal(0.0, 2.0, (400, 4)) * rng.choice([1.0, 1.0, 1.0, -1.0], (400, 4))
    coeffs = np.concatenate([np.ones((400, 1)), a], axis=1)
    ref = [bool(np.all(np.roots([c[4], c[3], c[2], c[1], 1.0]).real < 0)) for c in coeffs]
    got = np.asarray(hurwitz_stable_quartic(jnp.asarray(coeffs)))
    np.testing.assert_array_equal(got, ref)
    assert 20 < sum(ref) < 380  # both outcomes are exercised


@pytest.mark.parametrize("weights, sk", [("sk", 5), ("levy", 0)])
def test_wls_moments_give_the_wls_quartic_and_its_J(noisy, weights, sk):
    """At x = 1 the moment objective is J of the WLS quartic, computed independently by
    the SVD least-squares fit (no moments) and a quartic CiferObjective."""
    fit = levy_fit_response(noisy, sk_iterations=sk)
    quartic_map = ParameterMap.for_model(QuarticModel.from_array(fit.theta))
    cifer = CiferObjective.from_response(noisy, quartic_map)
    j_ref = cifer.cost_from_params(fit.theta)

    mask = np.asarray(noisy.mask)
    h = jnp.where(noisy.mask, noisy.H, 1.0 + 0.0j)
    wt = wls_moment_weights(noisy, weights, sk_iterations=sk)
    scale = levy_moments(W, h, wt).to_vector()
    obj = MomentObjective(CiferObjective.from_response(noisy, _quartic_map()), scale)
    ones = jnp.ones(10)
    # eq. (29) is the normal equations of the SVD fit: they agree to its conditioning
    # (test_wls.py measures rtol 1e-7 on the same kind of problem)
    np.testing.assert_allclose(np.asarray(obj.coefficients(ones)), np.asarray(fit.theta), rtol=1e-7)
    np.testing.assert_allclose(float(obj(ones)), float(j_ref), rtol=1e-8)
    assert 0.1 < float(j_ref) < 100.0  # a real residual, not a noise-free zero

    # the "sk" weights are those of the last SK pass: a plain weighted Levy fit with them
    # is the SK result, again without moments
    direct = levy_fit(W, h, wt)
    np.testing.assert_allclose(np.asarray(direct.theta), np.asarray(fit.theta), rtol=1e-9)
    assert np.all(np.asarray(wt)[~mask] == 0.0)

    # the printed eq. (29) (+S4) gives a different model at the same moments
    printed = MomentObjective(obj.fitness, scale, "paper")
    assert not np.allclose(np.asarray(printed.coefficients(ones)), np.asarray(fit.theta), rtol=1e-3)
    assert np.asarray(solve_levy_moments(obj.moments(ones))).shape == (5,)


def test_unstable_moment_vector_scores_inf(noisy):
    h = jnp.where(noisy.mask, noisy.H, 1.0 + 0.0j)
    scale = levy_moments(W, h, wls_moment_weights(noisy)).to_vector()
    obj = MomentObjective(CiferObjective.from_response(noisy, _quartic_map()), scale)
    rng = np.random.default_rng(1)
    xs = jnp.asarray(rng.uniform(0.0, 2.0, (100, 10)))
    f = np.asarray(jax.jit(jax.vmap(obj))(xs))
    p = np.asarray(obj.coefficients(xs))  # solve_levy_moments batches
    stable = np.array([np.all(np.roots([c[4], c[3], c[2], c[1], 1.0]).real < 0) for c in p])
    assert stable.any() and (~stable).any()
    assert np.all(np.isinf(f[~stable])) and np.all(np.isfinite(f[stable]))


def test_run_from_noise_free_data_keeps_the_exact_start(noise_free):
    res = identify_paper_mode(noise_free, key=jax.random.key(0), **SMALL)
    cfg = G.igwo(**SMALL)
    assert res.status == "ok" and res.reason == "ok"
    # the exact fit is kept: both J at rounding level (any other quartic leaves J orders
    # above it).  Not ``cost_J <= wls_cost_J``: at 1e-28 J is rounding noise, and the
    # optimiser's batched evaluation of the same start rounds differently from the unbatched
    # one (3.88e-28 against 3.85e-28 on the 2026-11-23 machine; equal before).  Elitism is
    # checked where J is not noise, on the R-50 runs below.
    assert float(res.cost_J) < 1e-20 and float(res.wls_cost_J) < 1e-20
    hist = np.asarray(res.convergence)
    assert hist.shape == (30,) and np.all(np.diff(hist) <= 0) and hist[-1] == float(res.cost_J)
    assert int(res.evaluations) == cfg.total_evaluations
    q = np.asarray(res.quartic.to_array())
    assert np.all(np.roots([q[4], q[3], q[2], q[1], 1.0]).real < 0)
    # J ~ 1e-27 pins the transfer function: the factored model is the truth
    np.testing.assert_allclose(np.asarray(res.paper_model.to_array()), np.asarray(TRUTH), rtol=1e-6)
    np.testing.assert_allclose(np.asarray(res.quartic.to_array()),
                               np.asarray(PaperModel.from_array(TRUTH).to_quartic().to_array()),
                               rtol=1e-6)


def test_same_key_same_result_other_key_other_search(r50_runs):
    a, b, c = r50_runs
    for leaf_a, leaf_b in zip(jax.tree.leaves(a), jax.tree.leaves(b)):
        np.testing.assert_array_equal(np.asarray(leaf_a), np.asarray(leaf_b))
    assert not np.array_equal(np.asarray(a.scaled_position), np.asarray(c.scaled_position))
    # the search moves off the WLS moments and lowers J
    for r in (a, c):
        assert float(r.cost_J) < float(r.wls_cost_J)
        assert bool(hurwitz_stable_quartic(r.quartic.to_array()))


def test_printed_convention_starts_worse_and_improves(noise_free):
    res = identify_paper_mode(noise_free, key=jax.random.key(0), convention="paper", **SMALL)
    assert res.convention == "paper"
    # measured: J = 40.65 at the WLS moments with +S4; the search must not make it worse
    assert float(res.wls_cost_J) > 1.0
    assert float(res.cost_J) < float(res.wls_cost_J)
    assert bool(hurwitz_stable_quartic(res.quartic.to_array()))


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(half_width=0.0), "half_width"),
        (dict(half_width=1.0), "half_width"),
        (dict(spread=-0.1), "spread"),
        (dict(spread=float("nan")), "spread"),
        (dict(seeded_fraction=0.0), "seeded_fraction"),
        (dict(weights="coherence"), "weights"),
        (dict(weights=jnp.ones(5)), "weights"),
        (dict(convention="printed"), "convention"),
        (dict(sk_iterations=-1), "sk_iterations"),
        (dict(wolves=3), "wolves"),
    ],
)
def test_bad_settings_raise_clear_errors(noise_free, kwargs, match):
    with pytest.raises(ValueError, match=match):
        identify_paper_mode(noise_free, key=jax.random.key(0), **kwargs)


def test_bad_data_and_objective_raise(noise_free):
    few = FrequencyResponse.from_complex(W[:10], noise_free.H[:10])
    with pytest.raises(ValueError, match="at least 20"):
        identify_paper_mode(few, key=jax.random.key(0))
    paper_map = ParameterMap.for_model(PaperModel.from_array(TRUTH))
    cifer = CiferObjective.from_response(noise_free, paper_map)
    with pytest.raises(ValueError, match="quartic"):
        MomentObjective(cifer, jnp.ones(10))
    cq = CiferObjective.from_response(noise_free, _quartic_map())
    with pytest.raises(ValueError, match="convention"):
        MomentObjective(cq, jnp.ones(10), "printed")
