"""Figures for identification results (matplotlib, non-interactive Agg backend).

Every figure is written through :func:`jaxgwo._atomic.atomic_savefig`: no partial files.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ._atomic import atomic_savefig


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def plot_identification(results: Sequence, path: str) -> None:
    """One column per channel: Bode magnitude and phase of the measured response (points
    shaded by coherence, masked points hollow) against the identified and WLS models; the
    convergence curve; the time-domain validation overlay when there is one."""
    plt = _pyplot()
    n = len(results)
    fig, axes = plt.subplots(4, n, figsize=(6.0 * n, 12.0), squeeze=False)
    for col, res in enumerate(results):
        fr = res.response
        w = np.asarray(fr.w)
        H = np.asarray(fr.H)
        coh = np.asarray(fr.coherence)
        mask = np.asarray(fr.mask)
        Hm = np.asarray(res.model.frequency_response(fr.w))
        Hw = np.asarray(res.wls_model.frequency_response(fr.w))
        ax_m, ax_p, ax_c, ax_t = axes[:, col]
        for ax, f in ((ax_m, lambda h: 20 * np.log10(np.abs(h))),
                      (ax_p, lambda h: np.degrees(np.unwrap(np.angle(h))))):
            meas = f(np.where(np.isfinite(H), H, np.nan + 0j))
            sc = ax.scatter(w[mask], meas[mask], c=coh[mask], cmap="viridis", vmin=0.0, vmax=1.0,
                            s=10, label="measured (colour: coherence)")
            ax.scatter(w[~mask], meas[~mask], facecolors="none", edgecolors="0.6", s=10,
                       label="coherence below threshold")
            ax.plot(w, f(Hm), "r-", lw=1.5, label=f"{res.method} (J = {res.cost_J:.1f})")
            ax.plot(w, f(Hw), "k--", lw=1.0, label=f"WLS start (J = {res.wls_cost_J:.1f})")
            ax.set_xscale("log")
            ax.grid(True, which="both", alpha=0.3)
        ax_m.set_title(f"{res.channel}: Bode")
        ax_m.set_ylabel("magnitude (dB)")
        ax_p.set_ylabel("phase (deg)")
        ax_p.set_xlabel("frequency (rad/s)")
        ax_m.legend(fontsize=7)
        fig.colorbar(sc, ax=ax_m, label="coherence")
        conv = np.asarray(res.convergence)
        if conv.size:
            ax_c.semilogy(np.arange(1, conv.size + 1), conv)
            ax_c.set_xlabel("iteration")
            ax_c.set_ylabel("best J")
        else:
            ax_c.text(0.5, 0.5, f"no iterations ({res.method})", ha="center", va="center",
                      transform=ax_c.transAxes)
        ax_c.set_title("convergence")
        ax_c.grid(True, which="both", alpha=0.3)
        val = res.validation
        if val is not None:
            offset = 0.0
            for k, (t, y, yp) in enumerate(zip(val.time, val.measured, val.predicted)):
                ax_t.plot(t + offset, y, "k-", lw=0.8, label="measured" if k == 0 else None)
                ax_t.plot(t + offset, yp, "r-", lw=0.8, label="model" if k == 0 else None)
                offset += float(t[-1]) + float(t[1] - t[0])
            ax_t.set_title(f"validation: R^2 = {val.r2:.3f}, TIC = {val.tic:.3f}")
            ax_t.set_xlabel("time (s, records end to end)")
            ax_t.set_ylabel("rate (rad/s)")
            ax_t.legend(fontsize=7)
        else:
            ax_t.text(0.5, 0.5, "no validation records", ha="center", va="center",
                      transform=ax_t.transAxes)
        ax_t.grid(True, alpha=0.3)
    fig.tight_layout()
    atomic_savefig(fig, path)
    plt.close(fig)
