r"""Helicopter plants for the simulator: the paper's model and the Yamaha R-50 hover model.

Both plants are frozen PyTrees whose parameters are array leaves, so a simulation can be
jitted once and vmapped over plant parameters.  Each exposes the same small interface
used by :mod:`jaxgwo._simulate`:

* ``derivative(x, swash, gust, tau_f, lag_floor)``: state derivative given the swashplate
  (servo-output) position of both cyclics ``(2,)``, the gust moment on roll and pitch
  ``(2,)`` (rad/s^2), and the ``rotor_flapping`` lag ``tau_f`` ``(2,)``;
* ``body_rates(x)``, ``attitude(x)``, ``velocity(x)``: ``(p, q)``, ``(phi, theta)`` and
  ``(v, u)``, the quantities a hovering pilot watches;
* ``servo_omega``, ``servo_zeta``: the second-order servo of each cyclic, eq. (14).

**Paper model**, eqs. (15)-(16): per channel ``K/(s^2 + s/tau + M)`` times the servo.  The
state realisation is physical: with ``m`` the rotor moment (rad/s^2) acting on the rate,

.. math::

    \dot p = m_f + d,\qquad \tau_f \dot m_f = m - m_f,\qquad \dot m = -m/\tau - M p + K \delta_s

so a gust moment ``d`` enters where a moment does, and the ``rotor_flapping`` lag ``m_f``
sits *inside* the rotor/fuselage loop, giving ``K/((s^2+s/tau)(tau_f s+1)+M)``.  With
``tau_f`` below the resolvable floor (half an integration step) ``m_f = m`` exactly.

**R-50 hover model** (Mettler, Tischler & Kanade 2002): the 13-state hybrid model of
``data/r50_hover.json`` (coupled flapping ``a, b``, stabilizer bar ``c, d``, heave, yaw
with rate gyro feedback, speed derivatives), plus second-order servos on both cyclics.
Pedal and collective are held at trim.  The ``rotor_flapping`` effect lags the flapping
moments ``L_b b`` and ``M_a a`` acting on ``p`` and ``q``.  The hover is unstable (a mode
near 0.32 rad/s): simulate it with a hold loop (:class:`jaxgwo._simulate.HoldLoop`).
"""

from __future__ import annotations

import functools
import importlib.resources
import json
import warnings
from typing import ClassVar

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Bool, Complex, Float, Int, PRNGKeyArray

__all__ = [
    "PaperPlant",
    "R50Plant",
    "PlantDraw",
    "R50_STATE_NAMES",
    "R50_PARAM_NAMES",
    "PAPER_RANGES",
    "SERVO_RANGES",
    "r50_reference",
    "r50_matrices",
    "r50_frequency_response",
    "paper_params_from_r50",
    "draw_paper_plant",
    "draw_r50_plant",
    "servo_response",
]

GRAVITY_FT_S2 = 32.2


@functools.cache
def _r50_json_text() -> str:
    return importlib.resources.files("jaxgwo").joinpath("data/r50_hover.json").read_text(encoding="utf-8")


def r50_reference() -> dict:
    """The packaged R-50 hover model description (a fresh copy of ``data/r50_hover.json``)."""
    return json.loads(_r50_json_text())


_REF = r50_reference()
R50_STATE_NAMES: tuple[str, ...] = tuple(_REF["state_order"])
R50_PARAM_NAMES: tuple[str, ...] = tuple(_REF["params"])
_IX = {n: i for i, n in enumerate(R50_STATE_NAMES)}
_PX = {n: i for i, n in enumerate(R50_PARAM_NAMES)}
_R50_SERVO = (float(_REF["servo_example"]["wn_rad_s"]), float(_REF["servo_example"]["zeta"]))
del _REF

PAPER_RANGES: dict[str, tuple[float, float]] = {
    "omega_rf": (7.0, 20.0),  # rotor/fuselage natural frequency sqrt(M), rad/s
    "tau": (0.1, 0.5),  # stabilizer-bar time constant, s (R-50: 0.34; paper table 2: 0.105-0.138)
    "static_gain": (0.5, 2.0),  # |K|/M, rad/s per unit cyclic
}
SERVO_RANGES: dict[str, tuple[float, float]] = {
    "omega_s": (25.0, 60.0),  # rad/s
    "zeta_s": (0.4, 0.8),
}


def _f64(x) -> Array:
    return jnp.asarray(x, dtype=jnp.float64)


def _pair(x) -> Array:
    return jnp.broadcast_to(_f64(x), (2,))


def servo_response(w: Float[Array, " freq"], omega_s, zeta_s) -> Complex[Array, " freq"]:
    """Second-order servo, eq. (14): ``omega_s^2 / (s^2 + 2 zeta_s omega_s s + omega_s^2)`` at ``s = j w``."""
    w2 = omega_s * omega_s
    den_re = w2 - w * w
    den_im = 2.0 * zeta_s * omega_s * w
    scale = w2 / (den_re * den_re + den_im * den_im)
    return jax.lax.complex(scale * den_re, -scale * den_im)


def lag_derivative(y, target, tau, floor):
    """Derivative of the lag ``tau y' = target - y``; below ``floor`` the lag is algebraic.

    A lag shorter than half an integration step cannot be resolved by RK4; the caller
    then uses ``target`` directly (:func:`lag_output`) and the state tracks it at rate
    ``1/floor`` so it stays bounded and ready.
    """
    return (target - y) / jnp.maximum(tau, floor)


def lag_output(y, target, tau, floor):
    return jnp.where(tau < floor, target, y)


class PaperPlant(eqx.Module):
    """The paper's per-channel model, eqs. (15)-(16), for both cyclic channels.

    ``lateral`` and ``longitudinal`` are ``(K, tau, M, omega_s, zeta_s)`` (see
    :data:`jaxgwo._transfer.PAPER_PARAM_NAMES`).  States: ``p, m_lat, mf_lat, q, m_lon,
    mf_lon, phi, theta`` (``phi``, ``theta`` only integrate the rates, for a hold loop).
    """

    lateral: Float[Array, " 5"] = eqx.field(converter=_f64)
    longitudinal: Float[Array, " 5"] = eqx.field(converter=_f64)

    n_states: ClassVar[int] = 8
    free_integrators: ClassVar[tuple[int, ...]] = (6, 7)
    """States that are pure integrators of outputs (excluded from stability checks without a hold loop)."""

    @classmethod
    def default(cls) -> PaperPlant:
        """The R-50 reduced to the paper's structure (:func:`paper_params_from_r50`)."""
        return paper_params_from_r50()

    @property
    def params(self) -> Float[Array, "2 5"]:
        return jnp.stack([self.lateral, self.longitudinal])

    @property
    def servo_omega(self) -> Float[Array, "2"]:
        return self.params[:, 3]

    @property
    def servo_zeta(self) -> Float[Array, "2"]:
        return self.params[:, 4]

    def derivative(self, x, swash, gust, tau_f, lag_floor):
        p = self.params
        k, tau, m_coef = p[:, 0], p[:, 1], p[:, 2]
        rate = x[jnp.array([0, 3])]
        m = x[jnp.array([1, 4])]
        mf = x[jnp.array([2, 5])]
        m_eff = lag_output(mf, m, tau_f, lag_floor)
        d_rate = m_eff + gust
        d_m = -m / tau - m_coef * rate + k * swash
        d_mf = lag_derivative(mf, m, tau_f, lag_floor)
        return jnp.stack([d_rate[0], d_m[0], d_mf[0], d_rate[1], d_m[1], d_mf[1], rate[0], rate[1]])

    def body_rates(self, x):
        return x[jnp.array([0, 3])]

    def attitude(self, x):
        return x[jnp.array([6, 7])]

    def velocity(self, x):
        return jnp.zeros((2,), dtype=x.dtype)

    def frequency_response(self, w: Float[Array, " freq"]) -> Complex[Array, "2 freq"]:
        """Analytic on-axis responses ``p/delta_lat`` and ``q/delta_lon`` (servo included)."""
        from ._transfer import paper_model_response

        return jnp.stack([paper_model_response(self.lateral, w), paper_model_response(self.longitudinal, w)])


def r50_matrices(params: Float[Array, " n_params"]) -> tuple[Float[Array, "13 13"], Float[Array, "13 4"]]:
    """``A`` (13x13) and ``B`` (13x4, inputs ``delta_lat, delta_lon, delta_ped, delta_col``) of the R-50.

    Built term by term from the equations in ``data/r50_hover.json`` (``params`` in
    :data:`R50_PARAM_NAMES` order; g = 32.2 ft/s^2).  Comparable to writing the
    equations out by hand with NumPy; the tests check the eigenvalues against the
    file's ``derived_check``.
    """
    P = {n: params[i] for n, i in _PX.items()}
    g = GRAVITY_FT_S2
    A = jnp.zeros((13, 13), dtype=params.dtype)
    B = jnp.zeros((13, 4), dtype=params.dtype)
    terms = [
        ("u", "u", P["Xu"]), ("u", "theta", -g), ("u", "a", P["Xa"]),
        ("v", "v", P["Yv"]), ("v", "phi", g), ("v", "b", P["Yb"]),
        ("p", "u", P["Lu"]), ("p", "v", P["Lv"]), ("p", "b", P["Lb"]), ("p", "w", P["Lw"]),
        ("q", "u", P["Mu"]), ("q", "v", P["Mv"]), ("q", "a", P["Ma"]), ("q", "w", P["Mw"]),
        ("phi", "p", 1.0), ("theta", "q", 1.0),
        ("a", "a", -1.0 / P["Tf"]), ("a", "q", -1.0), ("a", "b", P["Ab"] / P["Tf"]), ("a", "c", P["Ac"] / P["Tf"]),
        ("b", "b", -1.0 / P["Tf"]), ("b", "p", -1.0), ("b", "a", P["Ba"] / P["Tf"]), ("b", "d", P["Bd"] / P["Tf"]),
        ("w", "a", P["Za"]), ("w", "b", P["Zb"]), ("w", "w", P["Zw"]), ("w", "r", P["Zr"]),
        ("r", "v", P["Nv"]), ("r", "p", P["Np"]), ("r", "w", P["Nw"]), ("r", "r", P["Nr"]), ("r", "r_fb", P["Nrfb"]),
        ("r_fb", "r", P["Kr"]), ("r_fb", "r_fb", P["Krfb"]),
        ("c", "c", -1.0 / P["Ts"]), ("c", "q", -1.0),
        ("d", "d", -1.0 / P["Ts"]), ("d", "p", -1.0),
    ]  # fmt: skip
    rows = np.array([_IX[r] for r, _, _ in terms])
    cols = np.array([_IX[c] for _, c, _ in terms])
    A = A.at[rows, cols].add(jnp.stack([jnp.asarray(v, dtype=params.dtype) for _, _, v in terms]))
    inputs = [
        ("a", 0, P["Alat"] / P["Tf"]), ("a", 1, P["Alon"] / P["Tf"]),
        ("b", 0, P["Blat"] / P["Tf"]), ("b", 1, P["Blon"] / P["Tf"]),
        ("w", 3, P["Zcol"]), ("r", 2, P["Nped"]), ("r", 3, P["Ncol"]),
        ("c", 1, P["Clon"] / P["Ts"]), ("d", 0, P["Dlat"] / P["Ts"]),
    ]  # fmt: skip
    rows = np.array([_IX[r] for r, _, _ in inputs])
    cols = np.array([c for _, c, _ in inputs])
    B = B.at[rows, cols].add(jnp.stack([jnp.asarray(v, dtype=params.dtype) for _, _, v in inputs]))
    return A, B


def _r50_nominal_params() -> np.ndarray:
    ref = json.loads(_r50_json_text())["params"]
    return np.array([ref[n] for n in R50_PARAM_NAMES], dtype=np.float64)


class R50Plant(eqx.Module):
    """Yamaha R-50 hover model with second-order cyclic servos.

    ``params`` follows :data:`R50_PARAM_NAMES`; ``servo_omega``/``servo_zeta`` are
    ``(lateral, longitudinal)``.  States: the 13 of :data:`R50_STATE_NAMES`, then the
    ``rotor_flapping`` lagged flapping ``b_f, a_f``.
    """

    params: Float[Array, " n_params"] = eqx.field(converter=_f64)
    servo_omega: Float[Array, "2"] = eqx.field(converter=_pair)
    servo_zeta: Float[Array, "2"] = eqx.field(converter=_pair)

    n_states: ClassVar[int] = 15
    free_integrators: ClassVar[tuple[int, ...]] = ()

    @classmethod
    def default(cls) -> R50Plant:
        """Published R-50 parameters, servo from the file's ``servo_example`` (38.2 rad/s, 0.51)."""
        return cls(params=_r50_nominal_params(), servo_omega=_R50_SERVO[0], servo_zeta=_R50_SERVO[1])

    def param(self, name: str) -> Float[Array, ""]:
        return self.params[_PX[name]]

    def derivative(self, x, swash, gust, tau_f, lag_floor):
        A, B = r50_matrices(self.params)
        x13 = x[:13]
        b, a = x13[_IX["b"]], x13[_IX["a"]]
        flap = jnp.stack([b, a])
        flap_lagged = x[13:15]
        flap_eff = lag_output(flap_lagged, flap, tau_f, lag_floor)
        dx = A @ x13 + B[:, :2] @ swash
        # the lag acts on the flapping moments L_b b and M_a a only (rotor_flapping effect)
        dx = dx.at[_IX["p"]].add(self.param("Lb") * (flap_eff[0] - b) + gust[0])
        dx = dx.at[_IX["q"]].add(self.param("Ma") * (flap_eff[1] - a) + gust[1])
        d_lag = lag_derivative(flap_lagged, flap, tau_f, lag_floor)
        return jnp.concatenate([dx, d_lag])

    def body_rates(self, x):
        return x[jnp.array([_IX["p"], _IX["q"]])]

    def attitude(self, x):
        return x[jnp.array([_IX["phi"], _IX["theta"]])]

    def velocity(self, x):
        return x[jnp.array([_IX["v"], _IX["u"]])]

    def frequency_response(self, w: Float[Array, " freq"]) -> Complex[Array, "freq 2 2"]:
        """See :func:`r50_frequency_response`."""
        return r50_frequency_response(self, w)


def r50_frequency_response(plant: R50Plant, w: Float[Array, " freq"]) -> Complex[Array, "freq 2 2"]:
    """Open-loop ``[p, q]`` / ``[delta_lat, delta_lon]`` of the R-50 with servos, at ``s = j w``.

    ``C (jwI - A)^{-1} B`` times each input's servo; entry ``[f, i, j]`` is output ``i``
    over input ``j``.  Comparable to ``scipy.signal.freqresp`` of the state-space model.
    """
    A, B = r50_matrices(plant.params)
    rows = jnp.array([_IX["p"], _IX["q"]])

    def one(wk):
        s_minus_a = jax.lax.complex(-A, wk * jnp.eye(13, dtype=A.dtype))
        x = jnp.linalg.solve(s_minus_a, B[:, :2].astype(jnp.complex128))
        return x[rows, :] * servo_response(wk, plant.servo_omega, plant.servo_zeta)[None, :]

    return jax.vmap(one)(w)


def paper_params_from_r50(plant: R50Plant | None = None) -> PaperPlant:
    """The paper's eqs. (10) and (13) evaluated with R-50 parameters (``tau_m = T_f``, ``tau_s = T_s``).

    Lateral: ``K = L_b (B_lat + B_d D_lat)/T_s``, ``M = L_b (T_f + B_d T_s)/T_s``;
    longitudinal: ``K = M_a (A_lon + A_c C_lon)/T_s``, ``M = M_a (T_f + A_c T_s)/T_s``;
    ``tau = T_s``.  The servo is the R-50 plant's.  This is the reduced model whose
    structure error the default dataset carries (about 11.9 and 8.0 rad/s modes).
    """
    plant = R50Plant.default() if plant is None else plant
    P = {n: plant.params[i] for n, i in _PX.items()}
    ts, tf = P["Ts"], P["Tf"]
    lat = jnp.stack([
        P["Lb"] * (P["Blat"] + P["Bd"] * P["Dlat"]) / ts, ts, P["Lb"] * (tf + P["Bd"] * ts) / ts,
        plant.servo_omega[0], plant.servo_zeta[0],
    ])  # fmt: skip
    lon = jnp.stack([
        P["Ma"] * (P["Alon"] + P["Ac"] * P["Clon"]) / ts, ts, P["Ma"] * (tf + P["Ac"] * ts) / ts,
        plant.servo_omega[1], plant.servo_zeta[1],
    ])  # fmt: skip
    return PaperPlant(lateral=lat, longitudinal=lon)


# -- parameter draws with stability rejection ------------------------------------------


class PlantDraw(eqx.Module):
    """Result of a random plant draw.

    Attributes:
        plant: the accepted plant (the last candidate when none was stable).
        effects: the accepted effect parameters (:class:`jaxgwo._effects.EffectSet`).
        n_rejected: how many candidates were rejected as unstable or too lightly damped.
        found: whether any candidate passed; ``False`` means ``plant`` is NOT usable.
        max_real: largest eigenvalue real part of the accepted closed loop (rad/s).
        min_damping: smallest damping ratio of its oscillatory modes.
    """

    plant: PaperPlant | R50Plant
    effects: eqx.Module
    n_rejected: Int[Array, ""]
    found: Bool[Array, ""]
    max_real: Float[Array, ""]
    min_damping: Float[Array, ""]


def _uniform(key, lo, hi, shape=()):
    return jax.random.uniform(key, shape, dtype=jnp.float64, minval=lo, maxval=hi)


def _draw_paper_candidate(key, gain_sign):
    ks = jax.random.split(key, 5)
    omega_rf = _uniform(ks[0], *PAPER_RANGES["omega_rf"], (2,))
    tau = _uniform(ks[1], *PAPER_RANGES["tau"], (2,))
    gain = _uniform(ks[2], *PAPER_RANGES["static_gain"], (2,))
    ws = _uniform(ks[3], *SERVO_RANGES["omega_s"], (2,))
    zs = _uniform(ks[4], *SERVO_RANGES["zeta_s"], (2,))
    m = omega_rf * omega_rf
    k = jnp.asarray(gain_sign, dtype=jnp.float64) * gain * m
    p = jnp.stack([k, tau, m, ws, zs], axis=1)
    return PaperPlant(lateral=p[0], longitudinal=p[1])


def _draw_r50_candidate(key, spread):
    k1, k2, k3 = jax.random.split(key, 3)
    nominal = jnp.asarray(_r50_nominal_params())
    scale = _uniform(k1, 1.0 - spread, 1.0 + spread, nominal.shape)
    ws = _uniform(k2, *SERVO_RANGES["omega_s"], (2,))
    zs = _uniform(k3, *SERVO_RANGES["zeta_s"], (2,))
    return R50Plant(params=nominal * scale, servo_omega=ws, servo_zeta=zs)


def _draw_effects(key, names, axis):
    from ._effects import EffectSet, draw_effect_params

    effects = EffectSet()
    for k, name in zip(jax.random.split(key, max(len(names), 1)), names):
        effects = effects.with_effect(name, axis=axis, **draw_effect_params(k, name))
    return effects


@eqx.filter_jit
def _select(key, kind, option, names, axis, hold, max_tries, min_damping, max_real):
    from ._simulate import closed_loop_stability

    keys = jax.random.split(key, max_tries)

    def one(k):
        kp, ke = jax.random.split(k)
        plant = _draw_paper_candidate(kp, option) if kind == "paper" else _draw_r50_candidate(kp, option)
        effects = _draw_effects(ke, names, axis)
        stab = closed_loop_stability(plant, effects, hold)
        ok = (stab.max_real <= max_real) & (stab.min_damping >= min_damping)
        return plant, effects, ok, stab.max_real, stab.min_damping

    plants, effects, ok, mr, md = jax.vmap(one)(keys)
    found = jnp.any(ok)
    idx = jnp.where(found, jnp.argmax(ok), max_tries - 1)
    pick = lambda tree: jax.tree.map(lambda a: a[idx], tree)  # noqa: E731
    return PlantDraw(
        plant=pick(plants), effects=pick(effects), n_rejected=jnp.where(found, idx, max_tries),
        found=found, max_real=mr[idx], min_damping=md[idx],
    )  # fmt: skip


def _report(draw: PlantDraw, what: str) -> PlantDraw:
    if isinstance(draw.n_rejected, jax.core.Tracer):
        return draw  # under jit/vmap the caller reads n_rejected and found
    n = int(draw.n_rejected)
    if not bool(draw.found):
        raise ValueError(f"{what}: no stable candidate in {n} draws; widen the ranges or drop an effect")
    if n:
        warnings.warn(
            f"{what}: rejected {n} unstable or lightly damped candidate(s) before accepting one "
            f"(max real part {float(draw.max_real):.3g} rad/s, min damping {float(draw.min_damping):.3g})",
            stacklevel=3,
        )
    return draw


def draw_paper_plant(
    key: PRNGKeyArray,
    *,
    effects: tuple[str, ...] = (),
    axis: str = "both",
    hold=None,
    gain_sign: tuple[float, float] = (1.0, -1.0),
    max_tries: int = 32,
    min_damping: float = 0.05,
    max_real: float = -0.02,
) -> PlantDraw:
    """Draw a paper plant (and the named effects) from realistic ranges, rejecting unstable ones.

    Ranges: rotor/fuselage mode ``sqrt(M)`` 7-20 rad/s, ``tau`` 0.1-0.5 s, ``|K|/M``
    0.5-2 rad/s per unit, servo 25-60 rad/s with damping 0.4-0.8 (:data:`PAPER_RANGES`,
    :data:`SERVO_RANGES`); effect ranges from :data:`jaxgwo._effects.EFFECTS`.
    ``gain_sign`` is the sign of ``K`` per channel (R-50 convention: forward
    longitudinal stick pitches nose down).  ``max_tries`` candidates are drawn at once
    and the first whose linearised closed loop has every eigenvalue real part
    ``<= max_real`` and every oscillatory mode damped ``>= min_damping`` is kept;
    ``rotor_flapping`` in particular destabilises a stiff rotor/fuselage loop.
    The number rejected is returned in :attr:`PlantDraw.n_rejected` and, outside jit,
    reported with a ``UserWarning``; no stable candidate raises ``ValueError``.
    """
    sign = tuple(float(v) for v in gain_sign)
    draw = _select(key, "paper", sign, tuple(effects), axis, hold, int(max_tries), float(min_damping), float(max_real))
    return _report(draw, "draw_paper_plant")


def draw_r50_plant(
    key: PRNGKeyArray,
    *,
    effects: tuple[str, ...] = (),
    axis: str = "both",
    hold=None,
    spread: float = 0.15,
    max_tries: int = 32,
    min_damping: float = 0.05,
    max_real: float = -0.02,
) -> PlantDraw:
    """Draw an R-50 variant: every parameter scaled by ``U(1 - spread, 1 + spread)``, new servos.

    Stability is judged with the hold loop closed (``hold`` defaults to
    :meth:`jaxgwo._simulate.HoldLoop.r50`), since the bare hover is unstable.  Otherwise as
    :func:`draw_paper_plant`.
    """
    from ._simulate import HoldLoop

    hold = HoldLoop.r50() if hold is None else hold
    draw = _select(key, "r50", float(spread), tuple(effects), axis, hold, int(max_tries), float(min_damping), float(max_real))
    return _report(draw, "draw_r50_plant")

