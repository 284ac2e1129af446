"""How the engine's run time grows with frequency points, wolves, iterations and batch size.

    python benchmarks/scaling.py            # about 3-5 minutes on a 2-core machine
    python benchmarks/scaling.py --quick    # under a minute: fewer points, fewer repeats

One sweep per axis around the reference problem (the helicopter fit, IGWO, 200 log-spaced
frequency points, 50 wolves, 500 iterations, float64), the other axes held at the
reference.  Single runs for the first three axes, ``run_seeds`` (no history) for the
batch axis.  Each point is the median of repeats after compilation; the table gives the
time per run and per evaluated frequency point (time / (evaluations x frequencies)),
which is flat where the cost is linear.  Writes benchmarks/results/scaling.md and
scaling.png.
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import sys
import time


def _args():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="three points per axis, fewer repeats")
    ap.add_argument("--cpus", type=int, default=0, help="pin the process to this many cores "
                    "(0: leave it alone); set before JAX starts its thread pool")
    ap.add_argument("--out", default=os.path.join(os.path.dirname(os.path.abspath(__file__)),
                                                  "results"))
    return ap.parse_args()


sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from machine import cpu_model, pin_cpus  # noqa: E402

ARGS = _args()
pin_cpus(ARGS.cpus)

import jax  # noqa: E402

jax.config.update("jax_enable_x64", True)

import numpy as np  # noqa: E402

import jaxgwo  # noqa: E402

from jaxgwo._atomic import atomic_write_text  # noqa: E402
from jaxgwo._testfunctions import helicopter_problem  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
REF = {"freq": 200, "wolves": 50, "iterations": 500, "batch": 1}
FULL = {
    "freq": [20, 50, 100, 200, 500, 1000, 2000],
    "wolves": [10, 20, 50, 100, 200, 500],
    "iterations": [100, 250, 500, 1000, 2000],
    "batch": [1, 10, 100, 300, 1000],
}
QUICK = {
    "freq": [20, 200, 2000],
    "wolves": [10, 50, 500],
    "iterations": [100, 500, 2000],
    "batch": [1, 100, 1000],
}
LABEL = {"freq": "frequency points", "wolves": "wolves", "iterations": "iterations",
         "batch": "batch size (seeds per call)"}


def measure(freq: int, wolves: int, iterations: int, batch: int, repeats: int) -> dict:
    prob = helicopter_problem(n_freq=freq)
    lo, hi = prob.lower(), prob.upper()
    cfg = jaxgwo.igwo(wolves, iterations)
    if batch == 1:
        def call():
            jaxgwo.run(cfg, prob.objective, lo, hi, jax.random.key(1)).best_fitness.block_until_ready()
    else:
        keys = jax.random.split(jax.random.key(1), batch)

        def call():
            jaxgwo.run_seeds(cfg, prob.objective, lo, hi, keys,
                             keep_history=False).best_fitness.block_until_ready()
    t0 = time.perf_counter()
    call()
    compile_s = time.perf_counter() - t0
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        call()
        times.append(time.perf_counter() - t0)
    per_run = statistics.median(times) / batch
    best = min(times) / batch
    evals = cfg.total_evaluations
    return {"freq": freq, "wolves": wolves, "iterations": iterations, "batch": batch,
            "evaluations": evals, "compile_s": compile_s, "run_ms": per_run * 1e3,
            "best_ms": best * 1e3, "ns_per_point": best / (evals * freq) * 1e9}


def main() -> int:
    args = ARGS
    sweeps = QUICK if args.quick else FULL
    load_start = os.getloadavg()
    t_start = time.perf_counter()
    rows = {}
    for axis, values in sweeps.items():
        rows[axis] = []
        for v in values:
            shape = dict(REF, **{axis: v})
            big = shape["batch"] >= 300
            repeats = (2 if big else 5) if args.quick else (3 if big else 11)
            r = measure(**shape, repeats=repeats)
            rows[axis].append(r)
            print(f"{axis}={v}: {r['run_ms']:.3f} ms/run (best {r['best_ms']:.3f}), "
                  f"{r['ns_per_point']:.2f} ns/point "
                  f"(compile {r['compile_s']:.1f} s)", flush=True)
    load_end = os.getloadavg()
    wall = time.perf_counter() - t_start

    lines = [
        "# Engine scaling: helicopter fit, IGWO",
        "",
        f"Command: `python benchmarks/scaling.py{' --quick' if args.quick else ''}"
        f"{' --cpus %d' % args.cpus if args.cpus else ''}` "
        f"({wall:.0f} s).",
        "",
        f"Machine: {platform.machine()} {cpu_model()}, {os.cpu_count()} CPUs "
        f"({len(os.sched_getaffinity(0))} used); "
        f"load average {load_start[0]:.2f} at start, {load_end[0]:.2f} at end; "
        f"JAX {jax.__version__} on {jax.default_backend()}; float64.  Reference shape: "
        f"{REF['freq']} frequency points, {REF['wolves']} wolves, {REF['iterations']} "
        "iterations, one run per call; each table varies one of them.  Times are per run, "
        "after compilation: the median and the best of the repeats.  On a loaded machine "
        "the best is the steadier estimate of the uncontended cost, so 'per point' (best "
        "time per run / (evaluations x frequency points), flat where the cost is linear) "
        "and the plot use it.",
        "",
    ]
    for axis, rs in rows.items():
        lines += [
            f"## {LABEL[axis]}",
            "",
            f"| {LABEL[axis]} | evaluations | run, median (ms) | run, best (ms) "
            "| per point, best (ns) | compile (s) |",
            "|---|---|---|---|---|---|",
        ]
        for r in rs:
            lines.append(f"| {r[axis]} | {r['evaluations']} | {r['run_ms']:.3f} "
                         f"| {r['best_ms']:.3f} | {r['ns_per_point']:.2f} "
                         f"| {r['compile_s']:.1f} |")
        lines.append("")
    text = "\n".join(lines)
    os.makedirs(args.out, exist_ok=True)
    stem = "scaling" if not args.cpus else f"scaling_{args.cpus}cpu"
    atomic_write_text(os.path.join(args.out, stem + ".md"), text)
    print(text)

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 4, figsize=(16, 3.8))
    for ax, (axis, rs) in zip(axes, rows.items()):
        x = np.array([r[axis] for r in rs], dtype=float)
        y = np.array([r["best_ms"] for r in rs])
        ax.loglog(x, y, "o-", label="measured")
        i = list(x).index(REF[axis]) if REF[axis] in x else 0
        if axis == "batch":
            ax.axhline(y[i], color="grey", ls="--", label="one run per call")
            ax.set_ylabel("best time per run (ms)")
        else:
            ax.loglog(x, y[i] * x / x[i], color="grey", ls="--", label="linear through reference")
            ax.set_ylabel("best time per run (ms)")
        ax.set_xlabel(LABEL[axis])
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle(f"jaxgwo IGWO, helicopter fit; JAX {jax.__version__}, "
                 f"{os.cpu_count()} CPUs, float64", fontsize=10)
    fig.tight_layout()
    png = os.path.join(args.out, stem + ".png")
    tmp = png + ".tmp.png"
    fig.savefig(tmp, dpi=110)
    os.replace(tmp, png)
    return 0


if __name__ == "__main__":
    sys.exit(main())
