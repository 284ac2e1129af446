r"""Stage 5: fitness functions, as frozen objectives ``objective(x) -> scalar``.

**CIFER cost** (Tischler & Remple, *Aircraft and Rotorcraft System Identification*,
2nd ed., 2012, sec. 11.3):

.. math::

    J = \frac{20}{n}\sum_{i=1}^{n} W_\gamma(\omega_i)\Bigl[
        (|\hat T| - |T|)_{\mathrm{dB}}^2 + W_p\,(\angle\hat T - \angle T)_{\mathrm{deg}}^2\Bigr],
    \qquad W_p = 0.01745,

    W_\gamma = \bigl[1.58\,(1 - e^{-\gamma_{xy}^2})\bigr]^2 ,

summed over the ``n`` frequencies (20 or more, log-spaced) whose coherence passes the
mask; the phase error is wrapped to (-180, 180] degrees.

*Which exponent.*  In Tischler & Remple :math:`\gamma_{xy}^2` **is** the coherence (the
magnitude-squared coherence, what :func:`scipy.signal.coherence` and
:class:`~jaxgwo._spectral.FrequencyResponse` return), so the issue's
``exp(-coh)`` with ``coh`` = that coherence is the same formula.  The default
``weighting="tischler"`` takes the coherence as given: :math:`e^{-\gamma^2}`.  Reading
``exp(-coh^2)`` literally on the magnitude-squared coherence would square it twice
(:math:`e^{-\gamma^4}`); that variant is available as ``weighting="squared"`` (at
:math:`\gamma^2 = 0.6` it weights 0.23 instead of 0.51), and ``"none"`` gives unit
weights.  At :math:`\gamma^2 = 1` all three give ~1 (0.9976).

**Complex relative error**: :math:`\frac1n\sum W\,|\hat T/T - 1|^2`.

**Time-domain MSE** (paper sec. 3.3, step 1): :math:`\frac1N\sum (y_i - \hat y_i)^2` with
:math:`\hat y` = ``model.simulate(t, u)``.

Every objective is an ``eqx.Module`` whose data are array leaves and whose model
structure (:class:`~jaxgwo._models.ParameterMap`) is static; pass it as an argument to a
``jax.jit``/``eqx.filter_jit`` function and new data of the same shape does not
recompile.  ``objective(x)`` maps a flat vector through the parameter map; ``jax.vmap``
over a pack of vectors (or over a stacked batch of objectives) evaluates them together.
Non-finite values become ``+inf``.  For the paper model the CIFER cost multiplies the two quadratic factors in real
arithmetic and takes one ``log`` and one ``atan2`` per frequency (no complex division;
the phase branch does not matter because the error is wrapped).
"""

from __future__ import annotations

from typing import Literal

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Complex, Float

from ._models import PaperModel, ParameterMap, QuarticModel
from ._spectral import FrequencyResponse

__all__ = [
    "PHASE_WEIGHT",
    "coherence_weight",
    "wrap_degrees",
    "CiferObjective",
    "ComplexErrorObjective",
    "TimeDomainObjective",
    "cifer_cost",
]

PHASE_WEIGHT = 0.01745  # deg^-2 -> dB^2: 1 dB ~ 7.57 deg (Tischler & Remple)
Weighting = Literal["tischler", "squared", "none"]
_LOG10_20 = 20.0 / np.log(10.0)
_RAD2DEG = 180.0 / np.pi


def coherence_weight(coherence: Float[Array, " freq"], weighting: Weighting = "tischler"):
    """Coherence weighting ``W = (1.58 (1 - exp(-g)))^2`` (module docstring for ``g``).

    ``coherence`` is the magnitude-squared coherence.  ``"tischler"``: ``g = coherence``;
    ``"squared"``: ``g = coherence**2``; ``"none"``: ``W = 1``.
    """
    coh = jnp.clip(jnp.asarray(coherence, dtype=float), 0.0, 1.0)
    if weighting == "tischler":
        g = coh
    elif weighting == "squared":
        g = coh * coh
    elif weighting == "none":
        return jnp.ones_like(coh)
    else:
        raise ValueError("weighting must be 'tischler', 'squared' or 'none'")
    return (1.58 * (1.0 - jnp.exp(-g))) ** 2


def wrap_degrees(x: Float[Array, "..."]) -> Float[Array, "..."]:
    """Wrap an angle in degrees to (-180, 180]."""
    return 180.0 - jnp.mod(180.0 - x, 360.0)


def _finite_or_inf(v):
    return jnp.where(jnp.isfinite(v), v, jnp.inf)


def _model_db_phase(pmap: ParameterMap, p, w):
    """Model magnitude (dB) and phase (deg, any branch) at ``w``."""
    if pmap.kind == "paper":
        k, tau, m, ws, zs = p[0], p[1], p[2], p[3], p[4]
        w2 = w * w
        d1_re, d1_im = m - w2, w / tau
        d2_re, d2_im = ws * ws - w2, 2.0 * zs * ws * w
        num = k * ws * ws
        # one complex product of the two factors, then a single log and atan2 per point
        den_re = d1_re * d2_re - d1_im * d2_im
        den_im = d1_re * d2_im + d1_im * d2_re
        db = 0.5 * _LOG10_20 * (jnp.log(num * num) - jnp.log(den_re * den_re + den_im * den_im))
        ph = jnp.where(num < 0, np.pi, 0.0) - jnp.arctan2(den_im, den_re)
        return db, _RAD2DEG * ph
    return _db_phase(QuarticModel.from_array(p).frequency_response(w))


def _db_phase(h):
    """Magnitude (dB) and phase (deg) of a complex response."""
    return 0.5 * _LOG10_20 * jnp.log(h.real**2 + h.imag**2), _RAD2DEG * jnp.angle(h)


def _model_response(pmap: ParameterMap, p, w):
    cls = PaperModel if pmap.kind == "paper" else QuarticModel
    return cls.from_array(p).frequency_response(w)


class _ParameterObjective(eqx.Module):
    """What every objective shares: it is defined on physical parameters
    (``residuals_from_params``, ``cost_from_params``) and evaluated on the optimiser's flat
    vector ``x`` through its ``parameter_map``."""

    parameter_map: eqx.AbstractVar[ParameterMap]

    def residuals_from_params(self, p):
        raise NotImplementedError

    def cost_from_params(self, p):
        raise NotImplementedError

    def residuals(self, x: Float[Array, " dim"]) -> Float[Array, " m"]:
        """Residual vector of the flat vector ``x`` (cost = sum of squares)."""
        return self.residuals_from_params(self.parameter_map.params_from_vector(x))

    def cost(self, model: PaperModel | QuarticModel) -> Float[Array, ""]:
        """The cost of a model object (of the map's kind)."""
        return self.cost_from_params(model.to_array())

    def __call__(self, x: Float[Array, " dim"]) -> Float[Array, ""]:
        """The cost of the flat vector ``x`` (log-parameters, see ``ParameterMap``)."""
        return self.cost_from_params(self.parameter_map.params_from_vector(x))


class CiferObjective(_ParameterObjective):
    """CIFER cost ``J`` of a parameter vector against a measured response (module doc).

    Build with :meth:`from_response`.  ``weight`` already holds ``W_gamma`` times the
    mask, ``n`` the number of passing points; masked points have zero weight and finite
    placeholder data, so the shape is fixed and ``J`` ignores them.
    """

    w: Float[Array, " freq"]
    magnitude_db: Float[Array, " freq"]
    phase_deg: Float[Array, " freq"]
    weight: Float[Array, " freq"]
    n: Float[Array, ""]
    phase_weight: Float[Array, ""]
    parameter_map: ParameterMap

    @classmethod
    def from_response(
        cls,
        response: FrequencyResponse,
        parameter_map: ParameterMap,
        *,
        weighting: Weighting = "tischler",
        phase_weight: float = PHASE_WEIGHT,
        min_points: int = 20,
    ) -> "CiferObjective":
        """Precompute measured dB, phase and weights; ``ValueError`` if fewer than
        ``min_points`` frequencies pass the coherence mask."""
        mask = jnp.asarray(response.mask) & jnp.isfinite(jnp.abs(response.H))
        n = int(jnp.sum(mask))
        if n < min_points:
            raise ValueError(
                f"only {n} frequencies pass the coherence mask; the CIFER cost needs at "
                f"least {min_points}"
            )
        h = jnp.where(mask, response.H, 1.0 + 0.0j)
        return cls(
            w=jnp.asarray(response.w, dtype=float),
            magnitude_db=0.5 * _LOG10_20 * jnp.log(jnp.abs(h) ** 2),
            phase_deg=_RAD2DEG * jnp.angle(h),
            weight=jnp.where(mask, coherence_weight(response.coherence, weighting), 0.0),
            n=jnp.asarray(float(n)),
            phase_weight=jnp.asarray(float(phase_weight)),
            parameter_map=parameter_map,
        )

    def _errors(self, db, ph):
        """Model-minus-measured magnitude (dB) and phase (deg, wrapped) errors."""
        return db - self.magnitude_db, wrap_degrees(ph - self.phase_deg)

    def _residual_vector(self, db, ph) -> Float[Array, " 2freq"]:
        e_db, e_ph = self._errors(db, ph)
        s = jnp.sqrt(20.0 / self.n * self.weight)
        return jnp.concatenate([s * e_db, s * jnp.sqrt(self.phase_weight) * e_ph])

    def _cost(self, db, ph) -> Float[Array, ""]:
        e_db, e_ph = self._errors(db, ph)
        j = 20.0 / self.n * jnp.sum(self.weight * (e_db**2 + self.phase_weight * e_ph**2))
        return _finite_or_inf(j)

    def residuals_from_params(self, p: Float[Array, " dim"]) -> Float[Array, " 2freq"]:
        """Vector ``r`` with ``J = sum(r**2)``: magnitude rows then phase rows."""
        return self._residual_vector(*_model_db_phase(self.parameter_map, p, self.w))

    def cost_from_params(self, p: Float[Array, " dim"]) -> Float[Array, ""]:
        return self._cost(*_model_db_phase(self.parameter_map, p, self.w))

    def residuals_from_response(self, h: Complex[Array, " freq"]) -> Float[Array, " 2freq"]:
        """:meth:`residuals_from_params` of any model given by its complex response ``h``
        on ``self.w`` (for example the paper model times an unmodelled effect)."""
        return self._residual_vector(*_db_phase(h))

    def cost_from_response(self, h: Complex[Array, " freq"]) -> Float[Array, ""]:
        """``J`` of a model given by its complex response ``h`` on ``self.w`` (+inf when
        not finite)."""
        return self._cost(*_db_phase(h))

    def residual_variances(self, random_error: Float[Array, " freq"]) -> Float[Array, " 2freq"]:
        """Variance of each entry of :meth:`residuals_from_params` due to the measured
        response's random error ``eps`` (:func:`jaxgwo._spectral.random_error`).

        ``eps`` is the standard deviation of ``|H|/|H|`` and of the phase in radians
        (Bendat & Piersol), so the magnitude error has ``(20/ln 10) eps`` dB and the phase
        ``(180/pi) eps`` degrees; each is scaled by the residual's weight ``20/n W``
        (and ``W_p`` for phase).  Masked points get 0.  Used for the sandwich Cramer-Rao
        bounds (:func:`jaxgwo._metrics.parameter_uncertainty`): ``W_gamma`` is not the
        inverse of these variances, so ``J``'s Hessian alone misstates the covariance.
        """
        eps = jnp.where(self.weight > 0, jnp.asarray(random_error, dtype=float), 0.0)
        s2 = 20.0 / self.n * self.weight
        return jnp.concatenate([s2 * (_LOG10_20 * eps) ** 2,
                                s2 * self.phase_weight * (_RAD2DEG * eps) ** 2])



class ComplexErrorObjective(_ParameterObjective):
    """Complex relative error ``(1/n) sum W |T_model/T_meas - 1|^2`` (``W`` = mask, or the
    coherence weighting times the mask)."""

    w: Float[Array, " freq"]
    H_re: Float[Array, " freq"]
    H_im: Float[Array, " freq"]
    weight: Float[Array, " freq"]
    n: Float[Array, ""]
    parameter_map: ParameterMap

    @classmethod
    def from_response(
        cls,
        response: FrequencyResponse,
        parameter_map: ParameterMap,
        *,
        weighting: Weighting = "none",
    ) -> "ComplexErrorObjective":
        mask = jnp.asarray(response.mask) & jnp.isfinite(jnp.abs(response.H))
        n = int(jnp.sum(mask))
        if n == 0:
            raise ValueError("no frequency passes the coherence mask")
        h = jnp.where(mask, response.H, 1.0 + 0.0j)
        return cls(
            w=jnp.asarray(response.w, dtype=float),
            H_re=h.real,
            H_im=h.imag,
            weight=jnp.where(mask, coherence_weight(response.coherence, weighting), 0.0),
            n=jnp.asarray(float(n)),
            parameter_map=parameter_map,
        )

    def residuals_from_params(self, p: Float[Array, " dim"]) -> Float[Array, " 2freq"]:
        hm = _model_response(self.parameter_map, p, self.w)
        h = jax.lax.complex(self.H_re, self.H_im)
        e = hm / h - 1.0
        s = jnp.sqrt(self.weight / self.n)
        return jnp.concatenate([s * e.real, s * e.imag])

    def cost_from_params(self, p: Float[Array, " dim"]) -> Float[Array, ""]:
        return _finite_or_inf(jnp.sum(self.residuals_from_params(p) ** 2))



class TimeDomainObjective(_ParameterObjective):
    """The paper's fitness: mean squared error of the simulated output (sec. 3.3)."""

    t: Float[Array, " time"]
    u: Float[Array, " time"]
    y: Float[Array, " time"]
    parameter_map: ParameterMap

    @classmethod
    def from_arrays(cls, t, u, y, parameter_map: ParameterMap) -> "TimeDomainObjective":
        t, u, y = (jnp.asarray(a, dtype=float) for a in (t, u, y))
        if not (t.ndim == 1 and t.shape == u.shape == y.shape and t.shape[0] >= 2):
            raise ValueError("t, u and y must be 1-D arrays of the same length (>= 2)")
        return cls(t=t, u=u, y=y, parameter_map=parameter_map)

    def residuals_from_params(self, p: Float[Array, " dim"]) -> Float[Array, " time"]:
        cls = PaperModel if self.parameter_map.kind == "paper" else QuarticModel
        yhat = cls.from_array(p).simulate(self.t, self.u)
        return (self.y - yhat) / jnp.sqrt(float(self.t.shape[0]))

    def cost_from_params(self, p: Float[Array, " dim"]) -> Float[Array, ""]:
        return _finite_or_inf(jnp.sum(self.residuals_from_params(p) ** 2))



def cifer_cost(
    model: PaperModel | QuarticModel,
    response: FrequencyResponse,
    *,
    weighting: Weighting = "tischler",
    min_points: int = 20,
) -> float:
    """Convenience: CIFER ``J`` of one model against one measured response."""
    obj = CiferObjective.from_response(
        response, ParameterMap.for_model(model), weighting=weighting, min_points=min_points
    )
    return float(obj.cost(model))
