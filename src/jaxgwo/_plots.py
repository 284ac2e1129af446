"""Figures for identification results and optimiser studies (matplotlib, Agg backend).

Each ``*_figure`` function builds a :class:`matplotlib.figure.Figure` without touching
pyplot's global state; each ``plot_*`` function writes one through
:func:`jaxgwo._atomic.atomic_savefig` (no partial files) and releases it.
:func:`figure_png` renders a figure to PNG bytes (the HTML report embeds those).

* :func:`bode_figure` -- measured response points faded by coherence, the coherence-masked
  frequencies shaded, the fitted model and the WLS start.
* :func:`convergence_figure` -- best cost per iteration, median and interquartile band over
  seeds (:class:`ConvergenceBand`; from raw histories, a Monte-Carlo summary or a
  comparison report).
* :func:`validation_figure` -- the time-domain validation overlay.
* :func:`identification_figure` -- all three per channel, the figure ``identify --plot`` writes.
"""

from __future__ import annotations

import io
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from ._atomic import atomic_savefig

__all__ = [
    "ConvergenceBand",
    "bands_from_compare",
    "bands_from_montecarlo",
    "bode_figure",
    "convergence_figure",
    "figure_png",
    "identification_figure",
    "plot_bode",
    "plot_convergence",
    "plot_identification",
    "plot_validation",
    "save_figure",
    "validation_figure",
]

_MIN_ALPHA = 0.12  # points of zero coherence stay faintly visible


def _figure(**kw):
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    return Figure(**kw)


def save_figure(fig, path: str | os.PathLike, dpi: int = 110) -> None:
    """Write ``fig`` atomically (format from the extension) and release its memory, also
    when writing fails."""
    try:
        atomic_savefig(fig, path, dpi=dpi)
    finally:
        fig.clear()


def figure_png(fig, dpi: int = 100) -> bytes:
    """``fig`` as PNG bytes (in memory), then released."""
    buf = io.BytesIO()
    try:
        fig.savefig(buf, format="png", dpi=dpi)
    finally:
        fig.clear()
    return buf.getvalue()


# ----------------------------------------------------------------------------- Bode


def _runs(flags: np.ndarray) -> list[tuple[int, int]]:
    """Index ranges ``[start, stop)`` of the consecutive True entries of ``flags``."""
    edges = np.diff(np.concatenate([[0], flags.astype(np.int8), [0]]))
    return list(zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)))


def _shade_masked(ax, w: np.ndarray, mask: np.ndarray, label: bool) -> None:
    """Shade frequencies left out of the fit (coherence below threshold), from the midpoint
    to each neighbour on the log axis."""
    logw = np.log(w)
    mids = np.exp(np.concatenate([[logw[0]], 0.5 * (logw[1:] + logw[:-1]), [logw[-1]]]))
    for k, (a, b) in enumerate(_runs(~mask)):
        ax.axvspan(mids[a], mids[b], color="0.85", lw=0, zorder=0,
                   label="coherence below threshold (not fitted)" if label and k == 0 else None)


def log_frequency_axis(ax) -> None:
    """A log frequency axis labelled at 1, 2 and 5 of each decade in plain numbers, its other
    minor ticks unlabelled.  Matplotlib's default labels minor ticks as ``2x10^-1`` once the
    axis spans under about two decades (a diagnosis's 0.16-7.7 Hz band), and on a
    half-page panel those labels run into each other."""
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

    ax.set_xscale("log")
    ax.xaxis.set_major_locator(LogLocator(base=10.0, subs=(1.0, 2.0, 5.0)))
    ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _pos: f"{v:g}"))
    ax.xaxis.set_minor_formatter(NullFormatter())


def _bode_axes(ax_m, ax_p, res, colorbar_fig=None) -> None:
    from matplotlib.colors import to_rgba

    fr = res.response
    w = np.asarray(fr.w, dtype=float)
    H = np.asarray(fr.H)
    coh = np.clip(np.nan_to_num(np.asarray(fr.coherence, dtype=float)), 0.0, 1.0)
    mask = np.asarray(fr.mask, dtype=bool)
    finite = np.isfinite(H) & (H != 0)
    Hm = np.asarray(res.model.frequency_response(fr.w))
    Hw = np.asarray(res.wls_model.frequency_response(fr.w))
    colours = np.tile(np.asarray(to_rgba("C0")), (w.size, 1))
    colours[:, 3] = _MIN_ALPHA + (1.0 - _MIN_ALPHA) * coh
    meas_phase = np.full(w.size, np.nan)
    if finite.any():
        meas_phase[finite] = np.degrees(np.unwrap(np.angle(H[finite])))
    model_phase = np.degrees(np.unwrap(np.angle(Hm)))
    # put the measured phase on the model's branch (a multiple of 360 deg apart)
    if finite.any():
        k = np.round(np.nanmedian(model_phase[finite] - meas_phase[finite]) / 360.0)
        meas_phase += 360.0 * k
    with np.errstate(divide="ignore"):
        meas_mag = np.where(finite, 20 * np.log10(np.abs(np.where(finite, H, 1.0))), np.nan)
    for ax, meas, model, wls in (
        (ax_m, meas_mag, 20 * np.log10(np.abs(Hm)), 20 * np.log10(np.abs(Hw))),
        (ax_p, meas_phase, model_phase, np.degrees(np.unwrap(np.angle(Hw)))),
    ):
        _shade_masked(ax, w, mask, label=ax is ax_m)
        ax.scatter(w[finite], meas[finite], c=colours[finite], s=12, lw=0,
                   label="measured (opacity: coherence)")
        ax.plot(w, model, "C3-", lw=1.6, label=f"{res.method} (J = {res.cost_J:.1f})")
        ax.plot(w, wls, "k--", lw=0.9, label=f"WLS start (J = {res.wls_cost_J:.1f})")
        log_frequency_axis(ax)
        ax.set_xlim(w[0], w[-1])
        ax.grid(True, which="both", alpha=0.3)
    ax_m.set_title(f"{res.channel}: Bode")
    ax_m.set_ylabel("magnitude (dB)")
    ax_p.set_ylabel("phase (deg)")
    ax_p.set_xlabel("frequency (rad/s)")
    ax_m.legend(fontsize=7, loc="lower left")


def bode_figure(results: Sequence):
    """One column per channel result (:class:`jaxgwo.ChannelIdentification`): magnitude and
    phase of the measured response, points faded by coherence (opacity = coherence), the
    frequencies below the coherence threshold shaded, the fitted model and the WLS start."""
    n = len(results)
    fig = _figure(figsize=(6.0 * n, 6.5))
    axes = fig.subplots(2, n, squeeze=False, sharex="col")
    for col, res in enumerate(results):
        _bode_axes(axes[0, col], axes[1, col], res)
    fig.tight_layout()
    return fig


def plot_bode(results: Sequence, path: str | os.PathLike) -> None:
    """:func:`bode_figure`, written atomically to ``path``."""
    save_figure(bode_figure(results), path)


# ----------------------------------------------------------------------------- convergence


@dataclass(frozen=True)
class ConvergenceBand:
    """Best cost per iteration over seeds: median and the 25-75 % band (``q25``/``q75``
    equal the median for a single run)."""

    median: np.ndarray
    q25: np.ndarray
    q75: np.ndarray
    seeds: int = 1

    @classmethod
    def from_histories(cls, histories) -> "ConvergenceBand":
        """From ``(iterations,)`` (one run) or ``(seeds, iterations)`` best-cost histories."""
        h = np.asarray(histories, dtype=float)
        if h.ndim == 1:
            return cls(h, h, h, 1)
        if h.ndim != 2 or h.shape[1] == 0:
            raise ValueError(f"histories of shape {h.shape}; expected (iterations,) or "
                             "(seeds, iterations).")
        q25, med, q75 = np.percentile(h, [25, 50, 75], axis=0)
        return cls(med, q25, q75, h.shape[0])


def bands_from_montecarlo(summary) -> dict[str, ConvergenceBand]:
    """The Monte-Carlo history quantiles (``monte_carlo(..., keep_histories=True)``) as a
    band labelled ``"best cost"``; ``ValueError`` if the study kept none."""
    from ._montecarlo import QUANTILE_LEVELS

    hq = summary.history_quantiles
    if hq is None:
        raise ValueError("the Monte-Carlo study kept no convergence histories; run it with "
                         "keep_histories=True (jaxgwo montecarlo --histories).")
    idx = {round(100 * p): i for i, p in enumerate(QUANTILE_LEVELS)}
    return {"best cost": ConvergenceBand(hq[idx[50]], hq[idx[25]], hq[idx[75]], summary.n_seeds)}


def bands_from_compare(report, problem: str | None = None) -> dict[str, dict[str, ConvergenceBand]]:
    """``{problem: {variant: band}}`` from a :class:`jaxgwo._compare.CompareReport`."""
    out: dict[str, dict[str, ConvergenceBand]] = {}
    for r in report.rows:
        if problem is not None and r.problem != problem:
            continue
        out.setdefault(r.problem, {})[r.variant] = ConvergenceBand(
            np.asarray(r.history_median), np.asarray(r.history_q25), np.asarray(r.history_q75),
            report.seeds)
    return out


def _band_axes(ax, bands: Mapping[str, ConvergenceBand], ylabel: str) -> None:
    floor = 1e-300  # log axis: exact zeros (a solved benchmark) drawn at the floor
    for label, b in bands.items():
        it = np.arange(1, np.asarray(b.median).size + 1)
        (line,) = ax.plot(it, np.maximum(b.median, floor), lw=1.3,
                          label=label if b.seeds == 1 else f"{label} (median, IQR, {b.seeds} seeds)")
        if b.seeds > 1:
            ax.fill_between(it, np.maximum(b.q25, floor), np.maximum(b.q75, floor),
                            color=line.get_color(), alpha=0.2, lw=0)
    ax.set_yscale("log")
    ax.set_xlabel("iteration")
    ax.set_ylabel(ylabel)
    ax.grid(True, which="both", alpha=0.3)


def convergence_figure(panels: Mapping[str, Mapping[str, ConvergenceBand]], *,
                       ylabel: str = "best cost", title: str | None = None):
    """One panel per entry of ``panels`` (``{panel title: {curve label: band}}``): each
    curve's median best cost per iteration with its interquartile band over seeds."""
    if not panels:
        raise ValueError("no convergence curves to plot.")
    ncol = min(3, len(panels))
    nrow = -(-len(panels) // ncol)
    fig = _figure(figsize=(4.6 * ncol, 3.4 * nrow))
    axes = fig.subplots(nrow, ncol, squeeze=False)
    for ax, (name, bands) in zip(axes.flat, panels.items()):
        _band_axes(ax, bands, ylabel)
        ax.set_title(name, fontsize=9)
        ax.legend(fontsize=7)
    for ax in list(axes.flat)[len(panels):]:
        ax.set_visible(False)
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    return fig


def plot_convergence(panels: Mapping[str, Mapping[str, ConvergenceBand]], path: str | os.PathLike,
                     **kw) -> None:
    """:func:`convergence_figure`, written atomically to ``path``."""
    save_figure(convergence_figure(panels, **kw), path)


# ----------------------------------------------------------------------------- validation


def _validation_axes(ax, res) -> None:
    val = res.validation
    if val is None:
        ax.text(0.5, 0.5, "no validation records", ha="center", va="center",
                transform=ax.transAxes)
        ax.set_title(f"{res.channel}: validation")
        return
    offset = 0.0
    for k, (t, y, yp) in enumerate(zip(val.time, val.measured, val.predicted)):
        t = np.asarray(t)
        ax.plot(t + offset, y, "k-", lw=0.8, label="measured" if k == 0 else None)
        ax.plot(t + offset, yp, "C3-", lw=0.8, label="model" if k == 0 else None)
        if k:
            ax.axvline(offset, color="0.6", lw=0.6, ls=":")
        offset += float(t[-1]) + (float(t[1] - t[0]) if t.size > 1 else 0.0)
    ax.set_title(f"{res.channel}: validation R^2 = {val.r2:.3f}, TIC = {val.tic:.3f}")
    ax.set_xlabel("time (s, records end to end)")
    ax.set_ylabel("rate (rad/s)")
    ax.legend(fontsize=7)
    ax.grid(True, alpha=0.3)


def validation_figure(results: Sequence):
    """Measured and simulated rates on the held-out records, one row per channel."""
    fig = _figure(figsize=(10.0, 3.0 * len(results)))
    axes = fig.subplots(len(results), 1, squeeze=False)
    for ax, res in zip(axes[:, 0], results):
        _validation_axes(ax, res)
    fig.tight_layout()
    return fig


def plot_validation(results: Sequence, path: str | os.PathLike) -> None:
    """:func:`validation_figure`, written atomically to ``path``."""
    save_figure(validation_figure(results), path)


# ----------------------------------------------------------------------------- combined


def identification_figure(results: Sequence):
    """One column per channel: Bode (coherence-faded points, masked band shaded, model and
    WLS start), the convergence curve, the time-domain validation overlay."""
    n = len(results)
    fig = _figure(figsize=(6.0 * n, 12.0))
    axes = fig.subplots(4, n, squeeze=False)
    for col, res in enumerate(results):
        ax_m, ax_p, ax_c, ax_t = axes[:, col]
        _bode_axes(ax_m, ax_p, res)
        conv = np.asarray(res.convergence)
        if conv.size:
            _band_axes(ax_c, {f"{res.method}, seed {res.seed}": ConvergenceBand.from_histories(conv)},
                       "best J")
            ax_c.legend(fontsize=7)
        else:
            ax_c.text(0.5, 0.5, f"no iterations ({res.method})", ha="center", va="center",
                      transform=ax_c.transAxes)
        ax_c.set_title("convergence")
        _validation_axes(ax_t, res)
    fig.tight_layout()
    return fig


def plot_identification(results: Sequence, path: str | os.PathLike) -> None:
    """:func:`identification_figure`, written atomically to ``path``."""
    save_figure(identification_figure(results), path)
