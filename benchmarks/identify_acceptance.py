"""Acceptance of ``wls-igwo`` on the embedded default dataset (issue 4), both channels.

    python benchmarks/identify_acceptance.py

1. ``J`` of ``wls-igwo`` and ``wls-igwo+polish`` (seed 0, 50 wolves x 500 iterations),
   with ``wls`` and ``traditional`` for context, beside a multi-start reference: 100 runs
   of ``scipy.optimize.least_squares`` (Levenberg-Marquardt, JAX Jacobian) on the same
   sign-normalised CIFER objective in the same log-parameters, from the WLS start and 99
   starts drawn log-uniformly within a factor 5 of it (``zeta_s`` kept in [0.05, 3]).
   Acceptance: ``J_igwo <= 1.05 J_ref``.
2. Validation on the embedded multi-step records (one per channel): ``R^2`` (eq. 46) and
   TIC.  Acceptance: ``R^2 >= 0.85`` and ``J <= 150``.  To explain the ``R^2`` found, the
   same validation flights are simulated again with turbulence and gyro noise off (same
   inputs, same hold loop): ``R^2`` against that output, and the share of the measured
   output variance that the turbulence alone puts there.  Then R^2 over further flights
   (``--flights`` keys) at several turbulence levels: what level the 0.85 target needs.
3. Optimiser time of a 50 x 500 ``wls-igwo`` run on one channel (200 frequency points),
   after compilation, median of repeats: the ``runtime_s`` the pipeline reports (batched
   run plus ``block_until_ready``) and a direct ``run_batch`` call.

Writes benchmarks/results/identify_acceptance.md.
"""

from __future__ import annotations

import argparse
import math
import os
import platform
import statistics
import sys
import time

import jax
import jax.numpy as jnp
import numpy as np
from scipy.optimize import least_squares

import jaxgwo
from jaxgwo import _gwo as G
from jaxgwo import _identify as I
from jaxgwo._atomic import atomic_write_text
from jaxgwo._data import default_dataset
from jaxgwo._models import canonicalize_paper_params
from jaxgwo._plants import R50Plant
from jaxgwo._spectral import FrequencyResponse

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from validation_sets import default_validation_key, multistep_validation  # noqa: E402
from jaxgwo._simulate import Disturbance  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
CHANNELS = ("lateral", "longitudinal")
NAMES = ("K", "tau", "M", "omega_s", "zeta_s")


def _fmt_params(p) -> str:
    return ", ".join(f"{n}={v:.4g}" for n, v in zip(NAMES, np.asarray(p)))


def multistart_reference(prep, n_starts: int, factor: float, rng: np.random.Generator):
    """Best ``J`` of ``n_starts`` Levenberg-Marquardt fits of the CIFER residuals."""
    obj = prep.objective
    x0 = np.asarray(obj.parameter_map.to_vector(prep.start))
    half = math.log(factor)
    starts = x0[None] + rng.uniform(-half, half, size=(n_starts - 1, x0.size))
    starts[:, 4] = np.clip(starts[:, 4], math.log(0.05), math.log(3.0))
    starts = np.vstack([x0[None], starts])
    res_fn = lambda x: I._residuals(obj, x)  # noqa: E731  (the pipeline's jitted residuals
    jac_fn = lambda x: I._jacobian(obj, x)  # noqa: E731   and forward-mode Jacobian)
    costs, xs, nfev = [], [], []
    t0 = time.perf_counter()
    for s in starts:
        try:
            sol = least_squares(lambda x: np.asarray(res_fn(jnp.asarray(x))), s,
                                jac=lambda x: np.asarray(jac_fn(jnp.asarray(x))),
                                method="lm", xtol=1e-12, ftol=1e-12, max_nfev=2000)
            j = float(obj(jnp.asarray(sol.x)))
            x, nf = sol.x, sol.nfev
        except (ValueError, np.linalg.LinAlgError):  # non-finite residuals from a wild start
            j, x, nf = math.inf, s, 0
        costs.append(j if math.isfinite(j) else math.inf)
        xs.append(x)
        nfev.append(nf)
    elapsed = time.perf_counter() - t0
    costs = np.asarray(costs)
    ib = int(np.argmin(costs))
    best_x = np.asarray(xs[ib])
    lo, hi = I._box(jnp.asarray(x0), I.IdentifySettings().search_factor)
    in_box = bool(np.all((best_x >= np.asarray(lo)) & (best_x <= np.asarray(hi))))
    p_best = canonicalize_paper_params(obj.parameter_map.params_from_vector(jnp.asarray(best_x)))
    x_canon = np.asarray(obj.parameter_map.vector_from_params(p_best))
    in_box_canon = bool(np.all((x_canon >= np.asarray(lo)) & (x_canon <= np.asarray(hi))))
    fin = costs[np.isfinite(costs)]
    return {
        "best": float(costs[ib]),
        "median": float(np.median(fin)),
        "within1": int(np.sum(costs <= 1.01 * costs[ib])),
        "finite": int(fin.size),
        "from_wls": float(costs[0]),
        "params": np.asarray(p_best) * np.asarray([prep.sign, 1, 1, 1, 1]),
        "in_box": in_box or in_box_canon,
        "time_s": elapsed,
        "nfev_median": float(np.median(nfev)),
    }


def time_optimiser(record, repeats: int):
    """Median optimiser seconds of one-channel 50 x 500 ``wls-igwo`` runs after compilation."""
    settings = I.IdentifySettings(method="wls-igwo", seed=0)
    t0 = time.perf_counter()
    first = I.identify_channels({"lateral": [record]}, settings)["lateral"]
    compile_and_run = first.runtime_s
    first_wall = time.perf_counter() - t0
    pipeline = []
    for s in range(1, repeats + 1):
        r = I.identify_channels({"lateral": [record]}, I.IdentifySettings(method="wls-igwo", seed=s))
        pipeline.append(r["lateral"].runtime_s)

    prep = I._prepare([record], "lateral", settings)
    cfg = settings.optimiser()
    x0 = prep.objective.parameter_map.to_vector(prep.start)
    lo, hi = I._box(x0, settings.search_factor)
    init = I._seeded_wolves(jax.random.key(0), x0, lo, hi, 25, settings.seed_spread)[None]
    objs = G.stack_objectives([prep.objective])

    def once(seed):
        res = G.run_batch(cfg, objs, lo[None], hi[None], jax.random.split(jax.random.key(seed), 1),
                          init_wolves=init)
        return jax.block_until_ready(res.best_fitness)

    once(0)
    direct = []
    for s in range(1, repeats + 1):
        t0 = time.perf_counter()
        once(s)
        direct.append(time.perf_counter() - t0)
    return {
        "first_runtime_s": compile_and_run,
        "first_wall_s": first_wall,
        "pipeline": pipeline,
        "direct": direct,
        "n_freq": int(prep.objective.w.shape[0]),
        "n_pass": int(prep.objective.n),
        "evaluations": cfg.total_evaluations,
    }


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--starts", type=int, default=100)
    ap.add_argument("--factor", type=float, default=5.0)
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--flights", type=int, default=5, help="validation flights per turbulence level")
    ap.add_argument("--out", default=os.path.join(HERE, "results", "identify_acceptance.md"))
    args = ap.parse_args()
    wall0 = time.perf_counter()
    cmd = "python " + " ".join([os.path.relpath(sys.argv[0], os.path.dirname(HERE))] + sys.argv[1:])

    ds = default_dataset()
    recs = {c: [ds.identification[c]] for c in CHANNELS}
    val = {c: [ds.validation[c]] for c in CHANNELS}

    # the same validation flights, regenerated, and without turbulence / noise
    flown = {c: multistep_validation(default_validation_key(c), c) for c in CHANNELS}
    val_regen = {c: flown[c][0] for c in CHANNELS}
    val_clean = {c: flown[c][1] for c in CHANNELS}
    regen_err = max(float(np.max(np.abs(np.asarray(val_regen[c][n]) - np.asarray(ds.validation[c][n]))))
                    for c in CHANNELS for n in ("delta_lat", "delta_lon", "p", "q"))

    methods = ("wls", "traditional", "wls-igwo", "wls-igwo+polish")
    results = {}
    for m in methods:
        results[m] = I.identify_channels(recs, I.IdentifySettings(method=m, seed=0), validation=val)
        print(m, {c: round(results[m][c].cost_J, 3) for c in CHANNELS}, flush=True)

    settings = I.IdentifySettings()
    refs, preps = {}, {}
    for i, c in enumerate(CHANNELS):
        preps[c] = I._prepare(recs[c], c, settings)
        refs[c] = multistart_reference(preps[c], args.starts, args.factor, np.random.default_rng(2024 + i))
        print("reference", c, refs[c]["best"], flush=True)

    # the structural floor: the paper model fitted to the R-50's exact on-axis response
    w = jnp.geomspace(settings.w_min, settings.w_max, settings.n_frequencies)
    H = R50Plant.default().frequency_response(w)
    analytic = {}
    for i, c in enumerate(CHANNELS):
        resp = FrequencyResponse.from_complex(w, H[:, i, i])
        analytic[c] = I.identify_responses({c: resp}, I.IdentifySettings(method="traditional"))[c]

    variance = {}
    for i, c in enumerate(CHANNELS):
        y_name = ("p", "q")[i]
        y = np.asarray(val_regen[c][y_name]); y0 = np.asarray(val_clean[c][y_name])
        variance[c] = float(np.var(y - y0) / np.var(y))
    clean_r2 = {m: {c: I.validate(results[m][c].model, [val_clean[c]], c, settings).r2 for c in CHANNELS}
                for m in methods}

    # R^2 of the default model on further flights at several turbulence levels
    levels = (1.0, 0.5, 0.25, 0.0)
    by_level = {}
    for lev in levels:
        dist = Disturbance.default_dataset(gust_scale=lev)
        for c in CHANNELS:
            recs_l = [multistep_validation(jax.random.key(3000 + i), c, disturbance=dist)[0]
                      for i in range(args.flights)]
            v = I.validate(results["wls-igwo+polish"][c].model, recs_l, c, settings)
            by_level[lev, c] = np.asarray(v.per_record_r2)
        print("turbulence", lev, {c: round(float(np.mean(by_level[lev, c])), 3) for c in CHANNELS}, flush=True)

    timing = time_optimiser(ds.identification["lateral"], args.repeats)
    wall = time.perf_counter() - wall0

    L = []
    L.append("# Identification acceptance on the embedded default dataset (issue 4)\n")
    L.append(f"Command: `{cmd}`  ")
    L.append(f"Machine: `{platform.platform()}`, {platform.processor() or platform.machine()}, "
             f"{os.cpu_count()} CPUs (shared with other work; load average at the end "
             f"{', '.join(f'{x:.2f}' for x in os.getloadavg())})  ")
    L.append(f"JAX {jax.__version__} ({jax.default_backend()}), jaxgwo {jaxgwo.__version__ if hasattr(jaxgwo, '__version__') else '?'}, "
             f"float64 {jax.config.jax_enable_x64}, Python {platform.python_version()}  ")
    L.append(f"Wall time of the whole script: {wall:.0f} s\n")
    L.append("Data: the embedded default dataset (`jaxgwo._data.default_dataset()`, simulated R-50 "
             "hover, two sweeps per channel; validation on its multi-step record). Settings: "
             f"`IdentifySettings()` defaults ({settings.n_frequencies} log-spaced points "
             f"{settings.w_min:g}-{settings.w_max:g} rad/s, coherence >= {settings.coherence_threshold}, "
             f"IGWO box factor {settings.search_factor:g} around WLS), seed 0, 50 wolves x 500 iterations.\n")

    L.append("## 1. J against a 100-start least-squares reference\n")
    L.append(f"Reference: `scipy.optimize.least_squares(method='lm')` on `objective.residuals` "
             f"(J = sum r^2) with JAX's Jacobian, from the WLS start plus {args.starts - 1} starts "
             f"log-uniform within a factor {args.factor:g} of it (numpy `default_rng(2024)` / `(2025)`).\n")
    L.append("| channel | J wls | J traditional | J wls-igwo | J wls-igwo+polish | ref best J | ref median J "
             "| starts within 1 % of best | igwo / ref | polish / ref | within 5 %? |")
    L.append("|---|---|---|---|---|---|---|---|---|---|---|")
    for c in CHANNELS:
        r = refs[c]
        ji, jp = results["wls-igwo"][c].cost_J, results["wls-igwo+polish"][c].cost_J
        L.append(f"| {c} | {results['wls'][c].cost_J:.3f} | {results['traditional'][c].cost_J:.3f} | "
                 f"{ji:.3f} | {jp:.3f} | {r['best']:.3f} | {r['median']:.3f} | "
                 f"{r['within1']}/{args.starts} ({r['finite']} finite) | {ji / r['best']:.5f} | "
                 f"{jp / r['best']:.5f} | {'yes' if ji <= 1.05 * r['best'] else 'NO'} |")
    L.append("")
    for c in CHANNELS:
        r = refs[c]
        L.append(f"- {c}: reference best {_fmt_params(r['params'])}; "
                 f"wls-igwo {_fmt_params(results['wls-igwo'][c].model.to_array())}; "
                 f"best reference point {'inside' if r['in_box'] else 'OUTSIDE'} the IGWO search box; "
                 f"LM from the WLS start alone: J = {r['from_wls']:.3f}; "
                 f"{args.starts} LM fits took {r['time_s']:.1f} s (median {r['nfev_median']:.0f} residual evaluations).")
    for c in CHANNELS:
        a = analytic[c]
        L.append(f"- {c}, for scale: the paper model fitted (LM) to the R-50's exact on-axis response "
                 f"(13 states + servo, coherence 1, same {settings.n_frequencies} points) has J = "
                 f"{a.cost_J:.2f} with {_fmt_params(a.model.to_array())}. The sweep fit's parameters "
                 "lie within a few % of these (its J is lower mainly because its coherence weights "
                 "are below 1): the residual J is the model's structure error, not the optimiser.")
    L.append("")

    L.append("## 2. Validation on the embedded multi-step records\n")
    L.append("| channel | method | J | R^2 | TIC | R^2 >= 0.85? | J <= 150? | R^2 vs turbulence-free flight |")
    L.append("|---|---|---|---|---|---|---|---|")
    for c in CHANNELS:
        for m in methods:
            r = results[m][c]
            L.append(f"| {c} | {m} | {r.cost_J:.3f} | {r.validation.r2:.4f} | {r.validation.tic:.4f} | "
                     f"{'yes' if r.validation.r2 >= 0.85 else 'NO'} | {'yes' if r.cost_J <= 150 else 'NO'} | "
                     f"{clean_r2[m][c]:.4f} |")
    L.append("")
    L.append(f"The validation flights regenerated by `jaxgwo.multistep_validation` match the embedded "
             f"records to {regen_err:.1e} (CSV rounding). Flown again with turbulence and gyro noise off "
             "(same inputs, same pilot corrections, same hold loop), the turbulence alone accounts for "
             + ", ".join(f"{100 * variance[c]:.0f} % ({c})" for c in CHANNELS)
             + " of the measured rate variance var(y - y_turbulence_free)/var(y). No input-driven model, "
             "not even the true R-50 plant, can predict that part, so on this record R^2 is capped near "
             + ", ".join(f"{1 - variance[c]:.2f} ({c})" for c in CHANNELS)
             + ", below the 0.85 threshold. The last column is the R^2 against the turbulence-free "
             "flight: what remains there is the paper model's structure error (plus the hold loop's "
             "slow attitude/velocity motion, which the rate model does not contain).\n")
    L.append(f"R^2 of the `wls-igwo+polish` model on {args.flights} further validation flights per "
             "level (`jaxgwo.multistep_validation`, keys 3000-, the same inputs), with the default "
             "dataset's gust moment scaled (gyro noise kept):\n")
    L.append("| gust scale | " + " | ".join(f"{c} mean R^2 | {c} min | {c} max" for c in CHANNELS) + " |")
    L.append("|---|" + "---|---|---|" * len(CHANNELS))
    for lev in levels:
        cells = []
        for c in CHANNELS:
            a = by_level[lev, c]
            cells.append(f"{a.mean():.3f} | {a.min():.3f} | {a.max():.3f}")
        L.append(f"| {lev:g} | " + " | ".join(cells) + " |")
    L.append("")

    p, d = timing["pipeline"], timing["direct"]
    L.append("## 3. Optimiser time, one channel, 50 x 500 wls-igwo\n")
    L.append(f"Lateral channel of the default dataset: {timing['n_freq']} frequency points "
             f"({timing['n_pass']} pass the coherence mask), float64, {timing['evaluations']} fitness "
             f"evaluations per run (IGWO's encircling group is not re-evaluated).\n")
    L.append("| what | median (s) | min (s) | max (s) | repeats |")
    L.append("|---|---|---|---|---|")
    L.append(f"| first call incl. compilation (`runtime_s`) | {timing['first_runtime_s']:.3f} | | | 1 |")
    L.append(f"| pipeline `runtime_s` after compilation (new seed each call) | {statistics.median(p):.4f} | "
             f"{min(p):.4f} | {max(p):.4f} | {len(p)} |")
    L.append(f"| direct `run_batch` + `block_until_ready` | {statistics.median(d):.4f} | {min(d):.4f} | "
             f"{max(d):.4f} | {len(d)} |")
    L.append("")
    ok = statistics.median(p) < 0.5
    L.append(f"Acceptance (well under 1 s after compilation): {'met' if ok else 'NOT met'} "
             f"(median {statistics.median(p):.3f} s on this shared 2-core CPU).\n")

    L.append("## Verdict\n")
    for c in CHANNELS:
        r = results["wls-igwo"][c]
        L.append(f"- {c}: J {r.cost_J:.2f} vs reference {refs[c]['best']:.2f} "
                 f"({100 * (r.cost_J / refs[c]['best'] - 1):+.2f} %, {'within' if r.cost_J <= 1.05 * refs[c]['best'] else 'NOT within'} 5 %); "
                 f"J <= 150 {'met' if r.cost_J <= 150 else 'NOT met'}; "
                 f"validation R^2 {r.validation.r2:.3f}: R^2 >= 0.85 {'met' if r.validation.r2 >= 0.85 else 'NOT met'} "
                 f"(mean over {args.flights} further flights at full / half turbulence: "
                 f"{by_level[1.0, c].mean():.3f} / {by_level[0.5, c].mean():.3f}; calm: {by_level[0.0, c].mean():.3f}).")
    L.append("")
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    atomic_write_text(args.out, "\n".join(L))
    print("\n".join(L))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
