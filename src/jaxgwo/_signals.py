r"""Excitation signals for frequency-domain identification, as pure JAX functions.

Every signal is a function of a time vector ``t`` (seconds) so that it can be sampled at
any rate, jitted and vmapped over its parameters.  Random signals take an explicit
``jax.random`` key; the same key gives the same signal.

* :func:`frequency_sweep`: Tischler & Remple's piloted/automated sweep (long
  low-frequency periods first, then log-type growth of frequency, faded in and out).
* :func:`sid_chirp`: ArduPilot's System-ID exponential chirp (``SID_*`` parameters).
* :func:`doublet`, :func:`multistep_3211`: multi-step validation inputs.
* :func:`odd_multisine`: a random-phase odd multisine with unexcited detection lines
  (Pintelon & Schoukens), for nonlinearity detection.
* :func:`pilot_corrections`: small, band-limited, pilot-like activity for the off-axis
  cyclic, as real flight data always carries.

References: M. B. Tischler, R. K. Remple, *Aircraft and Rotorcraft System Identification*,
2nd ed., AIAA 2012, sec. 5.7 (sweep design, eqs. 5.4-5.6); ArduPilot ``AP_Math/chirp.cpp``
and ``ArduCopter/mode_systemid.cpp``; R. Pintelon, J. Schoukens, *System Identification: A
Frequency Domain Approach*, 2nd ed., Wiley 2012, ch. 4 (random-odd multisines).
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Bool, Float, Int, PRNGKeyArray

__all__ = [
    "time_vector",
    "frequency_sweep",
    "sweep_frequency_hz",
    "sid_chirp",
    "sid_chirp_frequency_hz",
    "sid_chirp_from_params",
    "doublet",
    "multistep_3211",
    "multistep",
    "Multisine",
    "odd_multisine",
    "pilot_corrections",
]

# Tischler & Remple's constants for the exponential sweep, eq. (5.6): K(T) = C2 (e^C1 - 1) ~ 1.
_SWEEP_C1 = 4.0
_SWEEP_C2 = 0.0187


def time_vector(duration_s: float, sample_rate_hz: float) -> Float[Array, " n"]:
    """``n = round(duration_s * sample_rate_hz)`` sample times ``k / sample_rate_hz``."""
    n = int(round(duration_s * sample_rate_hz))
    if n < 2:
        raise ValueError(f"duration {duration_s} s at {sample_rate_hz} Hz gives fewer than 2 samples")
    return jnp.arange(n, dtype=jnp.float64) / sample_rate_hz


def _cosine_window(t, start, fade_in, stop, fade_out):
    """Half-cosine fade from 0 to 1 over ``[start, start+fade_in]`` and back over the end."""
    rise = jnp.clip((t - start) / jnp.maximum(fade_in, 1e-12), 0.0, 1.0)
    fall = jnp.clip((stop - t) / jnp.maximum(fade_out, 1e-12), 0.0, 1.0)
    w = (0.5 - 0.5 * jnp.cos(jnp.pi * rise)) * (0.5 - 0.5 * jnp.cos(jnp.pi * fall))
    return jnp.where((t >= start) & (t <= stop), w, 0.0)


def _sweep_phase(t, f_start_hz, f_stop_hz, duration_s, n_low_cycles, c1, c2):
    w0 = 2.0 * jnp.pi * f_start_hz
    w1 = 2.0 * jnp.pi * f_stop_hz
    t_dwell = n_low_cycles / f_start_hz
    big_t = duration_s - t_dwell
    tau = jnp.clip(t - t_dwell, 0.0, big_t)
    growth = c2 * (big_t / c1 * jnp.expm1(c1 * tau / big_t) - tau)
    phase = w0 * jnp.minimum(t, t_dwell) + w0 * tau + (w1 - w0) * growth
    omega = jnp.where(t < t_dwell, w0, w0 + (w1 - w0) * c2 * jnp.expm1(c1 * tau / big_t))
    return phase, omega


def frequency_sweep(
    t: Float[Array, " n"],
    *,
    f_start_hz: float,
    f_stop_hz: float,
    duration_s: float,
    amplitude: float,
    n_low_cycles: float = 2.0,
    fade_in_s: float | None = None,
    fade_out_s: float | None = None,
    start_s: float = 0.0,
) -> Float[Array, " n"]:
    r"""Tischler-style frequency sweep ``amplitude * window(t) * sin(theta(t))``.

    The sweep holds ``n_low_cycles`` periods at ``f_start_hz`` (the long low-frequency
    periods Tischler & Remple ask for first), then grows the frequency exponentially,
    eq. (5.6) of Tischler & Remple:

    .. math::

        \omega(\tau) = \omega_{min} + K(\tau)(\omega_{max}-\omega_{min}),\quad
        K = C_2\,(e^{C_1 \tau / T} - 1),\ C_1 = 4,\ C_2 = 0.0187

    with ``tau`` the time since the end of the low-frequency dwell and ``T`` the rest of
    the duration; the phase ``theta`` is the exact integral of ``omega``.  A half-cosine
    fade-in (default one start period) and fade-out (default the last 3 % of the sweep)
    start and end it without a step.  Zero outside ``[start_s, start_s + duration_s]``.
    """
    tl = t - start_s
    phase, _ = _sweep_phase(tl, f_start_hz, f_stop_hz, duration_s, n_low_cycles, _SWEEP_C1, _SWEEP_C2)
    fade_in = 1.0 / f_start_hz if fade_in_s is None else fade_in_s
    fade_out = 0.03 * duration_s if fade_out_s is None else fade_out_s
    window = _cosine_window(tl, 0.0, fade_in, duration_s, fade_out)
    return amplitude * window * jnp.sin(phase)


def sweep_frequency_hz(
    t: Float[Array, " n"],
    *,
    f_start_hz: float,
    f_stop_hz: float,
    duration_s: float,
    n_low_cycles: float = 2.0,
    start_s: float = 0.0,
) -> Float[Array, " n"]:
    """Instantaneous frequency (Hz) of :func:`frequency_sweep` with the same arguments."""
    _, omega = _sweep_phase(t - start_s, f_start_hz, f_stop_hz, duration_s, n_low_cycles, _SWEEP_C1, _SWEEP_C2)
    return omega / (2.0 * jnp.pi)


def _sid_chirp_parts(t, f_start_hz, f_stop_hz, t_fade_in, t_rec, t_fade_out, t_const):
    w_min = 2.0 * jnp.pi * f_start_hz
    w_max = 2.0 * jnp.pi * f_stop_hz
    b = jnp.log(w_max / w_min)
    span = t_rec - t_const
    growth = jnp.exp(b * (t - t_const) / span)
    in_dwell = t <= t_const
    phase = jnp.where(in_dwell, w_min * (t - t_const), (w_min * span / b) * (growth - 1.0))
    omega = jnp.where(in_dwell, w_min, w_min * growth)
    rise = 0.5 - 0.5 * jnp.cos(jnp.pi * t / jnp.maximum(t_fade_in, 1e-12))
    fall = 0.5 - 0.5 * jnp.cos(jnp.pi * (t - (t_rec - t_fade_out)) / jnp.maximum(t_fade_out, 1e-12) + jnp.pi)
    window = jnp.where(
        t <= 0.0,
        0.0,
        jnp.where(t <= t_fade_in, rise, jnp.where(t <= t_rec - t_fade_out, 1.0, jnp.where(t <= t_rec, fall, 0.0))),
    )
    return window, phase, omega


def sid_chirp(
    t: Float[Array, " n"],
    *,
    f_start_hz: float,
    f_stop_hz: float,
    t_rec_s: float,
    magnitude: float,
    t_fade_in_s: float = 0.0,
    t_fade_out_s: float = 0.0,
    start_s: float = 0.0,
) -> Float[Array, " n"]:
    r"""ArduPilot System-ID exponential chirp (``AP_Math/chirp.cpp``, ``mode_systemid.cpp``).

    Parameter names map onto ArduPilot's: ``f_start_hz`` = ``SID_F_START_HZ``,
    ``f_stop_hz`` = ``SID_F_STOP_HZ``, ``t_fade_in_s`` = ``SID_T_FADE_IN``, ``t_rec_s`` =
    ``SID_T_REC``, ``t_fade_out_s`` = ``SID_T_FADE_OUT``, ``magnitude`` = ``SID_MAGNITUDE``.
    As in ``mode_systemid.cpp`` the chirp first dwells two full cycles at the start
    frequency (``t_c = 2 / SID_F_START_HZ``), then

    .. math::

        \omega(t) = \omega_{min}\, e^{B (t - t_c)/(T_{rec} - t_c)},\quad
        B = \ln(\omega_{max}/\omega_{min}),\quad
        \theta(t) = \frac{\omega_{min}(T_{rec}-t_c)}{B}\left(e^{B (t-t_c)/(T_{rec}-t_c)} - 1\right)

    under a half-cosine fade-in over ``[0, SID_T_FADE_IN]`` and fade-out over the last
    ``SID_T_FADE_OUT`` seconds of ``SID_T_REC``.  Zero before ``start_s`` and after
    ``start_s + SID_T_REC``.  Use :func:`sid_chirp_from_params` for a dict of ``SID_*``.
    """
    t_const = 2.0 / f_start_hz
    window, phase, _ = _sid_chirp_parts(t - start_s, f_start_hz, f_stop_hz, t_fade_in_s, t_rec_s, t_fade_out_s, t_const)
    return magnitude * window * jnp.sin(phase)


def sid_chirp_frequency_hz(
    t: Float[Array, " n"], *, f_start_hz: float, f_stop_hz: float, t_rec_s: float, start_s: float = 0.0
) -> Float[Array, " n"]:
    """Instantaneous frequency (Hz) of :func:`sid_chirp`."""
    _, _, omega = _sid_chirp_parts(t - start_s, f_start_hz, f_stop_hz, 0.0, t_rec_s, 0.0, 2.0 / f_start_hz)
    return omega / (2.0 * jnp.pi)


def sid_chirp_from_params(t: Float[Array, " n"], sid: Mapping[str, float], *, start_s: float = 0.0) -> Float[Array, " n"]:
    """:func:`sid_chirp` from ArduPilot parameter names (``SID_F_START_HZ``, ``SID_T_REC``, ...)."""
    required = ("SID_F_START_HZ", "SID_F_STOP_HZ", "SID_T_REC", "SID_MAGNITUDE")
    missing = [k for k in required if k not in sid]
    if missing:
        raise ValueError(f"missing ArduPilot parameter(s) {missing}; got {sorted(sid)}")
    return sid_chirp(
        t,
        f_start_hz=sid["SID_F_START_HZ"],
        f_stop_hz=sid["SID_F_STOP_HZ"],
        t_rec_s=sid["SID_T_REC"],
        magnitude=sid["SID_MAGNITUDE"],
        t_fade_in_s=sid.get("SID_T_FADE_IN", 0.0),
        t_fade_out_s=sid.get("SID_T_FADE_OUT", 0.0),
        start_s=start_s,
    )


def multistep(
    t: Float[Array, " n"], levels: tuple[float, ...], durations_s: tuple[float, ...], *, start_s: float = 0.0
) -> Float[Array, " n"]:
    """Piecewise-constant input: ``levels[i]`` for ``durations_s[i]`` seconds, from ``start_s``.

    Each step holds on ``[edge_i, edge_{i+1})``; zero before ``start_s`` and after the last step.
    """
    if len(levels) != len(durations_s):
        raise ValueError(f"{len(levels)} levels but {len(durations_s)} durations")
    out = jnp.zeros_like(t)
    edges = [start_s + math.fsum(durations_s[:i]) for i in range(len(durations_s) + 1)]
    eps = 1e-9  # edges that land on a sample time belong to the later step despite rounding
    for level, lo, hi in zip(levels, edges[:-1], edges[1:]):
        out = jnp.where((t >= lo - eps) & (t < hi - eps), level, out)
    return out


def doublet(t: Float[Array, " n"], *, amplitude: float, pulse_s: float, start_s: float = 0.0) -> Float[Array, " n"]:
    """Doublet: ``+amplitude`` for ``pulse_s``, then ``-amplitude`` for ``pulse_s``.

    Tischler & Remple sec. 5.9: choose ``pulse_s`` near ``1/(2 f)`` of the mode of interest.
    """
    return multistep(t, (amplitude, -amplitude), (pulse_s, pulse_s), start_s=start_s)


def multistep_3211(t: Float[Array, " n"], *, amplitude: float, unit_s: float, start_s: float = 0.0) -> Float[Array, " n"]:
    """3-2-1-1: ``+A`` for 3 units, ``-A`` for 2, ``+A`` for 1, ``-A`` for 1 (Koehler's input)."""
    a = amplitude
    return multistep(t, (a, -a, a, -a), (3 * unit_s, 2 * unit_s, unit_s, unit_s), start_s=start_s)


class Multisine(eqx.Module):
    """A periodic random-phase odd multisine and its line plan.

    Attributes:
        period_s: period ``P``; lines sit at ``k / P`` Hz.
        lines: harmonic numbers ``k`` of every odd line in the band.
        excited: which of ``lines`` carry power (the others are odd detection lines).
        phases: phase of each line (rad), uniform in ``[0, 2 pi)``; unused where not excited.
        scale: per-line amplitude, set so the sampled period peaks at the requested amplitude.
    """

    period_s: float = eqx.field(static=True)
    lines: Int[Array, " lines"]
    excited: Bool[Array, " lines"]
    phases: Float[Array, " lines"]
    scale: Float[Array, ""]

    def __call__(self, t: Float[Array, " n"]) -> Float[Array, " n"]:
        f = self.lines.astype(jnp.float64) / self.period_s
        arg = 2.0 * jnp.pi * f[None, :] * t[:, None] + self.phases[None, :]
        return self.scale * jnp.sum(jnp.where(self.excited[None, :], jnp.cos(arg), 0.0), axis=1)

    @property
    def excited_frequencies_hz(self) -> np.ndarray:
        return np.asarray(self.lines)[np.asarray(self.excited)] / self.period_s

    @property
    def detection_frequencies_hz(self) -> np.ndarray:
        """Odd lines left unexcited: power there means odd nonlinear distortion (or noise)."""
        return np.asarray(self.lines)[~np.asarray(self.excited)] / self.period_s


def odd_multisine(
    key: PRNGKeyArray,
    *,
    period_s: float,
    sample_rate_hz: float,
    f_min_hz: float,
    f_max_hz: float,
    amplitude: float,
    group_size: int = 3,
) -> Multisine:
    r"""Random-phase *random-odd* multisine (Pintelon & Schoukens ch. 4).

    Only odd harmonics ``k`` of ``1/period_s`` inside ``[f_min_hz, f_max_hz]`` are used, so
    every even line is a detection line for even nonlinearities.  The odd lines are cut
    into consecutive groups of ``group_size``; in each group one line chosen at random is
    left unexcited, a detection line for odd nonlinearities.  Excited lines have equal
    amplitude and independent uniform phases:

    .. math:: u(t) = A_s \sum_{k\ \mathrm{excited}} \cos(2\pi k t / P + \phi_k)

    with ``A_s`` chosen so the peak over one sampled period equals ``amplitude``.
    ``period_s * sample_rate_hz`` must be an integer (whole periods give leakage-free DFT lines).
    """
    n_per = period_s * sample_rate_hz
    if abs(n_per - round(n_per)) > 1e-9 * max(1.0, n_per):
        raise ValueError(f"period {period_s} s is not a whole number of samples at {sample_rate_hz} Hz")
    if not 0.0 < f_min_hz < f_max_hz <= sample_rate_hz / 2:
        raise ValueError(f"need 0 < f_min_hz < f_max_hz <= Nyquist; got {f_min_hz}, {f_max_hz}")
    k_lo = max(1, math.ceil(f_min_hz * period_s))
    k_hi = math.floor(f_max_hz * period_s)
    lines = np.arange(k_lo + (1 - k_lo % 2), k_hi + 1, 2)
    if lines.size < group_size:
        raise ValueError(f"band [{f_min_hz}, {f_max_hz}] Hz holds only {lines.size} odd lines at period {period_s} s")
    n_groups = lines.size // group_size
    k_skip, k_phase = jax.random.split(key)
    skip = jax.random.randint(k_skip, (n_groups,), 0, group_size)
    slot = jnp.arange(lines.size)
    in_group = slot < n_groups * group_size
    group_of = jnp.minimum(slot // group_size, n_groups - 1)
    excited = ~(in_group & (slot % group_size == skip[group_of]))
    phases = jax.random.uniform(k_phase, (lines.size,), minval=0.0, maxval=2.0 * jnp.pi)
    unit = Multisine(period_s=period_s, lines=jnp.asarray(lines), excited=excited, phases=phases, scale=jnp.ones(()))
    grid = jnp.arange(int(round(n_per)), dtype=jnp.float64) / sample_rate_hz
    peak = jnp.max(jnp.abs(unit(grid)))
    return Multisine(period_s=period_s, lines=unit.lines, excited=excited, phases=phases, scale=amplitude / peak)


def pilot_corrections(
    key: PRNGKeyArray,
    n: int,
    sample_rate_hz: float,
    *,
    rms: float | Float[Array, ""],
    bandwidth_hz: float | Float[Array, ""] = 0.4,
) -> Float[Array, " n"]:
    r"""Small pilot-like corrections: white noise through two first-order lags.

    The filter is ``H(z) = (1-a)^2 / (1 - a z^{-1})^2`` with ``a = exp(-2 pi f_c / f_s)``,
    i.e. the exact discretisation of two cascaded lags at ``bandwidth_hz``: the slow,
    smooth stick activity a pilot adds on the off-axis while holding hover.  The white
    input is scaled analytically so the stationary output has standard deviation
    ``rms``: for this filter :math:`\sum h_n^2 = (1-a)^4 (1+a^2)/(1-a^2)^3`.
    The filter starts from trim (zero), so the first ``~1/f_c`` seconds ramp up.
    """
    a = jnp.exp(-2.0 * jnp.pi * bandwidth_hz / sample_rate_hz)
    gain2 = (1.0 - a) ** 4 * (1.0 + a * a) / (1.0 - a * a) ** 3
    w = jax.random.normal(key, (n,), dtype=jnp.float64) * rms / jnp.sqrt(gain2)

    def step(carry, wk):
        y1, y2 = carry
        y1 = a * y1 + (1.0 - a) * wk
        y2 = a * y2 + (1.0 - a) * y1
        return (y1, y2), y2

    zero = jnp.zeros((), dtype=jnp.float64)
    _, y = jax.lax.scan(step, (zero, zero), w)
    return y
