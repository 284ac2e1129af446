r"""Stage 1: preprocessing of sweep flight data (paper section 4.2).

The paper removes the trend, rejects and corrects wild values (outliers), and smooths or
low-pass filters the data before the frequency response is computed.  Each step here is
optional, works on plain uniformly sampled arrays, and reports what it changed in a frozen
:class:`PreprocessReport`.

Order of the steps, and why:

1. **Wild values** first, because a single spike biases a least-squares trend.  Each
   sample is compared with a leave-one-out cubic prediction from its four neighbours,
   :math:`\hat x_i = (-x_{i-2} + 4x_{i-1} + 4x_{i+1} - x_{i+2})/6`; it is *wild* when
   the residual exceeds ``threshold`` robust standard deviations
   (:math:`1.4826\,\mathrm{MAD}` of the residuals).  Wild samples are replaced by a
   cubic spline through the good ones (:func:`reject_wild_values` says why this is not a
   running-median rule).
2. **Detrend** (``"constant"`` or ``"linear"``), comparable to ``scipy.signal.detrend``.
3. **Smoothing** with a Savitzky-Golay filter (zero phase, keeps peaks better than a
   moving average).
4. **Zero-phase low-pass**: a Butterworth filter run forwards and backwards
   (``scipy.signal.sosfiltfilt``), so the phase of the frequency response is not shifted.

This is the data path, not the hot path, so it is written in NumPy/SciPy.  SciPy is
imported where a step needs it: ``scipy.signal`` (smoothing, the low-pass) and
``scipy.interpolate`` (filling wild values) take about half a second to import, which the
default ``jaxgwo identify`` (no smoothing, no wild value) does not pay.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Literal

import equinox as eqx
import numpy as np
import scipy.ndimage

# the loader's tolerance on the time step: whatever the loader accepts, preprocessing accepts
from ._data import TIME_TOLERANCE

__all__ = [
    "SignalReport",
    "PreprocessReport",
    "reject_wild_values",
    "detrend",
    "smooth",
    "lowpass_zero_phase",
    "preprocess",
]

_MAD_TO_SIGMA = 1.482602218505602  # 1/Phi^-1(3/4): MAD of a Gaussian times this is sigma


class SignalReport(eqx.Module):
    """What preprocessing changed in one signal.

    ``wild_indices`` are the sample indices that were replaced by interpolation;
    ``trend`` is ``(offset, slope)`` of the removed trend (slope in units per second, zero
    for a constant detrend, both zero when not detrended).
    """

    name: str = eqx.field(static=True)
    wild_indices: tuple[int, ...] = eqx.field(static=True)
    trend: tuple[float, float] = eqx.field(static=True)
    smoothed_window: int | None = eqx.field(static=True)
    lowpass_hz: float | None = eqx.field(static=True)

    @property
    def n_corrected(self) -> int:
        """Number of samples replaced as wild values."""
        return len(self.wild_indices)


class PreprocessReport(eqx.Module):
    """Frozen record of every change :func:`preprocess` made, per signal."""

    signals: tuple[SignalReport, ...] = eqx.field(static=True)
    sample_rate_hz: float = eqx.field(static=True)

    def __getitem__(self, name: str) -> SignalReport:
        for rep in self.signals:
            if rep.name == name:
                return rep
        raise KeyError(name)

    @property
    def n_corrected(self) -> int:
        """Total number of corrected samples over all signals."""
        return sum(r.n_corrected for r in self.signals)

    def summary(self) -> str:
        """One readable line per signal."""
        lines = []
        for r in self.signals:
            idx = list(r.wild_indices[:8])
            more = "" if r.n_corrected <= 8 else f" (+{r.n_corrected - 8} more)"
            lines.append(
                f"{r.name}: {r.n_corrected} wild values corrected at {idx}{more}; "
                f"trend offset {r.trend[0]:.4g}, slope {r.trend[1]:.4g}/s; "
                f"smoothing {r.smoothed_window}; low-pass {r.lowpass_hz} Hz"
            )
        return "\n".join(lines)


def _sample_rate(time: np.ndarray) -> float:
    """Sample rate (Hz) of a uniformly sampled time vector, ``1/mean(diff(time))``."""
    time = np.asarray(time, dtype=float)
    if time.ndim != 1 or time.size < 3:
        raise ValueError(
            f"time has shape {time.shape}: preprocessing needs a 1-D record of at least "
            "3 samples"
        )
    if not np.all(np.isfinite(time)):
        i = int(np.flatnonzero(~np.isfinite(time))[0])
        raise ValueError(f"time is not finite at row {i} ({time[i]!r})")
    dt = np.diff(time)
    if np.any(dt <= 0):
        i = int(np.flatnonzero(dt <= 0)[0]) + 1
        raise ValueError(f"time must be strictly increasing; it is not at row {i}")
    med = float(np.median(dt))
    off = np.flatnonzero(np.abs(dt - med) > TIME_TOLERANCE * med)
    if off.size:
        raise ValueError(
            f"time must be uniformly sampled (each step within {TIME_TOLERANCE:.0%} of the "
            f"median); the step before row {int(off[0]) + 1} is not: resample the record first"
        )
    return float(1.0 / dt.mean())


def _prediction_residual(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Leave-one-out prediction residual of each sample and its noise-gain factor.

    Interior: cubic through ``x[i-2], x[i-1], x[i+1], x[i+2]``,
    ``(-x[i-2] + 4x[i-1] + 4x[i+1] - x[i+2]) / 6``; next to the ends the cubic through
    ``x[0], x[2], x[3], x[4]``, and at the ends the cubic extrapolation
    ``4x[1] - 6x[2] + 4x[3] - x[4]``.  The factor is the
    residual's standard deviation for unit white noise, so ``resid/factor`` has one scale.
    """
    n = x.size
    pred = np.empty(n)
    gain = np.empty(n)
    pred[2:-2] = (-x[:-4] + 4 * x[1:-3] + 4 * x[3:-1] - x[4:]) / 6.0
    gain[2:-2] = np.sqrt(1.0 + 34.0 / 36.0)
    # near the ends, cubics through the four nearest other samples too (lower-order
    # predictors there left a curvature error that looked wild on noise-free data)
    pred[1] = (x[0] + 6 * x[2] - 4 * x[3] + x[4]) / 4.0
    pred[-2] = (x[-1] + 6 * x[-3] - 4 * x[-4] + x[-5]) / 4.0
    gain[[1, -2]] = np.sqrt(1.0 + (1 + 36 + 16 + 1) / 16.0)
    pred[0] = 4 * x[1] - 6 * x[2] + 4 * x[3] - x[4]
    pred[-1] = 4 * x[-2] - 6 * x[-3] + 4 * x[-4] - x[-5]
    gain[[0, -1]] = np.sqrt(70.0)
    return x - pred, gain


def _local_scale(zr: np.ndarray, bad: np.ndarray, x: np.ndarray, window: int = 101):
    """Robust noise scale of the normalised residual around each sample.

    A running median of ``|residual|`` over ``window`` samples, not one global median: a
    sweep's residual grows with its frequency, and against a global scale set by the slow
    start every sample of the fast end looked wild (on a noise-free 0.15-12 Hz chirp at
    100 Hz a global scale flagged 4,000 samples).  A spike moves the median of 101
    samples by at most a few samples' worth.  A floor at a few ulps of the signal keeps a
    noise-free stretch from dividing by zero.
    """
    a = np.abs(zr)
    a = np.where(bad, np.median(a[~bad]), a)
    w = min(window, a.size if a.size % 2 else a.size - 1)
    local = _MAD_TO_SIGMA * scipy.ndimage.median_filter(a, size=w, mode="mirror")
    floor = 64.0 * np.finfo(float).eps * max(float(np.max(np.abs(x))), np.finfo(float).tiny)
    return np.maximum(local, floor)


def _at_level_change(x: np.ndarray, resid: np.ndarray, scale: np.ndarray,
                     threshold: float) -> np.ndarray:
    """Samples that continue the signal on one side: the edge of a step, not a spike.

    At the edge of a step input (a doublet, a 3-2-1-1) the leave-one-out cubic misses by
    up to half the step, so the samples next to it look wild, and filling them would
    round the steps off.  A spike departs from *both* sides; an edge sample lies on a
    straight continuation of the three samples on one side (as corrected so far: a
    filled spike near an edge must not hide the edge): both second
    differences ``x[i] - 2x[i+s] + x[i+2s]`` and ``x[i+s] - 2x[i+2s] + x[i+3s]`` are
    within ``max(|resid|/4, (2/3) threshold sqrt(6) sigma)``: a quarter of its own
    departure, or four standard deviations of a second difference of noise at the
    default ``threshold`` (so that a noisy edge is not flagged).  A burst of three or
    fewer wild samples bends one of those differences on both sides, so it is not
    mistaken for a step.  The price: a spike smaller than about ten noise sigmas, or one
    within three samples of a step edge, may pass for part of the step.
    """
    n = x.size
    tol = np.maximum(np.abs(resid) / 4.0, (2.0 / 3.0) * threshold * np.sqrt(6.0) * scale)
    i = np.arange(n)
    at_edge = np.zeros(n, dtype=bool)
    for side in (1, -1):
        js = [i + side * k for k in (1, 2, 3)]
        ok = (js[-1] >= 0) & (js[-1] < n)
        p1, p2, p3 = (x[np.clip(j, 0, n - 1)] for j in js)
        bend = np.maximum(np.abs(x - 2 * p1 + p2), np.abs(p1 - 2 * p2 + p3))
        at_edge |= ok & (bend <= tol)
    return at_edge


def reject_wild_values(
    x: np.ndarray, *, threshold: float = 6.0, max_iterations: int = 10
) -> tuple[np.ndarray, tuple[int, ...]]:
    r"""Replace wild values (outliers) by cubic-spline interpolation; returns the corrected
    copy and the sorted indices that were replaced.

    Each sample is predicted from its neighbours (leave-one-out cubic, see module
    docstring); a sample is wild when :math:`|x_i - \hat x_i| > k\,\hat\sigma\,g_i`
    with :math:`\hat\sigma` a running (101-sample) robust scale of residual/g
    (:func:`_local_scale`) and :math:`g_i`
    the residual's noise gain.  A spike also spoils its neighbours' predictions, so each
    pass accepts only local maxima (within three samples, the reach of the step test) of
    the normalised residual, fills them (without the other candidates next to them as
    spline knots), and repeats.  Non-finite samples are always wild.

    A sample that continues the signal on one side (:func:`_at_level_change`) is the
    edge of a step input (a doublet, a 3-2-1-1), not a wild value, and is left alone.

    A running-median (Hampel) baseline is *not* used: over a sweep it lags any component
    with fewer than about ``2 window`` samples per period, and flags (and would destroy)
    the high-frequency end of the sweep.  The cubic prediction's error on a sine with 8
    samples per period is 6% of its amplitude, so sweeps up to ``fs/8`` pass untouched.
    """
    x = np.asarray(x, dtype=float)
    if x.size < 5:
        raise ValueError("need at least 5 samples to look for wild values")
    bad = ~np.isfinite(x)
    if bad.all():
        raise ValueError("signal has no finite samples")
    idx_all = np.arange(x.size)
    xf = x.copy()

    def fill(xf, bad, suspect=None):
        # knots: the good samples, less suspects (candidates within two samples of one
        # this pass took: the rest of a burst, which as a knot would pull the fill to it)
        good = np.flatnonzero(~bad if suspect is None else ~bad & ~suspect)
        if good.size < 4 and suspect is not None:
            good = np.flatnonzero(~bad)
        if good.size < 4:
            raise ValueError("too few good samples to correct wild values")
        from scipy.interpolate import CubicSpline

        spline = CubicSpline(good, x[good], extrapolate=False)
        xf[bad] = spline(idx_all[bad])
        # beyond the first/last good sample a cubic extrapolates noise wildly: go linear
        lo, hi = good[:2], good[-2:]
        head = bad & (idx_all < good[0])
        tail = bad & (idx_all > good[-1])
        xf[head] = x[lo[0]] + (idx_all[head] - lo[0]) * (x[lo[1]] - x[lo[0]]) / (lo[1] - lo[0])
        xf[tail] = x[hi[1]] + (idx_all[tail] - hi[1]) * (x[hi[1]] - x[hi[0]]) / (hi[1] - hi[0])
        return xf

    if bad.any():
        xf = fill(xf, bad)
    for _ in range(max_iterations):
        resid, gain = _prediction_residual(xf)
        zr = resid / gain
        scale = _local_scale(zr, bad, xf)
        z = np.abs(zr) / scale
        z = np.where(_at_level_change(xf, resid, scale, threshold), 0.0, z)
        cand = (z > threshold) & ~bad
        if not cand.any():
            break
        new = cand & (z >= scipy.ndimage.maximum_filter1d(z, size=7, mode="nearest"))
        bad |= new
        near_new = scipy.ndimage.maximum_filter1d(new, size=5, mode="constant")
        xf = fill(xf, bad, cand & ~new & near_new)
    if bad.any():
        # give back samples that were only caught next to a spike: judged against the
        # prediction from the corrected series, their own value is fine
        resid, gain = _prediction_residual(xf)
        pred = xf - resid
        scale = _local_scale(resid / gain, bad, xf)
        with np.errstate(invalid="ignore", over="ignore"):  # a flat stretch: inf is not fine
            fine = np.abs(x - pred) / (gain * scale) <= threshold
        if (bad & fine).any():
            bad &= ~fine
            xf = x.copy()
            xf = fill(xf, bad) if bad.any() else xf
    idx = np.flatnonzero(bad)
    return xf, tuple(int(i) for i in idx)


def detrend(
    time: np.ndarray, x: np.ndarray, kind: Literal["constant", "linear"] = "linear"
) -> tuple[np.ndarray, tuple[float, float]]:
    """Remove a constant or linear trend; returns ``(x - trend, (offset, slope))``.

    The slope is per unit of ``time`` and the offset is the trend's value at ``time[0]``.
    Comparable to ``scipy.signal.detrend(x, type=kind)``.
    """
    time = np.asarray(time, dtype=float)
    x = np.asarray(x, dtype=float)
    tc = time - time[0]
    if kind == "constant":
        offset = float(np.mean(x))
        return x - offset, (offset, 0.0)
    if kind == "linear":
        slope, offset = np.polyfit(tc, x, 1)
        return x - (offset + slope * tc), (float(offset), float(slope))
    raise ValueError(f"detrend kind must be 'constant' or 'linear', not {kind!r}")


def smooth(x: np.ndarray, window: int, polyorder: int = 2) -> np.ndarray:
    """Zero-phase Savitzky-Golay smoothing over ``window`` samples (odd)."""
    if window % 2 == 0 or window <= polyorder:
        raise ValueError("smoothing window must be odd and larger than polyorder")
    import scipy.signal

    return scipy.signal.savgol_filter(np.asarray(x, dtype=float), window, polyorder)


def lowpass_zero_phase(
    x: np.ndarray, sample_rate_hz: float, cutoff_hz: float, order: int = 4
) -> np.ndarray:
    """Zero-phase Butterworth low-pass (forward-backward, ``scipy.signal.sosfiltfilt``).

    The effective amplitude response is the square of an ``order``-pole Butterworth and
    the phase is zero at every frequency.
    """
    nyq = 0.5 * sample_rate_hz
    if not 0.0 < cutoff_hz < nyq:
        raise ValueError(f"low-pass cutoff {cutoff_hz} Hz must lie in (0, {nyq}) Hz")
    import scipy.signal

    sos = scipy.signal.butter(order, cutoff_hz / nyq, btype="low", output="sos")
    return scipy.signal.sosfiltfilt(sos, np.asarray(x, dtype=float))


def preprocess(
    time: np.ndarray,
    signals: Mapping[str, np.ndarray],
    *,
    wild_values: bool = True,
    wild_threshold: float = 6.0,
    detrend_kind: Literal["constant", "linear"] | None = "linear",
    smoothing_window: int | None = None,
    lowpass_hz: float | None = None,
    lowpass_order: int = 4,
) -> tuple[dict[str, np.ndarray], PreprocessReport]:
    """Preprocess uniformly sampled signals; returns ``(processed, report)``.

    Every step is optional (``wild_values=False``, ``detrend_kind=None``,
    ``smoothing_window=None``, ``lowpass_hz=None`` switch them off); they run in the
    order wild values, detrend, smoothing, low-pass (module docstring).  The inputs are
    not modified.
    """
    fs = _sample_rate(time)
    n = np.asarray(time).shape[0]
    out: dict[str, np.ndarray] = {}
    reports = []
    for name, x in signals.items():
        x = np.asarray(x, dtype=float)
        if x.shape != (n,):
            raise ValueError(f"signal {name!r} has shape {x.shape}, time has ({n},)")
        wild: tuple[int, ...] = ()
        if wild_values:
            x, wild = reject_wild_values(x, threshold=wild_threshold)
        trend = (0.0, 0.0)
        if detrend_kind is not None:
            x, trend = detrend(time, x, detrend_kind)
        if smoothing_window is not None:
            x = smooth(x, smoothing_window)
        if lowpass_hz is not None:
            x = lowpass_zero_phase(x, fs, lowpass_hz, lowpass_order)
        out[name] = x
        reports.append(
            SignalReport(
                name=name,
                wild_indices=wild,
                trend=trend,
                smoothed_window=smoothing_window,
                lowpass_hz=lowpass_hz,
            )
        )
    return out, PreprocessReport(signals=tuple(reports), sample_rate_hz=fs)
