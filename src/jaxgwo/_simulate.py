r"""Time-domain flight simulator: plant + servos + effects + gusts + pilot hold + sensor noise.

One sample of the simulation, at sample rate :math:`f_s` (logger and autopilot rate):

1. The logged cyclic command is ``u_k = e_k + c_k``: the excitation ``e_k`` plus the hold
   loop's correction ``c_k`` (a pilot-like attitude/velocity hold, :class:`HoldLoop`).
   Exactly as an autopilot logs it, the recorded input is the total, so the data carries
   the closed-loop correlations real data has.
2. The command is held (zero-order hold) until the next sample, delayed by
   ``time_delay``, mixed with the off-axis command by ``cross_coupling``, and drives a
   second-order servo, eq. (14), whose output rate is limited by ``rate_limit`` and
   position by ``saturation``; ``backlash`` (an exact play operator) sits between servo
   and swashplate.
3. The plant (:mod:`jaxgwo._plants`) integrates with a Dryden-like gust moment on roll
   and pitch; the gyro sees the body rate through ``structural_mode`` and ``sensor_lag``,
   and white noise at a set signal-to-noise ratio is added to the logged rate.

Integration is classical RK4 with ``substeps`` internal steps per sample (default: an
internal step of at most 1 ms), inside ``jax.lax.scan`` over samples.  The measured rate
is logged at the sample instant, before the new command acts, so relative to the logged
samples the linear part is the ZOH equivalent of the continuous response: at low
frequency the continuous response delayed by half a sample (``dt/2``; metadata
``zoh_delay_s``).  Everything is jittable and vmappable over keys and parameters.

The gust filter is the Dryden form :math:`H(s) = (1 + \sqrt{3}\,T s)/(1 + T s)^2` with
``T = L/V``; driven by white noise of intensity :math:`\sigma^2 T` its output variance is
exactly :math:`\sigma^2` (``gust_rms``).
"""

from __future__ import annotations

import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jax.flatten_util import ravel_pytree
from jaxtyping import Array, Complex, Float, PRNGKeyArray

from ._data import FlightRecord, make_record
from ._effects import EffectSet
from ._plants import PaperPlant, R50Plant, lag_derivative, lag_output

__all__ = [
    "HoldLoop",
    "Disturbance",
    "SimulationResult",
    "Stability",
    "simulate",
    "closed_loop_stability",
    "default_substeps",
    "multistep_validation",
]

Plant = PaperPlant | R50Plant


def _f64(x) -> Array:
    return jnp.asarray(x, dtype=jnp.float64)


def _pair(x) -> Array:
    return jnp.broadcast_to(_f64(x), (2,))


class HoldLoop(eqx.Module):
    r"""Weak pilot-like attitude/velocity hold, per axis (lateral, longitudinal).

    .. math:: c' = (k_\theta\,\theta + k_q\,q + k_v\,v - c)/T_p

    with attitude ``(phi, theta)`` rad, rate ``(p, q)`` rad/s and velocity ``(v, u)``
    ft/s; ``c`` is added to the command.  The first-order ``lag_s`` is the pilot's
    reaction/neuromuscular lag.  Gains carry their sign (roll right needs positive
    ``delta_lat``; nose up needs negative ``delta_lon`` on the R-50).
    """

    attitude_gain: Float[Array, "2"] = eqx.field(converter=_pair)
    rate_gain: Float[Array, "2"] = eqx.field(converter=_pair)
    velocity_gain: Float[Array, "2"] = eqx.field(converter=_pair)
    lag_s: Float[Array, ""] = eqx.field(converter=_f64, default=0.3)

    @classmethod
    def r50(cls) -> HoldLoop:
        """Gains that stabilise the R-50 hover weakly: closed-loop hover modes near 0.9 rad/s
        with damping about 0.26 and 0.46, all eigenvalue real parts below -0.2 rad/s
        (well under the 0.25 Hz = 1.6 rad/s start of a sweep)."""
        return cls(attitude_gain=(-0.5, 0.8), rate_gain=(-0.05, 0.05), velocity_gain=(-0.02, -0.02), lag_s=0.3)

    def target(self, plant: Plant, x_plant) -> Float[Array, "2"]:
        return (
            self.attitude_gain * plant.attitude(x_plant)
            + self.rate_gain * plant.body_rates(x_plant)
            + self.velocity_gain * plant.velocity(x_plant)
        )


class Disturbance(eqx.Module):
    """Gust turbulence and sensor noise, per axis (lateral, longitudinal).

    Attributes:
        gust_rms: standard deviation of the Dryden-like gust moment on roll/pitch (rad/s^2).
        gust_time_constant_s: Dryden ``T = L/V`` (s); the gust bandwidth is about ``1/T``.
        snr_db: signal-to-noise ratio of the logged rate, ``20 log10(rms(rate)/rms(noise))``,
            with ``rms(rate)`` of the noiseless logged rate over the record (inf: none).
        noise_std: an absolute white gyro noise (rad/s), independent of the signal.  The two
            noise parts add in variance.
    """

    gust_rms: Float[Array, "2"] = eqx.field(converter=_pair, default=0.0)
    gust_time_constant_s: Float[Array, ""] = eqx.field(converter=_f64, default=1.0)
    snr_db: Float[Array, "2"] = eqx.field(converter=_pair, default=math.inf)
    noise_std: Float[Array, "2"] = eqx.field(converter=_pair, default=0.0)

    @classmethod
    def default_dataset(cls, gust_scale: float = 1.0) -> Disturbance:
        """The embedded default dataset's gusts and gyro noise
        (:data:`DEFAULT_DATASET_CONDITIONS`), the gust moment scaled by ``gust_scale``."""
        c = DEFAULT_DATASET_CONDITIONS
        return cls(gust_rms=tuple(gust_scale * g for g in c["gust_rms_rad_s2"]),
                   gust_time_constant_s=c["gust_time_constant_s"], noise_std=c["gyro_noise_std_rad_s"])


class Stability(eqx.Module):
    """Eigen-analysis of the linearised loop (plant, servos, hold loop; nonlinear effects off)."""

    eigenvalues: Complex[Array, " n"]
    max_real: Float[Array, ""]
    min_damping: Float[Array, ""]


class SimulationResult(eqx.Module):
    """What a simulation logged, each ``(n, 2)`` = (lateral, longitudinal) per sample.

    Attributes:
        time: sample times (s).
        command: logged cyclic ``(delta_lat, delta_lon)``: excitation plus hold correction.
        excitation: the excitation part alone.
        hold_correction: the hold loop's part alone.
        rate: logged ``(p, q)`` (rad/s): through structural mode and sensor lag, plus noise.
        rate_clean: the same without noise.
        body_rate: true body ``(p, q)`` (rad/s).
        servo: servo output position (after rate limit and saturation).
        swashplate: swashplate position (after backlash).
        gust: gust moment (rad/s^2).
        attitude: logged ``(phi, theta)`` (rad) as an attitude estimator gives it, which
            integrates the raw gyro: the airframe's attitude plus what a ``structural_mode``
            adds at the gyro, without the ``sensor_lag`` (a filter on the rate the
            controller and the log see), plus the estimator's own error (:func:`_attitude_error`).
        sample_rate: Hz.
    """

    time: Float[Array, " n"]
    command: Float[Array, "n 2"]
    excitation: Float[Array, "n 2"]
    hold_correction: Float[Array, "n 2"]
    rate: Float[Array, "n 2"]
    rate_clean: Float[Array, "n 2"]
    body_rate: Float[Array, "n 2"]
    servo: Float[Array, "n 2"]
    swashplate: Float[Array, "n 2"]
    gust: Float[Array, "n 2"]
    attitude: Float[Array, "n 2"]
    sample_rate: float = eqx.field(static=True)

    def to_record(self, metadata: dict | None = None, *, truth: bool = False, attitude: bool = False) -> FlightRecord:
        """The logged data as a :class:`FlightRecord` (``time, delta_lat, delta_lon, p, q``).

        With ``attitude=True`` it also logs the estimated attitude ``phi, theta`` (rad).
        With ``truth=True`` it also keeps ``p_true, q_true`` (body rates),
        ``exc_lat, exc_lon`` (excitation) and ``servo_lat, servo_lon`` as extra columns.
        """
        cols = {
            "delta_lat": self.command[:, 0], "delta_lon": self.command[:, 1],
            "p": self.rate[:, 0], "q": self.rate[:, 1],
        }  # fmt: skip
        if attitude:
            cols |= {"phi": self.attitude[:, 0], "theta": self.attitude[:, 1]}
        if truth:
            cols |= {
                "p_true": self.body_rate[:, 0], "q_true": self.body_rate[:, 1],
                "exc_lat": self.excitation[:, 0], "exc_lon": self.excitation[:, 1],
                "servo_lat": self.servo[:, 0], "servo_lon": self.servo[:, 1],
            }  # fmt: skip
        meta = {"zoh_delay_s": f"{0.5 / self.sample_rate:.6g}", "generator": "jaxgwo.simulate"}
        meta |= dict(metadata or {})
        return make_record(np.asarray(self.time), cols, meta, required=("delta_lat", "delta_lon", "p", "q"))


def default_substeps(sample_rate_hz: float, max_step_s: float = 1e-3) -> int:
    """Internal RK4 steps per sample so the step is at most ``max_step_s``."""
    return max(1, math.ceil(1.0 / (sample_rate_hz * max_step_s) - 1e-9))


# -- the continuous-time dynamics ------------------------------------------------------


def _init_state(plant: Plant):
    z2 = jnp.zeros((2,), dtype=jnp.float64)
    return {
        "plant": jnp.zeros((plant.n_states,), dtype=jnp.float64),
        "servo_pos": z2, "servo_vel": z2, "gust1": z2, "gust2": z2,
        "struct1": z2, "struct2": z2, "sensor": z2, "pilot": z2,
    }  # fmt: skip


def _servo_output(x, effects: EffectSet):
    lim = effects.saturation.limit
    return jnp.clip(x["servo_pos"], -lim, lim)


def _loop_derivative(x, cmd, gust_moment, swash_prev, plant, effects: EffectSet, floor, *, nonlinear=True):
    """Servo and plant derivatives: the part of the state that feeds back."""
    mixed = cmd + effects.cross_coupling.gain * cmd[::-1]
    ws, zs = plant.servo_omega, plant.servo_zeta
    pos, vel = x["servo_pos"], x["servo_vel"]
    acc = ws * ws * (mixed - pos) - 2.0 * zs * ws * vel
    if nonlinear:
        rate, lim, width = effects.rate_limit.rate, effects.saturation.limit, effects.backlash.width
        # rate limit: the output moves at most at `rate`; the velocity state stops there too
        acc = jnp.where(((vel >= rate) & (acc > 0.0)) | ((vel <= -rate) & (acc < 0.0)), 0.0, acc)
        v_out = jnp.clip(vel, -rate, rate)
        # saturation: the output stops at the end stop
        d_pos = jnp.where(((pos >= lim) & (v_out > 0.0)) | ((pos <= -lim) & (v_out < 0.0)), 0.0, v_out)
        out = jnp.clip(pos, -lim, lim)
        swash = jnp.clip(swash_prev, out - 0.5 * width, out + 0.5 * width)
    else:
        d_pos = vel
        swash = pos
    d_plant = plant.derivative(x["plant"], swash, gust_moment, effects.rotor_flapping.tau_f, floor)
    return d_plant, d_pos, acc


def _gust_moment(x):
    return x["gust2"] + math.sqrt(3.0) * (x["gust1"] - x["gust2"])


def _mode_at_gyro(effects: EffectSet):
    r"""What the structural mode's state adds at the gyro per unit of it,
    :math:`2(\zeta_z - \zeta_p)\omega_n`: the mode
    :math:`(s^2 + 2\zeta_z\omega_n s + \omega_n^2)/(s^2 + 2\zeta_p\omega_n s + \omega_n^2)` is
    :math:`1 + 2(\zeta_z - \zeta_p)\omega_n s/(s^2 + 2\zeta_p\omega_n s + \omega_n^2)`, whose second
    term is that times ``struct2`` for the rate and times ``struct1`` (its integral) for the attitude."""
    sm = effects.structural_mode
    return 2.0 * (sm.zeta_z - sm.zeta_p) * (2.0 * jnp.pi * sm.freq_hz)


def _struct_out(x, plant, effects: EffectSet):
    return plant.body_rates(x["plant"]) + _mode_at_gyro(effects) * x["struct2"]


def _raw_gyro_attitude(x, plant, effects: EffectSet):
    """The attitude the raw gyro integrates to: the airframe's plus what the structural mode
    adds at the gyro (``struct1`` integrates ``struct2``), before any ``sensor_lag``."""
    return plant.attitude(x["plant"]) + _mode_at_gyro(effects) * x["struct1"]


def _derivative(x, cmd, white, swash_prev, plant, effects, hold, t_gust, floor):
    d_plant, d_pos, d_vel = _loop_derivative(x, cmd, _gust_moment(x), swash_prev, plant, effects, floor)
    sm = effects.structural_mode
    wn = 2.0 * jnp.pi * sm.freq_hz
    body = plant.body_rates(x["plant"])
    struct_out = _struct_out(x, plant, effects)
    tau_s = 1.0 / (2.0 * jnp.pi * effects.sensor_lag.cutoff_hz)
    return {
        "plant": d_plant,
        "servo_pos": d_pos,
        "servo_vel": d_vel,
        "gust1": (white - x["gust1"]) / t_gust,
        "gust2": (x["gust1"] - x["gust2"]) / t_gust,
        "struct1": x["struct2"],
        "struct2": body - 2.0 * sm.zeta_p * wn * x["struct2"] - wn * wn * x["struct1"],
        "sensor": lag_derivative(x["sensor"], struct_out, tau_s, floor),
        "pilot": (hold.target(plant, x["plant"]) - x["pilot"]) / hold.lag_s,
    }


def _measured(x, plant, effects, floor):
    tau_s = 1.0 / (2.0 * jnp.pi * effects.sensor_lag.cutoff_hz)
    return lag_output(x["sensor"], _struct_out(x, plant, effects), tau_s, floor)


def _rk4(f, x, h):
    k1 = f(x)
    k2 = f(jax.tree.map(lambda a, b: a + 0.5 * h * b, x, k1))
    k3 = f(jax.tree.map(lambda a, b: a + 0.5 * h * b, x, k2))
    k4 = f(jax.tree.map(lambda a, b: a + h * b, x, k3))
    return jax.tree.map(lambda a, b1, b2, b3, b4: a + (h / 6.0) * (b1 + 2.0 * b2 + 2.0 * b3 + b4), x, k1, k2, k3, k4)


@eqx.filter_jit
def simulate(
    plant: Plant,
    excitation: Float[Array, "n 2"],
    key: PRNGKeyArray,
    *,
    sample_rate_hz: float = 100.0,
    effects: EffectSet | None = None,
    disturbance: Disturbance | None = None,
    hold: HoldLoop | None = None,
    substeps: int | None = None,
    max_delay_s: float = 0.25,
) -> SimulationResult:
    """Simulate a flight from trim under the cyclic ``excitation`` (``(n, 2)``: lat, lon).

    Args:
        plant: :class:`~jaxgwo._plants.PaperPlant` or :class:`~jaxgwo._plants.R50Plant`.
        excitation: per-sample excitation of ``delta_lat`` and ``delta_lon``, held (ZOH)
            over each sample; add off-axis pilot activity here
            (:func:`jaxgwo._signals.pilot_corrections`).
        key: PRNG key for the gust and the sensor noise.
        sample_rate_hz: logging rate (a Python float; static).
        effects: unmodelled effects (:class:`~jaxgwo._effects.EffectSet`); none by default.
        disturbance: gusts and noise; calm and noiseless by default.
        hold: pilot hold loop; ``None`` flies open loop (the R-50 then diverges slowly).
        substeps: RK4 steps per sample (default: internal step <= 1 ms).
        max_delay_s: longest ``time_delay`` supported (static buffer length).

    Returns:
        :class:`SimulationResult`.  ``vmap`` over ``key`` equals a loop over keys.
    """
    effects = EffectSet() if effects is None else effects
    disturbance = Disturbance() if disturbance is None else disturbance
    hold_loop = HoldLoop(0.0, 0.0, 0.0, 1.0) if hold is None else hold
    excitation = jnp.asarray(excitation, dtype=jnp.float64)
    n = excitation.shape[0]
    dt = 1.0 / sample_rate_hz
    nsub = default_substeps(sample_rate_hz) if substeps is None else int(substeps)
    h = dt / nsub
    floor = 0.5 * h
    n_buf = int(math.ceil(max_delay_s * sample_rate_hz)) + 2

    delay = effects.time_delay.delay_s
    delay = eqx.error_if(delay, jnp.any((delay < 0.0) | (delay > max_delay_s)), "time_delay delay_s outside [0, max_delay_s]")
    wn_h = 2.0 * jnp.pi * effects.structural_mode.freq_hz * h
    delay = eqx.error_if(delay, jnp.any(wn_h > 1.0), "structural_mode freq_hz too high for the integration step; raise substeps")

    k_gust, k_noise = jax.random.split(key)
    t_gust = disturbance.gust_time_constant_s
    white = jax.random.normal(k_gust, (n, 2), dtype=jnp.float64) * disturbance.gust_rms * jnp.sqrt(t_gust / dt)
    axes = jnp.arange(2)

    def sample_step(carry, inp):
        x, swash, buf = carry
        exc_k, white_k = inp
        corr = x["pilot"]
        u_k = exc_k + corr
        buf = jnp.concatenate([u_k[None, :], buf[:-1]], axis=0)
        logged = {
            "command": u_k, "hold_correction": corr,
            "rate_clean": _measured(x, plant, effects, floor),
            "body_rate": plant.body_rates(x["plant"]),
            "servo": _servo_output(x, effects), "swashplate": swash, "gust": _gust_moment(x),
            "attitude": _raw_gyro_attitude(x, plant, effects),
        }  # fmt: skip

        def substep(j, xs):
            x, swash = xs
            t_mid = (j.astype(jnp.float64) + 0.5) * h
            # the command applied at t_k + t_mid is the one logged at t_k + t_mid - delay
            back = -jnp.floor((t_mid - delay) / dt).astype(jnp.int32)
            cmd = buf[jnp.clip(back, 0, n_buf - 1), axes]
            f = lambda s: _derivative(s, cmd, white_k, swash, plant, effects, hold_loop, t_gust, floor)  # noqa: E731
            x = _rk4(f, x, h)
            out = _servo_output(x, effects)
            half = 0.5 * effects.backlash.width
            swash = jnp.clip(swash, out - half, out + half)
            return x, swash

        x, swash = jax.lax.fori_loop(0, nsub, substep, (x, swash))
        return (x, swash, buf), logged

    init = (_init_state(plant), jnp.zeros((2,), dtype=jnp.float64), jnp.zeros((n_buf, 2), dtype=jnp.float64))
    _, logged = jax.lax.scan(sample_step, init, (excitation, white))

    clean = logged["rate_clean"]
    signal_rms = jnp.sqrt(jnp.mean((clean - jnp.mean(clean, axis=0)) ** 2, axis=0))
    noise_std = jnp.sqrt((signal_rms / 10.0 ** (disturbance.snr_db / 20.0)) ** 2 + disturbance.noise_std**2)
    rate = clean + jax.random.normal(k_noise, (n, 2), dtype=jnp.float64) * noise_std
    # its own key: the attitude's error leaves every other draw as it was
    attitude = logged["attitude"] + _attitude_error(jax.random.fold_in(k_noise, 1), n, dt, noise_std)
    return SimulationResult(
        time=jnp.arange(n, dtype=jnp.float64) * dt,
        command=logged["command"],
        excitation=excitation,
        hold_correction=logged["hold_correction"],
        rate=rate,
        rate_clean=clean,
        body_rate=logged["body_rate"],
        servo=logged["servo"],
        swashplate=logged["swashplate"],
        gust=logged["gust"],
        attitude=attitude,
        sample_rate=float(sample_rate_hz),
    )


ATTITUDE_ESTIMATOR_HZ = 0.1
"""Corner of the simulated attitude estimator's drift correction (Hz)."""


def _attitude_error(key: PRNGKeyArray, n: int, dt: float, rate_noise_std: Float[Array, "2"]) -> Float[Array, "n 2"]:
    r"""The error of a logged attitude, ``(n, 2)`` rad, as a complementary-filter or EKF
    estimator makes it: it integrates the raw gyro's delta angles (before any gyro filter)
    and corrects the drift from the accelerometers below :data:`ATTITUDE_ESTIMATOR_HZ`.
    Its error is then an independent white rate noise of the gyro's level integrated by
    :math:`1/(s + \omega_e)`, :math:`e_k = a\,e_{k-1} + dt\,n_k` with
    :math:`a = e^{-\omega_e dt}`: above the corner its derivative is as noisy as the gyro."""
    a = math.exp(-2.0 * math.pi * ATTITUDE_ESTIMATOR_HZ * dt)
    white = jax.random.normal(key, (n, 2), dtype=jnp.float64) * rate_noise_std * dt

    def step(e, w):
        e = a * e + w
        return e, e

    return jax.lax.scan(step, jnp.zeros((2,), jnp.float64), white)[1]


@eqx.filter_jit
def closed_loop_stability(plant: Plant, effects: EffectSet | None = None, hold: HoldLoop | None = None) -> Stability:
    """Eigenvalues of the linearised feedback loop: plant, servos, linear in-loop effects, hold.

    The Jacobian of the same dynamics the simulator integrates, at trim, over the states
    that feed back (plant, servo, pilot lag).  ``rotor_flapping`` and ``cross_coupling``
    are included; the nonlinear effects are taken as off (small-signal), and the gust,
    structural-mode and sensor-lag states are left out because nothing feeds back
    from them.  ``time_delay`` is left out too: the hold loop is far slower than any
    realistic delay.  Without a hold loop the attitude integrators of the paper plant
    are left out (they integrate an output and feed nothing back).  Jittable and
    vmappable.
    """
    effects = EffectSet() if effects is None else effects
    x0 = _init_state(plant)
    loop = {k: x0[k] for k in ("plant", "servo_pos", "servo_vel", "pilot")}
    if hold is None:
        loop.pop("pilot")
    flat, unravel = ravel_pytree(loop)
    floor = 1e-4  # effects below 0.1 ms are treated as instantaneous, as in the simulator

    def f(v):
        xl = unravel(v)
        full = dict(x0) | xl
        cmd = xl["pilot"] if hold is not None else jnp.zeros((2,), dtype=jnp.float64)
        d_plant, d_pos, d_vel = _loop_derivative(
            full, cmd, jnp.zeros((2,), dtype=jnp.float64), jnp.zeros((2,), dtype=jnp.float64),
            plant, effects, floor, nonlinear=False,
        )  # fmt: skip
        out = {"plant": d_plant, "servo_pos": d_pos, "servo_vel": d_vel}
        if hold is not None:
            out["pilot"] = (hold.target(plant, full["plant"]) - xl["pilot"]) / hold.lag_s
        return ravel_pytree(out)[0]

    jac = jax.jacfwd(f)(flat)
    if hold is None and plant.free_integrators:
        keep = np.setdiff1d(np.arange(flat.shape[0]), np.asarray(plant.free_integrators))
        jac = jac[np.ix_(keep, keep)]
    # frozen sub-floor lags contribute eigenvalue -1/floor (fast, stable); harmless here
    eig = jnp.linalg.eigvals(jac)
    mag = jnp.abs(eig)
    osc = jnp.abs(eig.imag) > 1e-8 * jnp.maximum(mag, 1.0)
    damping = jnp.where(osc, -eig.real / jnp.maximum(mag, 1e-300), 1.0)
    return Stability(eigenvalues=eig, max_real=jnp.max(eig.real), min_damping=jnp.min(damping))


# -- the embedded default dataset --------------------------------------------------------

DEFAULT_DATASET_SEED = 50
"""Seed of the embedded default dataset (``jaxgwo simulate --default-dataset DIR``)."""

DEFAULT_DATASET_CONDITIONS = {
    "sample_rate_hz": 100.0,
    "gust_rms_rad_s2": (1.0, 0.4),  # pitch inertia ~2.5x roll inertia
    "gust_time_constant_s": 1.5,
    "gyro_noise_std_rad_s": 0.002,
    "sweep_hz": (0.25, 12.0),
    "sweep_duration_s": 90.0,
    "sweep_amplitudes": (0.08, 0.14),
    "off_axis_rms": 0.01,
    "validation_amplitudes": (0.1, 0.12),  # 3-2-1-1, doublet: between the two sweep amplitudes
}


def default_dataset_records(key: PRNGKeyArray | None = None) -> dict[str, FlightRecord]:
    """Simulate the embedded default dataset from the R-50 hover model.

    Returns ``{"lateral": ..., "longitudinal": ..., "validation_lateral": ...,
    "validation_longitudinal": ...}``:

    * ``lateral`` / ``longitudinal`` (identification, 191 s each): 3 s of hover, a
      90 s Tischler sweep 0.25-12 Hz at amplitude 0.08 on that channel's cyclic, 5 s of
      hover, the same sweep at amplitude 0.14, 3 s of hover.  The other cyclic carries
      pilot-like corrections (0.01 rms, 0.4 Hz), and both carry the hold loop's.
    * ``validation_lateral`` / ``validation_longitudinal`` (30 s each, held out): on that
      channel's cyclic a 3-2-1-1 (0.1, 0.4 s unit) at 2 s, a doublet (0.12, 0.5 s) at
      12 s and a reversed, faster 3-2-1-1 (-0.1, 0.3 s unit) at 20 s; small corrections
      (0.005 rms) on both cyclics.

    All at 100 Hz with Dryden-like gusts (1 rad/s^2 rms, T = 1.5 s), 0.005 rad/s gyro
    noise and the :meth:`HoldLoop.r50` hold.  ``key`` defaults to
    ``jax.random.key(DEFAULT_DATASET_SEED)``.
    """
    from ._signals import frequency_sweep, pilot_corrections

    key = jax.random.key(DEFAULT_DATASET_SEED) if key is None else key
    c = DEFAULT_DATASET_CONDITIONS
    fs = c["sample_rate_hz"]
    plant = R50Plant.default()
    hold = HoldLoop.r50()
    dist = Disturbance.default_dataset()
    common = {
        "plant": "R-50 hover (Mettler, Tischler & Kanade 2002) with servos 38.2 rad/s, 0.51",
        "hold_loop": "weak pilot-like attitude/velocity hold (HoldLoop.r50); logged cyclics are totals",
        "turbulence": (
            f"Dryden-like gust moment {c['gust_rms_rad_s2'][0]} (roll), {c['gust_rms_rad_s2'][1]} (pitch) "
            f"rad/s^2 rms, T {c['gust_time_constant_s']} s"
        ),
        "noise": f"white gyro noise {c['gyro_noise_std_rad_s']} rad/s rms",
        "regenerate": "jaxgwo simulate --default-dataset DIR",
    }
    k_lat, k_lon, k_val = jax.random.split(key, 3)
    out: dict[str, FlightRecord] = {}
    f0, f1 = c["sweep_hz"]
    dur = c["sweep_duration_s"]
    a1, a2 = c["sweep_amplitudes"]
    for name, axis, k in (("lateral", 0, k_lat), ("longitudinal", 1, k_lon)):
        starts = (3.0, 3.0 + dur + 5.0)
        total = starts[1] + dur + 3.0
        n = int(round(total * fs))
        t = jnp.arange(n, dtype=jnp.float64) / fs
        sweep = sum(
            frequency_sweep(t, f_start_hz=f0, f_stop_hz=f1, duration_s=dur, amplitude=a, start_s=s)
            for a, s in zip((a1, a2), starts)
        )
        k_off, k_sim = jax.random.split(k)
        off = pilot_corrections(k_off, n, fs, rms=c["off_axis_rms"])
        exc = jnp.stack([sweep, off] if axis == 0 else [off, sweep], axis=1)
        res = simulate(plant, exc, k_sim, sample_rate_hz=fs, disturbance=dist, hold=hold)
        cyclic = "delta_lat" if axis == 0 else "delta_lon"
        meta = dict(common)
        meta["record"] = f"identification, {name} channel ({cyclic} -> {'p' if axis == 0 else 'q'})"
        for i, (a, s) in enumerate(zip((a1, a2), starts), start=1):
            meta[f"segment_{i}"] = f"{s:g}-{s + dur:g} s: sweep {f0:g}-{f1:g} Hz on {cyclic}, amplitude {a:g}"
        meta["off_axis"] = f"pilot-like corrections {c['off_axis_rms']} rms on the other cyclic"
        out[name] = res.to_record(meta)

    for name, k in zip(("lateral", "longitudinal"), jax.random.split(k_val)):
        out[f"validation_{name}"] = multistep_validation(k, name, disturbance=dist, meta=common)[0]
    return out


def multistep_validation(
    key: PRNGKeyArray,
    channel: str,
    *,
    amplitudes: tuple[float, float] | None = None,
    unit_s: float = 0.4,
    pulse_s: float = 0.5,
    disturbance: Disturbance | None = None,
    meta: dict | None = None,
) -> tuple[FlightRecord, FlightRecord]:
    """One held-out multi-step flight of the R-50 on one channel, and its calm twin.

    One record per channel, each exciting its own cyclic, as flight-test verification of
    single-input models does: an input on the other axis would score the unmodelled
    cross-coupling (the diagnosis' ``cross_coupling`` candidate), not the model.  30 s at
    100 Hz: a 3-2-1-1 (``amplitudes[0]``, ``unit_s`` = 0.4 s unit) at 2 s, a doublet
    (``amplitudes[1]``, ``pulse_s`` = 0.5 s pulses) at 12 s and a reversed, faster 3-2-1-1
    (unit ``0.75 unit_s``) at 20 s, with
    pilot-like corrections (0.005 rms) on both cyclics, the weak hold loop, and
    ``disturbance`` (default: the default dataset's gusts and gyro noise).

    Returns ``(record, calm)``: ``calm`` is the same flight (same input, same key) with
    gusts and noise off, the part of the output that a rate model driven by the logged
    input can predict at all.  With ``split(split(key(DEFAULT_DATASET_SEED), 3)[2])[i]``
    (i = 0 lateral, 1 longitudinal) ``record`` is the embedded validation record.
    """
    from ._signals import doublet, multistep_3211, pilot_corrections

    if channel not in ("lateral", "longitudinal"):
        raise ValueError(f"channel must be 'lateral' or 'longitudinal', not {channel!r}")
    c = DEFAULT_DATASET_CONDITIONS
    fs = c["sample_rate_hz"]
    va, da = c["validation_amplitudes"] if amplitudes is None else amplitudes
    if disturbance is None:
        disturbance = Disturbance.default_dataset()
    n = int(round(30.0 * fs))
    t = jnp.arange(n, dtype=jnp.float64) / fs
    on_axis = (
        multistep_3211(t, amplitude=va, unit_s=unit_s, start_s=2.0)
        + doublet(t, amplitude=da, pulse_s=pulse_s, start_s=12.0)
        + multistep_3211(t, amplitude=-va, unit_s=0.75 * unit_s, start_s=20.0)
    )
    axis = 0 if channel == "lateral" else 1
    k1, k2, k_sim = jax.random.split(key, 3)
    own = on_axis + pilot_corrections(k1, n, fs, rms=0.5 * c["off_axis_rms"])
    other = pilot_corrections(k2, n, fs, rms=0.5 * c["off_axis_rms"])
    exc = jnp.stack([own, other] if axis == 0 else [other, own], axis=1)
    plant, hold = R50Plant.default(), HoldLoop.r50()
    cyclic = "delta_lat" if axis == 0 else "delta_lon"
    info = dict(meta or {})
    info["record"] = f"validation, {channel} channel ({cyclic} -> {'p' if axis == 0 else 'q'}), multi-step inputs"
    info["segment_1"] = f"2-{2 + 7 * unit_s:g} s: 3-2-1-1 on {cyclic}, amplitude {va:g}, unit {unit_s:g} s"
    info["segment_2"] = f"12-{12 + 2 * pulse_s:g} s: doublet on {cyclic}, amplitude {da:g}, pulse {pulse_s:g} s"
    info["segment_3"] = (f"20-{20 + 5.25 * unit_s:g} s: 3-2-1-1 on {cyclic}, amplitude {-va:g}, "
                         f"unit {0.75 * unit_s:g} s")
    info["off_axis"] = f"pilot-like corrections {0.5 * c['off_axis_rms']} rms on both cyclics"
    res = simulate(plant, exc, k_sim, sample_rate_hz=fs, disturbance=disturbance, hold=hold)
    calm = simulate(plant, exc, k_sim, sample_rate_hz=fs, disturbance=Disturbance(), hold=hold)
    calm_info = info | {"turbulence": "off", "noise": "off"}
    return res.to_record(info), calm.to_record(calm_info)
