"""A plain NumPy-vectorised GWO: the reference the JAX engine is timed against.

The pack update and the objective are vectorised over wolves (no Python loop over wolves),
as a competent NumPy user would write it; the objective is the same complex relative error
as :class:`jaxgwo._testfunctions.FrequencyFit`.
"""

from __future__ import annotations

import numpy as np


def paper_response_np(P: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Paper-model response for a pack ``P`` of shape (wolves, 5) at ``w``: (wolves, freq)."""
    K, tau, M, ws, zs = (P[:, i:i + 1] for i in range(5))
    s = 1j * w[None, :]
    return K / (s * s + s / tau + M) * ws**2 / (s * s + 2 * zs * ws * s + ws**2)


def frequency_fit_np(P, w, target):
    g = paper_response_np(P, w)
    return np.mean(np.abs(g - target) ** 2 / np.abs(target) ** 2, axis=1)


def gwo_numpy(objective, lower, upper, wolves, iterations, rng: np.random.Generator):
    """GWO with best-ever leaders, linear a from 2 to 0; returns (best x, best f)."""
    dim = lower.size
    X = lower + rng.random((wolves, dim)) * (upper - lower)
    f = objective(X)
    order = np.argsort(f)[:3]
    L, Lf = X[order].copy(), f[order].copy()
    for t in range(iterations):
        a = 2.0 * (1.0 - t / iterations)
        r1 = rng.random((3, wolves, dim))
        r2 = rng.random((3, wolves, dim))
        A = 2.0 * a * r1 - a
        C = 2.0 * r2
        Xs = L[:, None, :] - A * np.abs(C * L[:, None, :] - X[None])
        X = np.clip(Xs.mean(axis=0), lower, upper)
        f = objective(X)
        f = np.where(np.isfinite(f), f, np.inf)
        allX = np.concatenate([L, X])
        allf = np.concatenate([Lf, f])
        order = np.argsort(allf)[:3]
        L, Lf = allX[order].copy(), allf[order].copy()
    return L[0], Lf[0]
