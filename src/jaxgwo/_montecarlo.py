r"""Monte-Carlo studies: thousands of independent GWO/IGWO seeds in bounded memory.

:func:`monte_carlo` splits ``key`` into ``n_seeds`` keys exactly as a user would
(``keys = jax.random.split(key, n_seeds)``) and runs them in chunks of ``chunk`` seeds, each
chunk one compiled :func:`jaxgwo.run_seeds` call of the same shape (the last chunk is padded
with copies of the last key and the padding dropped, so it reuses the compiled call).  Seed
``i`` of the study therefore equals ``run(config, objective, lower, upper, keys[i])``.

Only what a study needs is kept on the host: each seed's final best fitness and best
position, ``n_seeds * (dim + 1)`` floats.  Convergence histories (``iterations`` floats per
seed) are kept only when asked, and then not per seed but as a per-iteration histogram of
:math:`\log_{10}` of the best fitness over seeds, from which quantiles are read
(:data:`HISTORY_BINS_PER_DECADE` bins per decade, so a history quantile is exact to within
a factor :math:`10^{1/50} \approx 1.047`).  Progress is reported per chunk from the host,
never from inside the compiled run.

Success (as in Monte-Carlo studies of identification methods): a seed succeeds when every
parameter lies within a relative ``tolerance`` of the truth,
:math:`|\hat\theta_j - \theta_j| \le \mathrm{tol}\,|\theta_j|` for all :math:`j` (an absolute
``tolerance`` where :math:`\theta_j = 0`).
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable, Sequence

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float, PRNGKeyArray

from ._atomic import atomic_savefig
from ._gwo import GreyWolfConfig, run_seeds

QUANTILE_LEVELS = (0.05, 0.25, 0.50, 0.75, 0.95)
HISTORY_BINS_PER_DECADE = 50
_HISTORY_LOG10_RANGE = (-40.0, 20.0)  # fitness outside is clipped into the end bins


@dataclasses.dataclass(frozen=True)
class MonteCarloSummary:
    """The outcome of :func:`monte_carlo` (host NumPy arrays; small whatever ``n_seeds``).

    Attributes:
        best_fitness: final best fitness of each seed, ``(n_seeds,)``.
        best_position: final best parameters of each seed, ``(n_seeds, dim)``.
        n_seeds: number of seeds run.
        chunk: seeds per compiled call.
        wall_time_s: wall time of the whole study, seconds (compilation included).
        compile_time_s: wall time of the first chunk minus the median of the others
            (an estimate of compilation; 0 when there is one chunk).
        evaluations_per_seed: objective evaluations of one run.
        truth: the true parameters, or ``None``.
        tolerance: relative tolerance of the success test.
        parameter_names: a name per parameter.
        history_quantiles: ``(len(QUANTILE_LEVELS), iterations)`` quantiles over seeds of the
            best fitness after each iteration, or ``None`` unless histories were asked for.
    """

    best_fitness: np.ndarray
    best_position: np.ndarray
    n_seeds: int
    chunk: int
    wall_time_s: float
    compile_time_s: float
    evaluations_per_seed: int
    truth: np.ndarray | None
    tolerance: float
    parameter_names: tuple[str, ...]
    history_quantiles: np.ndarray | None = None

    @property
    def success(self) -> np.ndarray | None:
        """Per seed: every parameter within ``tolerance`` of the truth (``None`` without one)."""
        if self.truth is None:
            return None
        scale = np.where(self.truth != 0.0, np.abs(self.truth), 1.0)
        return np.all(np.abs(self.best_position - self.truth) <= self.tolerance * scale, axis=1)

    @property
    def success_rate(self) -> float | None:
        s = self.success
        return None if s is None else float(np.mean(s))

    def parameter_statistics(self) -> dict[str, dict[str, float]]:
        """Per parameter: quantiles 5/25/50/75/95 %, mean and standard deviation over seeds."""
        q = np.quantile(self.best_position, QUANTILE_LEVELS, axis=0)
        mean, std = self.best_position.mean(axis=0), self.best_position.std(axis=0)
        out = {}
        for j, name in enumerate(self.parameter_names):
            stats = {_qname(p): float(q[i, j]) for i, p in enumerate(QUANTILE_LEVELS)}
            stats.update(mean=float(mean[j]), std=float(std[j]))
            if self.truth is not None:
                stats["truth"] = float(self.truth[j])
            out[name] = stats
        return out

    def cost_statistics(self) -> dict[str, float | int]:
        """Quantiles of the final best fitness over seeds (finite seeds), min, max, and the
        count of seeds that found no finite fitness."""
        f = self.best_fitness
        finite = f[np.isfinite(f)]
        out: dict[str, float | int] = {"non_finite": int(f.size - finite.size)}
        if finite.size:
            q = np.quantile(finite, QUANTILE_LEVELS)
            out.update({_qname(p): float(v) for p, v in zip(QUANTILE_LEVELS, q)})
            out.update(min=float(finite.min()), max=float(finite.max()),
                       mean=float(finite.mean()))
        return out

    def to_json(self) -> dict:
        """A JSON-serialisable summary (no per-seed arrays)."""
        out = {
            "n_seeds": self.n_seeds,
            "chunk": self.chunk,
            "wall_time_s": self.wall_time_s,
            "compile_time_s": self.compile_time_s,
            "seconds_per_seed": self.wall_time_s / self.n_seeds,
            "evaluations_per_seed": self.evaluations_per_seed,
            "tolerance": self.tolerance,
            "success_rate": self.success_rate,
            "truth": None if self.truth is None else [float(v) for v in self.truth],
            "parameters": self.parameter_statistics(),
            "cost": self.cost_statistics(),
            "quantile_levels": list(QUANTILE_LEVELS),
        }
        if self.history_quantiles is not None:
            out["history_quantiles"] = {
                _qname(p): [float(v) for v in row]
                for p, row in zip(QUANTILE_LEVELS, self.history_quantiles)
            }
        return out


def _qname(p: float) -> str:
    return f"q{round(100 * p):02d}"


class _HistoryHistogram:
    """Per-iteration counts of log10(best fitness) in fixed bins: memory
    ``iterations * bins`` whatever the number of seeds."""

    def __init__(self, iterations: int):
        lo, hi = _HISTORY_LOG10_RANGE
        self.n_bins = int(round((hi - lo) * HISTORY_BINS_PER_DECADE))
        self.counts = np.zeros((iterations, self.n_bins), dtype=np.int64)

    def add(self, histories: np.ndarray) -> None:
        lo, _ = _HISTORY_LOG10_RANGE
        with np.errstate(divide="ignore", invalid="ignore"):
            x = np.log10(np.where(np.isnan(histories), np.inf, histories))
        b = np.floor((x - lo) * HISTORY_BINS_PER_DECADE)
        b = np.clip(np.nan_to_num(b, nan=0.0, posinf=self.n_bins - 1, neginf=0.0),
                    0, self.n_bins - 1).astype(np.int64)
        iters = self.counts.shape[0]
        flat = (np.arange(iters)[None, :] * self.n_bins + b).ravel()
        self.counts += np.bincount(flat, minlength=iters * self.n_bins).reshape(iters, -1)

    def quantiles(self) -> np.ndarray:
        """Quantiles read at bin centres, ``(len(QUANTILE_LEVELS), iterations)``."""
        lo, _ = _HISTORY_LOG10_RANGE
        cum = np.cumsum(self.counts, axis=1)
        total = cum[:, -1:]
        out = np.empty((len(QUANTILE_LEVELS), self.counts.shape[0]))
        for i, p in enumerate(QUANTILE_LEVELS):
            idx = np.argmax(cum >= np.maximum(1, np.ceil(p * total)), axis=1)
            out[i] = 10.0 ** (lo + (idx + 0.5) / HISTORY_BINS_PER_DECADE)
        return out


def monte_carlo(
    config: GreyWolfConfig,
    objective: Callable[[Float[Array, " dim"]], Float[Array, ""]],
    lower: Float[Array, " dim"],
    upper: Float[Array, " dim"],
    key: PRNGKeyArray,
    n_seeds: int,
    *,
    chunk: int = 100,
    truth: Sequence[float] | None = None,
    tolerance: float = 0.01,
    keep_histories: bool = False,
    parameter_names: Sequence[str] | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> MonteCarloSummary:
    """Run ``n_seeds`` independent optimisations in chunks and summarise them.

    Args:
        config, objective, lower, upper: as for :func:`jaxgwo.run`.
        key: split into ``n_seeds`` keys by ``jax.random.split(key, n_seeds)``; seed ``i``
            equals ``run(config, objective, lower, upper, keys[i])``.
        n_seeds: number of seeds, >= 1.
        chunk: seeds per compiled call (capped at ``n_seeds``).  Larger chunks amortise
            dispatch, but memory and cache pressure grow with it (about
            ``chunk * wolves * n_freq`` complex intermediates for a frequency-response
            fit).  On the reference problem (50 x 500, 200 frequencies, 2-core CPU) 100
            ran at about 12-16 ms/seed, 250 at 14-18 ms, and 500 was several times slower.
        truth: true parameters for the success rate, or ``None``.
        tolerance: relative tolerance per parameter of the success test, > 0.
        keep_histories: also summarise the convergence histories as per-iteration
            quantiles over seeds (never all histories).
        parameter_names: names for the summary (default ``x0, x1, ...``).
        progress: called on the host as ``progress(seeds_done, n_seeds)`` after each chunk.

    With more than one local device each chunk is sharded over all of them
    (:func:`jaxgwo._sharding.run_seeds_sharded`).

    Raises:
        ValueError: for ``n_seeds < 1``, ``chunk < 1``, a non-positive tolerance, or a
            ``truth`` / ``parameter_names`` of the wrong length.
    """
    if not isinstance(n_seeds, (int, np.integer)) or n_seeds < 1:
        raise ValueError(f"n_seeds={n_seeds!r}: run at least one seed (n_seeds >= 1).")
    if not isinstance(chunk, (int, np.integer)) or chunk < 1:
        raise ValueError(f"chunk={chunk!r}: a chunk holds at least one seed (chunk >= 1).")
    if not (math.isfinite(tolerance) and tolerance > 0.0):
        raise ValueError(f"tolerance={tolerance!r}: pass a positive relative tolerance.")
    dim = int(np.shape(lower)[0])
    if truth is not None:
        truth = np.asarray(truth, dtype=np.float64)
        if truth.shape != (dim,):
            raise ValueError(f"truth has shape {truth.shape}; the problem has {dim} parameters.")
    names = tuple(parameter_names) if parameter_names is not None else tuple(
        f"x{j}" for j in range(dim))
    if len(names) != dim:
        raise ValueError(f"{len(names)} parameter names for {dim} parameters.")

    chunk = int(min(chunk, n_seeds))
    n_chunks = -(-n_seeds // chunk)
    keys = jax.random.split(key, n_seeds)
    pad = n_chunks * chunk - n_seeds
    if pad:
        keys = jnp.concatenate([keys, jnp.repeat(keys[-1:], pad, axis=0)])

    # Several local devices (GPUs, or CPU cores exposed as host devices): shard each
    # chunk's seed axis over them; the results equal run_seeds' (tests/test_sharding.py).
    if len(jax.local_devices()) > 1:
        from ._sharding import run_seeds_sharded as runner
    else:
        runner = run_seeds
    best_fitness = np.empty(n_seeds)
    best_position = np.empty((n_seeds, dim))
    hist = _HistoryHistogram(config.iterations) if keep_histories else None
    evaluations = config.total_evaluations
    chunk_times = []
    t_start = time.perf_counter()
    for c in range(n_chunks):
        t0 = time.perf_counter()
        res = runner(config, objective, lower, upper, keys[c * chunk:(c + 1) * chunk],
                     keep_history=keep_histories)
        start, stop = c * chunk, min((c + 1) * chunk, n_seeds)
        keep = stop - start  # the padding of the last chunk is dropped here
        best_fitness[start:stop] = np.asarray(res.best_fitness)[:keep]
        best_position[start:stop] = np.asarray(res.best_position)[:keep]
        if hist is not None:
            hist.add(np.asarray(res.history_best)[:keep])
        if c == 0:
            evaluations = int(np.asarray(res.evaluations)[0])
        del res
        chunk_times.append(time.perf_counter() - t0)
        if progress is not None:
            progress(stop, n_seeds)
    wall = time.perf_counter() - t_start
    compile_time = (max(0.0, chunk_times[0] - float(np.median(chunk_times[1:])))
                    if n_chunks > 1 else 0.0)
    return MonteCarloSummary(
        best_fitness=best_fitness,
        best_position=best_position,
        n_seeds=int(n_seeds),
        chunk=chunk,
        wall_time_s=wall,
        compile_time_s=compile_time,
        evaluations_per_seed=evaluations,
        truth=truth,
        tolerance=float(tolerance),
        parameter_names=names,
        history_quantiles=None if hist is None else hist.quantiles(),
    )


def plot_monte_carlo(summary: MonteCarloSummary, path, *, bins: int = 40) -> None:
    """Histograms of each identified parameter over seeds (truth and tolerance band
    marked) and of log10 of the final cost, written atomically to ``path``."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    dim = summary.best_position.shape[1]
    n = dim + 1
    cols = min(3, n)
    rows = -(-n // cols)
    fig = Figure(figsize=(4.0 * cols, 3.0 * rows), layout="constrained")
    axes = fig.subplots(rows, cols, squeeze=False).ravel()
    for j in range(dim):
        ax = axes[j]
        ax.hist(summary.best_position[:, j], bins=bins, color="C0")
        ax.set_xlabel(summary.parameter_names[j])
        ax.set_ylabel("seeds")
        if summary.truth is not None:
            t = summary.truth[j]
            tol = summary.tolerance * (abs(t) if t != 0 else 1.0)
            ax.axvline(t, color="C3", label="truth")
            ax.axvspan(t - tol, t + tol, color="C3", alpha=0.15,
                       label=f"±{summary.tolerance:g} rel.")
            ax.legend(fontsize="small")
    ax = axes[dim]
    f = summary.best_fitness
    f = f[np.isfinite(f) & (f > 0)]
    if f.size:
        ax.hist(np.log10(f), bins=bins, color="C2")
    ax.set_xlabel("log10 final cost")
    ax.set_ylabel("seeds")
    for ax in axes[n:]:
        ax.set_visible(False)
    rate = summary.success_rate
    fig.suptitle(f"{summary.n_seeds} seeds" + ("" if rate is None else
                                                f", success {100 * rate:.1f} %"))
    atomic_savefig(fig, path)
