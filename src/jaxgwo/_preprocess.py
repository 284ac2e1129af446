r"""Stage 1: preprocessing of sweep flight data (paper section 4.2).

The paper removes the trend, rejects and corrects wild values (outliers), and smooths or
low-pass filters the data before the frequency response is computed.  Each step here is
optional, works on plain uniformly sampled arrays, and reports what it changed in a frozen
:class:`PreprocessReport`.

Order of the steps, and why:

1. **Wild values** first, because a single spike biases a least-squares trend.  A sample
   is *wild* when its distance from a running median exceeds ``threshold`` robust standard
   deviations, :math:`|x_i - \tilde x_i| > k\,\hat\sigma`, where :math:`\tilde x` is
   the centred running median over ``window`` samples (Hampel filter) and
   :math:`\hat\sigma = 1.4826\,\mathrm{MAD}(\Delta^2 x)/\sqrt 6` is a robust noise
   scale from second differences.  Wild samples are
   replaced by linear interpolation between the nearest good neighbours.
2. **Detrend** (``"constant"`` or ``"linear"``), comparable to ``scipy.signal.detrend``.
3. **Smoothing** with a Savitzky-Golay filter (zero phase, keeps peaks better than a
   moving average).
4. **Zero-phase low-pass**: a Butterworth filter run forwards and backwards
   (``scipy.signal.sosfiltfilt``), so the phase of the frequency response is not shifted.

This is the data path, not the hot path, so it is written in NumPy/SciPy.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Literal

import equinox as eqx
import numpy as np
import scipy.ndimage
import scipy.signal

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
    time = np.asarray(time, dtype=float)
    if time.ndim != 1 or time.size < 3:
        raise ValueError("time must be a 1-D array with at least 3 samples")
    dt = np.diff(time)
    if np.any(dt <= 0):
        raise ValueError("time must be strictly increasing")
    if np.max(np.abs(dt - dt.mean())) > 1e-6 * max(dt.mean(), 1e-300) + 1e-9:
        raise ValueError("time must be uniformly sampled (resample the record first)")
    return float(1.0 / dt.mean())


def reject_wild_values(
    x: np.ndarray, *, window: int = 11, threshold: float = 5.0
) -> tuple[np.ndarray, tuple[int, ...]]:
    """Replace wild values (outliers) by linear interpolation; Hampel rule.

    A sample is wild when :math:`|x_i - \\mathrm{med}_w(x)_i| > k\\,\\hat\\sigma` with
    :math:`\\hat\\sigma = 1.4826\\,\\mathrm{MAD}(\\Delta^2 x)/\\sqrt 6`.  Near the record ends
    the running median of a steep ramp is biased by about ``slope * window / 4``.

    Returns the corrected copy and the sorted indices that were replaced.
    """
    x = np.asarray(x, dtype=float)
    if window < 3 or window % 2 == 0:
        raise ValueError("window must be an odd integer >= 3")
    finite = np.isfinite(x)
    if not finite.any():
        raise ValueError("signal has no finite samples")
    xf = np.where(finite, x, np.median(x[finite]))
    # "mirror" keeps an end sample out of its own padding, so a spike on the last sample
    # is still one value among `window` and cannot become the median
    baseline = scipy.ndimage.median_filter(xf, size=window, mode="mirror")
    resid = xf - baseline
    # noise scale from second differences: var(x[i+1] - 2x[i] + x[i-1]) = 6 sigma^2 for
    # white noise, and a smooth finely sampled signal contributes little to it.  (The MAD
    # of `resid` itself under-estimates sigma by ~30%: the median is correlated with x_i.)
    d2 = np.diff(xf, 2)
    scale = _MAD_TO_SIGMA * np.median(np.abs(d2 - np.median(d2))) / np.sqrt(6.0)
    if scale == 0.0:
        # piecewise-linear signal: anything off the running median is wild
        bad = np.abs(resid) > 1e-12 * max(np.max(np.abs(xf)), 1.0)
    else:
        bad = np.abs(resid) > threshold * scale
    bad |= ~finite
    idx = np.flatnonzero(bad)
    if idx.size == 0:
        return x.copy(), ()
    good = np.flatnonzero(~bad)
    if good.size < 2:
        raise ValueError("too few good samples to correct wild values")
    out = x.copy()
    out[idx] = np.interp(idx, good, x[good])
    return out, tuple(int(i) for i in idx)


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
    sos = scipy.signal.butter(order, cutoff_hz / nyq, btype="low", output="sos")
    return scipy.signal.sosfiltfilt(sos, np.asarray(x, dtype=float))


def preprocess(
    time: np.ndarray,
    signals: Mapping[str, np.ndarray],
    *,
    wild_values: bool = True,
    wild_window: int = 11,
    wild_threshold: float = 5.0,
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
            x, wild = reject_wild_values(x, window=wild_window, threshold=wild_threshold)
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
