"""The paper model's frequency response against scipy.signal.freqs."""

import jax.numpy as jnp
import numpy as np
import scipy.signal as ss

from jaxgwo._transfer import paper_model_coefficients, paper_model_response, polyval_jw

PARAMS = jnp.array([250.0, 0.1, 144.0, 38.2261, 0.5118])
W = jnp.logspace(-1, 2.5, 300)


def test_paper_model_response_matches_scipy():
    num, den = paper_model_coefficients(PARAMS)
    _, ref = ss.freqs(np.asarray(num), np.asarray(den), worN=np.asarray(W))
    got = np.asarray(paper_model_response(PARAMS, W))
    np.testing.assert_allclose(got, ref, rtol=1e-12, atol=0)


def test_coefficients_are_the_product_of_the_two_quadratics():
    K, tau, M, ws, zs = (float(v) for v in PARAMS)
    num, den = paper_model_coefficients(PARAMS)
    ref = np.polymul([1.0, 1.0 / tau, M], [1.0, 2 * zs * ws, ws * ws])
    np.testing.assert_allclose(np.asarray(den), ref, rtol=1e-14)
    np.testing.assert_allclose(np.asarray(num), [K * ws * ws], rtol=1e-14)


def test_polyval_jw_matches_numpy():
    c = jnp.array([2.0, -3.0, 0.5, 7.0, 1.0])
    np.testing.assert_allclose(np.asarray(polyval_jw(c, W)),
                               np.polyval(np.asarray(c), 1j * np.asarray(W)), rtol=1e-14)
