"""``jaxgwo montecarlo``: many seeds of the reference helicopter fit, summarised."""

from __future__ import annotations

import argparse
import json
import math
import os
import sys

DESCRIPTION = """\
Run N independent GWO/IGWO seeds of the reference problem (the paper model's 5-parameter
fit K, tau, M, omega_s, zeta_s to its own response on 200 log-spaced points, 1-60 rad/s)
in chunks of compiled, vmapped calls, and summarise: parameter distributions, success rate
(all parameters within --tolerance of the truth), cost quantiles.  Memory stays bounded:
only each seed's final cost and parameters are kept.

A progress line per chunk (rate, ETA) is shown on a terminal; --quiet hides it.

Examples:
  jaxgwo montecarlo --seeds 1000 --json mc.json --plot mc.png --convergence-plot conv.png
  jaxgwo montecarlo --seeds 10000 --chunk 100 --method igwo --wolves 50 --iterations 500
"""

PARAMETER_NAMES = ("K", "tau", "M", "omega_s", "zeta_s")


def add_parser(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        "montecarlo",
        help="many optimiser seeds of the reference problem: distributions and success rate",
        description=DESCRIPTION,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--seeds", type=int, default=1000, metavar="N", help="number of seeds (1000)")
    p.add_argument("--chunk", type=int, default=100, metavar="N",
                   help="seeds per compiled call (100); memory and cache pressure grow with it")
    p.add_argument("--devices", type=int, default=os.cpu_count() or 1, metavar="N",
                   help="CPU cores to shard the seeds over, as JAX host devices "
                        f"(default: all, {os.cpu_count() or 1} here)")
    p.add_argument("--method", choices=("gwo", "igwo"), default="igwo", help="optimiser (igwo)")
    p.add_argument("--wolves", type=int, default=50, metavar="N", help="pack size (50)")
    p.add_argument("--iterations", type=int, default=500, metavar="N", help="iterations (500)")
    p.add_argument("--seed", type=int, default=0, metavar="N",
                   help="master PRNG seed, split into one key per run (0)")
    p.add_argument("--tolerance", type=float, default=0.01, metavar="F",
                   help="relative tolerance per parameter for success (0.01)")
    p.add_argument("--histories", action="store_true",
                   help="also report per-iteration quantiles of the best cost over seeds")
    p.add_argument("--json", metavar="OUT", help="write the summary as JSON")
    p.add_argument("--plot", metavar="OUT.png", help="write parameter and cost histograms")
    p.add_argument("--convergence-plot", metavar="OUT.png",
                   help="write the best cost per iteration, median and IQR band over seeds "
                        "(implies --histories)")
    p.add_argument("--quiet", action="store_true",
                   help="no progress line (shown only on a terminal) and no summary")
    p.set_defaults(func=run)
    return p


def _check(args) -> None:
    if args.seeds < 1:
        raise ValueError(f"--seeds must be >= 1, got {args.seeds}")
    if args.devices < 1:
        raise ValueError(f"--devices must be >= 1, got {args.devices}")
    if args.chunk < 1:
        raise ValueError(f"--chunk must be >= 1, got {args.chunk}")
    if args.wolves < 4:
        raise ValueError(f"--wolves must be >= 4 (alpha, beta, delta and one more), got {args.wolves}")
    if args.iterations < 1:
        raise ValueError(f"--iterations must be >= 1, got {args.iterations}")
    if not (math.isfinite(args.tolerance) and args.tolerance > 0):
        raise ValueError(f"--tolerance must be a positive number, got {args.tolerance}")
    from ._identify import check_output_paths

    check_output_paths(args, ("json", "plot", "convergence_plot"))


def _use_cpu_cores(devices: int) -> None:
    """Expose ``devices`` CPU cores as JAX host devices, so the seed axis can be sharded
    over them.  Works only before JAX starts its backend (the CLI has not, at this point);
    an ``XLA_FLAGS`` that already sets a device count is left alone."""
    flags = os.environ.get("XLA_FLAGS", "")
    if devices > 1 and "xla_force_host_platform_device_count" not in flags:
        os.environ["XLA_FLAGS"] = f"{flags} --xla_force_host_platform_device_count={devices}".strip()


def run(args) -> int:
    _check(args)
    _use_cpu_cores(args.devices)
    import jax

    import jaxgwo
    from jaxgwo._atomic import atomic_write_text
    from jaxgwo._montecarlo import monte_carlo, plot_monte_carlo
    from jaxgwo._progress import Progress
    from jaxgwo._testfunctions import HELICOPTER_TRUTH, helicopter_problem

    problem = helicopter_problem()
    make = jaxgwo.igwo if args.method == "igwo" else jaxgwo.gwo
    config = make(args.wolves, args.iterations)
    histories = args.histories or bool(args.convergence_plot)
    with Progress(args.seeds, "montecarlo", "seeds", quiet=args.quiet) as bar:
        summary = monte_carlo(
            config, problem.objective, problem.lower(), problem.upper(),
            jax.random.key(args.seed), args.seeds, chunk=args.chunk,
            truth=HELICOPTER_TRUTH, tolerance=args.tolerance,
            keep_histories=histories, parameter_names=PARAMETER_NAMES,
            progress=lambda done, total: bar.update(done),
        )
    report = summary.to_json()
    report["method"] = args.method
    report["wolves"] = args.wolves
    report["iterations"] = args.iterations
    report["seed"] = args.seed
    report["jax_version"] = jax.__version__
    report["devices"] = len(jax.local_devices())
    if args.json:
        atomic_write_text(args.json, json.dumps(report, indent=2) + "\n")
    if args.plot:
        plot_monte_carlo(summary, args.plot)
    if args.convergence_plot:
        from jaxgwo._plots import bands_from_montecarlo, plot_convergence

        panel = f"{args.method}, {args.wolves} wolves x {args.iterations} iterations"
        plot_convergence({panel: bands_from_montecarlo(summary)},
                         args.convergence_plot, ylabel="best cost",
                         title="reference helicopter fit: best cost over seeds")
    if not args.quiet:
        cost = report["cost"]
        print(f"{summary.n_seeds} seeds ({args.method}, {args.wolves} wolves x "
              f"{args.iterations} iterations) in {summary.wall_time_s:.1f} s "
              f"({1e3 * summary.wall_time_s / summary.n_seeds:.2f} ms/seed, chunk {summary.chunk}, "
              f"{report['devices']} device(s))")
        print(f"success within {args.tolerance:g} rel.: {100 * summary.success_rate:.1f} %   "
              f"cost median {cost.get('q50', float('nan')):.3g}, "
              f"95 % {cost.get('q95', float('nan')):.3g}")
        for name, st in report["parameters"].items():
            print(f"  {name:8s} truth {st['truth']:<9.5g} median {st['q50']:<11.6g} "
                  f"5-95 % [{st['q05']:.6g}, {st['q95']:.6g}]")
    return 0
