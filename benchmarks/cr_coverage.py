"""Do the reported Cramer-Rao bounds cover the truth? (issue 4 acceptance)

    python benchmarks/cr_coverage.py [--seeds 5] [--noise 0.05]

Paper plant (K, tau, M, omega_s, zeta_s) = (-500, 0.1, 150, 40, 0.7), one 60 s
0.15-12 Hz exponential sweep at 100 Hz, simulated with the model's exact ZOH response,
white output noise of ``noise`` x std(output), identified with ``wls-igwo+polish`` at the
default settings.  For each seed: |estimate - truth| / CR bound per parameter.  Writes
benchmarks/results/cr_coverage.md.
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time

import jax
import jax.numpy as jnp
import numpy as np

import jaxgwo
from jaxgwo._atomic import atomic_write_text
from jaxgwo._data import make_record
from jaxgwo._identify import IdentifySettings, identify_channels
from jaxgwo._models import PaperModel

HERE = os.path.dirname(os.path.abspath(__file__))
TRUTH = np.array([-500.0, 0.1, 150.0, 40.0, 0.7])
NAMES = ("K", "tau", "M", "omega_s", "zeta_s")


def record(noise: float, seed: int, fs: float = 100.0, T: float = 60.0):
    truth = PaperModel.from_array(jnp.asarray(TRUTH))
    t = np.arange(0.0, T, 1.0 / fs)
    f0, f1 = 0.15, 12.0
    u = 0.1 * np.sin(2 * np.pi * f0 * T / np.log(f1 / f0) * (np.exp(t / T * np.log(f1 / f0)) - 1))
    y = np.asarray(truth.simulate(jnp.asarray(t), jnp.asarray(u)))
    rng = np.random.default_rng(seed)
    return make_record(t, {"delta_lat": u, "p": y + noise * np.std(y) * rng.standard_normal(y.size)})


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--noise", type=float, default=0.05)
    args = ap.parse_args()
    t0 = time.perf_counter()
    rows, within1, within2 = [], 0, 0
    for s in range(args.seeds):
        res = identify_channels({"lateral": [record(args.noise, s)]},
                                IdentifySettings(method="wls-igwo+polish", seed=s))["lateral"]
        p = np.asarray(res.model.to_array())
        cr = np.asarray(res.uncertainty.cramer_rao)
        z = np.abs(p - TRUTH) / cr
        within1 += bool(np.all(z <= 1.0))
        within2 += bool(np.all(z <= 2.0))
        rows.append((s, z, 100 * (p / TRUTH - 1), np.asarray(res.uncertainty.cramer_rao_percent),
                     res.cost_J))
    lines = [
        "# Cramer-Rao bound coverage", "",
        f"Command: `python benchmarks/cr_coverage.py --seeds {args.seeds} --noise {args.noise}`", "",
        f"Machine: {platform.machine()}, {os.cpu_count()} CPUs; JAX {jax.__version__}; "
        f"jaxgwo {jaxgwo.__version__}; wall {time.perf_counter() - t0:.0f} s.", "",
        "| seed | " + " | ".join(f"{n}: err % / CR % / err/CR" for n in NAMES) + " | J |",
        "|---|" + "---|" * (len(NAMES) + 1),
    ]
    for s, z, err, crp, j in rows:
        cells = " | ".join(f"{e:+.2f} / {c:.2f} / {q:.2f}" for e, c, q in zip(err, crp, z))
        lines.append(f"| {s} | {cells} | {j:.2f} |")
    lines += ["", f"All five parameters within 1 CR bound: {within1}/{args.seeds} seeds; "
              f"within 2 CR bounds: {within2}/{args.seeds} seeds."]
    text = "\n".join(lines) + "\n"
    os.makedirs(os.path.join(HERE, "results"), exist_ok=True)
    atomic_write_text(os.path.join(HERE, "results", "cr_coverage.md"), text)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
