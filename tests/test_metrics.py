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
