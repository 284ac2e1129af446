r"""The identification pipeline: flight records in, a validated rate model out.

Per channel (lateral ``p/delta_lat`` or longitudinal ``q/delta_lon``):

1. **Preprocess** each record (paper section 4.2): wild values, detrend (optional
   smoothing / zero-phase low-pass); what changed is reported.
2. **Frequency response**: CIFER-style composite H1 estimate with coherence on
   log-spaced frequencies, pooled over the records.
3. **WLS start** (eqs. 17-29): Levy fit of ``b0/(a4 s^4 + ... + a1 s + 1)`` with
   Sanathanan-Koerner passes, factored into the paper model with the servo as the faster
   pair.
4. **Refine** by the chosen method, minimising the CIFER cost ``J``:

   * ``wls``: the WLS model alone;
   * ``traditional``: a local least-squares fit of ``J`` from the WLS start (the paper's
     baseline; ``scipy.optimize.least_squares`` on the residual vector with JAX's Jacobian);
   * ``wls-gwo`` / ``wls-igwo``: the pack is seeded around the WLS solution (in
     log-parameters) and searches a box around it;
   * ``wls-igwo+polish``: then an optax L-BFGS polish of the best wolf, in log-parameters;
   * ``paper``: the paper's own parameterisation: IGWO over the Levy moment sums of
     eq. (29) around their WLS values (:mod:`jaxgwo._paper_mode`), factored at the end.

5. **Validate** on held-out records: the model is simulated from the measured input and
   compared with the measured output (R^2 of eq. 46, Theil's inequality coefficient, RMS),
   and Cramer-Rao bounds of the parameters come from the Fisher information of ``J``.

Several channels or records of the same shape are identified in one batched, compiled
optimiser call (:func:`identify_channels`), not a Python loop of full runs.

To batch channels whose gains have opposite signs, every response is normalised to a
positive low-frequency gain before the search (``H -> sign * H``) and the sign is put
back on ``K`` afterwards.
"""

from __future__ import annotations

import functools
import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from . import _gwo as G
from ._aot import cached_jit
from ._cost import CiferObjective
from ._data import CHANNELS, FlightRecord
from ._metrics import ParameterUncertainty, parameter_uncertainty, r_squared, rms_error, theil_inequality
from ._models import PaperModel, ParameterMap, QuarticModel, canonicalize_paper_params
from ._preprocess import PreprocessReport, preprocess
from ._spectral import FrequencyResponse, _device, composite_frequency_response, zoh_correction
from ._wls import levy_fit_response

METHODS = ("wls", "traditional", "wls-gwo", "wls-igwo", "wls-igwo+polish", "paper")


class IdentificationError(ValueError):
    """The data cannot support the requested identification (the message says why)."""


def _need_int(name: str, value, minimum: int | None, why: str) -> None:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise ValueError(f"{name}={value!r} must be an integer ({why}).")
    if minimum is not None and value < minimum:
        raise ValueError(f"{name}={value!r}: pass {name} >= {minimum} ({why}).")


def _need_real(name: str, value) -> None:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ValueError(f"{name}={value!r} must be a number.")
    if math.isnan(value):
        raise ValueError(f"{name} is NaN; pass a number.")


@dataclass(frozen=True)
class IdentifySettings:
    """Everything that shapes an identification run.

    ``search_factor``: the box is ``[p/f, p*f]`` around the WLS value ``p`` of each
    parameter (``zeta_s`` gets ``f`` too, but is capped to ``[0.05, 3]``).
    ``seed_spread``: standard deviation, in natural-log units, of the seeded wolves around
    the WLS start; ``seeded_fraction`` of the pack is seeded, the rest uniform in the box.
    ``zoh_correction``: divide the held input's half-sample delay and droop out of the
    measured response (:func:`jaxgwo._spectral.zoh_correction`); turn off for data whose
    input was not held between samples.
    """

    method: str = "wls-igwo"
    wolves: int = 50
    iterations: int = 500
    seed: int = 0
    w_min: float = 1.0
    w_max: float = 60.0
    n_frequencies: int = 200
    coherence_threshold: float = 0.6
    sk_iterations: int = 5
    search_factor: float = 3.0
    seed_spread: float = 0.1
    seeded_fraction: float = 0.5
    polish_steps: int = 200
    zoh_correction: bool = True
    wild_values: bool = True
    detrend: str | None = "linear"
    lowpass_hz: float | None = None

    def __post_init__(self):
        if self.method not in METHODS:
            raise ValueError(f"unknown method {self.method!r}; choose one of {', '.join(METHODS)}.")
        _need_int("wolves", self.wolves, 4, "a grey wolf pack needs alpha, beta, delta and an "
                  "omega (the paper uses 50)")
        _need_int("iterations", self.iterations, 1, "the paper uses 500")
        _need_int("seed", self.seed, -(2**63), "a 64-bit integer")
        if self.seed >= 2**63:  # jax.random.key takes a C long
            raise ValueError(f"seed={self.seed!r}: pass seed < 2**63 (a 64-bit integer).")
        _need_int("n_frequencies", self.n_frequencies, 20, "the CIFER cost needs >= 20")
        _need_int("sk_iterations", self.sk_iterations, 0, "Sanathanan-Koerner passes")
        _need_int("polish_steps", self.polish_steps, 0, "L-BFGS steps")
        for name in ("w_min", "w_max", "coherence_threshold", "search_factor", "seed_spread",
                     "seeded_fraction"):
            _need_real(name, getattr(self, name))
        if not 0.0 < self.w_min < self.w_max < math.inf:
            raise ValueError(
                f"frequency band [{self.w_min}, {self.w_max}] rad/s is empty or inverted, or "
                "not finite; pass 0 < w_min < w_max (finite)."
            )
        if not 0.0 <= self.coherence_threshold < 1.0:
            raise ValueError(
                f"coherence_threshold {self.coherence_threshold}: pass a value in [0, 1) "
                "(0.6 is usual)."
            )
        if not 1.0 < self.search_factor < math.inf:
            raise ValueError(f"search_factor {self.search_factor} must be finite and exceed 1.")
        if not 0.0 <= self.seed_spread < math.inf:
            raise ValueError(f"seed_spread {self.seed_spread} must be finite and >= 0.")
        if not 0.0 <= self.seeded_fraction <= 1.0:
            raise ValueError(f"seeded_fraction {self.seeded_fraction} must lie in [0, 1].")
        for name in ("zoh_correction", "wild_values"):
            if not isinstance(getattr(self, name), (bool, np.bool_)):
                raise ValueError(f"{name}={getattr(self, name)!r} must be True or False.")
        if self.detrend not in (None, "constant", "linear"):
            raise ValueError(f"detrend {self.detrend!r}: choose None, 'constant' or 'linear'.")
        if self.lowpass_hz is not None:
            _need_real("lowpass_hz", self.lowpass_hz)
            if not 0.0 < self.lowpass_hz < math.inf:
                raise ValueError(f"lowpass_hz {self.lowpass_hz}: pass a positive cutoff or None.")

    def optimiser(self) -> G.GreyWolfConfig:
        if self.method == "wls-gwo":
            return G.gwo(self.wolves, self.iterations)
        return G.igwo(self.wolves, self.iterations)


@dataclass(frozen=True)
class Validation:
    """Time-domain validation on held-out records (all records concatenated for the scores)."""

    r2: float
    tic: float
    rms: float
    per_record_r2: tuple[float, ...]
    time: tuple[np.ndarray, ...] = field(repr=False)
    measured: tuple[np.ndarray, ...] = field(repr=False)
    predicted: tuple[np.ndarray, ...] = field(repr=False)


@dataclass(frozen=True)
class ChannelIdentification:
    """The identified model of one channel and how well it fits and validates."""

    channel: str
    method: str
    seed: int
    model: PaperModel
    wls_model: PaperModel
    response: FrequencyResponse = field(repr=False)
    cost_J: float
    wls_cost_J: float
    mse: float
    convergence: np.ndarray = field(repr=False)
    uncertainty: ParameterUncertainty = field(repr=False)
    evaluations: int
    runtime_s: float
    preprocessing: tuple[PreprocessReport, ...] = field(repr=False)
    validation: Validation | None = None


# ----------------------------------------------------------------------------- stages


def channel_signals(record: FlightRecord, channel: str) -> tuple[np.ndarray, np.ndarray]:
    """``(input, output)`` of ``channel`` from ``record``, with a clear error if absent."""
    if channel not in CHANNELS:
        raise ValueError(f"unknown channel {channel!r}; choose lateral or longitudinal.")
    u_name, y_name = CHANNELS[channel]
    missing = [c for c in (u_name, y_name) if c not in record.columns]
    if missing:
        raise IdentificationError(
            f"the {channel} channel needs columns {u_name!r} and {y_name!r}; missing "
            f"{', '.join(map(repr, missing))}. The record has: {', '.join(record.columns)}."
        )
    return np.asarray(record[u_name], float), np.asarray(record[y_name], float)


MIN_SAMPLES = 5
"""Fewest samples a record may have (the wild-value check predicts each sample from four
neighbours)."""

MAX_ABS_SAMPLE = 1e150
"""Largest sample magnitude identification accepts: the fit's mean-square error and the
validation's R^2 square the samples, which overflows float64 (1.8e308) beyond about 1e154."""

MAX_GAIN_DECADES = 100
"""The measured gain |H| must lie within ``10**-100 .. 10**100``: the CIFER cost and the
WLS weights square it, which overflows float64 beyond about 1e154."""


def _check_signals(rec: FlightRecord, channel: str, role: str, index: int) -> None:
    """Reject a record identification cannot use, naming the record, column and row."""
    u_name, y_name = CHANNELS[channel]
    where = f"{role} record {index} ({channel} channel)"
    if rec.n_samples < MIN_SAMPLES:
        raise IdentificationError(
            f"{where} has {rec.n_samples} samples; identification needs at least "
            f"{MIN_SAMPLES}. Use a longer record."
        )
    for name in ("time", u_name, y_name):
        x = np.asarray(rec[name], float)
        bad = np.flatnonzero(~np.isfinite(x))  # a FlightRecord built without make_record
        if bad.size:
            i = int(bad[0])
            raise IdentificationError(
                f"{where}: column {name!r} has a non-finite value ({float(x[i])!r}) at row {i}; "
                "build records with make_record or load_record, which reject these."
            )
        if name == "time":
            continue
        big = np.flatnonzero(~(np.abs(x) <= MAX_ABS_SAMPLE))
        if big.size:
            i = int(big[0])
            raise IdentificationError(
                f"{where}: column {name!r} reaches {x[i]:.3g} at row {i}, beyond "
                f"{MAX_ABS_SAMPLE:.0e}; rescale the column (check its units)."
            )


def _check_varies(raw: np.ndarray, clean: np.ndarray, where: str, role: str, name: str,
                  what: str, n_wild: int) -> None:
    """A signal that preprocessing leaves flat (constant, or a straight line that the
    detrend removes) carries no frequency content: its spectra are rounding noise."""
    scale = float(np.max(np.abs(raw)))
    if np.ptp(clean) > 1e-9 * scale:
        return
    if n_wild:
        n = raw.size
        line = np.polyval(np.polyfit(np.arange(n, dtype=float), raw, 1), np.arange(n, dtype=float))
        if np.ptp(raw - line) > 1e-9 * scale:
            raise IdentificationError(
                f"{where}: the {role} (column {name!r}) varies only in {n_wild} isolated "
                "sample(s), which the wild-value correction replaced, leaving it flat, so "
                f"{what}. If those samples are real, identify with "
                "IdentifySettings(wild_values=False)."
            )
    raise IdentificationError(
        f"{where}: the {role} is constant (column {name!r}, or a straight line, which "
        f"detrending removes), so {what}."
    )


def _preprocessed(records, channel, settings, role="identification"):
    pairs, reports = [], []
    u_name, y_name = CHANNELS.get(channel, ("input", "output"))
    for i, rec in enumerate(records):
        u, y = channel_signals(rec, channel)
        _check_signals(rec, channel, role, i)
        where = f"{role} record {i} ({channel} channel)"
        try:
            clean, report = preprocess(
                np.asarray(rec.time), {"u": u, "y": y}, wild_values=settings.wild_values,
                detrend_kind=settings.detrend, lowpass_hz=settings.lowpass_hz,
            )
        except ValueError as err:  # e.g. a low-pass cutoff above this record's Nyquist
            raise IdentificationError(f"{where}: preprocessing: {err}") from None
        pairs.append((np.asarray(clean["u"]), np.asarray(clean["y"])))
        reports.append(report)
        _check_varies(u, pairs[-1][0], where, "input", u_name,
                      "nothing excites the channel; use a record with a frequency sweep on "
                      "that cyclic", report["u"].n_corrected)
        _check_varies(y, pairs[-1][1], where, "output", y_name,
                      "there is no response to identify or score; check that the rate "
                      "column is the one the gyro logged", report["y"].n_corrected)
    return pairs, tuple(reports)


def _check_rates(records: Sequence[FlightRecord]) -> float:
    rates = {round(float(r.sample_rate), 6) for r in records}
    if len(rates) != 1:
        raise IdentificationError(
            f"records have different sample rates {sorted(rates)} Hz; resample them to one rate."
        )
    return float(records[0].sample_rate)


def _gain_sign(response: FrequencyResponse) -> float:
    """Sign of the low-frequency gain: the phase of the first passing points near 0 or 180."""
    H = np.asarray(response.H)[np.asarray(response.mask)]
    if H.size == 0:
        raise IdentificationError("no frequency passes the coherence mask.")
    head = H[: max(3, H.size // 10)]
    return 1.0 if np.median(np.real(head)) >= 0.0 else -1.0


def _flip(response: FrequencyResponse, sign: float) -> FrequencyResponse:
    return eqx.tree_at(lambda r: r.H, response, response.H * sign)


def wls_start(response: FrequencyResponse, sk_iterations: int = 5) -> tuple[PaperModel, str]:
    """The WLS (Levy) start as a paper model, and a note on how it was obtained.

    Falls back to a generic small-helicopter guess when the quartic does not factor into
    two stable quadratics (the note says so)."""
    fit = levy_fit_response(response, sk_iterations=sk_iterations)
    q = QuarticModel.from_array(jnp.asarray(fit.theta))
    try:
        return PaperModel.from_quartic(q).canonical(), "wls"
    except ValueError as err:
        H = np.asarray(response.H)[np.asarray(response.mask)]
        w = np.asarray(response.w)[np.asarray(response.mask)]
        m, tau, ws, zs = 100.0, 0.1, 40.0, 0.6
        k = float(np.abs(H[0]) * np.abs((m - w[0] ** 2) + 1j * w[0] / tau))
        note = f"WLS quartic did not factor ({err}); started from a generic guess"
        return PaperModel.from_array(jnp.asarray([k, tau, m, ws, zs])), note


ZETA_S_RANGE = (0.05, 3.0)
"""The servo damping every search box keeps to (a physical servo; the paper's is 0.5-0.7)."""


def _box(x0, factor: float) -> tuple[np.ndarray, np.ndarray]:
    """The search box ``[x0 - ln f, x0 + ln f]`` (log-parameters), ``zeta_s`` capped.

    Host NumPy, like :func:`_seeded_wolves`: additions, clips and maxima round exactly as
    XLA's do, and each would otherwise compile a small program in every fresh process."""
    half = math.log(factor)
    x0 = np.asarray(x0, dtype=float)
    lo, hi = x0 - half, x0 + half
    # zeta_s (index 4) is kept physical: [0.05, 3], the box around the start's value moved
    # inside first (a WLS start can put it far outside: 0.004 on a paper plant with an
    # 18 ms delay, where capping alone left the box inverted)
    z_lo, z_hi = (math.log(v) for v in ZETA_S_RANGE)
    c = min(max(float(x0[4]), z_lo), z_hi)
    lo[4] = max(c - half, z_lo)
    hi[4] = min(c + half, z_hi)
    return lo, hi


def _seeded_wolves(key, x0, lo, hi, n, spread) -> np.ndarray:
    """``n`` wolves normal around ``x0`` (standard deviation ``spread``), clipped to the
    box; wolf 0 is ``x0`` itself."""
    x0 = np.asarray(x0, dtype=float)
    return _seeded_from_normals(jax.random.normal(key, (n, x0.shape[0])), x0, lo, hi, spread)


def _seeded_from_normals(normals, x0, lo, hi, spread) -> np.ndarray:
    """:func:`_seeded_wolves` given its unit normal draws ``(n, dim)``."""
    x0, lo, hi = (np.asarray(a, dtype=float) for a in (x0, lo, hi))
    noise = spread * np.asarray(normals)
    wolves = _clip(x0[None] + noise, lo, hi)
    wolves[0] = _clip(x0, lo, hi)
    return wolves


@functools.partial(jax.jit, static_argnums=(1, 2, 3))
def _search_randomness(seed, channels: int, n_seed: int, dim: int):
    """The unit normals of each channel's seeded wolves and each channel's optimiser key,
    from ``seed``: the splits :func:`_identify_prepared` made one call at a time, in one
    program (integer hashing and the normal transform of each draw, as in
    ``jax.random.normal``; the same bits)."""
    k_seed, k_run = jax.random.split(jax.random.key(seed))
    seed_keys = jax.random.split(k_seed, channels)
    normals = jnp.stack([jax.random.normal(seed_keys[i], (n_seed, dim))
                         for i in range(channels)])
    return normals, jax.random.split(k_run, channels)


def _clip(x, lo, hi):
    # jnp.clip's order (max, then min), which np.clip does not promise
    return np.minimum(np.maximum(x, lo), hi)


@eqx.filter_jit
def polish(objective, x0, steps: int):
    """L-BFGS polish (optax) of ``objective`` from ``x0``; returns the best point seen."""
    # imported when traced: a warm CLI run reuses the stored program and skips optax's
    # import (about 0.1 s)
    import optax

    opt = optax.lbfgs()
    vg = optax.value_and_grad_from_state(objective)

    def body(carry, _):
        x, state, best_x, best_f = carry
        f, g = vg(x, state=state)
        g = jnp.where(jnp.isfinite(g), g, 0.0)
        better = f < best_f
        best_x = jnp.where(better, x, best_x)
        best_f = jnp.where(better, f, best_f)
        upd, state = opt.update(g, state, x, value=f, grad=g, value_fn=objective)
        return (optax.apply_updates(x, upd), state, best_x, best_f), f

    # optax's L-BFGS mixes int32 and int64 internally; allow standard promotion here so
    # the polish also runs under strict promotion (the test suite's setting)
    with jax.numpy_dtype_promotion("standard"):
        init = (x0, opt.init(x0), x0, objective(x0))
        (x, _, best_x, best_f), _ = jax.lax.scan(body, init, None, length=steps)
    f_end = objective(x)
    return jnp.where(f_end < best_f, x, best_x)


@cached_jit
@eqx.filter_jit
def _polish_batch(objectives, xs, steps: int):
    """:func:`polish` of each channel, vmapped inside one jit so that a second run (or a
    warm persistent cache) neither re-traces nor re-lowers it."""
    return eqx.filter_vmap(lambda o, x: polish(o, x, steps))(objectives, xs)


@cached_jit(compiler_options=G._compiler_options)
def _search(config, objectives, lower, upper, keys, init_wolves):
    """:func:`jaxgwo.run_batch` reduced to what identification reads from it (one
    compiled program, which :func:`jaxgwo._aot.cached_jit` keeps across runs)."""
    res = G.run_batch(config, objectives, lower, upper, keys, init_wolves=init_wolves)
    return res.best_position, res.history_best, res.evaluations


def _residuals(objective, x):
    return objective.residuals(x)


@eqx.filter_jit
def _jacobian(objective, x):
    return jax.jacfwd(objective.residuals)(x)


def _traditional(objective: CiferObjective, x0: jax.Array) -> jax.Array:
    """The paper's baseline: a local least-squares fit of J from the WLS start."""
    from scipy.optimize import least_squares

    sol = least_squares(
        lambda x: np.asarray(_residuals(objective, jnp.asarray(x))),
        np.asarray(x0),
        jac=lambda x: np.asarray(_jacobian(objective, jnp.asarray(x))),
        method="lm",
        xtol=1e-12,
        ftol=1e-12,
    )
    return jnp.asarray(sol.x)


def _time_mse(model: PaperModel, pairs, dt) -> float:
    errs = []
    for u, y in pairs:
        t = jnp.asarray(np.arange(u.size) * dt)
        pred = np.asarray(model.simulate(t, jnp.asarray(u)))
        errs.append((pred - y) ** 2)
    return float(np.mean(np.concatenate(errs)))


def validate(model: PaperModel, records: Sequence[FlightRecord], channel: str,
             settings: IdentifySettings) -> Validation:
    """Simulate ``model`` from each held-out record's input; score against its output."""
    pairs, _ = _preprocessed(records, channel, settings, role="validation")
    return _validate_pairs(model, records, pairs)


def _validate_pairs(model: PaperModel, records: Sequence[FlightRecord], pairs) -> Validation:
    """:func:`validate` of records whose signals are already preprocessed (``pairs``)."""
    times, meas, pred = [], [], []
    for rec, (u, y) in zip(records, pairs):
        t = np.asarray(rec.time)
        t = t - float(t[0])
        yp = np.asarray(model.simulate(_device(t), _device(u)))
        times.append(t)
        meas.append(y)
        pred.append(yp)
    y_all, p_all = _device(np.concatenate(meas)), _device(np.concatenate(pred))
    return Validation(
        r2=float(r_squared(y_all, p_all)),
        tic=float(theil_inequality(y_all, p_all)),
        rms=float(rms_error(y_all, p_all)),
        per_record_r2=tuple(float(r_squared(_device(m), _device(p)))
                            for m, p in zip(meas, pred)),
        time=tuple(times),
        measured=tuple(meas),
        predicted=tuple(pred),
    )


# ----------------------------------------------------------------------------- pipeline


@dataclass(frozen=True)
class _Prepared:
    channel: str
    pairs: list
    reports: tuple
    dt: float
    response: FrequencyResponse  # as measured (the objective holds the sign-normalised one)
    sign: float
    start: PaperModel  # sign-normalised WLS start
    start_note: str
    objective: CiferObjective


def _prepare(records, channel, settings) -> _Prepared:
    """Records of one channel -> preprocessing -> composite response -> WLS start."""
    if not records:
        raise IdentificationError(f"no identification records for the {channel} channel.")
    fs = _check_rates(records)
    pairs, reports = _preprocessed(records, channel, settings)
    try:
        response = composite_frequency_response(
            pairs, fs, w_min=settings.w_min, w_max=settings.w_max,
            n_frequencies=settings.n_frequencies,
            coherence_threshold=settings.coherence_threshold,
        )
    except ValueError as err:
        raise IdentificationError(f"{channel}: {err}") from err
    if settings.zoh_correction:
        response = zoh_correction(response, fs)
    return _prepare_response(response, channel, settings, pairs, reports, 1.0 / fs)


def _check_response(response: FrequencyResponse, channel: str) -> None:
    """Reject a frequency response the cost cannot use (given directly, or measured)."""
    if not isinstance(response, FrequencyResponse):
        raise IdentificationError(
            f"{channel}: expected a FrequencyResponse, got {type(response).__name__}; build "
            "one with FrequencyResponse.from_complex(w, H, coherence)."
        )
    w = np.asarray(response.w)
    H = np.asarray(response.H)
    coh = np.asarray(response.coherence)
    mask = np.asarray(response.mask)
    if w.ndim != 1 or w.size < 2:
        raise IdentificationError(f"{channel}: the frequencies w have shape {w.shape}; pass a 1-D grid.")
    for name, a in (("H", H), ("coherence", coh), ("mask", mask)):
        if a.shape != w.shape:
            raise IdentificationError(
                f"{channel}: {name} has shape {a.shape} but w has {w.shape}; one value per frequency."
            )
    bad = np.flatnonzero(~(np.isfinite(w) & (w > 0)))
    if bad.size:
        i = int(bad[0])
        raise IdentificationError(
            f"{channel}: frequency w[{i}] = {float(w[i])!r} rad/s; every frequency must be "
            "finite and positive."
        )
    bad = np.flatnonzero(np.diff(w) <= 0)
    if bad.size:
        i = int(bad[0]) + 1
        raise IdentificationError(
            f"{channel}: frequencies are not strictly increasing at w[{i}] = {float(w[i])!r} "
            f"rad/s (after {float(w[i - 1])!r}); sort them and drop duplicates."
        )
    mag = np.abs(H)
    used = mask & np.isfinite(mag)
    bad = np.flatnonzero(used & ~(np.isfinite(coh) & (coh >= 0.0) & (coh <= 1.0)))
    if bad.size:
        i = int(bad[0])
        raise IdentificationError(
            f"{channel}: coherence at w[{i}] = {w[i]:.4g} rad/s is {float(coh[i])!r}; the "
            "magnitude-squared coherence lies in [0, 1]."
        )
    thr = float(response.coherence_threshold)
    bad = np.flatnonzero(used & (coh < thr))
    if bad.size:  # FrequencyResponse's invariant: the mask holds coherence >= threshold
        i = int(bad[0])
        raise IdentificationError(
            f"{channel}: w[{i}] = {w[i]:.4g} rad/s is in the mask with coherence "
            f"{float(coh[i]):.3g}, below the response's coherence_threshold {thr:g}; build "
            "the response with FrequencyResponse.from_complex(w, H, coherence) so the mask "
            "follows the coherence."
        )
    with np.errstate(divide="ignore"):
        decades = np.abs(np.log10(mag))
    bad = np.flatnonzero(used & ~(decades <= MAX_GAIN_DECADES))
    if bad.size:
        i = int(bad[0])
        raise IdentificationError(
            f"{channel}: the gain |H| at w[{i}] = {w[i]:.4g} rad/s is {mag[i]:.3g}, outside "
            f"1e-{MAX_GAIN_DECADES}..1e{MAX_GAIN_DECADES}; rescale the input or output "
            "(check their units)."
        )


def _prepare_response(response, channel, settings, pairs=(), reports=(), dt=float("nan")):
    """A measured response -> sign normalisation -> WLS start -> CIFER objective."""
    _check_response(response, channel)
    if response.n_passing < 20:
        raise IdentificationError(
            f"{channel}: only {response.n_passing} of {response.w.shape[0]} frequencies "
            f"have coherence >= {settings.coherence_threshold}; the CIFER cost needs 20. "
            "Use a longer or stronger sweep, or lower --coherence."
        )
    sign = _gain_sign(response)
    response_n = _flip(response, sign)
    start, note = wls_start(response_n, settings.sk_iterations)
    if float(start.K) < 0:
        # The low-frequency phase guessed the gain's sign wrong and WLS disagrees: trust
        # WLS.  -start fits -response_n exactly as start fits response_n.
        sign = -sign
        response_n = _flip(response, sign)
        start = PaperModel.from_array(start.to_array() * jnp.asarray([-1.0, 1, 1, 1, 1]))
    pmap = ParameterMap.for_model(start)
    objective = CiferObjective.from_response(response_n, pmap)
    return _Prepared(channel, list(pairs), tuple(reports), dt, response, sign, start, note,
                     objective)


def independent_points(response: FrequencyResponse) -> float:
    """Effective number of independent frequency points behind ``J``.

    Log-spaced points closer than the resolution ``2 pi / T_window`` of the window that
    supplied them share FFT bins, so their errors are correlated.  Each passing point
    counts ``min(1, spacing / resolution)``; an analytic response (no window) counts 1.
    """
    w = np.asarray(response.w, float)
    mask = np.asarray(response.mask)
    spacing = np.gradient(w)
    win = np.asarray(response.window_s, float)
    resolution = np.where(np.isfinite(win) & (win > 0), 2.0 * np.pi / np.where(win > 0, win, 1.0), 0.0)
    share = np.where(resolution > 0, np.minimum(1.0, spacing / np.where(resolution > 0, resolution, 1.0)), 1.0)
    return float(np.sum(share[mask]))


def _dependence_corrected(unc: ParameterUncertainty, response: FrequencyResponse):
    """Scale Cramer-Rao bounds by ``sqrt(m / m_eff)``: the Fisher information of ``J``
    counts each of its ``m`` points as independent, which over-states it when points
    share FFT bins (:func:`independent_points`)."""
    m = float(np.sum(np.asarray(response.mask)))
    m_eff = independent_points(response)
    f = math.sqrt(m / m_eff) if m_eff > 0 else float("inf")
    # host NumPy: a product or quotient rounds as XLA's does, without compiling one
    fisher, cov, *sds = (np.asarray(a) for a in (
        unc.fisher, unc.covariance, unc.cramer_rao, unc.cramer_rao_percent,
        unc.insensitivity, unc.insensitivity_percent))
    scaled = (fisher / f**2, cov * f**2, *(a * f for a in sds))
    return eqx.tree_at(
        lambda u: (u.fisher, u.covariance, u.cramer_rao, u.cramer_rao_percent,
                   u.insensitivity, u.insensitivity_percent),
        unc,
        tuple(_device(a) for a in scaled),
    )


def _measured_variances(prep: _Prepared):
    """Per-residual variances of ``J`` from the measured random error, or ``None`` when
    the response carries none (an analytic response: coherence 1, no averages).

    With them the Cramer-Rao bounds are the sandwich of :mod:`jaxgwo._metrics` (the
    coherence weights of ``J`` are not inverse variances); without them, the bounds fall
    back to the residual-variance convention ``J/(m - p)``.
    """
    eps = np.asarray(prep.response.random_error, float)[np.asarray(prep.objective.weight) > 0]
    if eps.size == 0 or not np.all(np.isfinite(eps) & (eps > 0)):
        return None
    return prep.objective.residual_variances(prep.response.random_error)


@eqx.filter_jit
def _best_params(pmap: ParameterMap, x):
    """The canonical paper parameters of the optimiser's log-vector ``x``, in one compiled
    program (exp, products, quotients and selections: no addition for XLA to fuse into a
    multiply-add, so the bits are those of the operations run one by one)."""
    return canonicalize_paper_params(pmap.params_from_vector(x))


def _finish(prep: _Prepared, x_best, convergence, evaluations, runtime, settings,
            validation_records, validation_pairs=None) -> ChannelIdentification:
    pmap = prep.objective.parameter_map
    p = _best_params(pmap, x_best)
    model_n = PaperModel.from_array(p)
    cost = float(prep.objective.cost(model_n))
    if not (np.all(np.isfinite(np.asarray(p))) and math.isfinite(cost)):
        # never hand back NaN parameters or an infinite cost as if they were a result
        raise IdentificationError(
            f"{prep.channel}: the {settings.method} fit ended at non-finite parameters or cost "
            f"(params {np.asarray(p).tolist()}, J = {cost}); the response is probably not "
            "a rate response of this model (check the coherence and the columns), or try "
            "another --method."
        )
    wls_cost = float(prep.objective.cost(prep.start))
    flip = jnp.asarray([prep.sign, 1.0, 1.0, 1.0, 1.0])
    model = PaperModel.from_array(p * flip)
    wls_model = PaperModel.from_array(prep.start.to_array() * flip)
    unc = _dependence_corrected(
        parameter_uncertainty(prep.objective.residuals_from_params, p,
                              ("K", "tau", "M", "omega_s", "zeta_s"),
                              residual_variance=_measured_variances(prep)),
        prep.response,
    )
    # the sign flip leaves every bound's size unchanged; report values with their true sign
    unc = eqx.tree_at(lambda u: u.values, unc, unc.values * flip)
    val = None
    if validation_records and validation_pairs is not None:
        val = _validate_pairs(model, validation_records, validation_pairs)
    elif validation_records:
        val = validate(model, validation_records, prep.channel, settings)
    return ChannelIdentification(
        channel=prep.channel,
        method=settings.method,
        seed=settings.seed,
        model=model,
        wls_model=wls_model,
        response=prep.response,
        cost_J=cost,
        wls_cost_J=wls_cost,
        mse=_time_mse(model, prep.pairs, prep.dt) if prep.pairs else float("nan"),
        convergence=np.asarray(convergence),
        uncertainty=unc,
        evaluations=int(evaluations),
        runtime_s=runtime,
        preprocessing=prep.reports,
        validation=val,
    )


def identify_channels(
    records: dict[str, Sequence[FlightRecord]],
    settings: IdentifySettings = IdentifySettings(),
    validation: Sequence[FlightRecord] | Mapping[str, Sequence[FlightRecord]] | None = None,
) -> dict[str, ChannelIdentification]:
    """Identify the paper model for each channel in ``records`` (``{channel: [records]}``).

    All channels are searched in one batched optimiser call.  ``validation`` records are
    held out: nothing is fitted to them.  Either one list scored for every channel, or
    ``{channel: [records]}`` (a channel left out is not validated).
    """
    _check_record_lists(records, "records")
    if validation is not None:
        _check_record_lists(validation if isinstance(validation, Mapping)
                            else {"any channel": validation}, "validation")
    validation_pairs = _check_validation(validation, list(records), settings)
    preps = [_prepare(list(recs), ch, settings) for ch, recs in records.items()]
    return _identify_prepared(preps, settings, validation, validation_pairs)


def _check_record_lists(records, what: str) -> None:
    """``{name: [FlightRecord, ...]}``, or a clear error saying what was passed instead."""
    if not isinstance(records, Mapping):
        raise IdentificationError(
            f"{what} must be a dict {{channel: [FlightRecord, ...]}}, not "
            f"{type(records).__name__}."
        )
    if what == "records" and not records:
        raise IdentificationError("no channel to identify: pass {'lateral': [record, ...]}.")
    for name, recs in records.items():
        if isinstance(recs, (FlightRecord, str, bytes)) or not isinstance(recs, Sequence):
            raise IdentificationError(
                f"{what}[{name!r}] must be a list of FlightRecord, not "
                f"{type(recs).__name__}; wrap a single record in a list."
            )
        for i, r in enumerate(recs):
            if not isinstance(r, FlightRecord):
                raise IdentificationError(
                    f"{what}[{name!r}][{i}] is a {type(r).__name__}, not a FlightRecord; "
                    "load files with jaxgwo load_record or build arrays with make_record."
                )


def _check_validation(validation, channels, settings) -> dict[str, list]:
    """Reject unusable held-out records before the optimiser runs, not after.  Returns
    their preprocessed signals per channel, for :func:`_identify_prepared` to score with
    (preprocessing them a second time would repeat the same work)."""
    pairs = {}
    if not validation:
        return pairs
    for ch in channels:
        if ch not in CHANNELS:
            continue  # _prepare names the unknown channel
        recs = validation.get(ch) if isinstance(validation, Mapping) else validation
        if recs:
            pairs[ch] = _preprocessed(list(recs), ch, settings, role="validation")[0]
    return pairs


def identify_responses(
    responses: dict[str, FrequencyResponse],
    settings: IdentifySettings = IdentifySettings(),
) -> dict[str, ChannelIdentification]:
    """Identify the paper model from already-measured frequency responses (for example a
    CIFER export, or an analytic response), one batched optimiser call for all channels.
    ``fit.mse`` is NaN: there is no time history to simulate."""
    if not isinstance(responses, Mapping) or not responses:
        raise IdentificationError(
            "pass the responses as a non-empty dict {channel: FrequencyResponse}."
        )
    preps = [_prepare_response(r, ch, settings) for ch, r in responses.items()]
    return _identify_prepared(preps, settings, None)


def _identify_prepared(preps, settings, validation, validation_pairs=None):
    t0 = time.perf_counter()
    method = settings.method
    if method == "wls":
        xs = [p.objective.parameter_map.to_vector(p.start) for p in preps]
        histories = [np.zeros(0)] * len(preps)
        evals = [0] * len(preps)
    elif method == "paper":
        from ._paper_mode import identify_paper_mode

        key = jax.random.key(settings.seed)
        xs, histories, evals = [], [], []
        for i, p in enumerate(preps):
            r = identify_paper_mode(
                _flip(p.response, p.sign), key=jax.random.fold_in(key, i),
                wolves=settings.wolves, iterations=settings.iterations,
                sk_iterations=settings.sk_iterations,
            )
            if r.paper_model is None:
                raise IdentificationError(
                    f"{p.channel}: the paper-mode quartic does not factor into the paper "
                    f"model ({r.reason}); use another --method."
                )
            xs.append(p.objective.parameter_map.to_vector(r.paper_model.canonical()))
            histories.append(np.asarray(r.convergence))
            evals.append(int(r.evaluations))
    elif method == "traditional":
        xs, histories, evals = [], [], []
        for p in preps:
            x0 = p.objective.parameter_map.to_vector(p.start)
            xs.append(_traditional(p.objective, x0))
            histories.append(np.zeros(0))
            evals.append(0)
    else:
        cfg = settings.optimiser()
        x0s = np.stack([np.asarray(p.objective.parameter_map.to_vector(p.start))
                        for p in preps])
        boxes = [_box(x0, settings.search_factor) for x0 in x0s]
        lo_np, hi_np = np.stack([b[0] for b in boxes]), np.stack([b[1] for b in boxes])
        lo, hi = _device(lo_np), _device(hi_np)
        n_seed = max(1, int(round(settings.seeded_fraction * settings.wolves)))
        normals, run_keys = _search_randomness(settings.seed, len(preps), n_seed,
                                               x0s.shape[1])
        normals = np.asarray(normals)
        init_np = np.stack([
            _seeded_from_normals(normals[i], x0s[i], boxes[i][0], boxes[i][1],
                                 settings.seed_spread)
            for i in range(len(preps))
        ])
        init = _device(init_np)
        objectives = G.stack_objectives([p.objective for p in preps])
        if (np.all(np.isfinite(lo_np) & np.isfinite(hi_np) & (lo_np < hi_np))
                and np.all(np.isfinite(init_np))):
            best, history, evaluations = _search(cfg, objectives, lo, hi, run_keys, init)
        else:  # run_batch's own checks (skipped inside a trace) say what is wrong
            res = G.run_batch(cfg, objectives, lo, hi, run_keys, init_wolves=init)
            best, history, evaluations = res.best_position, res.history_best, res.evaluations
        if method.endswith("+polish"):
            best = _polish_batch(objectives, best, settings.polish_steps)
        xs = list(np.asarray(best))  # rows on the host: no per-row slicing program
        histories = list(np.asarray(history))
        evals = [int(e) for e in np.asarray(evaluations)]
    jax.block_until_ready(xs)
    runtime = (time.perf_counter() - t0) / len(preps)
    return {
        p.channel: _finish(p, xs[i], histories[i], evals[i], runtime, settings,
                           validation.get(p.channel) if isinstance(validation, Mapping)
                           else validation, (validation_pairs or {}).get(p.channel))
        for i, p in enumerate(preps)
    }
