r"""Stage 2: frequency-response estimation with coherence, CIFER-style composite windows.

**H1 estimate.**  Each record ``(u, y)`` is cut into Hann-windowed segments of
``nperseg`` samples overlapping by ``noverlap``; each segment is mean-removed and
Fourier transformed.  The one-sided spectral densities are averaged over *all* segments of
*all* records (records are never spliced into one time series, so no artificial jump is
created where they meet):

.. math::

    G_{uu} = \frac{2}{n_d}\sum_k \frac{|U_k|^2}{f_s \sum w^2},\quad
    G_{yy} = \frac{2}{n_d}\sum_k \frac{|Y_k|^2}{f_s \sum w^2},\quad
    G_{uy} = \frac{2}{n_d}\sum_k \frac{U_k^* Y_k}{f_s \sum w^2},

    \hat H = G_{uy}/G_{uu},\qquad \gamma^2 = |G_{uy}|^2/(G_{uu} G_{yy}),

with ``n_d`` the number of averaged segments.  For one record this is exactly
``scipy.signal.csd(u, y, fs, window="hann", nperseg, noverlap)`` and
``scipy.signal.coherence`` (same scaling, same one-sided doubling).

**Composite windows** (Tischler & Remple, *Aircraft and Rotorcraft System
Identification*, 2nd ed., ch. 7-8, CIFER's COMPOSITE).  Several window lengths are run; a
window of length :math:`T_w` is used only above :math:`\omega \ge 2\pi\,p/T_w`
(``min_periods`` ``p = 2`` periods per window).  Each estimate is brought onto the
log-spaced output grid by averaging the spectral densities of the FFT bins inside each
output bin (frequency smoothing; ``n_d`` counts segments times bins, an optimistic count
because neighbouring Hann bins are correlated), or by linear interpolation of the spectra
where a bin holds no FFT line.  The normalised random error of the magnitude,

.. math::  \varepsilon_r = \frac{\sqrt{1-\gamma^2}}{|\gamma|\sqrt{2 n_d}},

decides the composite: ``"min_error"`` takes, at each frequency, the window with the
smallest :math:`\varepsilon_r`; ``"blend"`` averages the spectra with weights
:math:`1/\varepsilon_r^2`.  Estimates from fewer than ``min_averages`` averages are not
used (with :math:`n_d = 1`, :math:`\gamma^2 \equiv 1` and the error formula is meaningless).

This is the data path; it is NumPy.  The result is a frozen :class:`FrequencyResponse`
holding JAX arrays, ready for the cost functions.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Literal

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Bool, Complex, Float

__all__ = [
    "SpectralEstimate",
    "FrequencyResponse",
    "cross_spectral_estimate",
    "random_error",
    "composite_frequency_response",
    "log_frequencies",
]

Record = tuple[np.ndarray, np.ndarray]


def _device(a: np.ndarray) -> Array:
    """A NumPy result as a JAX array.  ``jax.device_put`` copies it as it is, where
    ``jnp.asarray`` compiles a small program per shape (tens of milliseconds each in a
    fresh process)."""
    return jax.device_put(a)


class SpectralEstimate(eqx.Module):
    """Welch-averaged auto and cross spectral densities on the FFT grid of one window.

    ``Gxx``/``Gyy``/``Gxy`` are one-sided densities (units^2/Hz), ``Gxy = E[conj(U) Y]``.
    """

    frequency_hz: Float[Array, " bins"]
    Gxx: Float[Array, " bins"]
    Gyy: Float[Array, " bins"]
    Gxy: Complex[Array, " bins"]
    n_averages: int = eqx.field(static=True)
    nperseg: int = eqx.field(static=True)
    sample_rate_hz: float = eqx.field(static=True)

    @property
    def w(self) -> Float[Array, " bins"]:
        """Frequencies in rad/s."""
        return 2.0 * jnp.pi * self.frequency_hz

    @property
    def H(self) -> Complex[Array, " bins"]:
        """H1 frequency-response estimate ``Gxy/Gxx``."""
        return self.Gxy / self.Gxx

    @property
    def coherence(self) -> Float[Array, " bins"]:
        """Magnitude-squared coherence ``|Gxy|^2/(Gxx Gyy)``, as ``scipy.signal.coherence``."""
        return jnp.abs(self.Gxy) ** 2 / (self.Gxx * self.Gyy)


class FrequencyResponse(eqx.Module):
    """A measured frequency response on a (log-spaced) grid.

    Fields: ``w`` (rad/s), ``H`` (complex, output/input), ``coherence`` (magnitude-squared,
    :math:`\\gamma^2`), ``random_error`` (normalised random error of ``|H|``),
    ``n_averages`` (effective ``n_d`` per point), ``mask`` (coherence passes the threshold
    and the estimate is finite), ``window_s`` (window length that supplied each point, or
    the dominant one for a blend; NaN where none did).
    """

    w: Float[Array, " freq"]
    H: Complex[Array, " freq"]
    coherence: Float[Array, " freq"]
    random_error: Float[Array, " freq"]
    n_averages: Float[Array, " freq"]
    mask: Bool[Array, " freq"]
    window_s: Float[Array, " freq"]
    coherence_threshold: float = eqx.field(static=True, default=0.6)

    @classmethod
    def from_complex(
        cls,
        w: Float[Array, " freq"],
        H: Complex[Array, " freq"],
        coherence: Float[Array, " freq"] | None = None,
        coherence_threshold: float = 0.6,
    ) -> "FrequencyResponse":
        """Wrap a known response (e.g. an analytic model) with coherence 1 unless given."""
        w = jnp.asarray(w, dtype=float)
        H = jnp.asarray(H, dtype=complex)
        coh = jnp.ones_like(w) if coherence is None else jnp.asarray(coherence, dtype=float)
        nd = jnp.full_like(w, jnp.inf)
        return cls(
            w=w,
            H=H,
            coherence=coh,
            random_error=jnp.asarray(random_error(np.asarray(coh), np.asarray(nd))),
            n_averages=nd,
            mask=(coh >= coherence_threshold) & jnp.isfinite(jnp.abs(H)),
            window_s=jnp.full_like(w, jnp.nan),
            coherence_threshold=coherence_threshold,
        )

    @property
    def magnitude_db(self) -> Float[Array, " freq"]:
        """``20 log10 |H|``."""
        return 20.0 * jnp.log10(jnp.abs(self.H))

    @property
    def phase_deg(self) -> Float[Array, " freq"]:
        """Phase in degrees, unwrapped along frequency."""
        return jnp.rad2deg(jnp.unwrap(jnp.angle(self.H)))

    @property
    def n_passing(self) -> int:
        """Number of frequencies whose coherence passes the threshold."""
        return int(np.sum(np.asarray(self.mask)))

    def masked(self) -> "FrequencyResponse":
        """Only the points that pass the mask (host-side; changes the shape)."""
        keep = np.asarray(self.mask)
        return FrequencyResponse(
            w=self.w[keep],
            H=self.H[keep],
            coherence=self.coherence[keep],
            random_error=self.random_error[keep],
            n_averages=self.n_averages[keep],
            mask=self.mask[keep],
            window_s=self.window_s[keep],
            coherence_threshold=self.coherence_threshold,
        )


def log_frequencies(w_min: float, w_max: float, n: int = 200) -> np.ndarray:
    """``n`` log-spaced frequencies from ``w_min`` to ``w_max`` rad/s."""
    if not 0 < w_min < w_max:
        raise ValueError("need 0 < w_min < w_max")
    return np.geomspace(w_min, w_max, n)


def random_error(coherence: np.ndarray, n_averages: np.ndarray) -> np.ndarray:
    r"""Normalised random error of ``|H|``: :math:`\sqrt{1-\gamma^2}/(|\gamma|\sqrt{2 n_d})`.

    ``coherence`` is the magnitude-squared coherence :math:`\gamma^2` (Bendat & Piersol,
    Tischler & Remple eq. 7.xx).  Zero coherence gives ``inf``.
    """
    coh = np.clip(np.asarray(coherence, dtype=float), 0.0, 1.0)
    nd = np.asarray(n_averages, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        err = np.sqrt(1.0 - coh) / (np.sqrt(coh) * np.sqrt(2.0 * nd))
    return np.where(np.isnan(err), np.inf, err)


def _as_records(records) -> list[Record]:
    if isinstance(records, tuple) and len(records) == 2 and np.ndim(records[0]) == 1:
        records = [records]
    out = []
    for i, rec in enumerate(records):
        u, y = (np.asarray(a, dtype=float) for a in rec)
        if u.ndim != 1 or u.shape != y.shape:
            raise ValueError(f"record {i}: input and output must be 1-D of equal length")
        if not (np.all(np.isfinite(u)) and np.all(np.isfinite(y))):
            raise ValueError(f"record {i}: contains non-finite samples")
        out.append((u, y))
    if not out:
        raise ValueError("no records given")
    return out


def _power_of_two_scale(signals: Sequence[np.ndarray]) -> float:
    """The power of two nearest the largest magnitude in ``signals`` (1 for all-zero)."""
    peak = max((float(np.max(np.abs(x))) if x.size else 0.0) for x in signals)
    if peak == 0.0:
        return 1.0
    return float(np.ldexp(1.0, int(np.frexp(peak)[1])))


def _segment_sums(u, y, nperseg, noverlap, win, detrend):
    step = nperseg - noverlap
    nseg = (u.size - noverlap) // step if u.size >= nperseg else 0
    if nseg < 1:
        return None
    idx = np.arange(nperseg)[None, :] + step * np.arange(nseg)[:, None]
    us, ys = u[idx], y[idx]
    if detrend == "constant":
        us = us - us.mean(axis=1, keepdims=True)
        ys = ys - ys.mean(axis=1, keepdims=True)
    elif detrend is not None:
        raise ValueError("detrend must be 'constant' or None")
    U = np.fft.rfft(us * win, axis=1)
    Y = np.fft.rfft(ys * win, axis=1)
    return (
        np.sum(np.abs(U) ** 2, axis=0),
        np.sum(np.abs(Y) ** 2, axis=0),
        np.sum(np.conj(U) * Y, axis=0),
        nseg,
    )


def _window(name: str, n: int) -> np.ndarray:
    """The periodic (DFT-even) window ``scipy.signal.get_window(name, n)``.  The Hann
    window is computed here exactly as SciPy computes it (the same operations, so the
    same bits), which keeps ``scipy.signal`` (about half a second) out of the import."""
    if name != "hann" or n <= 1:
        import scipy.signal

        return scipy.signal.get_window(name, n)
    # scipy.signal.windows.general_cosine(n + 1, [0.5, 0.5]) without its last sample
    fac = np.linspace(-np.pi, np.pi, n + 1)
    w = np.zeros(n + 1)
    for k, a in enumerate((0.5, 0.5)):
        w += a * np.cos(k * fac)
    return w[:-1]


def cross_spectral_estimate(
    records: Record | Sequence[Record],
    sample_rate_hz: float,
    nperseg: int,
    noverlap: int | None = None,
    window: str = "hann",
    detrend: Literal["constant"] | None = "constant",
) -> SpectralEstimate:
    """Welch auto/cross spectra averaged over every segment of every record.

    ``records`` is one ``(u, y)`` pair or a sequence of them (same sample rate).
    ``noverlap`` defaults to ``nperseg // 2``.  Records shorter than ``nperseg`` are
    skipped; if none is long enough a ``ValueError`` says the minimum duration.
    For one record this equals ``scipy.signal.csd``/``welch`` with the same arguments.
    """
    recs = _as_records(records)
    if noverlap is None:
        noverlap = nperseg // 2
    if not 0 <= noverlap < nperseg:
        raise ValueError("need 0 <= noverlap < nperseg")
    win = _window(window, nperseg)
    sxx = syy = 0.0
    sxy = 0.0j
    nd = 0
    for u, y in recs:
        got = _segment_sums(u, y, nperseg, noverlap, win, detrend)
        if got is None:
            continue
        a, b, c, n = got
        sxx, syy, sxy, nd = sxx + a, syy + b, sxy + c, nd + n
    if nd == 0:
        longest = max(u.size for u, _ in recs) / sample_rate_hz
        raise ValueError(
            f"record too short: a window of {nperseg / sample_rate_hz:.3g} s needs records of "
            f"at least {nperseg / sample_rate_hz:.3g} s; the longest is {longest:.3g} s"
        )
    scale = 1.0 / (sample_rate_hz * np.sum(win**2) * nd)
    one_sided = np.full(nperseg // 2 + 1, 2.0)
    one_sided[0] = 1.0
    if nperseg % 2 == 0:
        one_sided[-1] = 1.0
    f = np.fft.rfftfreq(nperseg, 1.0 / sample_rate_hz)
    return SpectralEstimate(
        frequency_hz=_device(f),
        Gxx=_device(sxx * scale * one_sided),
        Gyy=_device(syy * scale * one_sided),
        Gxy=_device(sxy * scale * one_sided),
        n_averages=int(nd),
        nperseg=int(nperseg),
        sample_rate_hz=float(sample_rate_hz),
    )


def _onto_grid(est: SpectralEstimate, w_out: np.ndarray, w_low: float):
    """Average (or interpolate) the spectra of ``est`` onto the log grid ``w_out``."""
    w_fft = 2.0 * np.pi * np.asarray(est.frequency_hz)  # est.w, without a device op
    gxx, gyy, gxy = (np.asarray(a) for a in (est.Gxx, est.Gyy, est.Gxy))
    logw = np.log(w_out)
    if w_out.size > 1:
        mids = 0.5 * (logw[1:] + logw[:-1])
        lo = np.concatenate([[logw[0] - (mids[0] - logw[0])], mids])
        hi = np.concatenate([mids, [logw[-1] + (logw[-1] - mids[-1])]])
    else:
        lo, hi = logw - 1e-9, logw + 1e-9
    with np.errstate(divide="ignore"):
        logf = np.log(w_fft)
    # bin index of each FFT line; lines outside every bin get -1
    which = np.searchsorted(hi, logf, side="right")
    inside = (which < w_out.size) & (logf >= lo[np.minimum(which, w_out.size - 1)])
    inside &= w_fft >= w_low
    which = np.where(inside, which, -1)
    count = np.bincount(which[inside], minlength=w_out.size).astype(float)
    sum_xx = np.bincount(which[inside], weights=gxx[inside], minlength=w_out.size)
    sum_yy = np.bincount(which[inside], weights=gyy[inside], minlength=w_out.size)
    sum_re = np.bincount(which[inside], weights=gxy.real[inside], minlength=w_out.size)
    sum_im = np.bincount(which[inside], weights=gxy.imag[inside], minlength=w_out.size)
    with np.errstate(invalid="ignore", divide="ignore"):
        out_xx = sum_xx / count
        out_yy = sum_yy / count
        out_xy = (sum_re + 1j * sum_im) / count
    empty = count == 0
    interp = lambda a: np.interp(w_out, w_fft, a)  # noqa: E731
    out_xx = np.where(empty, interp(gxx), out_xx)
    out_yy = np.where(empty, interp(gyy), out_yy)
    out_xy = np.where(empty, interp(gxy.real) + 1j * interp(gxy.imag), out_xy)
    nd = est.n_averages * np.maximum(count, 1.0)
    usable = (w_out >= w_low) & (w_out <= w_fft[-1])
    return out_xx, out_yy, out_xy, nd, usable


def composite_frequency_response(
    records: Record | Sequence[Record],
    sample_rate_hz: float,
    w: np.ndarray | None = None,
    *,
    w_min: float = 1.0,
    w_max: float = 60.0,
    n_frequencies: int = 200,
    window_lengths_s: Sequence[float] | None = None,
    overlap: float = 0.5,
    combine: Literal["min_error", "blend"] = "min_error",
    coherence_threshold: float = 0.6,
    min_periods: float = 2.0,
    min_averages: int = 4,
) -> FrequencyResponse:
    """CIFER-style composite H1 estimate on log-spaced frequencies (module docstring).

    ``w`` (rad/s) defaults to ``n_frequencies`` log-spaced points over ``[w_min, w_max]``.
    ``window_lengths_s`` defaults to five windows spaced geometrically from ``T =
    min_periods 2 pi / w[0]`` (the longest window that still resolves the lowest frequency)
    down to ``T/4``.  Shorter windows give many more averages and so a smaller *random*
    error, but a window short against the system's impulse response biases H1 and lowers
    the coherence (a bias the error formula does not see); CIFER's window sets also span
    a factor of about 4-5.  Raises
    ``ValueError`` when the records are too short for the band (the message gives the
    minimum duration), when ``w`` exceeds the Nyquist frequency, or when no frequency
    reaches the coherence threshold.
    """
    recs = _as_records(records)
    # Work on signals scaled by powers of two near their peaks, so the spectra neither
    # overflow (|u|^2 summed over a segment passes 1e308 for samples near 1e150) nor
    # underflow; powers of two scale exactly, so ordinary data give identical results.
    # H is put back on the data's scale at the end; coherence does not depend on it.
    u_scale, y_scale = (_power_of_two_scale([r[k] for r in recs]) for k in (0, 1))
    recs = [(u / u_scale, y / y_scale) for u, y in recs]
    w_out = np.asarray(log_frequencies(w_min, w_max, n_frequencies) if w is None else w, float)
    if w_out.ndim != 1 or np.any(np.diff(w_out) <= 0) or w_out[0] <= 0:
        raise ValueError("w must be positive and strictly increasing")
    nyquist = np.pi * sample_rate_hz
    if w_out[-1] > nyquist:
        raise ValueError(
            f"w_max {w_out[-1]:.4g} rad/s exceeds the Nyquist frequency {nyquist:.4g} rad/s of "
            f"data sampled at {sample_rate_hz:.4g} Hz; lower w_max (or check that the time "
            "column is in seconds)"
        )
    if not 0.0 <= overlap < 1.0:
        raise ValueError("overlap must be in [0, 1)")
    t_need = min_periods * 2.0 * np.pi / w_out[0]
    durations = [u.size / sample_rate_hz for u, _ in recs]
    # segments a window of t_need would give, pooled over the records
    step = t_need * (1.0 - overlap)
    pooled = sum(int((d - t_need * overlap) // step) for d in durations if d >= t_need)
    if pooled < min_averages:
        need = t_need * (1.0 + (min_averages - 1) * (1.0 - overlap))
        raise ValueError(
            f"record too short for the band: the lowest frequency {w_out[0]:.3g} rad/s needs "
            f"{min_periods:g} periods per window ({t_need:.3g} s) and {min_averages} averages, "
            f"i.e. at least {need:.3g} s of record; the longest record is {max(durations):.3g} s"
        )
    if window_lengths_s is None:
        window_lengths_s = [t_need / 4.0 ** (k / 4) for k in range(5)]
    n_min = 8
    wins = sorted({int(round(t * sample_rate_hz)) for t in window_lengths_s}, reverse=True)
    wins = [n for n in wins if n >= n_min]
    if not wins:
        raise ValueError(f"window lengths must hold at least {n_min} samples")

    per = []  # (Gxx, Gyy, Gxy, nd, err, T)
    for nper in wins:
        try:
            est = cross_spectral_estimate(
                recs, sample_rate_hz, nper, noverlap=int(round(overlap * nper))
            )
        except ValueError:
            continue  # window longer than every record: it simply contributes nothing
        t_win = nper / sample_rate_hz
        gxx, gyy, gxy, nd, usable = _onto_grid(est, w_out, min_periods * 2 * np.pi / t_win)
        with np.errstate(invalid="ignore", divide="ignore"):
            coh = np.abs(gxy) ** 2 / (gxx * gyy)
        err = random_error(coh, nd)
        err = np.where(usable & (nd >= min_averages) & np.isfinite(coh), err, np.inf)
        per.append((gxx, gyy, gxy, nd, err, t_win))
    if not per:
        raise ValueError("no window length fits inside any record")

    errs = np.stack([p[4] for p in per])  # (windows, freq)
    tw = np.array([p[5] for p in per])
    any_ok = np.isfinite(errs).any(axis=0)
    if combine == "min_error":
        best = np.argmin(errs, axis=0)
        pick = lambda k: np.stack([p[k] for p in per])[best, np.arange(w_out.size)]  # noqa: E731
        gxx, gyy, gxy, nd = pick(0), pick(1), pick(2), pick(3)
        win_s = tw[best]
    elif combine == "blend":
        e = np.maximum(errs, 1e-12)  # a noise-free estimate has zero error
        wts = np.where(np.isfinite(e), 1.0 / e**2, 0.0)
        tot = wts.sum(axis=0)
        with np.errstate(invalid="ignore", divide="ignore"):
            wts = wts / tot
        blend = lambda k: np.nansum(wts * np.stack([p[k] for p in per]), axis=0)  # noqa: E731
        gxx, gyy, gxy = blend(0), blend(1), blend(2)
        nd = np.sum(np.where(wts > 0, np.stack([p[3] for p in per]), 0.0), axis=0)
        win_s = tw[np.argmax(wts, axis=0)]
    else:
        raise ValueError("combine must be 'min_error' or 'blend'")
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        H = gxy / gxx * (y_scale / u_scale)
        coh = np.clip(np.abs(gxy) ** 2 / (gxx * gyy), 0.0, 1.0)
    undefined = np.isnan(coh)  # 0/0: a silent (constant) output or input
    coh = np.where(undefined, 0.0, coh)
    coh = np.where(any_ok, coh, 0.0)
    H = np.where(any_ok, H, np.nan + 0j)
    nd = np.where(any_ok, nd, 0.0)
    win_s = np.where(any_ok, win_s, np.nan)
    err = random_error(coh, nd)
    mask = any_ok & ~undefined & (coh >= coherence_threshold) & np.isfinite(H)
    if not mask.any() and (any_ok & ~undefined & (coh >= coherence_threshold)).any():
        raise ValueError(
            f"the gain |H| overflows float64: the output is about {y_scale:.3g} and the input "
            f"about {u_scale:.3g} in size; rescale the columns (check their units)"
        )
    if not mask.any():
        best_coh = float(np.max(coh)) if coh.size else 0.0
        raise ValueError(
            f"no usable coherence: no frequency reaches the threshold {coherence_threshold:g} "
            f"(the highest is {best_coh:.3g}); check that the input excites the band"
        )
    return FrequencyResponse(
        w=_device(w_out),
        H=_device(H),
        coherence=_device(coh),
        random_error=_device(err),
        n_averages=_device(nd.astype(float)),
        mask=_device(mask),
        window_s=_device(win_s),
        coherence_threshold=float(coherence_threshold),
    )


def zoh_correction(response: FrequencyResponse, sample_rate_hz: float) -> FrequencyResponse:
    r"""Remove the zero-order hold of sampled input data from a measured response.

    An input logged at the samples and *held* between them (as an autopilot's servo
    commands are, and as :func:`jaxgwo.simulate` applies them) reaches a continuous plant
    :math:`G` through the hold, so the sampled data's response is, to first order in the
    aliasing,

    .. math:: H(\omega) = G(j\omega)\, e^{-j\omega T/2}\, \frac{\sin(\omega T/2)}{\omega T/2}

    with :math:`T = 1/f_s`: a half-sample delay (18 deg at 10 Hz for 100 Hz data) and a small
    magnitude droop.  A continuous model fitted to :math:`H` absorbs them into its servo
    parameters; dividing them out lets it estimate :math:`G` itself.
    """
    w = np.asarray(response.w, dtype=float)
    half = 0.5 * w / float(sample_rate_hz)
    hold = np.exp(-1j * half) * np.sinc(half / np.pi)
    return eqx.tree_at(lambda r: r.H, response, response.H / _device(hold))
