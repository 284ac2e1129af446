"""Stage 7 metrics against hand computations, closed forms and Monte Carlo."""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest
import scipy.optimize

from jaxgwo._cost import CiferObjective
from jaxgwo._metrics import parameter_uncertainty, r_squared, rms_error, theil_inequality
from jaxgwo._models import PaperModel, ParameterMap
from jaxgwo._spectral import FrequencyResponse


def test_r2_tic_rms_by_hand():
    y = jnp.array([1.0, 2.0, 3.0, 4.0])
    yh = jnp.array([1.1, 1.9, 3.2, 3.8])
    # SSE = 0.10, SST = 5  ->  R^2 = 0.98
    assert float(r_squared(y, yh)) == pytest.approx(0.98, rel=1e-12)
    assert float(rms_error(y, yh)) == pytest.approx(np.sqrt(0.1 / 4), rel=1e-12)
    tic = np.sqrt(0.1 / 4) / (np.sqrt(30 / 4) + np.sqrt(29.5 / 4))  # = 0.028989...
    assert float(theil_inequality(y, yh)) == pytest.approx(tic, rel=1e-12)
    assert float(theil_inequality(y, y)) == 0.0 and float(r_squared(y, y)) == 1.0
    assert float(theil_inequality(y, -y)) == pytest.approx(1.0)


def test_linear_problem_cr_equals_closed_form():
    rng = np.random.default_rng(0)
    a = rng.standard_normal((30, 3))
    y = rng.standard_normal(30)
    theta = jnp.asarray(np.linalg.lstsq(a, y, rcond=None)[0])
    res = lambda th: jnp.asarray(a) @ th - jnp.asarray(y)  # noqa: E731
    unc = parameter_uncertainty(res, theta, ("x", "y", "z"), noise_variance=0.25)
    ref = np.sqrt(np.diag(0.25 * np.linalg.inv(a.T @ a)))
    np.testing.assert_allclose(np.asarray(unc.cramer_rao), ref, rtol=1e-10)
    np.testing.assert_allclose(np.asarray(unc.insensitivity), np.sqrt(0.25 / np.diag(a.T @ a)),
                               rtol=1e-10)
    # a posteriori sigma^2 = SSE/(m - p)
    est = parameter_uncertainty(res, theta)
    assert float(est.noise_variance) == pytest.approx(np.sum((a @ np.asarray(theta) - y) ** 2) / 27)
    assert np.all(np.asarray(unc.insensitivity) <= np.asarray(unc.cramer_rao) + 1e-15)


def test_nonlinear_cr_against_finite_differences_and_monte_carlo():
    t = np.linspace(0.0, 3.0, 30)
    true = np.array([2.0, 1.3])
    sigma = 0.05
    model = lambda th, tt: th[0] * jnp.exp(-th[1] * tt)  # noqa: E731
    y0 = np.asarray(model(jnp.asarray(true), jnp.asarray(t)))
    res = lambda th: model(th, jnp.asarray(t)) - jnp.asarray(y0)  # noqa: E731
    unc = parameter_uncertainty(res, jnp.asarray(true), ("a", "b"), noise_variance=sigma**2)
    # finite-difference Jacobian reference for the Fisher information
    h = 1e-6
    jfd = np.stack([(np.asarray(res(jnp.asarray(true + h * e))) -
                     np.asarray(res(jnp.asarray(true - h * e)))) / (2 * h) for e in np.eye(2)], 1)
    np.testing.assert_allclose(np.asarray(unc.fisher), jfd.T @ jfd / sigma**2, rtol=1e-7)
    # Monte Carlo: 300 noisy fits; sample std within 15% of the bound (std of a std
    # estimate from 300 draws is ~4%, plus mild nonlinearity)
    rng = np.random.default_rng(1)
    fits = []
    for _ in range(300):
        yn = y0 + sigma * rng.standard_normal(t.size)
        f = scipy.optimize.least_squares(lambda th: th[0] * np.exp(-th[1] * t) - yn, true)
        fits.append(f.x)
    np.testing.assert_allclose(np.std(fits, axis=0), np.asarray(unc.cramer_rao), rtol=0.15)


def test_cifer_uncertainty_shapes_and_percent():
    truth = jnp.array([-500.0, 0.1, 150.0, 40.0, 0.7])
    w = jnp.geomspace(1.0, 60.0, 60)
    rng = np.random.default_rng(2)
    h = np.asarray(PaperModel.from_array(truth).frequency_response(w))
    h = h * (1 + 0.03 * (rng.standard_normal(h.size) + 1j * rng.standard_normal(h.size)))
    fr = FrequencyResponse.from_complex(w, jnp.asarray(h))
    m = PaperModel.from_array(truth)
    obj = CiferObjective.from_response(fr, ParameterMap.for_model(m))
    unc = parameter_uncertainty(obj.residuals_from_params, m.to_array(), m.names)
    d = unc.as_dict()
    assert set(d) == {"K", "tau", "M", "omega_s", "zeta_s"}
    cr = np.asarray(unc.cramer_rao_percent)
    assert np.all(np.isfinite(cr)) and np.all(cr > 0) and np.all(cr < 50)
    np.testing.assert_allclose(cr, 100 * np.asarray(unc.cramer_rao) / np.abs(np.asarray(truth)))
    # the residual Jacobian through the fast paper path equals finite differences
    res = eqx.filter_jit(obj.residuals_from_params)
    jr = np.asarray(eqx.filter_jit(lambda o, th: jax.jacfwd(o.residuals_from_params)(th))(obj, truth))
    e = 1e-6 * np.asarray(truth)
    col0 = (np.asarray(res(truth.at[0].add(e[0]))) - np.asarray(res(truth.at[0].add(-e[0])))) / (2 * e[0])
    np.testing.assert_allclose(jr[:, 0], col0, rtol=1e-5, atol=1e-9)


def _weighted_linear_problem(seed=3, m=40):
    """Linear least squares with CIFER-like mismatched weights: residual ``r = sqrt(w)
    (a theta - y)`` but noise standard deviation ``s`` unrelated to ``1/sqrt(w)``."""
    rng = np.random.default_rng(seed)
    a = rng.standard_normal((m, 3))
    wts = rng.uniform(0.3, 1.0, m)
    s = np.where(np.arange(m) < m // 2, 0.02, 0.2)  # half the points ten times noisier
    return a, wts, s


def test_sandwich_equals_numpy_and_monte_carlo():
    a, wts, s = _weighted_linear_problem()
    theta0 = np.array([1.0, -2.0, 0.5])
    y0 = a @ theta0
    aw = np.sqrt(wts)[:, None] * a
    res = lambda th: jnp.sqrt(jnp.asarray(wts)) * (jnp.asarray(a) @ th - jnp.asarray(y0))  # noqa: E731
    v = wts * s**2  # variance of each weighted residual
    unc = parameter_uncertainty(res, jnp.asarray(theta0), ("x", "y", "z"), residual_variance=v)
    # independent reference: the sandwich in plain NumPy
    ai = np.linalg.inv(aw.T @ aw)
    ref = ai @ (aw.T @ (v[:, None] * aw)) @ ai
    np.testing.assert_allclose(np.asarray(unc.covariance), ref, rtol=1e-10)
    np.testing.assert_allclose(np.asarray(unc.fisher), np.linalg.inv(ref), rtol=1e-8)
    np.testing.assert_allclose(np.asarray(unc.insensitivity), 1 / np.sqrt(np.diag(np.linalg.inv(ref))),
                               rtol=1e-8)
    # Monte Carlo: the weighted LS estimate's scatter over 4000 noise draws matches; the
    # relative std of a standard-deviation estimate from 4000 draws is ~1.1 %, so 5 %
    rng = np.random.default_rng(4)
    ys = y0[None, :] + s[None, :] * rng.standard_normal((4000, y0.size))
    est = np.linalg.solve(aw.T @ aw, aw.T @ (np.sqrt(wts)[None, :] * ys).T).T
    np.testing.assert_allclose(est.std(axis=0, ddof=1), np.asarray(unc.cramer_rao), rtol=0.05)
    # ... which the residual-variance (J/(m-p)) convention, fed the true mean variance,
    # misses by far more than that: the sandwich is what makes the bound right here
    naive = parameter_uncertainty(res, jnp.asarray(theta0), noise_variance=float(np.mean(v)))
    assert np.max(np.abs(np.asarray(naive.cramer_rao) / est.std(axis=0, ddof=1) - 1)) > 0.2


def test_sandwich_with_equal_variances_is_the_classical_bound():
    a, wts, _ = _weighted_linear_problem(seed=5)
    res = lambda th: jnp.sqrt(jnp.asarray(wts)) * (jnp.asarray(a) @ th)  # noqa: E731
    th = jnp.asarray([0.3, 0.2, 0.1])
    sand = parameter_uncertainty(res, th, residual_variance=np.full(wts.size, 0.01))
    classic = parameter_uncertainty(res, th, noise_variance=0.01)
    np.testing.assert_allclose(np.asarray(sand.cramer_rao), np.asarray(classic.cramer_rao), rtol=1e-10)
    assert float(sand.noise_variance) == pytest.approx(0.01)


def test_cifer_residual_variances_match_monte_carlo():
    """Complex noise of relative size eps on |H| and eps rad on the phase gives the
    residual variances ``CiferObjective.residual_variances`` states (small-eps limit)."""
    truth = jnp.array([-500.0, 0.1, 150.0, 40.0, 0.7])
    w = jnp.geomspace(1.0, 60.0, 40)
    m = PaperModel.from_array(truth)
    h = np.asarray(m.frequency_response(w))
    coh = np.linspace(0.65, 0.99, w.size)
    eps = np.sqrt(1 - coh) / np.sqrt(coh) / np.sqrt(2 * 20)  # n_d = 20
    obj = CiferObjective.from_response(FrequencyResponse.from_complex(w, jnp.asarray(h), jnp.asarray(coh)),
                                       ParameterMap.for_model(m))
    rng = np.random.default_rng(6)
    scale = 1e-3 / eps.max()  # keep the linearisation exact to ~1e-3
    z = rng.standard_normal((3000, w.size)) + 1j * rng.standard_normal((3000, w.size))
    hm = h[None, :] * np.exp(scale * eps * z)  # log-|H| and phase errors ~ N(0, (scale eps)^2)
    with_data = lambda o, hh: eqx.tree_at(  # noqa: E731  the measured dB and phase swapped in
        lambda q: (q.magnitude_db, q.phase_deg), o,
        (20 * jnp.log10(jnp.abs(hh)), jnp.rad2deg(jnp.angle(hh))))
    draws = jax.vmap(lambda hh: with_data(obj, hh).residuals_from_params(m.to_array()))(jnp.asarray(hm))
    var = np.asarray(obj.residual_variances(jnp.asarray(scale * eps)))
    # variance of a variance estimate from 3000 draws: ~2.6 % relative; 5 sigma
    np.testing.assert_allclose(np.var(draws, axis=0), var, rtol=0.13)


def test_cifer_sandwich_bound_matches_scatter_of_nonlinear_fits():
    """The paper model fitted by Levenberg-Marquardt to 200 responses with random error
    of known size (noise as in the test above, n_d = 20, coherence 0.65-0.99): the
    scatter of the estimates matches the sandwich bound, not J/(m-p) times the Hessian."""
    truth = jnp.array([-500.0, 0.1, 150.0, 40.0, 0.7])
    m = PaperModel.from_array(truth)
    w = jnp.geomspace(1.0, 60.0, 50)
    h = np.asarray(m.frequency_response(w))
    coh = np.linspace(0.99, 0.65, w.size)  # worse at high frequency, as in flight data
    eps = np.sqrt(1 - coh) / np.sqrt(coh) / np.sqrt(2 * 20)
    obj = CiferObjective.from_response(FrequencyResponse.from_complex(w, jnp.asarray(h), jnp.asarray(coh)),
                                       ParameterMap.for_model(m))

    @jax.jit
    def fun_jac(th, db, ph):
        o = eqx.tree_at(lambda q: (q.magnitude_db, q.phase_deg), obj, (db, ph))
        return o.residuals_from_params(th), jax.jacfwd(o.residuals_from_params)(th)

    rng = np.random.default_rng(7)
    t0 = np.asarray(truth)
    fits = []
    for _ in range(200):
        z = rng.standard_normal(w.size) + 1j * rng.standard_normal(w.size)
        hm = h * np.exp(eps * z)
        db, ph = jnp.asarray(20 * np.log10(np.abs(hm))), jnp.asarray(np.degrees(np.angle(hm)))
        f = scipy.optimize.least_squares(
            lambda th: np.asarray(fun_jac(jnp.asarray(th), db, ph)[0]), t0,
            jac=lambda th: np.asarray(fun_jac(jnp.asarray(th), db, ph)[1]), method="lm")
        fits.append(f.x)
    spread = np.std(fits, axis=0, ddof=1)
    unc = parameter_uncertainty(obj.residuals_from_params, truth,
                                residual_variance=obj.residual_variances(jnp.asarray(eps)))
    # std of a std estimate from 200 draws ~5 %, plus nonlinearity at eps up to 9 %: 20 %
    np.testing.assert_allclose(spread, np.asarray(unc.cramer_rao), rtol=0.2)
    # the classical bound with the true mean variance misses some parameter by > 20 %
    naive = parameter_uncertainty(obj.residuals_from_params, truth,
                                  noise_variance=float(np.mean(obj.residual_variances(jnp.asarray(eps)))))
    assert np.max(np.abs(np.asarray(naive.cramer_rao) / spread - 1)) > 0.2
