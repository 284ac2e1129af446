"""Stage 3 Levy WLS against numpy.linalg.lstsq, a known truth, and eq. (29)."""

import json
from pathlib import Path

import jax.numpy as jnp
import numpy as np
import pytest

from jaxgwo._transfer import paper_model_coefficients, paper_model_response
from jaxgwo._wls import (
    LevyMoments,
    levy_design,
    levy_fit,
    levy_moment_matrix,
    levy_moments,
    quartic_to_paper_params,
    solve_levy_moments,
)

TRUTH = jnp.array([500.0, 0.1, 150.0, 40.0, 0.7])  # K, tau, M, omega_s, zeta_s
W = jnp.geomspace(1.0, 60.0, 200)
# the paper's published numbers (a copy of shared/reference/seed_paper_results.json)
SEED_JSON = Path(__file__).resolve().parent / "data" / "seed_paper_results.json"


def _true_theta():
    num, den = paper_model_coefficients(TRUTH)
    den = np.asarray(den) / float(den[-1])
    return np.r_[float(num[0]) / float(paper_model_coefficients(TRUTH)[1][-1]), den[-2::-1]]


def _noisy(seed=0, level=0.03):
    rng = np.random.default_rng(seed)
    h = np.asarray(paper_model_response(TRUTH, W))
    noise = level * np.abs(h) * (rng.standard_normal(h.size) + 1j * rng.standard_normal(h.size))
    wts = rng.uniform(0.6, 1.0, h.size)
    return jnp.asarray(h + noise), jnp.asarray(wts)


def test_exact_recovery_noise_free():
    fit = levy_fit(W, paper_model_response(TRUTH, W))
    np.testing.assert_allclose(np.asarray(fit.theta), _true_theta(), rtol=1e-9)
    num, den = paper_model_coefficients(TRUTH)
    np.testing.assert_allclose(np.asarray(fit.denominator) * float(den[-1]), np.asarray(den),
                               rtol=1e-9)
    np.testing.assert_allclose(np.asarray(fit.numerator) * float(den[-1]), np.asarray(num),
                               rtol=1e-9)


def test_matches_numpy_lstsq_on_weighted_noisy_problem():
    h, wts = _noisy()
    fit = levy_fit(W, h, wts)
    A, y = levy_design(W, h, 0, 4, 1.0)  # unscaled rows: numpy solves the raw problem
    rw = np.sqrt(np.r_[wts, wts])
    ref = np.linalg.lstsq(np.asarray(A) * rw[:, None], np.asarray(y) * rw, rcond=None)[0]
    # the raw design has cond ~1e9 (see test below), so numpy's answer carries ~1e-7
    np.testing.assert_allclose(np.asarray(fit.theta), ref, rtol=1e-6)


def test_conditioning_200_points_1_to_60():
    fit = levy_fit(W, paper_model_response(TRUTH, W))
    raw = np.linalg.cond(np.asarray(levy_design(W, paper_model_response(TRUTH, W))[0]))
    # measured: 3.2 scaled against 4.0e5 raw (w^0..w^4 |H| columns); the normal equations
    # of eq. (29) would square the raw figure
    assert float(fit.condition_number) < 1e3, float(fit.condition_number)
    assert raw > 1e5


def test_moment_solve_equals_direct_solve():
    h, wts = _noisy(1)
    fit = levy_fit(W, h, wts)
    m = levy_moments(W, h, wts)
    x = solve_levy_moments(m, "derived")
    np.testing.assert_allclose(np.asarray(x), np.asarray(fit.theta), rtol=1e-7)
    # the normal-equation matrix is A^T W A with rows 4 and 5 negated
    A, y = levy_design(W, h, 0, 4, 1.0)
    rw = np.r_[wts, wts]
    ata = np.asarray(A).T @ (rw[:, None] * np.asarray(A))
    atb = np.asarray(A).T @ (rw * np.asarray(y))
    sign = np.array([1, 1, 1, -1, -1.0])
    M, rhs = levy_moment_matrix(m)
    # entries span 1e2..1e16; the structural zeros come out of cancellation in A^T A
    scale = np.abs(ata).max()
    np.testing.assert_allclose(np.asarray(M), sign[:, None] * ata, rtol=1e-12, atol=1e-15 * scale)
    np.testing.assert_allclose(np.asarray(rhs), sign * atb, rtol=1e-12, atol=1e-15 * scale)
    # the printed sign of S4 in row 1 changes the answer
    xp = solve_levy_moments(m, "paper")
    assert not np.allclose(np.asarray(xp), np.asarray(x), rtol=1e-3)


def test_moment_solve_batches():
    vs = jnp.stack([levy_moments(W, _noisy(s)[0]).to_vector() for s in range(3)])
    batch = solve_levy_moments(LevyMoments.from_vector(vs))
    for i in range(3):
        one = solve_levy_moments(LevyMoments.from_vector(vs[i]))
        np.testing.assert_allclose(np.asarray(batch[i]), np.asarray(one), rtol=1e-12)


def test_sanathanan_koerner_reduces_output_error():
    h, wts = _noisy(2, level=0.1)

    v = wts / jnp.abs(h) ** 2  # relative-error weighting

    def out_err(fit):
        s = 1j * np.asarray(W)
        g = np.polyval(np.asarray(fit.numerator), s) / np.polyval(np.asarray(fit.denominator), s)
        return float(np.sum(np.asarray(v) * np.abs(np.asarray(h) - g) ** 2))

    # Levy minimises sum v |D|^2 |H - N/D|^2; SK removes the |D|^2 and so must do better
    # on the output error sum v |H - N/D|^2
    e0 = out_err(levy_fit(W, h, v))
    e5 = out_err(levy_fit(W, h, v, sk_iterations=5))
    assert e5 < 0.9 * e0, (e5, e0)


def test_quartic_to_paper_params_recovers_truth_and_resolves_alias():
    th = _true_theta()
    got = quartic_to_paper_params(*th)
    assert got.ok, got.reason
    np.testing.assert_allclose(got.params, np.asarray(TRUTH), rtol=1e-8)
    # the swapped factorisation has the same quartic; the rule gives back the same params
    k, tau, m, ws, zs = np.asarray(TRUTH)
    swapped = jnp.array([k * ws**2 / m, 1 / (2 * zs * ws), ws**2, np.sqrt(m), 1 / (2 * tau * np.sqrt(m))])
    num, den = paper_model_coefficients(swapped)
    den = np.asarray(den)
    th2 = np.r_[float(num[0]) / den[-1], den[-2::-1] / den[-1]]
    np.testing.assert_allclose(quartic_to_paper_params(*th2).params, np.asarray(TRUTH), rtol=1e-8)


def test_quartic_to_paper_params_four_real_poles():
    # (s+2)(s+5) rotor, (s+30)(s+50) servo: fastest two poles are the servo
    den = np.polymul(np.polymul([1, 2], [1, 5]), np.polymul([1, 30], [1, 50]))
    th = np.r_[1.0, den[-2::-1] / den[-1]]
    got = quartic_to_paper_params(*th)
    assert got.ok
    k, tau, m, ws, zs = got.params
    assert tau == pytest.approx(1 / 7) and m == pytest.approx(10.0)
    assert ws == pytest.approx(np.sqrt(1500)) and zs == pytest.approx(80 / (2 * np.sqrt(1500)))


def test_published_models_are_rejected_with_reason():
    d = json.loads(SEED_JSON.read_text())
    for key in ("eq44_lateral_tf", "eq45_longitudinal_tf"):
        num, den = d[key]["num"][0], np.asarray(d[key]["den"])
        got = quartic_to_paper_params(num / den[-1], *(den[-2::-1] / den[-1]))
        assert not got.ok and "unstable" in got.reason
    assert "a4" in quartic_to_paper_params(1.0, 0.1, 0.01, 0.001, -1e-6).reason


def test_paper_table1_does_not_give_eq44():
    """Finding: Table 1 and eq. (29) do not reproduce eq. (44)/(45) for any S0."""
    d = json.loads(SEED_JSON.read_text())
    for ch, key in (("lateral", "eq44_lateral_tf"), ("longitudinal", "eq45_longitudinal_tf")):
        mom = dict(d["table1_wls_igwo_moments"][ch], S0=0.0)
        num, den = d[key]["num"][0], np.asarray(d[key]["den"])
        x = np.r_[num / den[-1], den[-2::-1] / den[-1]]
        for conv in ("derived", "paper"):
            M, rhs = levy_moment_matrix(LevyMoments(**{k: jnp.asarray(v) for k, v in mom.items()}), conv)
            # rows 2-5 do not involve S0; eq. (44) misses them by more than the RHS itself
            r = np.asarray(M)[2] @ x - np.asarray(rhs)[2]
            assert abs(r) > abs(float(rhs[2]))


def test_fit_from_frequency_response_ignores_masked_nan():
    from jaxgwo._spectral import FrequencyResponse
    from jaxgwo._wls import levy_fit_response

    h = np.asarray(paper_model_response(TRUTH, W)).copy()
    coh = np.ones(W.size)
    coh[:10] = 0.1  # masked out ...
    h[:10] = np.nan  # ... and not even finite there
    fr = FrequencyResponse.from_complex(W, jnp.asarray(h), jnp.asarray(coh))
    fit = levy_fit_response(fr)
    np.testing.assert_allclose(np.asarray(fit.theta), _true_theta(), rtol=1e-8)
