"""GWO versus IGWO (and IGWO ablations) on F1-F13 at dimension 30 and the helicopter fit.

    python benchmarks/gwo_vs_igwo.py            # 50 wolves, 500 iterations, 30 seeds
    python benchmarks/gwo_vs_igwo.py --seeds 5  # quicker

Writes benchmarks/results/gwo_vs_igwo.md (the table, with machine and versions) and
benchmarks/results/gwo_vs_igwo.png (median and IQR convergence per problem).
"""

from __future__ import annotations

import argparse
import os
import platform
import sys

import jax

import jaxgwo  # noqa: F401  (float64)
from jaxgwo._atomic import atomic_write_text
from jaxgwo._compare import plot_convergence, run_comparison, variants
from jaxgwo._testfunctions import helicopter_problem, mirjalili_functions

HERE = os.path.dirname(os.path.abspath(__file__))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--seeds", type=int, default=30)
    ap.add_argument("--wolves", type=int, default=50)
    ap.add_argument("--iterations", type=int, default=500)
    ap.add_argument("--dim", type=int, default=30)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", default=os.path.join(HERE, "results"))
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)
    key_f7, key_runs = jax.random.split(jax.random.key(args.seed))
    problems = list(mirjalili_functions(key_f7)) + [helicopter_problem()]
    report = run_comparison(
        problems, variants(args.wolves, args.iterations), dim=args.dim, seeds=args.seeds,
        key=key_runs, progress=lambda m: print(m, file=sys.stderr, flush=True),
    )
    wins = "\n".join(
        f"- {name}: better than GWO on {b}, no significant difference on {s}, worse on {w} "
        f"of {b + s + w} problems (p < 0.05, judged by the median)"
        for name, (b, s, w) in report.wins().items()
    )
    text = (
        "# GWO vs IGWO\n\n"
        f"Command: `python benchmarks/gwo_vs_igwo.py --seeds {args.seeds} --wolves {args.wolves} "
        f"--iterations {args.iterations} --dim {args.dim} --seed {args.seed}`\n\n"
        f"Machine: {platform.machine()}, {os.cpu_count()} CPUs, {platform.platform()}; "
        f"JAX {jax.__version__} on {jax.default_backend()}; float64. "
        f"Wall time {report.seconds:.0f} s including compilation.\n\n"
        + report.to_markdown() + "\n" + wins + "\n"
    )
    atomic_write_text(os.path.join(args.out, "gwo_vs_igwo.md"), text)
    plot_convergence(report, os.path.join(args.out, "gwo_vs_igwo.png"))
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
