r"""Frequency responses of the helicopter rate models, as pure JAX functions.

The paper's per-channel model, eqs. (15)-(16), is a rotor/fuselage quadratic times a
second-order servo, eq. (14):

.. math::

    G(s) = \frac{K}{s^2 + s/\tau + M}\;
           \frac{\omega_s^2}{s^2 + 2\zeta_s\omega_s s + \omega_s^2}

with ``params = (K, tau, M, omega_s, zeta_s)``.  For the lateral channel
``K = L_b1 (B_lat + B_d1 D_lat)/tau_sp``, ``1/tau = 1/tau_sp`` and
``M = L_b1 (tau_m + B_d1 tau_sp)/tau_sp``; the longitudinal channel is the same with
``M_a1``, ``A_lon``, ``A_c1``, ``C_lon`` and ``tau_sq``.

Everything here is written in real arithmetic on ``(re, im)`` pairs where that avoids
redundant complex work, and returns complex arrays for the caller.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
from jaxtyping import Array, Complex, Float

PAPER_PARAM_NAMES = ("K", "tau", "M", "omega_s", "zeta_s")


def polyval_jw(coeffs: Float[Array, " n"], w: Float[Array, " freq"]) -> Complex[Array, " freq"]:
    """Evaluate the s-polynomial ``coeffs`` (highest power first) at ``s = j w``.

    Comparable to ``numpy.polyval(coeffs, 1j * w)``.
    """
    # Horner's rule on (re, im): (re + j im)(j w) + c = (c - im w) + j (re w)
    re = jnp.zeros_like(w)
    im = jnp.zeros_like(w)
    for i in range(coeffs.shape[0]):
        re, im = coeffs[i] - im * w, re * w
    return jax.lax.complex(re, im)


def paper_model_response(
    params: Float[Array, " 5"], w: Float[Array, " freq"]
) -> Complex[Array, " freq"]:
    """Frequency response of the paper model, eqs. (15)-(16), at ``s = j w`` (w in rad/s).

    ``params = (K, tau, M, omega_s, zeta_s)``.  The rotor/fuselage factor
    ``K/(s^2 + s/tau + M)`` multiplies the servo ``omega_s^2/(s^2 + 2 zeta_s omega_s s + omega_s^2)``.
    """
    k, tau, m, ws, zs = params[0], params[1], params[2], params[3], params[4]
    w2 = w * w
    # rotor/fuselage denominator: (M - w^2) + j w / tau
    d1_re = m - w2
    d1_im = w / tau
    # servo denominator: (ws^2 - w^2) + j 2 zs ws w
    d2_re = ws * ws - w2
    d2_im = 2.0 * zs * ws * w
    den_re = d1_re * d2_re - d1_im * d2_im
    den_im = d1_re * d2_im + d1_im * d2_re
    num = k * ws * ws
    mag2 = den_re * den_re + den_im * den_im
    scale = num / mag2
    return jax.lax.complex(scale * den_re, -scale * den_im)


def paper_model_coefficients(params: Float[Array, " 5"]) -> tuple[Array, Array]:
    """Numerator and denominator of eqs. (15)-(16) as s-polynomials, highest power first."""
    k, tau, m, ws, zs = params[0], params[1], params[2], params[3], params[4]
    d1 = jnp.stack([jnp.ones_like(tau), 1.0 / tau, m])
    d2 = jnp.stack([jnp.ones_like(ws), 2.0 * zs * ws, ws * ws])
    den = jnp.convolve(d1, d2)
    num = jnp.reshape(k * ws * ws, (1,))
    return num, den
