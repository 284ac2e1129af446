r"""Sim-to-real gap diagnosis, step 3: *which* effect explains the gap, and *how far* it shrinks.

Every candidate of the fixed vocabulary (:data:`jaxgwo._effects.EFFECTS`) is added to the
nominal paper model, refitted, and scored on the held-out records in the time domain.

* **Series and in-loop linear effects** (``time_delay``, ``sensor_lag``,
  ``rotor_flapping``, ``structural_mode`` and pairs of them) are refitted on the CIFER cost
  ``J`` of the identification response: all five paper parameters plus the effect's, in
  one batched call of the project's optimiser (:func:`jaxgwo._gwo.run_batch`) seeded at the
  nominal fit, then polished by ``scipy.optimize.least_squares`` with JAX's Jacobian.  One
  objective, :class:`AugmentedCifer`, serves every candidate: its six effect coordinates
  ``z = (delay_s, log cutoff_hz, tau_f, log freq_hz, log zeta_p, log zeta_z)`` are switched
  on by an ``active`` mask leaf, so candidates of every kind share one compiled search.
* ``cross_coupling`` has no single-input frequency-domain signature (the H1 estimate is
  unbiased when the cyclics are uncorrelated), so its gain is the least-squares
  regression of the time-domain residual on the off-axis input passed through the model.
* **Nonlinear effects** (``rate_limit``, ``backlash``, ``saturation``) are fitted in the
  time domain on the identification records: a second-order servo with the nonlinearity,
  integrated by RK4 (as the simulator does), drives the rotor part; one vmapped call
  evaluates a grid of every candidate's parameter, a bounded scalar search refines it, and
  the output gain is refitted in closed form.

Scores (:class:`CandidateScore`): held-out R^2 and TIC, ``J``, the fraction of the R^2 gap
closed, a BIC on the held-out residuals with the effective number of samples
``n dt / T_c`` (``T_c`` the residual's correlation time), and a block z-score of the
reduction in squared error (blocks of ``4 T_c``, at least 0.5 s).  A candidate *beats noise*
when its z-score exceeds ``z_min``, its BIC improves and it closes at least ``min_gap``
of the gap.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Bool, Float

from . import _gwo as G
from ._cost import CiferObjective, wrap_degrees
from ._effects import EFFECTS, rotor_flapping_response, sensor_lag_response, structural_mode_response, time_delay_response
from ._identify import _jacobian, _residuals  # the jitted residual/Jacobian pair
from ._metrics import r_squared, theil_inequality
from ._models import simulate_transfer_function

__all__ = [
    "FREQUENCY_DOMAIN",
    "NONLINEAR",
    "AugmentedCifer",
    "ModelSpec",
    "simulate_model",
    "fit_linear_candidates",
    "fit_cross_coupling",
    "fit_nonlinear_candidates",
    "score_candidate",
    "CandidateScore",
]

FREQUENCY_DOMAIN = ("time_delay", "sensor_lag", "rotor_flapping", "structural_mode")
NONLINEAR = ("rate_limit", "backlash", "saturation")
_SLOTS = {"time_delay": (0,), "sensor_lag": (1,), "rotor_flapping": (2,), "structural_mode": (3, 4, 5)}
# search box of z, wider than the realistic ranges of _effects.EFFECTS
_Z_LO = np.array([0.0, math.log(2.0), 0.0, math.log(3.0), math.log(0.01), math.log(0.02)])
_Z_HI = np.array([0.15, math.log(100.0), 0.1, math.log(45.0), math.log(0.5), math.log(1.5)])
_Z_NEUTRAL = np.array([0.0, math.log(100.0), 0.0, math.log(10.0), 0.0, 0.0])
_LOG10_20 = 20.0 / math.log(10.0)


def effect_params_from_z(name: str, z) -> dict[str, float]:
    """The named effect's parameters from the six effect coordinates ``z``."""
    z = np.asarray(z, float)
    if name == "time_delay":
        return {"delay_s": float(z[0])}
    if name == "sensor_lag":
        return {"cutoff_hz": float(np.exp(z[1]))}
    if name == "rotor_flapping":
        return {"tau_f": float(z[2])}
    if name == "structural_mode":
        return {"freq_hz": float(np.exp(z[3])), "zeta_p": float(np.exp(z[4])), "zeta_z": float(np.exp(z[5]))}
    raise ValueError(f"{name} is not fitted in the frequency domain")


class AugmentedCifer(eqx.Module):
    r"""CIFER cost ``J`` (as :class:`jaxgwo._cost.CiferObjective`) of the paper model with the
    linear effects selected by ``active``.

    ``x = (log K, log tau, log M, log omega_s, log zeta_s, z_0..z_5)`` on the sign-normalised
    response; inactive effect coordinates leave the response unchanged.
    """

    w: Float[Array, " freq"]
    magnitude_db: Float[Array, " freq"]
    phase_deg: Float[Array, " freq"]
    weight: Float[Array, " freq"]
    n: Float[Array, ""]
    phase_weight: Float[Array, ""]
    active: Bool[Array, " 6"]

    @classmethod
    def from_cifer(cls, objective: CiferObjective, active) -> AugmentedCifer:
        return cls(objective.w, objective.magnitude_db, objective.phase_deg, objective.weight, objective.n,
                   objective.phase_weight, jnp.asarray(active, dtype=bool))  # fmt: skip

    def response(self, x: Float[Array, " 11"]):
        p = jnp.exp(x[:5])
        z = x[5:]
        a = self.active
        one = jnp.ones_like(self.w).astype(jnp.complex128)
        h = rotor_flapping_response(p, self.w, jnp.where(a[2], z[2], 0.0))
        h = h * jnp.where(a[0], time_delay_response(self.w, z[0]), one)
        h = h * jnp.where(a[1], sensor_lag_response(self.w, jnp.exp(z[1])), one)
        sm = structural_mode_response(self.w, jnp.exp(z[3]), jnp.exp(z[4]), jnp.exp(z[5]))
        return h * jnp.where(a[3], sm, one)

    def residuals(self, x: Float[Array, " 11"]) -> Float[Array, " 2freq"]:
        h = self.response(x)
        db = 0.5 * _LOG10_20 * jnp.log(h.real**2 + h.imag**2)
        ph = jnp.rad2deg(jnp.angle(h))
        s = jnp.sqrt(20.0 / self.n * self.weight)
        return jnp.concatenate([s * (db - self.magnitude_db), s * jnp.sqrt(self.phase_weight) * wrap_degrees(ph - self.phase_deg)])

    def __call__(self, x: Float[Array, " 11"]) -> Float[Array, ""]:
        r = self.residuals(x)
        j = jnp.sum(r * r)
        return jnp.where(jnp.isfinite(j), j, jnp.inf)




@dataclass(frozen=True)
class LinearFit:
    """One frequency-domain refit: paper parameters (sign-normalised), effect parameters, J."""

    effects: tuple[str, ...]
    x: np.ndarray
    cost_J: float
    params: dict
    """``{effect: {param: value}}``."""
    sigma: dict
    """``{effect: {param: 1-sigma}}`` from the Jacobian of J (delta method for logs)."""


def _active_mask(names: Sequence[str]) -> np.ndarray:
    act = np.zeros(6, bool)
    for n in names:
        act[list(_SLOTS[n])] = True
    return act


def fit_linear_candidates(
    objective: CiferObjective,
    x_nominal: np.ndarray,
    candidates: Sequence[tuple[str, ...]],
    key,
    *,
    wolves: int = 20,
    iterations: int = 60,
    search_factor: float = 2.0,
    dependence_factor: float = 1.0,
) -> list[LinearFit]:
    """Refit the paper model plus each tuple of frequency-domain effects on ``J``.

    All candidates go through one :func:`jaxgwo._gwo.run_batch` call (IGWO, pack seeded at
    the nominal ``x_nominal`` in log-parameters, effect coordinates spread over their box),
    then a bounded ``least_squares`` polish of the active coordinates.
    ``dependence_factor`` scales the bounds for correlated frequency points
    (``sqrt(m / m_eff)``, as in :func:`jaxgwo._identify._dependence_corrected`).
    """
    from scipy.optimize import least_squares

    if not candidates:
        return []
    x_nom = np.asarray(x_nominal, float)
    half = math.log(search_factor)
    objs, los, his, inits = [], [], [], []
    k_init, k_run = jax.random.split(key)
    init_keys = jax.random.split(k_init, len(candidates))
    n_seed = max(2, wolves // 2)
    for i, names in enumerate(candidates):
        act = _active_mask(names)
        lo = np.r_[x_nom - half, np.where(act, _Z_LO, _Z_NEUTRAL)]
        hi = np.r_[x_nom + half, np.where(act, _Z_HI, _Z_NEUTRAL + 1e-9)]
        lo[4], hi[4] = max(lo[4], math.log(0.05)), min(hi[4], math.log(3.0))
        ku, kn = jax.random.split(init_keys[i])
        u = np.asarray(jax.random.uniform(ku, (n_seed, 6), dtype=jnp.float64))
        z0 = np.where(act, _Z_LO + u * (_Z_HI - _Z_LO), _Z_NEUTRAL)
        xp = x_nom + 0.05 * np.asarray(jax.random.normal(kn, (n_seed, 5), dtype=jnp.float64))
        init = np.clip(np.concatenate([xp, z0], axis=1), lo, hi)
        init[0, :5] = x_nom
        objs.append(AugmentedCifer.from_cifer(objective, act))
        los.append(lo)
        his.append(hi)
        inits.append(init)
    cfg = G.igwo(wolves, iterations)
    res = G.run_batch(cfg, G.stack_objectives(objs), jnp.asarray(np.stack(los)), jnp.asarray(np.stack(his)),
                      jax.random.split(k_run, len(candidates)), init_wolves=jnp.asarray(np.stack(inits)))  # fmt: skip
    best = np.asarray(res.best_position)
    out = []
    for names, obj, lo, hi, xb in zip(candidates, objs, los, his, best):
        act = np.r_[np.ones(5, bool), _active_mask(names)]
        idx = np.flatnonzero(act)
        full = xb.copy()

        def fun(v, full=full, idx=idx, obj=obj):
            x = full.copy()
            x[idx] = v
            return np.asarray(_residuals(obj, jnp.asarray(x)))

        def jac(v, full=full, idx=idx, obj=obj):
            x = full.copy()
            x[idx] = v
            return np.asarray(_jacobian(obj, jnp.asarray(x)))[:, idx]

        # the polish may leave the optimiser's box for the paper parameters, not the effect's
        plo = np.where(np.arange(idx.size) < 5, -np.inf, lo[idx])
        phi = np.where(np.arange(idx.size) < 5, np.inf, hi[idx])
        v0 = np.clip(xb[idx], plo + 1e-12, phi - 1e-12)
        sol = least_squares(fun, v0, jac=jac, bounds=(plo, phi), method="trf", xtol=1e-10, ftol=1e-10, max_nfev=200)
        x = full.copy()
        x[idx] = sol.x
        cost = float(np.sum(sol.fun**2))
        if not cost <= float(obj(jnp.asarray(xb))):
            x, cost = xb, float(obj(jnp.asarray(xb)))
        Jm = jac(x[idx])
        m = int(np.sum(np.asarray(obj.weight) > 0))
        s2 = cost / max(1, 2 * m - idx.size)
        cov = np.linalg.pinv(Jm.T @ Jm) * s2 * dependence_factor**2
        sd = np.sqrt(np.maximum(np.diag(cov), 0.0))
        z = x[5:]
        zsd = np.zeros(6)
        zsd[idx[idx >= 5] - 5] = sd[5:]
        params = {n: effect_params_from_z(n, z) for n in names}
        sigma = {}
        for n in names:
            sl = _SLOTS[n]
            vals = params[n]
            sig = {}
            for (pname, v), s in zip(vals.items(), sl):
                logged = n in ("sensor_lag", "structural_mode")
                sig[pname] = float(abs(v) * zsd[s]) if logged else float(zsd[s])
            sigma[n] = sig
        out.append(LinearFit(tuple(names), x, cost, params, sigma))
    return out


# ----------------------------------------------------------------------------- time domain


@dataclass(frozen=True)
class ModelSpec:
    """A paper model (true-sign ``K, tau, M, omega_s, zeta_s``) with effects, for simulation."""

    params: np.ndarray
    effects: Mapping[str, Mapping[str, float]] = field(default_factory=dict)
    gain_scale: float = 1.0


class _ServoParams(eqx.Module):
    omega: Float[Array, ""]
    zeta: Float[Array, ""]
    rate: Float[Array, ""]
    limit: Float[Array, ""]
    width: Float[Array, ""]


@eqx.filter_jit
def _nonlinear_servo(sp: _ServoParams, u: Float[Array, " n"], dt: float, substeps: int = 4) -> Float[Array, " n"]:
    """Swashplate position mid-way through each sample interval of a second-order servo with
    rate limit, saturation and backlash (the simulator's rules, :mod:`jaxgwo._simulate`), driven
    by the held input ``u``.  Mid-interval samples make the following ZOH rotor simulation
    free of a half-sample lag."""
    h = dt / substeps

    def deriv(state, cmd):
        pos, vel = state
        acc = sp.omega**2 * (cmd - pos) - 2.0 * sp.zeta * sp.omega * vel
        acc = jnp.where(((vel >= sp.rate) & (acc > 0.0)) | ((vel <= -sp.rate) & (acc < 0.0)), 0.0, acc)
        v_out = jnp.clip(vel, -sp.rate, sp.rate)
        d_pos = jnp.where(((pos >= sp.limit) & (v_out > 0.0)) | ((pos <= -sp.limit) & (v_out < 0.0)), 0.0, v_out)
        return jnp.stack([d_pos, acc])

    def sub(carry, cmd):
        state, swash = carry
        k1 = deriv(state, cmd)
        k2 = deriv(state + 0.5 * h * k1, cmd)
        k3 = deriv(state + 0.5 * h * k2, cmd)
        k4 = deriv(state + h * k3, cmd)
        state = state + (h / 6.0) * (k1 + 2 * k2 + 2 * k3 + k4)
        out = jnp.clip(state[0], -sp.limit, sp.limit)
        swash = jnp.clip(swash, out - 0.5 * sp.width, out + 0.5 * sp.width)
        return state, swash

    def step(carry, uk):
        state, swash = carry
        mid = None
        for j in range(substeps):
            state, swash = sub((state, swash), uk)
            if j == substeps // 2 - 1:
                mid = swash
        return (state, swash), mid

    _, mids = jax.lax.scan(step, (jnp.zeros(2), jnp.zeros(())), u)
    return mids


def _delayed(t: np.ndarray, u: np.ndarray, delay: float) -> np.ndarray:
    if delay <= 0.0:
        return u
    return np.interp(t - delay, t, u, left=0.0)


def _post_filter(effects) -> tuple[np.ndarray, np.ndarray]:
    num, den = np.array([1.0]), np.array([1.0])
    if "sensor_lag" in effects:
        den = np.polymul(den, [1.0 / (2.0 * np.pi * effects["sensor_lag"]["cutoff_hz"]), 1.0])
    if "structural_mode" in effects:
        e = effects["structural_mode"]
        wn = 2.0 * np.pi * e["freq_hz"]
        num = np.polymul(num, [1.0, 2.0 * e["zeta_z"] * wn, wn * wn])
        den = np.polymul(den, [1.0, 2.0 * e["zeta_p"] * wn, wn * wn])
    return num, den


def _rotor_den(tau, m, tau_f):
    if tau_f > 1e-4:  # below 0.1 ms the cubic is ill-conditioned and the lag negligible
        return np.array([tau_f, 1.0 + tau_f / tau, 1.0 / tau, m])
    return np.array([1.0, 1.0 / tau, m])


def _servo_params(spec: ModelSpec, effects) -> _ServoParams:
    _k, _tau, _m, ws, zs = (float(v) for v in spec.params)
    return _ServoParams(
        jnp.asarray(ws), jnp.asarray(zs),
        jnp.asarray(effects.get("rate_limit", {}).get("rate", np.inf)),
        jnp.asarray(effects.get("saturation", {}).get("limit", np.inf)),
        jnp.asarray(effects.get("backlash", {}).get("width", 0.0)),
    )  # fmt: skip


def simulate_model(spec: ModelSpec, t: np.ndarray, u: np.ndarray, u_off: np.ndarray | None = None) -> np.ndarray:
    """Output of ``spec`` for the on-axis input ``u`` (and off-axis ``u_off`` for
    ``cross_coupling``) at uniform times ``t``, from rest, as the simulator composes the
    effects: mixing, delay, servo (with nonlinearities), rotor (with flapping), gyro filters."""
    eff = dict(spec.effects)
    k, tau, m, ws, zs = (float(v) for v in spec.params)
    t = np.asarray(t, float)
    u = np.asarray(u, float)
    if "cross_coupling" in eff and u_off is not None:
        u = u + eff["cross_coupling"]["gain"] * np.asarray(u_off, float)
    u = _delayed(t, u, eff.get("time_delay", {}).get("delay_s", 0.0))
    rden = _rotor_den(tau, m, eff.get("rotor_flapping", {}).get("tau_f", 0.0))
    pnum, pden = _post_filter(eff)
    tj = jnp.asarray(t)
    if any(n in eff for n in NONLINEAR):
        swash = _nonlinear_servo(_servo_params(spec, eff), jnp.asarray(u), float(t[1] - t[0]))
        y = simulate_transfer_function(jnp.asarray([k]), jnp.asarray(rden), tj, swash)
        if pden.size > 1:
            y = simulate_transfer_function(jnp.asarray(pnum), jnp.asarray(pden), tj, y)
    else:
        num = np.polymul([k * ws * ws], pnum)
        den = np.polymul(np.polymul(rden, [1.0, 2.0 * zs * ws, ws * ws]), pden)
        y = simulate_transfer_function(jnp.asarray(num), jnp.asarray(den), tj, jnp.asarray(u))
    return spec.gain_scale * np.asarray(y)


# ----------------------------------------------------------------------------- cross coupling


@dataclass(frozen=True)
class TimeFit:
    """A time-domain refit: the effect parameters, their 1-sigma, and the output gain scale."""

    effects: tuple[str, ...]
    params: dict
    sigma: dict
    gain_scale: float
    train_mse: float


def fit_cross_coupling(base: ModelSpec, train: Sequence[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]],
                       correlation_time_s: float = 0.1) -> TimeFit:
    """Least-squares gain ``g`` of ``y - G u = g (G u_off)`` on the identification records
    ``(t, u, u_off, y)``; the bound counts ``n dt / T_c`` independent samples."""
    num = den = 0.0
    res, xs = [], []
    base0 = ModelSpec(base.params, {k: v for k, v in base.effects.items() if k != "cross_coupling"}, base.gain_scale)
    for t, u, u_off, y in train:
        r = y - simulate_model(base0, t, u)
        x = simulate_model(base0, t, u_off)
        num += float(r @ x)
        den += float(x @ x)
        res.append(r)
        xs.append(x)
    g = num / den if den > 0 else 0.0
    e = np.concatenate([r - g * x for r, x in zip(res, xs)])
    dt = float(train[0][0][1] - train[0][0][0])
    n_eff = max(2.0, e.size * dt / max(correlation_time_s, dt))
    sig = math.sqrt(float(np.mean(e**2)) * e.size / n_eff / den) if den > 0 else float("inf")
    return TimeFit(("cross_coupling",), {"cross_coupling": {"gain": g}}, {"cross_coupling": {"gain": sig}}, 1.0,
                   float(np.mean(e**2)))  # fmt: skip


# ----------------------------------------------------------------------------- nonlinear


_NL_PARAM = {"rate_limit": "rate", "backlash": "width", "saturation": "limit"}


def _nl_grid(name: str, u_scale: float, n: int) -> np.ndarray:
    """Candidate values spanning the realistic range, widened, and scaled to the input where
    the effect is an amplitude (saturation limit relative to the largest input)."""
    lo, hi = EFFECTS[name].ranges[0]
    if name == "saturation":
        return np.geomspace(0.2 * u_scale, 1.2 * u_scale, n)
    return np.geomspace(lo / 2.0, hi * 2.0, n)


def fit_nonlinear_candidates(
    base: ModelSpec,
    train: Sequence[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]],
    names: Sequence[str] = NONLINEAR,
    *,
    grid: int = 12,
    refine_steps: int = 12,
) -> list[TimeFit]:
    """Fit each nonlinear effect's parameter (and an output gain, in closed form) to the
    identification records ``(t, u, u_off, y)`` by mean squared output error.

    A grid of every candidate's parameter is evaluated in one vmapped servo simulation per
    record; a golden-section search on the log-parameter between the best grid point's
    neighbours refines it.
    """
    names = [n for n in names if n in NONLINEAR]
    if not names:
        return []
    _k, tau, m, _ws, _zs = (float(v) for v in base.params)
    k = float(base.params[0])
    dt = float(train[0][0][1] - train[0][0][0])
    u_scale = max(float(np.max(np.abs(u))) for _t, u, _o, _y in train)
    rden = jnp.asarray(_rotor_den(tau, m, base.effects.get("rotor_flapping", {}).get("tau_f", 0.0)))
    delay = base.effects.get("time_delay", {}).get("delay_s", 0.0)

    def servo_batch(values: dict[str, np.ndarray]) -> _ServoParams:
        nb = len(next(iter(values.values())))
        e = {n: {_NL_PARAM[n]: v} for n, v in values.items()}
        ws, zs = float(base.params[3]), float(base.params[4])
        return _ServoParams(
            jnp.full(nb, ws), jnp.full(nb, zs),
            jnp.asarray(e.get("rate_limit", {}).get("rate", np.full(nb, np.inf))),
            jnp.asarray(e.get("saturation", {}).get("limit", np.full(nb, np.inf))),
            jnp.asarray(e.get("backlash", {}).get("width", np.zeros(nb))),
        )  # fmt: skip

    sims = jax.vmap(lambda sp, u, t: simulate_transfer_function(jnp.asarray([k]), rden, t,
                                                                _nonlinear_servo(sp, u, dt)),
                    in_axes=(0, None, None))  # fmt: skip

    def mse_and_scale(sp: _ServoParams):
        yy = ys = ss = 0.0
        n_tot = 0
        for t, u, _o, y in train:
            ud = _delayed(t, u, delay)
            s = np.asarray(sims(sp, jnp.asarray(ud), jnp.asarray(t)))
            yy = yy + float(y @ y)
            ys = ys + s @ y
            ss = ss + np.sum(s * s, axis=1)
            n_tot += y.size
        c = np.where(ss > 0, ys / np.where(ss > 0, ss, 1.0), 1.0)
        mse = (yy - 2 * c * ys + c * c * ss) / n_tot
        return mse, c

    grids = {n: _nl_grid(n, u_scale, grid) for n in names}
    # one batch: every candidate's grid, the others neutral
    rows = []
    for n in names:
        for v in grids[n]:
            rows.append((n, v))
    vals = {n: np.array([v if nn == n else (np.inf if n != "backlash" else 0.0) for nn, v in rows]) for n in names}
    mse, scale = mse_and_scale(servo_batch(vals))
    out = []
    for n in names:
        sel = np.array([nn == n for nn, _ in rows])
        g = grids[n]
        e = mse[sel]
        i = int(np.argmin(e))
        a, b = math.log(g[max(i - 1, 0)]), math.log(g[min(i + 1, g.size - 1)])
        best_v, best_e, best_c = g[i], e[i], scale[sel][i]
        # golden-section search on log(value)
        gr = (math.sqrt(5.0) - 1.0) / 2.0
        c1, c2 = b - gr * (b - a), a + gr * (b - a)

        def f(lv, n=n):
            mm, cc = mse_and_scale(servo_batch({n: np.array([math.exp(lv)])}))
            return float(mm[0]), float(cc[0])

        f1, f2 = f(c1), f(c2)
        for _ in range(refine_steps):
            if f1[0] < f2[0]:
                b, c2, f2 = c2, c1, f1
                c1 = b - gr * (b - a)
                f1 = f(c1)
            else:
                a, c1, f1 = c1, c2, f2
                c2 = a + gr * (b - a)
                f2 = f(c2)
        for lv, (mm, cc) in ((c1, f1), (c2, f2)):
            if mm < best_e:
                best_v, best_e, best_c = math.exp(lv), mm, cc
        # curvature of the mse in log(value) -> a rough 1-sigma from the effective sample count
        h = 0.05
        lv = math.log(best_v)
        fp, fm = f(lv + h)[0], f(lv - h)[0]
        curv = (fp - 2 * best_e + fm) / h**2
        n_tot = sum(y.size for *_r, y in train)
        n_eff = max(2.0, n_tot * dt / 0.1)
        sig_log = math.sqrt(2.0 * best_e / n_eff / curv) if curv > 0 else float("inf")
        pname = _NL_PARAM[n]
        out.append(TimeFit((n,), {n: {pname: float(best_v)}}, {n: {pname: float(best_v * sig_log)}}, float(best_c),
                           float(best_e)))  # fmt: skip
    return out


# ----------------------------------------------------------------------------- scoring


@dataclass(frozen=True)
class CandidateScore:
    """Held-out scores of one augmented model against the nominal one."""

    effects: tuple[str, ...]
    params: dict
    sigma: dict
    val_r2: float
    val_tic: float
    cost_J: float
    gap_closed: float
    delta_bic: float
    z_score: float
    beats_noise: bool
    agreement: float
    score: float
    n_params: int
    predicted: tuple = field(repr=False, default=())


def score_candidate(
    effects: tuple[str, ...], params: dict, sigma: dict, predicted: Sequence[np.ndarray], measured: Sequence[np.ndarray],
    nominal_predicted: Sequence[np.ndarray], nominal_r2: float, cost_J: float, n_params: int, correlation_time_s: float,
    dt: float, agreement: float, *, z_min: float = 3.0, min_gap: float = 0.03,
) -> CandidateScore:
    """Score an augmented model's held-out prediction (module docstring for the rules)."""
    y = np.concatenate(measured)
    p = np.concatenate(predicted)
    p0 = np.concatenate(nominal_predicted)
    r2 = float(r_squared(jnp.asarray(y), jnp.asarray(p)))
    tic = float(theil_inequality(jnp.asarray(y), jnp.asarray(p)))
    gap = (r2 - nominal_r2) / (1.0 - nominal_r2) if nominal_r2 < 1.0 else 0.0
    n_eff = max(2.0, y.size * dt / max(correlation_time_s, dt))
    rss, rss0 = float(np.sum((y - p) ** 2)), float(np.sum((y - p0) ** 2))
    dbic = n_eff * math.log(rss / rss0) + n_params * math.log(n_eff)
    d = (y - p0) ** 2 - (y - p) ** 2
    block = max(int(round(max(4.0 * correlation_time_s, 0.5) / dt)), 1)
    nb = d.size // block
    if nb >= 3:
        mb = d[: nb * block].reshape(nb, block).mean(axis=1)
        z = float(mb.mean() / (mb.std(ddof=1) / math.sqrt(nb) + 1e-300))
    else:
        z = 0.0
    ok = bool(z > z_min and dbic < 0.0 and gap > min_gap)
    score = gap + 0.05 * agreement - (0.0 if ok else 1.0)
    return CandidateScore(effects, params, sigma, r2, tic, cost_J, gap, dbic, z, ok, agreement, score, n_params,
                          tuple(predicted))  # fmt: skip
