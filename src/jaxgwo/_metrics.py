r"""Stage 7: validation metrics and parameter uncertainty.

**Time-domain fit** of a simulated output :math:`\hat y` to the measured :math:`y`:

* coefficient of determination, paper eq. (46):
  :math:`R^2 = 1 - \sum (y_i - \hat y_i)^2 / \sum (y_i - \bar y)^2`;
* Theil inequality coefficient (Theil 1966; Tischler & Remple sec. 15):
  :math:`\mathrm{TIC} = \sqrt{\tfrac1N\sum(y-\hat y)^2} / \bigl(\sqrt{\tfrac1N\sum y^2} +
  \sqrt{\tfrac1N\sum \hat y^2}\bigr)`, 0 for a perfect fit, 1 at worst (< 0.25-0.3 is a
  good rotorcraft model);
* RMS error :math:`\sqrt{\tfrac1N\sum(y-\hat y)^2}`.

**Parameter uncertainty.**  For a cost written as a sum of squares,
:math:`J(\theta) = \|r(\theta)\|^2` (e.g. :meth:`CiferObjective.residuals_from_params
<jaxgwo._cost.CiferObjective.residuals_from_params>`), the Fisher information is
approximated by the Gauss-Newton form

.. math::  F = \frac{1}{\sigma^2} \, J_r^\top J_r, \qquad J_r = \partial r/\partial\theta

(``jax.jacfwd``).  The Cramer-Rao bound of parameter ``i`` is
:math:`\mathrm{CR}_i = \sqrt{(F^{-1})_{ii}}` (one standard deviation) and Tischler's
insensitivity is :math:`I_i = 1/\sqrt{F_{ii}}` (the standard deviation if all other
parameters were known); both are also given in percent of :math:`|\theta_i|`.
:math:`\sigma^2` is the residual variance: by default estimated after the fit as
:math:`J/(m - p)` (``m`` residuals with non-zero weight, ``p`` parameters), which makes the
bounds statistical one-sigma bounds when the weighted residuals are independent with equal
variance.  ``noise_variance=1.0`` gives Tischler & Remple's formula as written
(:math:`H = J_r^\top J_r` is their Gauss-Newton Hessian of the CIFER cost, without the
factor 2); Tischler's guidelines are :math:`\mathrm{CR} \lesssim 20\%` and
:math:`I \lesssim 10\%`.

**Known residual variances (sandwich).**  When each residual's variance :math:`v_i` is
known (for the CIFER cost, from the measured response's random error:
:meth:`CiferObjective.residual_variances <jaxgwo._cost.CiferObjective.residual_variances>`)
but the cost's weights are not their inverses (CIFER's :math:`W_\gamma` is not), the
least-squares estimate has the covariance

.. math::  C = A^{-1} B A^{-1}, \qquad A = J_r^\top J_r, \quad
           B = J_r^\top \operatorname{diag}(v) J_r

(the Huber-White sandwich with model-based variances; it reduces to
:math:`\sigma^2 A^{-1}` when all :math:`v_i = \sigma^2`).  The Fisher information is then
:math:`F = C^{-1} = A B^{-1} A`.  It describes the scatter from random error only, not a
bias from model-structure error.  Frequency-response points from a spectral estimate
are not independent, so every convention here is a guide, not an exact confidence
interval; ``benchmarks/cr_coverage.py`` measures how well the bounds cover.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import equinox as eqx
import jax
import jax.numpy as jnp
from jaxtyping import Array, Float

from ._aot import cached_jit

__all__ = [
    "r_squared",
    "theil_inequality",
    "rms_error",
    "ParameterUncertainty",
    "fisher_information",
    "parameter_uncertainty",
]


def r_squared(y: Float[Array, " n"], y_hat: Float[Array, " n"]) -> Float[Array, ""]:
    """Coefficient of determination, eq. (46)."""
    y, y_hat = jnp.asarray(y, dtype=float), jnp.asarray(y_hat, dtype=float)
    return 1.0 - jnp.sum((y - y_hat) ** 2) / jnp.sum((y - jnp.mean(y)) ** 2)


def rms_error(y: Float[Array, " n"], y_hat: Float[Array, " n"]) -> Float[Array, ""]:
    """Root-mean-square error (units of ``y``)."""
    y, y_hat = jnp.asarray(y, dtype=float), jnp.asarray(y_hat, dtype=float)
    return jnp.sqrt(jnp.mean((y - y_hat) ** 2))


def theil_inequality(y: Float[Array, " n"], y_hat: Float[Array, " n"]) -> Float[Array, ""]:
    """Theil inequality coefficient, in [0, 1] (module docstring)."""
    y, y_hat = jnp.asarray(y, dtype=float), jnp.asarray(y_hat, dtype=float)
    return rms_error(y, y_hat) / (jnp.sqrt(jnp.mean(y**2)) + jnp.sqrt(jnp.mean(y_hat**2)))


class ParameterUncertainty(eqx.Module):
    """Cramer-Rao bounds and insensitivities of identified parameters (module docstring).

    ``cramer_rao`` and ``insensitivity`` are one-sigma values in the parameters' units;
    the ``*_percent`` fields are relative to ``|values|``.  ``noise_variance`` is the
    :math:`\\sigma^2` used.  Singular information gives ``inf`` bounds.
    """

    names: tuple[str, ...] = eqx.field(static=True)
    values: Float[Array, " p"]
    fisher: Float[Array, "p p"]
    covariance: Float[Array, "p p"]
    cramer_rao: Float[Array, " p"]
    cramer_rao_percent: Float[Array, " p"]
    insensitivity: Float[Array, " p"]
    insensitivity_percent: Float[Array, " p"]
    noise_variance: Float[Array, ""]

    def as_dict(self) -> dict[str, dict[str, float]]:
        """``{name: {value, cr_bound, cr_percent, insensitivity_percent}}``."""
        return {
            n: {
                "value": float(self.values[i]),
                "cr_bound": float(self.cramer_rao[i]),
                "cr_percent": float(self.cramer_rao_percent[i]),
                "insensitivity_percent": float(self.insensitivity_percent[i]),
            }
            for i, n in enumerate(self.names)
        }


def fisher_information(
    residual_fn: Callable[[Float[Array, " p"]], Float[Array, " m"]],
    theta: Float[Array, " p"],
    noise_variance: float | None = None,
) -> tuple[Float[Array, "p p"], Float[Array, ""]]:
    """Gauss-Newton Fisher information ``J_r^T J_r / sigma^2`` and the ``sigma^2`` used.

    ``sigma^2`` defaults to ``||r||^2 / (m - p)`` with ``m`` the number of residuals that
    are not identically zero at ``theta`` (masked frequencies contribute exact zeros).
    """
    theta = jnp.asarray(theta, dtype=float)
    r = residual_fn(theta)
    jr = jax.jacfwd(residual_fn)(theta)
    if noise_variance is None:
        active = jnp.sum(jnp.any(jr != 0.0, axis=1) | (r != 0.0))
        dof = jnp.maximum(active - theta.shape[0], 1)
        sigma2 = jnp.sum(r**2) / dof.astype(float)
    else:
        sigma2 = jnp.asarray(float(noise_variance))
    return jr.T @ jr / sigma2, sigma2


def _equilibrated_inverse(m, d):
    """``m^-1`` computed as ``D^-1 (D^-1 m D^-1)^-1 D^-1`` with ``D = diag(d)``: the
    parameters differ by decades (K ~ 1e2, a4 ~ 1e-6)."""
    ds = jnp.where(d > 0, d, 1.0)
    return jnp.linalg.inv(m / ds[:, None] / ds[None, :]) / ds[:, None] / ds[None, :]


def _sandwich(jr, residual_variance):
    """Fisher information ``A B^-1 A`` and covariance ``A^-1 B A^-1`` (module docstring)."""
    a = jr.T @ jr
    b = jr.T @ (jnp.asarray(residual_variance, dtype=float)[:, None] * jr)
    a_inv = _equilibrated_inverse(a, jnp.sqrt(jnp.diagonal(a)))
    cov = a_inv @ b @ a_inv
    cov = 0.5 * (cov + cov.T)
    return _equilibrated_inverse(cov, jnp.sqrt(jnp.abs(jnp.diagonal(cov)))), cov


@cached_jit
@eqx.filter_jit
def _uncertainty_arrays(residual_fn, theta, noise_variance, residual_variance=None):
    if residual_variance is None:
        fisher, sigma2 = fisher_information(residual_fn, theta, noise_variance)
        d = jnp.sqrt(jnp.diagonal(fisher))
        cov = _equilibrated_inverse(fisher, d)
    else:
        jr = jax.jacfwd(residual_fn)(theta)
        v = jnp.asarray(residual_variance, dtype=float)
        fisher, cov = _sandwich(jr, v)
        active = jnp.any(jr != 0.0, axis=1)
        sigma2 = jnp.sum(jnp.where(active, v, 0.0)) / jnp.maximum(jnp.sum(active), 1).astype(float)
        d = jnp.sqrt(jnp.diagonal(fisher))
    ds = jnp.where(d > 0, d, 1.0)
    var = jnp.diagonal(cov)
    ok = jnp.all(jnp.isfinite(cov)) & jnp.all(d > 0) & jnp.all(var > 0)
    cr = jnp.where(ok, jnp.sqrt(jnp.abs(var)), jnp.inf)
    ins = jnp.where(d > 0, 1.0 / ds, jnp.inf)
    return fisher, sigma2, cov, cr, ins


def parameter_uncertainty(
    residual_fn: Callable[[Float[Array, " p"]], Float[Array, " m"]],
    theta: Float[Array, " p"],
    names: Sequence[str] | None = None,
    noise_variance: float | None = None,
    residual_variance: Float[Array, " m"] | None = None,
) -> ParameterUncertainty:
    """Cramer-Rao bounds and insensitivities at ``theta`` for ``J = ||residual_fn||^2``.

    For the CIFER cost of a fitted model: ``parameter_uncertainty(
    objective.residuals_from_params, model.to_array(), model.names)``; bounds are then
    in the physical parameters (not the optimiser's log-parameters).
    ``residual_variance`` (one variance per residual) selects the sandwich covariance of
    the module docstring; ``noise_variance`` is then ignored and the stored
    ``noise_variance`` is the mean of the variances over the residuals that depend on
    ``theta``.
    """
    theta = jnp.asarray(theta, dtype=float)
    names = tuple(names) if names is not None else tuple(f"p{i}" for i in range(theta.size))
    if residual_variance is not None:
        residual_variance = jnp.asarray(residual_variance, dtype=float)
    fisher, sigma2, cov, cr, ins = _uncertainty_arrays(residual_fn, theta, noise_variance,
                                                       residual_variance)
    scale = 100.0 / jnp.abs(theta)
    return ParameterUncertainty(
        names=names,
        values=theta,
        fisher=fisher,
        covariance=cov,
        cramer_rao=cr,
        cramer_rao_percent=cr * scale,
        insensitivity=ins,
        insensitivity_percent=ins * scale,
        noise_variance=sigma2,
    )
