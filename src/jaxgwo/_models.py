r"""Stage 4: the identified models as frozen equinox modules.

* :class:`PaperModel` -- the paper's physical structure, eqs. (14)-(16):

  .. math::

      G(s) = \frac{K}{s^2 + s/\tau + M}\,\frac{\omega_s^2}{s^2 + 2\zeta_s\omega_s s + \omega_s^2}.

  **Identifiability.**  :math:`G` is unchanged when the two quadratics swap roles
  (:math:`\tau \leftrightarrow 1/(2\zeta_s\omega_s)`, :math:`M \leftrightarrow
  \omega_s^2`, :math:`K \to K\omega_s^2/M`), so every transfer function has two
  parameter vectors.  The canonical one (:func:`canonicalize_paper_params`) has the
  **servo as the faster pair**, :math:`\omega_s \ge \sqrt{M}`: the actuator bandwidth of
  a small helicopter's servos (tens of rad/s) is above the rotor/fuselage mode.

* :class:`QuarticModel` -- :math:`b_0/(a_4 s^4 + a_3 s^3 + a_2 s^2 + a_1 s + 1)`, eq. (28).

Both expose ``frequency_response(w)``, ``numerator``/``denominator`` (s-polynomials,
highest power first), ``params`` (names to floats), ``to_scipy()``, ``to_control()`` and
``simulate(t, u)`` (zero-order-hold time response, equal to
``scipy.signal.lsim(..., interp=False)``; pure JAX, so it ``vmap``\ s over a batch of
models).  :class:`ParameterMap` maps a model to and from the flat vector the optimiser
searches (logarithms of the positive parameters).
"""

from __future__ import annotations

from typing import Literal

import equinox as eqx
import jax
import jax.numpy as jnp
import jax.scipy.linalg
import numpy as np
from jaxtyping import Array, Complex, Float

from ._aot import cached_jit
from ._transfer import PAPER_PARAM_NAMES, paper_model_coefficients, paper_model_response
from ._wls import quartic_to_paper_params

__all__ = [
    "PaperModel",
    "QuarticModel",
    "PhysicalDerivatives",
    "canonicalize_paper_params",
    "paper_model_from_physical",
    "simulate_transfer_function",
    "simulate_transfer_function_delayed",
    "ParameterMap",
    "QUARTIC_PARAM_NAMES",
]

QUARTIC_PARAM_NAMES = ("b0", "a1", "a2", "a3", "a4")


def _jw(w):
    return jax.lax.complex(jnp.zeros_like(w), w)


def _scaled_realisation(numerator, denominator, t):
    """The frequency-scaled system's controllable canonical form as the augmented
    ``[[A, B], [0, 0]]``, with ``C``, the feedthrough ``D`` and the sample step in scaled
    time (:func:`simulate_transfer_function`)."""
    den = jnp.asarray(denominator, dtype=float)
    num = jnp.asarray(numerator, dtype=float)
    n = den.shape[0] - 1
    num = jnp.concatenate([jnp.zeros(n + 1 - num.shape[0]), num])  # pad to length n+1
    lead = den[0]
    w0 = jnp.abs(den[-1] / lead) ** (1.0 / n)
    w0 = jnp.where(jnp.isfinite(w0) & (w0 > 0), w0, 1.0)
    # coefficient of s^k scaled by w0^k / (lead w0^n): monic in sigma
    powers = jnp.arange(n, -1, -1, dtype=float)
    scale = w0**powers / (lead * w0**n)
    dens = den * scale
    nums = num * scale
    d_feed = nums[0]  # direct feedthrough (dens[0] == 1)
    c_num = nums[1:] - d_feed * dens[1:]  # strictly proper remainder
    # controllable canonical form: x' = A x + B u, y = C x + D u
    A = jnp.zeros((n, n)).at[0, :].set(-dens[1:]).at[1:, :-1].set(jnp.eye(n - 1))
    B = jnp.zeros((n, 1)).at[0, 0].set(1.0)
    aug = jnp.zeros((n + 1, n + 1)).at[:n, :n].set(A).at[:n, n:].set(B)
    return aug, c_num, d_feed, (t[1] - t[0]) * w0


@jax.jit
def simulate_transfer_function(
    numerator: Float[Array, " m1"],
    denominator: Float[Array, " n1"],
    t: Float[Array, " time"],
    u: Float[Array, " time"],
) -> Float[Array, " time"]:
    r"""Zero-order-hold response of ``numerator/denominator`` to samples ``u`` at times ``t``.

    Equals ``scipy.signal.lsim((num, den), u, t, interp=False)[1]`` from rest.  ``t`` must
    be uniformly spaced (the step is ``t[1] - t[0]``); the system must be proper.  The
    realisation is the controllable canonical form of the *frequency-scaled* system
    (:math:`s = \omega_0\sigma`, :math:`\omega_0 = |a_0/a_n|^{1/n}`), so its entries are
    O(1) even when the coefficients span many decades; ZOH discretisation is invariant to
    that time scaling.  Discretisation by the matrix exponential of the augmented
    :math:`[[A, B], [0, 0]]\,\Delta t`, then a ``lax.scan`` over samples.
    """
    aug, C, d_feed, dt = _scaled_realisation(numerator, denominator, t)
    n = aug.shape[0] - 1
    e = jax.scipy.linalg.expm(aug * dt)
    Ad, Bd = e[:n, :n], e[:n, n]

    def step(x, uk):
        return Ad @ x + Bd * uk, C @ x + d_feed * uk

    _, y = jax.lax.scan(step, jnp.zeros(n), jnp.asarray(u, dtype=float))
    return y


@jax.jit
def simulate_transfer_function_delayed(
    numerator: Float[Array, " m1"],
    denominator: Float[Array, " n1"],
    t: Float[Array, " time"],
    u: Float[Array, " time"],
    delay: Float[Array, ""],
) -> Float[Array, " time"]:
    r"""Response of ``numerator/denominator`` to the zero-order-held samples ``u`` delayed
    by ``delay`` seconds (zero before the record), exact at the sample times.

    With :math:`\tau = (k + f)\,\Delta t`, :math:`0 \le f < 1`, the held input is
    ``u[j - k - 1]`` over the first :math:`f\,\Delta t` of sample interval ``j`` and
    ``u[j - k]`` over the rest, so (the modified z-transform)

    .. math:: x_{j+1} = e^{A\Delta t} x_j + \Gamma((1-f)\Delta t)\,u_{j-k}
              + e^{A(1-f)\Delta t}\,\Gamma(f\Delta t)\,u_{j-k-1},
              \qquad \Gamma(h) = \int_0^h e^{A\sigma} d\sigma\, B,

    both from matrix exponentials of the augmented :math:`[[A, B], [0, 0]]`
    (:func:`simulate_transfer_function`'s realisation).  At ``f = 0`` it is that function
    on ``u`` shifted by ``k`` samples.  Linear interpolation of the samples (the interval
    average of the delayed input) has a kink at every whole sample of delay, where an
    output-error fit of the delay can stop; this response is smooth in ``delay`` there
    (continuously differentiable where the relative degree is at least two, as for the
    paper model).
    """
    aug, C, d_feed, dt = _scaled_realisation(numerator, denominator, t)
    n = aug.shape[0] - 1
    s = jnp.asarray(delay, dtype=float) / (t[1] - t[0])
    k = jnp.floor(s)
    f = s - k
    e_late = jax.scipy.linalg.expm(aug * ((1.0 - f) * dt))
    e_early = jax.scipy.linalg.expm(aug * (f * dt))
    Ad = e_late[:n, :n] @ e_early[:n, :n]
    b_now, b_prev = e_late[:n, n], e_late[:n, :n] @ e_early[:n, n]
    u = jnp.asarray(u, dtype=float)
    idx = jnp.arange(u.shape[0]) - k.astype(jnp.arange(0).dtype)

    def shifted(i):
        return jnp.where(i >= 0, u[jnp.clip(i, 0, u.shape[0] - 1)], 0.0)

    u_now, u_prev = shifted(idx), shifted(idx - 1)
    u_at_sample = jnp.where(f > 0.0, u_prev, u_now)  # the held input at the sample instant itself

    def step(x, uk):
        now, prev, at = uk
        return Ad @ x + b_now * now + b_prev * prev, C @ x + d_feed * at

    _, y = jax.lax.scan(step, jnp.zeros(n), (u_now, u_prev, u_at_sample))
    return y


# the same program, kept across runs by the CLI (jaxgwo._aot); simulate_transfer_function
# itself stays a plain jax.jit function (its .lower and friends are public)
_simulate_cached = cached_jit(simulate_transfer_function,
                              name="jaxgwo._models.simulate_transfer_function")


class _TransferModel(eqx.Module):
    """Shared behaviour: exports and simulation from ``numerator``/``denominator``."""

    def to_scipy(self):
        """``scipy.signal.TransferFunction`` (continuous)."""
        import scipy.signal

        return scipy.signal.TransferFunction(
            np.asarray(self.numerator), np.asarray(self.denominator)
        )

    def to_control(self):
        """``control.TransferFunction``; needs python-control (``pip install control``)."""
        try:
            import control
        except ImportError as exc:  # pragma: no cover - depends on the environment
            raise ImportError(
                "python-control is not installed; `pip install control` "
                "(or `pip install jaxgwo[control]`) to use to_control()"
            ) from exc
        return control.tf(np.asarray(self.numerator), np.asarray(self.denominator))

    def simulate(self, t: Float[Array, " time"], u: Float[Array, " time"]) -> Float[Array, " time"]:
        """ZOH output for input samples ``u`` at uniform times ``t`` (see
        :func:`simulate_transfer_function`; equals ``scipy.signal.lsim(..., interp=False)``)."""
        return _simulate_cached(self.numerator, self.denominator, t, u)


def canonicalize_paper_params(p: Float[Array, " 5"]) -> Float[Array, " 5"]:
    r"""Resolve the factor-swap alias: return the parameters with :math:`\omega_s \ge \sqrt{M}`.

    If the rotor/fuselage pair is faster, the quadratics are swapped:
    :math:`(K, \tau, M, \omega_s, \zeta_s) \to (K\omega_s^2/M,\ 1/(2\zeta_s\omega_s),\
    \omega_s^2,\ \sqrt M,\ 1/(2\tau\sqrt M))`, which leaves :math:`G(s)` unchanged.
    Pure JAX (``vmap``-able); vectors with :math:`M \le 0` are returned as they are.
    """
    k, tau, m, ws, zs = p[0], p[1], p[2], p[3], p[4]
    wr = jnp.sqrt(jnp.maximum(m, 0.0))
    safe_m = jnp.where(m > 0, m, 1.0)
    safe_wr = jnp.where(m > 0, wr, 1.0)
    swapped = jnp.stack(
        [k * ws**2 / safe_m, 1.0 / (2.0 * zs * ws), ws**2, wr, 1.0 / (2.0 * tau * safe_wr)]
    )
    return jnp.where((m > 0) & (wr > ws), swapped, p)


# One compiled program instead of a dozen operations dispatched one by one (each of which
# compiles in a fresh process).  Bit-identical: the function multiplies, divides, takes
# square roots and selects, and never adds, so XLA has no multiply-add to fuse.
_canonicalize_jit = jax.jit(canonicalize_paper_params)


class PhysicalDerivatives(eqx.Module):
    r"""The paper's physical quantities (Table 2) from a :class:`PaperModel`, eqs. (10)-(16).

    With the geometry constants given, :math:`1/\tau = 1/\tau_{sp}` and
    :math:`M = L_{b_1}(\tau_m + B_{d_1}\tau_{sp})/\tau_{sp}` give
    :math:`\tau_{sp}` and ``rotor_derivative`` :math:`L_{b_1}`;
    :math:`K = L_{b_1}(B_{lat} + B_{d_1}D_{lat})/\tau_{sp}` gives a second, independent
    estimate ``rotor_derivative_from_gain``.  The two agree only if the geometry constants
    fit the data; their ratio is a consistency check.  Longitudinal: :math:`M_{a_1}`,
    :math:`\tau_{sq}`, :math:`A_{c_1}`, :math:`A_{lon}`, :math:`C_{lon}`.
    """

    channel: str = eqx.field(static=True)
    rotor_derivative: Float[Array, ""]
    rotor_derivative_from_gain: Float[Array, ""]
    stabilizer_time_constant: Float[Array, ""]

    def as_dict(self) -> dict[str, float]:
        d, t = ("L_b1", "tau_sp") if self.channel == "lateral" else ("M_a1", "tau_sq")
        return {
            d: float(self.rotor_derivative),
            f"{d}_from_gain": float(self.rotor_derivative_from_gain),
            t: float(self.stabilizer_time_constant),
        }


class PaperModel(_TransferModel):
    """Paper model, eqs. (15)-(16): ``K/(s^2 + s/tau + M) * ws^2/(s^2 + 2 zs ws s + ws^2)``.

    Units: ``K`` in output/input times rad^2/s^2, ``tau`` s, ``M`` rad^2/s^2, ``omega_s``
    rad/s, ``zeta_s`` dimensionless.  Fields are array leaves (scalars, or a batch).
    """

    K: Float[Array, "*batch"]
    tau: Float[Array, "*batch"]
    M: Float[Array, "*batch"]
    omega_s: Float[Array, "*batch"]
    zeta_s: Float[Array, "*batch"]

    names = PAPER_PARAM_NAMES

    @classmethod
    def from_array(cls, p: Float[Array, "*batch 5"]) -> "PaperModel":
        p = jnp.asarray(p, dtype=float)
        return cls(*(p[..., i] for i in range(5)))

    def to_array(self) -> Float[Array, "*batch 5"]:
        return jnp.stack([self.K, self.tau, self.M, self.omega_s, self.zeta_s], axis=-1)

    @property
    def params(self) -> dict[str, float]:
        return {k: float(v) for k, v in zip(self.names, self.to_array())}

    @property
    def numerator(self) -> Float[Array, " 1"]:
        return paper_model_coefficients(self.to_array())[0]

    @property
    def denominator(self) -> Float[Array, " 5"]:
        return paper_model_coefficients(self.to_array())[1]

    def frequency_response(self, w: Float[Array, " freq"]) -> Complex[Array, " freq"]:
        """``G(j w)``, w in rad/s (:func:`jaxgwo._transfer.paper_model_response`)."""
        return paper_model_response(self.to_array(), jnp.asarray(w, dtype=float))

    def canonical(self) -> "PaperModel":
        """The same transfer function with the servo as the faster pair."""
        return PaperModel.from_array(_canonicalize_jit(self.to_array()))

    def to_quartic(self) -> "QuarticModel":
        num, den = self.numerator, self.denominator
        c = den[-1]
        return QuarticModel(num[0] / c, den[3] / c, den[2] / c, den[1] / c, den[0] / c)

    @classmethod
    def from_quartic(cls, q: "QuarticModel") -> "PaperModel":
        """Factor a quartic (servo = faster pair); ``ValueError`` with the reason if it
        does not split into two stable quadratics."""
        got = quartic_to_paper_params(*(float(v) for v in q.to_array()))
        if not got.ok:
            raise ValueError(f"quartic has no paper-model form: {got.reason}")
        return cls.from_array(jnp.asarray(got.params))

    def physical_derivatives(
        self,
        tau_m: float,
        stabilizer_gain: float,
        cyclic_gain: float,
        stabilizer_input_gain: float,
        channel: Literal["lateral", "longitudinal"] = "lateral",
    ) -> PhysicalDerivatives:
        """Map to Table 2 given geometry: ``tau_m``, ``B_d1``/``A_c1`` (``stabilizer_gain``),
        ``B_lat``/``A_lon`` (``cyclic_gain``), ``D_lat``/``C_lon`` (``stabilizer_input_gain``).
        Uses the canonical form (eqs. 10, 13, 15, 16)."""
        c = self.canonical()
        tau_sp = c.tau
        lb1 = c.M * tau_sp / (tau_m + stabilizer_gain * tau_sp)
        lb1_gain = c.K * tau_sp / (cyclic_gain + stabilizer_gain * stabilizer_input_gain)
        return PhysicalDerivatives(channel, lb1, lb1_gain, tau_sp)


def paper_model_from_physical(
    rotor_derivative: float,
    stabilizer_time_constant: float,
    tau_m: float,
    stabilizer_gain: float,
    cyclic_gain: float,
    stabilizer_input_gain: float,
    omega_s: float,
    zeta_s: float,
) -> PaperModel:
    """Eq. (15)/(16) forwards: ``L_b1``, ``tau_sp`` and geometry to a :class:`PaperModel`."""
    tsp = stabilizer_time_constant
    k = rotor_derivative * (cyclic_gain + stabilizer_gain * stabilizer_input_gain) / tsp
    m = rotor_derivative * (tau_m + stabilizer_gain * tsp) / tsp
    return PaperModel.from_array(jnp.asarray([k, tsp, m, omega_s, zeta_s], dtype=float))


class QuarticModel(_TransferModel):
    """``b0/(a4 s^4 + a3 s^3 + a2 s^2 + a1 s + 1)``, eq. (28); fields are array leaves."""

    b0: Float[Array, "*batch"]
    a1: Float[Array, "*batch"]
    a2: Float[Array, "*batch"]
    a3: Float[Array, "*batch"]
    a4: Float[Array, "*batch"]

    names = QUARTIC_PARAM_NAMES

    @classmethod
    def from_array(cls, p: Float[Array, "*batch 5"]) -> "QuarticModel":
        p = jnp.asarray(p, dtype=float)
        return cls(*(p[..., i] for i in range(5)))

    def to_array(self) -> Float[Array, "*batch 5"]:
        return jnp.stack([self.b0, self.a1, self.a2, self.a3, self.a4], axis=-1)

    @property
    def params(self) -> dict[str, float]:
        return {k: float(v) for k, v in zip(self.names, self.to_array())}

    @property
    def numerator(self) -> Float[Array, " 1"]:
        return jnp.reshape(self.b0, (1,))

    @property
    def denominator(self) -> Float[Array, " 5"]:
        return jnp.stack([self.a4, self.a3, self.a2, self.a1, jnp.ones_like(self.a1)])

    def frequency_response(self, w: Float[Array, " freq"]) -> Complex[Array, " freq"]:
        """``G(j w)`` in real arithmetic: ``D = (1 - a2 w^2 + a4 w^4) + j w (a1 - a3 w^2)``
        (eqs. 18-19)."""
        w = jnp.asarray(w, dtype=float)
        w2 = w * w
        d_re = 1.0 - self.a2 * w2 + self.a4 * w2 * w2
        d_im = w * (self.a1 - self.a3 * w2)
        mag2 = d_re * d_re + d_im * d_im
        return jax.lax.complex(self.b0 * d_re / mag2, -self.b0 * d_im / mag2)

    def to_paper(self) -> PaperModel:
        """:meth:`PaperModel.from_quartic`."""
        return PaperModel.from_quartic(self)


class ParameterMap(eqx.Module):
    r"""Flat vector :math:`x` <-> model, for the optimiser.

    Component ``i`` is :math:`\log(p_i/\mathrm{sign}_i)` where ``log[i]`` and :math:`p_i`
    otherwise, so a search in :math:`x` keeps positive parameters positive and works in
    relative steps.  The sign of a gain (the paper's lateral gain is negative) is fixed,
    static, and taken from the starting model by :meth:`for_model`.
    """

    kind: str = eqx.field(static=True)
    log: tuple[bool, ...] = eqx.field(static=True)
    signs: tuple[float, ...] = eqx.field(static=True)

    @classmethod
    def for_model(cls, model: PaperModel | QuarticModel) -> "ParameterMap":
        """All five parameters in logs; the gain (``K`` or ``b0``) keeps the model's sign."""
        kind = "paper" if isinstance(model, PaperModel) else "quartic"
        gain = float(model.to_array()[0])
        return cls(kind, (True,) * 5, (1.0 if gain >= 0 else -1.0,) + (1.0,) * 4)

    @property
    def names(self) -> tuple[str, ...]:
        return PAPER_PARAM_NAMES if self.kind == "paper" else QUARTIC_PARAM_NAMES

    @property
    def dim(self) -> int:
        return len(self.log)

    def params_from_vector(self, x: Float[Array, "*batch dim"]) -> Float[Array, "*batch dim"]:
        sg = jnp.asarray(self.signs, dtype=float)
        lg = jnp.asarray(self.log)
        return jnp.where(lg, sg * jnp.exp(x), x)

    def vector_from_params(self, p: Float[Array, "*batch dim"]) -> Float[Array, "*batch dim"]:
        sg = jnp.asarray(self.signs, dtype=float)
        lg = jnp.asarray(self.log)
        return jnp.where(lg, jnp.log(jnp.where(lg, p * sg, 1.0)), p)

    def from_vector(self, x: Float[Array, "*batch dim"]) -> PaperModel | QuarticModel:
        cls = PaperModel if self.kind == "paper" else QuarticModel
        return cls.from_array(self.params_from_vector(x))

    def to_vector(self, model: PaperModel | QuarticModel) -> Float[Array, "*batch dim"]:
        return self.vector_from_params(model.to_array())
