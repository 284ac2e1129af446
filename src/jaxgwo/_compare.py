"""Fair GWO-versus-IGWO comparisons: the same problems, seeds, pack and iterations.

Every variant is run over the same seeds in one vmapped call per problem.  The report
gives, per problem and variant, the median, interquartile range and best of the final
error ``f(x) - f*`` (``f*`` the known minimum), the number of objective evaluations the
variant actually made, and the two-sided Wilcoxon rank-sum p-value of its final errors
against GWO's (``scipy.stats.ranksums``).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import jax
import numpy as np

from . import _gwo as G
from ._atomic import atomic_savefig
from ._testfunctions import Problem


def variants(wolves: int, iterations: int) -> dict[str, G.GreyWolfConfig]:
    """GWO, IGWO with both eq. (39) schedules, and IGWO with each improvement switched off.

    ``igwo`` is the package default (see :func:`jaxgwo.igwo`).
    """
    return {
        "gwo": G.gwo(wolves, iterations),
        "igwo": G.igwo(wolves, iterations),
        "igwo eq39 as printed": G.igwo(wolves, iterations, schedule="eq39"),
        "igwo eq39 e^(t/T)": G.igwo(wolves, iterations, schedule="eq39-exp"),
        "igwo linear a": G.igwo(wolves, iterations, schedule="linear"),
        "igwo no grouping": G.igwo(wolves, iterations, grouping="none"),
        "igwo reinit grouping": G.igwo(wolves, iterations, grouping="reinit"),
        "igwo no dynamic weights": G.igwo(wolves, iterations, dynamic_weights=False),
    }


@dataclass(frozen=True)
class CompareRow:
    problem: str
    variant: str
    median: float
    q25: float
    q75: float
    best: float
    evaluations: int
    p_value: float  # rank-sum against GWO on the same problem; nan for GWO itself
    history_median: np.ndarray
    history_q25: np.ndarray
    history_q75: np.ndarray


@dataclass(frozen=True)
class CompareReport:
    rows: tuple[CompareRow, ...]
    wolves: int
    iterations: int
    seeds: int
    dim: int
    seconds: float

    def to_markdown(self) -> str:
        head = (
            f"Final error f(x) - f* over {self.seeds} seeds; {self.wolves} wolves, "
            f"{self.iterations} iterations, dimension {self.dim} (helicopter: 5). "
            "p: two-sided Wilcoxon rank-sum against GWO.\n\n"
            "| problem | variant | median | IQR (q25 - q75) | best | evaluations | p vs GWO |\n"
            "|---|---|---|---|---|---|---|\n"
        )
        lines = []
        for r in self.rows:
            p = "-" if np.isnan(r.p_value) else f"{r.p_value:.2g}"
            lines.append(
                f"| {r.problem} | {r.variant} | {r.median:.3g} | {r.q25:.3g} - {r.q75:.3g} "
                f"| {r.best:.3g} | {r.evaluations} | {p} |"
            )
        return head + "\n".join(lines) + "\n"

    def wins(self) -> dict[str, tuple[int, int, int]]:
        """Per variant: (significantly better, not different, significantly worse) than
        GWO at p < 0.05, judged by the median."""
        gwo = {r.problem: r.median for r in self.rows if r.variant == "gwo"}
        out: dict[str, list[int]] = {}
        for r in self.rows:
            if r.variant == "gwo":
                continue
            tally = out.setdefault(r.variant, [0, 0, 0])
            if r.p_value < 0.05 and r.median < gwo[r.problem]:
                tally[0] += 1
            elif r.p_value < 0.05 and r.median > gwo[r.problem]:
                tally[2] += 1
            else:
                tally[1] += 1
        return {k: tuple(v) for k, v in out.items()}


def run_comparison(
    problems: Sequence[Problem],
    configs: dict[str, G.GreyWolfConfig],
    *,
    dim: int,
    seeds: int,
    key: jax.Array,
    progress: Callable[[str], None] | None = None,
) -> CompareReport:
    """Run every variant on every problem over ``seeds`` seeds (the same keys for all)."""
    from scipy.stats import ranksums
    import time

    t0 = time.perf_counter()
    keys = jax.random.split(key, seeds)
    rows = []
    any_cfg = next(iter(configs.values()))
    for prob in problems:
        d = prob.fixed_dim or dim
        lo, hi, fstar = prob.lower(d), prob.upper(d), prob.optimum(d)
        finals: dict[str, np.ndarray] = {}
        for name, cfg in configs.items():
            res = G.run_seeds(cfg, prob.objective, lo, hi, keys)
            err = np.asarray(res.best_fitness) - fstar
            hist = np.asarray(res.history_best) - fstar
            finals[name] = err
            q = np.percentile(hist, [25, 50, 75], axis=0)
            rows.append(
                dict(
                    problem=prob.name,
                    variant=name,
                    median=float(np.median(err)),
                    q25=float(np.percentile(err, 25)),
                    q75=float(np.percentile(err, 75)),
                    best=float(np.min(err)),
                    evaluations=int(np.asarray(res.evaluations)[0]),
                    history_median=q[1],
                    history_q25=q[0],
                    history_q75=q[2],
                )
            )
            if progress:
                progress(f"{prob.name:28s} {name:26s} median {np.median(err):.3g}")
        base = finals.get("gwo")
        for row in rows[-len(configs):]:
            if base is None or row["variant"] == "gwo":
                row["p_value"] = float("nan")
            elif np.array_equal(finals[row["variant"]], base):
                row["p_value"] = 1.0
            else:
                row["p_value"] = float(ranksums(finals[row["variant"]], base).pvalue)
    return CompareReport(
        rows=tuple(CompareRow(**r) for r in rows),
        wolves=any_cfg.wolves,
        iterations=any_cfg.iterations,
        seeds=seeds,
        dim=dim,
        seconds=time.perf_counter() - t0,
    )


def plot_convergence(report: CompareReport, path: str) -> None:
    """Median best error per iteration with its IQR band, one panel per problem."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    problems = list(dict.fromkeys(r.problem for r in report.rows))
    ncol = min(4, len(problems))
    nrow = -(-len(problems) // ncol)
    fig, axes = plt.subplots(nrow, ncol, figsize=(4.2 * ncol, 3.2 * nrow), squeeze=False)
    floor = 1e-300
    for ax, prob in zip(axes.flat, problems):
        for r in (r for r in report.rows if r.problem == prob):
            it = np.arange(1, r.history_median.size + 1)
            (line,) = ax.plot(it, np.maximum(r.history_median, floor), lw=1.2, label=r.variant)
            ax.fill_between(it, np.maximum(r.history_q25, floor), np.maximum(r.history_q75, floor),
                            color=line.get_color(), alpha=0.15, lw=0)
        ax.set_yscale("log")
        ax.set_title(prob, fontsize=9)
        ax.set_xlabel("iteration")
        ax.set_ylabel("best f - f*")
    for ax in list(axes.flat)[len(problems):]:
        ax.axis("off")
    handles, labels = axes.flat[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=4, fontsize=8)
    fig.suptitle(
        f"GWO vs IGWO: median and IQR over {report.seeds} seeds "
        f"({report.wolves} wolves, {report.iterations} iterations)"
    )
    fig.tight_layout(rect=(0, 0.06, 1, 0.96))
    atomic_savefig(fig, path)
    plt.close(fig)
