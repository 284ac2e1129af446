"""Speed of one IGWO identification run on the helicopter problem, against NumPy.

    python benchmarks/speed_engine.py

The reference problem: fit (K, tau, M, omega_s, zeta_s) on 200 log-spaced points from 1 to
60 rad/s, 50 wolves, 500 iterations, float64.  Times, all after compilation and as medians
of repeats, in one process: a single jaxgwo IGWO run, a batch of 100 seeds (per run), and a
plain NumPy-vectorised GWO of the same problem (benchmarks/numpy_gwo.py).  Compile time is
reported separately.  Writes benchmarks/results/speed_engine.md.
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import sys
import time

import jax
import numpy as np

import jaxgwo
from jaxgwo._atomic import atomic_write_text
from jaxgwo._testfunctions import helicopter_problem

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from numpy_gwo import frequency_fit_np, gwo_numpy  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))


def _median_time(fn, repeats):
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--batch", type=int, default=100)
    ap.add_argument("--out", default=os.path.join(HERE, "results"))
    args = ap.parse_args()
    prob = helicopter_problem(n_freq=200)
    lo, hi = prob.lower(), prob.upper()
    cfg = jaxgwo.igwo(50, 500)
    gcfg = jaxgwo.gwo(50, 500)

    def single(c, k):
        return jaxgwo.run(c, prob.objective, lo, hi, k).best_fitness.block_until_ready()

    keys = jax.random.split(jax.random.key(1), args.batch)

    def batch(c):
        return jaxgwo.run_seeds(c, prob.objective, lo, hi, keys).best_fitness.block_until_ready()

    rows = []
    for name, c in (("IGWO", cfg), ("GWO", gcfg)):
        t0 = time.perf_counter()
        single(c, jax.random.key(0))
        compile_single = time.perf_counter() - t0
        t_single = _median_time(lambda: single(c, jax.random.key(2)), args.repeats)
        t0 = time.perf_counter()
        batch(c)
        compile_batch = time.perf_counter() - t0
        t_batch = _median_time(lambda: batch(c), max(3, args.repeats // 2)) / args.batch
        rows.append((name, c.total_evaluations, compile_single, t_single, compile_batch, t_batch))

    w = np.asarray(prob.objective.w)
    target = np.asarray(prob.objective.target_re) + 1j * np.asarray(prob.objective.target_im)
    lo_np, hi_np = np.asarray(lo), np.asarray(hi)
    t_np = _median_time(
        lambda: gwo_numpy(lambda P: frequency_fit_np(P, w, target), lo_np, hi_np, 50, 500,
                          np.random.default_rng(0)),
        max(3, args.repeats // 2),
    )

    lines = [
        "# Engine speed: helicopter 5-parameter fit, 200 points, 50 wolves x 500 iterations",
        "",
        "Command: `python benchmarks/speed_engine.py`",
        "",
        f"Machine: {platform.machine()}, {os.cpu_count()} CPUs; JAX {jax.__version__} on "
        f"{jax.default_backend()}; float64; medians of {args.repeats} repeats.",
        "",
        f"NumPy-vectorised GWO reference (25,050 evaluations): **{t_np * 1e3:.1f} ms** per run.",
        "",
        "| optimiser | evaluations | compile, single (s) | single run (ms) | speed-up vs NumPy "
        f"| compile, batch of {args.batch} (s) | batched, per run (ms) | speed-up vs NumPy |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for name, ev, cs, ts, cb, tb in rows:
        lines.append(
            f"| {name} | {ev} | {cs:.2f} | {ts * 1e3:.1f} | {t_np / ts:.1f}x | {cb:.2f} "
            f"| {tb * 1e3:.2f} | {t_np / tb:.1f}x |"
        )
    text = "\n".join(lines) + "\n"
    os.makedirs(args.out, exist_ok=True)
    atomic_write_text(os.path.join(args.out, "speed_engine.md"), text)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
