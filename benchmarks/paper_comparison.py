"""The paper's comparison (Figs 13-14): validation R^2 of each method on ten flights.

    python benchmarks/paper_comparison.py

* Identification: the embedded default dataset's sweep records (two sweeps per channel,
  simulated R-50 hover), the same for every method.
* Validation: ten multi-step flights per channel made by the simulator from the R-50 plant
  (not the paper plant, so model-structure error is present) with the default dataset's
  turbulence, gyro noise, pilot corrections and hold loop; the recipe of the embedded
  validation records (``jaxgwo.multistep_validation``: one record per channel, exciting
  that channel's cyclic), each with its own key and its own 3-2-1-1 unit and doublet
  pulse length (listed in the output).
* Methods: ``traditional``, ``wls-gwo``, ``wls-igwo``, ``wls-igwo+polish``, ``paper`` (IGWO over
  the eq. (29) moment sums) (and ``wls``
  for context), 50 wolves x 500 iterations; R^2 per validation set with seed 0, means,
  and the paper's relative difference ``(mean R2_igwo - mean R2_x) / mean R2_x``.
* Seeds: the stochastic methods are repeated over ``--seeds`` optimiser seeds; the spread
  of ``J`` and of the mean validation R^2 per method is what a GWO-vs-IGWO verdict rests on.
* The same ten flights without turbulence and noise give a second R^2 (model error alone).

Writes benchmarks/results/paper_comparison.md and paper_comparison.png.
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time

import jax
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import jaxgwo  # noqa: E402,F401  (float64 on)
from jaxgwo import _identify as I  # noqa: E402
from jaxgwo._atomic import atomic_savefig, atomic_write_text  # noqa: E402
from jaxgwo._data import default_dataset  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from validation_sets import multistep_validation  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
CHANNELS = ("lateral", "longitudinal")
METHODS = ("wls", "traditional", "wls-gwo", "wls-igwo", "wls-igwo+polish", "paper")
STOCHASTIC = ("wls-gwo", "wls-igwo", "wls-igwo+polish", "paper")
EQUAL_BUDGET = "wls-gwo 400 it"
UNITS_S = (0.3, 0.35, 0.4, 0.45, 0.5)
PULSES_S = (0.4, 0.5, 0.6, 0.7)
PAPER = {"lateral": {"wls-gwo": 10.0, "traditional": 11.0},
         "longitudinal": {"wls-gwo": 10.0, "traditional": 12.0}}


def validation_flights(n_sets: int, first_seed: int):
    flights = []
    for i in range(n_sets):
        seed = first_seed + i
        unit, pulse = UNITS_S[i % len(UNITS_S)], PULSES_S[i % len(PULSES_S)]
        flown = {c: multistep_validation(jax.random.fold_in(jax.random.key(seed), i_c), c,
                                         unit_s=unit, pulse_s=pulse)
                 for i_c, c in enumerate(CHANNELS)}
        flights.append({"seed": seed, "unit_s": unit, "pulse_s": pulse,
                        "record": {c: flown[c][0] for c in CHANNELS},
                        "clean": {c: flown[c][1] for c in CHANNELS}})
    return flights


def rel(a: float, b: float) -> float:
    return 100.0 * (a - b) / b


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--sets", type=int, default=10)
    ap.add_argument("--first-key", type=int, default=1001, help="jax.random.key of set i is first-key + i")
    ap.add_argument("--seeds", type=int, default=10, help="optimiser seeds 0 .. seeds-1")
    ap.add_argument("--out", default=os.path.join(HERE, "results", "paper_comparison.md"))
    args = ap.parse_args()
    wall0 = time.perf_counter()
    cmd = "python " + " ".join([os.path.relpath(sys.argv[0], os.path.dirname(HERE))] + sys.argv[1:])
    png = os.path.splitext(args.out)[0] + ".png"

    ds = default_dataset()
    recs = {c: [ds.identification[c]] for c in CHANNELS}
    flights = validation_flights(args.sets, args.first_key)
    val = {c: [f["record"][c] for f in flights] for c in CHANNELS}
    val_clean = {c: [f["clean"][c] for f in flights] for c in CHANNELS}
    settings = I.IdentifySettings()

    # seed 0, every method: R^2 per validation set
    r2, r2_clean, J, evals = {}, {}, {}, {}
    for m in METHODS:
        out = I.identify_channels(recs, I.IdentifySettings(method=m, seed=0), validation=val)
        for c in CHANNELS:
            r2[m, c] = np.asarray(out[c].validation.per_record_r2)
            r2_clean[m, c] = np.asarray(I.validate(out[c].model, val_clean[c], c, settings).per_record_r2)
            J[m, c] = out[c].cost_J
            evals[m] = out[c].evaluations
        print(m, {c: round(J[m, c], 3) for c in CHANNELS}, flush=True)

    # seeds: spread of J and of the mean validation R^2
    # GWO evaluates all 50 wolves per iteration, IGWO only its 40 chasers: "wls-gwo 400 it"
    # gives GWO IGWO's budget of fitness evaluations (50 + 400 x 50 = 50 + 500 x 40)
    runs = {m: {"method": m} for m in STOCHASTIC}
    runs[EQUAL_BUDGET] = {"method": "wls-gwo", "iterations": 400}
    seedJ = {(m, c): [] for m in runs for c in CHANNELS}
    seedR2 = {(m, c): [] for m in runs for c in CHANNELS}
    for m, kw in runs.items():
        for s in range(args.seeds):
            out = I.identify_channels(recs, I.IdentifySettings(seed=s, **kw), validation=val)
            for c in CHANNELS:
                seedJ[m, c].append(out[c].cost_J)
                seedR2[m, c].append(float(np.mean(out[c].validation.per_record_r2)))
        print("seeds", m, {c: round(min(seedJ[m, c]), 3) for c in CHANNELS}, flush=True)
    wall = time.perf_counter() - wall0

    # ------------------------------------------------------------------ figure
    fig, axes = plt.subplots(2, 2, figsize=(12, 8.5))
    sets = np.arange(1, args.sets + 1)
    styles = {"traditional": ("s-", "tab:gray"), "wls-gwo": ("^-", "tab:blue"),
              "wls-igwo": ("o-", "tab:red"), "wls-igwo+polish": ("x--", "tab:green"),
              "paper": ("d:", "tab:purple")}
    for j, c in enumerate(CHANNELS):
        ax = axes[0, j]
        for m, (st, col) in styles.items():
            ax.plot(sets, r2[m, c], st, color=col, label=f"{m} (mean {np.mean(r2[m, c]):.3f})", ms=5)
        ax.set_title(f"{c}: validation R$^2$ per set (seed 0)")
        ax.set_xlabel("validation set")
        ax.set_ylabel("R$^2$ (eq. 46)")
        ax.set_xticks(sets)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
        ax = axes[1, j]
        shown = STOCHASTIC + (EQUAL_BUDGET,)
        for k, m in enumerate(shown):
            ys = np.asarray(seedJ[m, c])
            ax.plot(np.full(ys.size, k) + np.linspace(-0.15, 0.15, ys.size), ys, "o",
                    color=styles.get(m, ("", "tab:cyan"))[1], ms=5)
        ax.axhline(J["traditional", c], color="tab:gray", ls=":", label="traditional")
        ax.set_xticks(range(len(shown)))
        ax.set_xticklabels(shown, fontsize=8)
        ax.set_ylabel("CIFER cost J")
        ax.set_title(f"{c}: J over {args.seeds} optimiser seeds")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle("Simulated R-50: identification on the default sweeps, ten multi-step validation flights")
    fig.tight_layout()
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    atomic_savefig(fig, png)
    plt.close(fig)

    # ------------------------------------------------------------------ report
    L = []
    L.append("# The paper's comparison (Figs 13-14) on simulated R-50 flights\n")
    L.append(f"Command: `{cmd}`  ")
    L.append(f"Machine: `{platform.platform()}`, {os.cpu_count()} CPUs (shared)  ")
    L.append(f"JAX {jax.__version__} ({jax.default_backend()}), float64 {jax.config.jax_enable_x64}, "
             f"Python {platform.python_version()}  ")
    L.append(f"Wall time of the whole script: {wall:.0f} s  ")
    L.append(f"Figure: `{os.path.basename(png)}`\n")
    L.append("**Identification:** the embedded default dataset's sweep records (not re-simulated), "
             "`IdentifySettings()` defaults, 50 wolves x 500 iterations "
             f"(fitness evaluations per run: wls-gwo {evals['wls-gwo']}, wls-igwo {evals['wls-igwo']}: "
             "IGWO does not re-evaluate its encircling group).\n")
    L.append("**Validation flights** (`jaxgwo.multistep_validation`, one record per channel with key "
             "`fold_in(key(set key), 0 lateral / 1 longitudinal)`; R-50 hover plant with servos, "
             "`HoldLoop.r50()`, default-dataset gusts 1.0/0.4 rad/s^2 rms with T = 1.5 s, 0.002 rad/s "
             "gyro noise, pilot corrections 0.005 rms on both cyclics; 30 s at 100 Hz; on the channel's "
             "cyclic a 3-2-1-1 (0.1) at 2 s, a doublet (0.12) at 12 s and a reversed 3-2-1-1 with "
             "0.75 x the unit at 20 s):\n")
    L.append("| set | jax.random.key | 3-2-1-1 unit (s) | doublet pulse (s) |")
    L.append("|---|---|---|---|")
    for i, f in enumerate(flights, 1):
        L.append(f"| {i} | {f['seed']} | {f['unit_s']:g} | {f['pulse_s']:g} |")
    L.append("")

    for c in CHANNELS:
        L.append(f"## {c}: validation R^2 per set (optimiser seed 0)\n")
        L.append("| method | J | " + " | ".join(f"set {i}" for i in sets) + " | mean | mean, turbulence-free |")
        L.append("|---|---|" + "---|" * args.sets + "---|---|")
        for m in METHODS:
            L.append(f"| {m} | {J[m, c]:.3f} | " + " | ".join(f"{v:.4f}" for v in r2[m, c])
                     + f" | **{np.mean(r2[m, c]):.4f}** | {np.mean(r2_clean[m, c]):.4f} |")
        L.append("")
        L.append("Relative difference of mean R^2, `(mean R2_igwo - mean R2_x) / mean R2_x` "
                 "(paper: " + ", ".join(f"{v:g} % vs {k}" for k, v in PAPER[c].items()) + "):\n")
        for x in ("traditional", "wls-gwo", "wls"):
            L.append(f"- wls-igwo vs {x}: {rel(np.mean(r2['wls-igwo', c]), np.mean(r2[x, c])):+.3f} %"
                     f" (turbulence-free flights: "
                     f"{rel(np.mean(r2_clean['wls-igwo', c]), np.mean(r2_clean[x, c])):+.3f} %)")
        L.append(f"- wls-igwo+polish vs traditional: "
                 f"{rel(np.mean(r2['wls-igwo+polish', c]), np.mean(r2['traditional', c])):+.4f} %")
        L.append("")

    L.append(f"## Over {args.seeds} optimiser seeds (0 .. {args.seeds - 1})\n")
    L.append(f"`{EQUAL_BUDGET}`: wls-gwo with 400 iterations, i.e. the same number of fitness "
             f"evaluations as wls-igwo's 500 ({evals['wls-igwo']}).\n")
    L.append("| channel | method | J median | J mean | J std | J min | J max | mean R^2 (10 sets): median | min | max |")
    L.append("|---|---|---|---|---|---|---|---|---|---|")
    for c in CHANNELS:
        L.append(f"| {c} | traditional (deterministic) | {J['traditional', c]:.3f} | | | | | "
                 f"{np.mean(r2['traditional', c]):.4f} | | |")
        for m in STOCHASTIC + (EQUAL_BUDGET,):
            js, rs = np.asarray(seedJ[m, c]), np.asarray(seedR2[m, c])
            L.append(f"| {c} | {m} | {np.median(js):.3f} | {js.mean():.3f} | {js.std(ddof=1):.3f} | "
                     f"{js.min():.3f} | {js.max():.3f} | {np.median(rs):.4f} | {rs.min():.4f} | {rs.max():.4f} |")
    L.append("")
    for c in CHANNELS:
        g, ig = np.asarray(seedJ["wls-gwo", c]), np.asarray(seedJ["wls-igwo", c])
        wins = float(np.mean(ig[:, None] < g[None, :]))
        gr, ir = np.asarray(seedR2["wls-gwo", c]), np.asarray(seedR2["wls-igwo", c])
        g4 = np.asarray(seedJ[EQUAL_BUDGET, c])
        L.append(f"- {c}: P(J_igwo < J_gwo) over all seed pairs = {wins:.2f} "
                 f"(against GWO at IGWO's evaluation budget: {float(np.mean(ig[:, None] < g4[None, :])):.2f}); "
                 f"median J igwo/gwo = "
                 f"{np.median(ig) / np.median(g):.5f}; J above traditional's (a local minimum reached "
                 f"by LM from WLS): gwo {rel(np.median(g), J['traditional', c]):+.3f} %, "
                 f"igwo {rel(np.median(ig), J['traditional', c]):+.3f} % (medians); "
                 f"relative mean-R^2 difference igwo vs gwo over seeds: "
                 f"{rel(np.median(ir), np.median(gr)):+.3f} % (medians), "
                 f"{rel(ir.mean(), gr.mean()):+.3f} % (means).")
    L.append("")

    L.append("## Verdict\n")
    for c in CHANNELS:
        d_gwo = rel(np.mean(np.asarray(seedR2["wls-igwo", c])), np.mean(np.asarray(seedR2["wls-gwo", c])))
        d_trad = rel(np.mean(r2["wls-igwo", c]), np.mean(r2["traditional", c]))
        j_ratio = float(np.median(seedJ["wls-igwo", c]) / np.median(seedJ["wls-gwo", c]))
        L.append(f"- {c}: the paper reports wls-igwo R^2 {PAPER[c]['wls-gwo']:g} % above wls-gwo and "
                 f"{PAPER[c]['traditional']:g} % above traditional. Here: {d_gwo:+.2f} % vs wls-gwo "
                 f"(mean over seeds) and {d_trad:+.2f} % vs traditional (seed 0). "
                 + ("IGWO does not beat GWO by anything like the paper's margin here. "
                    if d_gwo < 1.0 else "IGWO beats GWO on R^2 here. ")
                 + f"On the cost it minimises, IGWO is {'worse' if j_ratio > 1 else 'better'} than GWO: "
                 f"median J igwo/gwo = {j_ratio:.4f} over {args.seeds} seeds each.")
    L.append("")
    worst = {c: rel(max(max(seedJ[m, c]) for m in STOCHASTIC), J["traditional", c]) for c in CHANNELS}
    L.append("All the methods minimise the same cost J from the same WLS start, and all end at or "
             "near the same minimum (the traditional LM fit and the polished IGWO reach it exactly; the "
             "100-start reference in identify_acceptance.md finds no better one); the worst of all "
             "seeds is " + ", ".join(f"{worst[c]:+.2f} % ({c})" for c in CHANNELS) + " above it. Their "
             "models, and hence their validation R^2, are nearly identical: the R^2 differences between "
             "methods are far smaller than the differences between validation flights, which the "
             "turbulence dominates, and a higher J does not even mean a lower R^2 here.\n")
    atomic_write_text(args.out, "\n".join(L))
    print("\n".join(L))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
