"""Do the reported Cramer-Rao bounds describe the real scatter? (issue 4 acceptance)

    python benchmarks/cr_coverage.py [--seeds 20] [--noise 0.05] [--flights 8]

Part 1, paper plant (K, tau, M, omega_s, zeta_s) = (-500, 0.1, 150, 40, 0.7): one 60 s
0.15-12 Hz exponential sweep at 100 Hz, simulated with the model's exact ZOH response,
white output noise of ``noise`` x std(output) drawn with numpy ``default_rng(seed)``,
identified with ``wls-igwo+polish`` at the default settings.  Per seed and parameter:
error / reported CR bound.  Reports the acceptance reading (seeds 0-4: all five
parameters within their bound), the per-parameter coverage against the 68.3 % / 95.4 %
of a calibrated one-sigma bound, the RMS error against the mean bound, and the joint
coverage a calibrated bound would give (Gaussian with the reported covariance, sampled).

Part 2, the embedded dataset's conditions (simulated R-50 with gusts, ``flights``
independent flights ``default_dataset_records(key(100 + k))``): the flight-to-flight
standard deviation of each parameter against the mean reported bound.  Here the paper
model is structurally wrong, so the scatter also contains the movement of the best-fit
point with the coherence weights.

Writes benchmarks/results/cr_coverage.md.
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
ONE_SIGMA, TWO_SIGMA = 0.6827, 0.9545


def record(noise: float, seed: int, fs: float = 100.0, T: float = 60.0):
    truth = PaperModel.from_array(jnp.asarray(TRUTH))
    t = np.arange(0.0, T, 1.0 / fs)
    f0, f1 = 0.15, 12.0
    u = 0.1 * np.sin(2 * np.pi * f0 * T / np.log(f1 / f0) * (np.exp(t / T * np.log(f1 / f0)) - 1))
    y = np.asarray(truth.simulate(jnp.asarray(t), jnp.asarray(u)))
    rng = np.random.default_rng(seed)
    return make_record(t, {"delta_lat": u, "p": y + noise * np.std(y) * rng.standard_normal(y.size)})


def joint_coverage(cov: np.ndarray, k: float, n: int = 200_000) -> float:
    """P(all |e_i| <= k sigma_i) for e ~ N(0, cov): what a calibrated bound would give."""
    d = np.sqrt(np.diag(cov))
    corr = cov / d[:, None] / d[None, :]
    z = np.random.default_rng(0).multivariate_normal(np.zeros(len(d)), corr, size=n)
    return float(np.mean(np.all(np.abs(z) <= k, axis=1)))


def paper_plant(seeds: int, noise: float):
    rows = []
    for s in range(seeds):
        res = identify_channels({"lateral": [record(noise, s)]},
                                IdentifySettings(method="wls-igwo+polish", seed=s))["lateral"]
        unc = res.uncertainty
        p = np.asarray(res.model.to_array())
        rows.append(dict(seed=s, err=100 * (p / TRUTH - 1), z=(p - TRUTH) / np.asarray(unc.cramer_rao),
                         crp=np.asarray(unc.cramer_rao_percent), cov=np.asarray(unc.covariance),
                         J=res.cost_J))
    return rows


def r50_flights(flights: int):
    from jaxgwo._simulate import default_dataset_records

    out = {ch: ([], []) for ch in ("lateral", "longitudinal")}
    for k in range(flights):
        recs = default_dataset_records(jax.random.key(100 + k))
        res = identify_channels({ch: [recs[ch]] for ch in out},
                                IdentifySettings(method="wls-igwo+polish", seed=0))
        for ch in out:
            out[ch][0].append(np.asarray(res[ch].model.to_array()))
            out[ch][1].append(np.asarray(res[ch].uncertainty.cramer_rao_percent))
    return {ch: (np.array(p), np.array(c)) for ch, (p, c) in out.items()}


def report(args, rows, r50, wall) -> str:
    z = np.array([r["z"] for r in rows])
    err = np.array([r["err"] for r in rows])
    crp = np.array([r["crp"] for r in rows])
    first = rows[:5]
    acc1 = sum(bool(np.all(np.abs(r["z"]) <= 1)) for r in first)
    acc2 = sum(bool(np.all(np.abs(r["z"]) <= 2)) for r in first)
    cal1 = np.mean([joint_coverage(r["cov"], 1.0) for r in rows])
    cal2 = np.mean([joint_coverage(r["cov"], 2.0) for r in rows])
    cmd = (f"python benchmarks/cr_coverage.py --seeds {args.seeds} --noise {args.noise} "
           f"--flights {args.flights}")
    lines = [
        "# Cramer-Rao bound coverage", "",
        f"Command: `{cmd}`", "",
        f"Machine: {platform.machine()}, {os.cpu_count()} CPUs; JAX {jax.__version__}; "
        f"jaxgwo {jaxgwo.__version__}; wall {wall:.0f} s.", "",
        "The bounds are the sandwich Cramer-Rao bounds of `jaxgwo._metrics` (covariance "
        "A^-1 B A^-1 from the measured random error of each frequency point, corrected for "
        "points that share FFT bins): one standard deviation of the random scatter.", "",
        f"## 1. Paper plant, {args.noise:g} output noise, {args.seeds} seeds", "",
        "| seed | " + " | ".join(f"{n}: err % / CR % / err/CR" for n in NAMES) + " | J |",
        "|---|" + "---|" * (len(NAMES) + 1),
    ]
    for r in rows:
        cells = " | ".join(f"{e:+.2f} / {c:.2f} / {q:+.2f}" for e, c, q in zip(r["err"], r["crp"], r["z"]))
        lines.append(f"| {r['seed']} | {cells} | {r['J']:.2f} |")
    lines += [
        "", "| | " + " | ".join(NAMES) + " |", "|---|" + "---|" * len(NAMES),
        "| mean error % | " + " | ".join(f"{v:+.2f}" for v in err.mean(0)) + " |",
        "| RMS error % | " + " | ".join(f"{v:.2f}" for v in np.sqrt((err**2).mean(0))) + " |",
        "| mean CR bound % | " + " | ".join(f"{v:.2f}" for v in crp.mean(0)) + " |",
        "| RMS error / mean CR | " + " | ".join(
            f"{v:.2f}" for v in np.sqrt((err**2).mean(0)) / crp.mean(0)) + " |",
        f"| within 1 CR (calibrated: {100 * ONE_SIGMA:.0f} %) | " + " | ".join(
            f"{100 * v:.0f} %" for v in np.mean(np.abs(z) <= 1, 0)) + " |",
        f"| within 2 CR (calibrated: {100 * TWO_SIGMA:.0f} %) | " + " | ".join(
            f"{100 * v:.0f} %" for v in np.mean(np.abs(z) <= 2, 0)) + " |",
        "",
        f"All five parameters at once, over the {len(rows)} seeds: within 1 CR bound "
        f"{100 * np.mean(np.all(np.abs(z) <= 1, 1)):.0f} % (a calibrated bound with the "
        f"reported correlations gives {100 * cal1:.0f} %); within 2 CR bounds "
        f"{100 * np.mean(np.all(np.abs(z) <= 2, 1)):.0f} % (calibrated: {100 * cal2:.0f} %).",
        "",
        f"Acceptance reading (seeds 0-4, all five parameters inside their bound): within 1 CR "
        f"bound {acc1}/5 seeds, within 2 CR bounds {acc2}/5 seeds.  For a calibrated "
        f"one-sigma bound the chance that one seed has all five inside is about "
        f"{100 * cal1:.0f} %, so 4 of 5 seeds inside one sigma would have probability "
        f"{100 * _at_least(4, 5, cal1):.1f} %; at two sigma it is "
        f"{100 * _at_least(4, 5, cal2):.0f} %.",
    ]
    if r50:
        lines += ["", f"## 2. Embedded dataset's conditions (R-50, gusts), {args.flights} flights",
                  "", "| channel | | " + " | ".join(NAMES) + " |", "|---|---|" + "---|" * len(NAMES)]
        for ch, (p, c) in r50.items():
            sd = 100 * p.std(0, ddof=1) / np.abs(p.mean(0))
            lines += [f"| {ch} | flight-to-flight std % | " + " | ".join(f"{v:.2f}" for v in sd) + " |",
                      f"| {ch} | mean CR bound % | " + " | ".join(f"{v:.2f}" for v in c.mean(0)) + " |",
                      f"| {ch} | std / CR | " + " | ".join(f"{v:.2f}" for v in sd / c.mean(0)) + " |"]
        lines += ["", "With the paper model structurally wrong for the R-50, the best-fit point "
                  "also moves with the flight's coherence weights, which the random-error bound "
                  "does not contain; the std/CR ratios above measure that excess (the standard "
                  "deviation of 8 flights is itself uncertain by about 25 %)."]
    return "\n".join(lines) + "\n"


def _at_least(k: int, n: int, p: float) -> float:
    from math import comb

    return sum(comb(n, j) * p**j * (1 - p) ** (n - j) for j in range(k, n + 1))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--noise", type=float, default=0.05)
    ap.add_argument("--flights", type=int, default=8, help="R-50 flights for part 2 (0: skip)")
    args = ap.parse_args()
    if args.seeds < 5:
        ap.error("--seeds must be >= 5 (the acceptance reading uses seeds 0-4)")
    t0 = time.perf_counter()
    rows = paper_plant(args.seeds, args.noise)
    r50 = r50_flights(args.flights) if args.flights > 1 else None
    text = report(args, rows, r50, time.perf_counter() - t0)
    os.makedirs(os.path.join(HERE, "results"), exist_ok=True)
    atomic_write_text(os.path.join(HERE, "results", "cr_coverage.md"), text)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
