"""Speed of the engine on the helicopter identification problem, against NumPy and C.

    python benchmarks/speed_engine.py              # both cores
    python benchmarks/speed_engine.py --cpus 1     # pinned to one core

The reference problem: fit (K, tau, M, omega_s, zeta_s) on 200 log-spaced points from 1 to
60 rad/s, 50 wolves, 500 iterations, float64.  Times, all after compilation and as medians
of repeats, in one process and interleaved so that machine load hits every row alike:

* a single jaxgwo IGWO (and GWO) run, and the per-run time of a batch of 1,000 seeds in one
  call (``run_seeds``, no history kept);
* a plain NumPy-vectorised GWO of the same problem (benchmarks/numpy_gwo.py), the reference
  every ratio is taken against;
* the objective alone: 25,050 evaluations x 200 frequencies in one jitted ``vmap``, and the
  same arithmetic in C (benchmarks/objective_floor.c, built with ``gcc -O3 -march=native``
  when gcc is on the PATH) -- the floor an optimiser run cannot beat.

Compile times are reported separately; the load average at the start and end is recorded,
because on a shared 2-core machine it moves every number.  Writes
benchmarks/results/speed_engine.md.
"""

from __future__ import annotations

import argparse
import os
import platform
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))


def _args():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--repeats", type=int, default=7, help="repeats of the single runs")
    ap.add_argument("--batch", type=int, default=1000, help="seeds in the batched call")
    ap.add_argument("--batch-repeats", type=int, default=3)
    ap.add_argument("--cpus", type=int, default=0, help="pin the process to this many cores "
                    "(0: leave it alone); must be set before JAX starts its thread pool")
    ap.add_argument("--out", default=os.path.join(HERE, "results"))
    return ap.parse_args()


sys.path.insert(0, HERE)
from machine import cpu_model, pin_cpus  # noqa: E402

ARGS = _args()
pin_cpus(ARGS.cpus)

import jax  # noqa: E402

jax.config.update("jax_enable_x64", True)

import numpy as np  # noqa: E402

import jaxgwo  # noqa: E402

from jaxgwo._atomic import atomic_write_text  # noqa: E402
from jaxgwo._gwo import _compiler_options  # noqa: E402
from jaxgwo._testfunctions import helicopter_problem  # noqa: E402

from numpy_gwo import frequency_fit_np, gwo_numpy  # noqa: E402


def _interleaved(fns: dict, repeats: int) -> dict:
    """Median seconds of each callable, the callables taking turns in every round."""
    times = {k: [] for k in fns}
    for _ in range(repeats):
        for k, fn in fns.items():
            t0 = time.perf_counter()
            fn()
            times[k].append(time.perf_counter() - t0)
    return {k: statistics.median(v) for k, v in times.items()}


def _timed(fn) -> float:
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


def c_floor(n_freq: int, evals: int) -> tuple[float, float] | None:
    """(median, min) seconds of the C objective floor, or None without gcc."""
    gcc = shutil.which("gcc")
    if gcc is None:
        return None
    with tempfile.TemporaryDirectory() as tmp:
        exe = os.path.join(tmp, "objective_floor")
        src = os.path.join(HERE, "objective_floor.c")
        subprocess.run([gcc, "-O3", "-march=native", "-o", exe, src, "-lm"], check=True)
        out = subprocess.run([exe, str(n_freq), str(evals), "31"], check=True,
                             capture_output=True, text=True).stdout.split()
    return float(out[0]) * 1e-3, float(out[1]) * 1e-3


def main() -> int:
    args = ARGS
    load_start = os.getloadavg()
    prob = helicopter_problem(n_freq=200)
    lo, hi = prob.lower(), prob.upper()
    configs = {"IGWO": jaxgwo.igwo(50, 500), "GWO": jaxgwo.gwo(50, 500)}
    keys = jax.random.split(jax.random.key(1), args.batch)

    def single(c, k):
        return lambda: jaxgwo.run(c, prob.objective, lo, hi, k).best_fitness.block_until_ready()

    def batch(c):
        return lambda: jaxgwo.run_seeds(c, prob.objective, lo, hi, keys,
                                        keep_history=False).best_fitness.block_until_ready()

    compile_s = {}
    for name, c in configs.items():
        compile_s[name, "single"] = _timed(single(c, jax.random.key(0)))
        compile_s[name, "batch"] = _timed(batch(c))

    w = np.asarray(prob.objective.w)
    target = np.asarray(prob.objective.target_re) + 1j * np.asarray(prob.objective.target_im)
    lo_np, hi_np = np.asarray(lo), np.asarray(hi)

    def numpy_run():
        gwo_numpy(lambda P: frequency_fit_np(P, w, target), lo_np, hi_np, 50, 500,
                  np.random.default_rng(0))

    evals = configs["GWO"].total_evaluations
    X = lo + jax.random.uniform(jax.random.key(3), (evals, 5)) * (hi - lo)
    # the options the engine compiles with (YNNPACK off for eltwise/reduce on CPU)
    objective_only = jax.jit(jax.vmap(prob.objective),
                             compiler_options=dict(_compiler_options()) or None)
    objective_only(X).block_until_ready()

    singles = {"numpy": numpy_run, "objective": lambda: objective_only(X).block_until_ready()}
    for name, c in configs.items():
        singles[name] = single(c, jax.random.key(2))
    t1 = _interleaved(singles, args.repeats)
    tb = _interleaved({name: batch(c) for name, c in configs.items()}, args.batch_repeats)
    tb = {k: v / args.batch for k, v in tb.items()}
    t_np = t1["numpy"]
    floor = c_floor(200, evals)
    load_end = os.getloadavg()

    cpus = len(os.sched_getaffinity(0))
    lines = [
        "# Engine speed: helicopter 5-parameter fit, 200 points, 50 wolves x 500 iterations",
        "",
        f"Command: `python benchmarks/speed_engine.py{' --cpus %d' % args.cpus if args.cpus else ''}`",
        "",
        f"Machine: {platform.machine()} {cpu_model()}, {os.cpu_count()} CPUs "
        f"({cpus} used); load average {load_start[0]:.2f} at start, {load_end[0]:.2f} at "
        f"end; JAX {jax.__version__} on {jax.default_backend()}; float64; medians of "
        f"{args.repeats} (single) and {args.batch_repeats} (batch of {args.batch}) repeats, "
        "interleaved.",
        "",
        f"NumPy-vectorised GWO reference ({evals:,} evaluations): **{t_np * 1e3:.1f} ms** per run.",
        "",
        "| optimiser | evaluations | compile, single (s) | single run (ms) | vs NumPy "
        f"| compile, batch of {args.batch} (s) | batched, per run (ms) | vs NumPy |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for name, c in configs.items():
        ts, b = t1[name], tb[name]
        lines.append(
            f"| {name} | {c.total_evaluations} | {compile_s[name, 'single']:.2f} | {ts * 1e3:.1f} "
            f"| {t_np / ts:.1f}x | {compile_s[name, 'batch']:.2f} | {b * 1e3:.2f} "
            f"| {t_np / b:.1f}x |"
        )
    lines += [
        "",
        f"Objective alone, {evals:,} evaluations x 200 frequencies (the work of one GWO run):",
        "",
        "| implementation | time (ms) | per point (ns) |",
        "|---|---|---|",
        f"| jaxgwo `FrequencyFit`, one jitted vmap | {t1['objective'] * 1e3:.2f} "
        f"| {t1['objective'] / (evals * 200) * 1e9:.2f} |",
    ]
    if floor is not None:
        lines.append(f"| C, gcc -O3 -march=native, one thread (median / best of 31) "
                     f"| {floor[0] * 1e3:.2f} / {floor[1] * 1e3:.2f} "
                     f"| {floor[0] / (evals * 200) * 1e9:.2f} / {floor[1] / (evals * 200) * 1e9:.2f} |")
        lines += [
            "",
            f"Batched GWO per run / C objective floor (median): "
            f"**{tb['GWO'] / floor[0]:.2f}x**; IGWO (20,050 evaluations) per run / C floor "
            f"scaled to its evaluations: **{tb['IGWO'] / (floor[0] * 20050 / evals):.2f}x**.",
        ]
    text = "\n".join(lines) + "\n"
    os.makedirs(args.out, exist_ok=True)
    name = "speed_engine.md" if not args.cpus else f"speed_engine_{args.cpus}cpu.md"
    atomic_write_text(os.path.join(args.out, name), text)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
