"""The structure families of ``r50_structure_families.py`` on noisy blind-study cases.

For each case of a blind-study workdir (``benchmarks/blind_diagnosis.py --simulate-only
--workdir W``; named, or without names every R-50 case of the chosen classes), the nominal
paper model is identified on TRAIN as the diagnosis does, and then the paper model x a
structure (``mode``: the structure step's wide-box mode; ``leadlag``: a first-order
lead-lag; ``leadlag_mode``: that lead-lag times a mode held to 0.5-3 Hz, the family that
fits the published R-50 to 0.78 deg noise-free) x each linear effect is refitted on the
CIFER cost ``J`` of the TRAIN response (bounded ``scipy.optimize.least_squares`` from a
grid of starts, JAX's Jacobian).  Prints ``J`` per pair, the fitted effect parameter and
the p-value of the ``J`` F-test the diagnosis applies to an effect beside its base
(:func:`jaxgwo._diagnose_which.j_f_test_p` on the case's independent frequencies, the
family alone as the base), beside the key's truth; ``--out`` writes the table as markdown.
A development probe: frequency domain only, no held-out scoring.

Usage: ``python benchmarks/r50_structure_noisy.py WORKDIR [case_019 case_063 ...]
[--classes none,rotor_flapping] [--effects none,rotor_flapping,time_delay]
[--families mode,leadlag_mode] [--out FILE.md]``
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time

import jax
import jax.numpy as jnp
import numpy as np
from scipy.optimize import least_squares

import jaxgwo  # noqa: F401  (float64)
from jaxgwo._data import load_record
from jaxgwo._diagnose import _DELAY_GRID_S
from jaxgwo._diagnose_which import (_LEAD_LAG_BOX, _LEAD_LAG_STARTS, _SLOTS, _Z_HI, _Z_HI_STRUCTURE, _Z_LO,
                                    _flipped_objective, delay_aware_start, j_f_test_p)  # fmt: skip
from jaxgwo._effects import rotor_flapping_response, sensor_lag_response, structural_mode_response, time_delay_response
from jaxgwo._identify import IdentifySettings, _prepare, identify_channels, independent_points

# the blind study's identification settings (benchmarks/blind_diagnosis.py)
IDS = IdentifySettings(method="wls-igwo+polish", wolves=12, iterations=30, n_frequencies=80, polish_steps=40,
                       w_max=120.0)  # fmt: skip
# name -> (lower, upper, starts) of its coordinates: the diagnosis's z boxes (jaxgwo._diagnose_which) as they
# were when this probe was run (the structure step's box now reaches down to 1 Hz, _Z_LO_STRUCTURE)
STRUCT = {
    "mode": (_Z_LO[3:6], _Z_HI_STRUCTURE[3:6],
             [np.log([f, zp, zz]) for f in (3.5, 6, 10) for zp, zz in ((0.5, 1.5), (0.3, 3))]),
    "leadlag": (np.log([0.08, 0.08]), np.log([80.0, 80.0]), [np.log([a, b]) for a in (0.5, 1.1, 2) for b in (2, 4, 8)]),
}  # fmt: skip
# the lead-lag (zero, pole in Hz) times a low mode (Hz, pole damping, zero damping) in r50_structure_families.py's
# box: the box and starts the diagnosis's LeadLagAirframe refit took from this probe
STRUCT["leadlag_mode"] = (*_LEAD_LAG_BOX, list(_LEAD_LAG_STARTS))
EFF_STARTS = {
    "none": [np.zeros(0)],
    "time_delay": [np.array([d]) for d in (0.005, 0.02, 0.05)],
    "sensor_lag": [np.log([c]) for c in (8, 20, 50)],
    "rotor_flapping": [np.array([t]) for t in (0.005, 0.02, 0.05)],
    "structural_mode": [np.log([f, 0.05, 0.15]) for f in (5, 8, 11, 14, 18, 24)],
}
EFF = {e: (_Z_LO[list(_SLOTS.get(e, ()))], _Z_HI[list(_SLOTS.get(e, ()))], st) for e, st in EFF_STARTS.items()}


def make(obj, sname, ename):
    """Jitted residuals of ``J`` and their Jacobian for paper x structure ``sname`` x effect ``ename``;
    ``x = (log K, log tau, log M, log omega_s, log zeta_s, structure, effect)``."""
    w = obj.w
    ns = STRUCT[sname][0].size

    def resp(x):
        p, s, e = jnp.exp(x[:5]), x[5 : 5 + ns], x[5 + ns :]
        h = rotor_flapping_response(p, w, e[0] if ename == "rotor_flapping" else 0.0)
        if sname == "mode":
            h = h * structural_mode_response(w, jnp.exp(s[0]), jnp.exp(s[1]), jnp.exp(s[2]))
        else:
            jw = 1j * w
            h = h * (jw / (2 * jnp.pi * jnp.exp(s[0])) + 1) / (jw / (2 * jnp.pi * jnp.exp(s[1])) + 1)
            if sname == "leadlag_mode":
                h = h * structural_mode_response(w, jnp.exp(s[2]), jnp.exp(s[3]), jnp.exp(s[4]))
        if ename == "time_delay":
            h = h * time_delay_response(w, e[0])
        if ename == "sensor_lag":
            h = h * sensor_lag_response(w, jnp.exp(e[0]))
        if ename == "structural_mode":
            h = h * structural_mode_response(w, jnp.exp(e[0]), jnp.exp(e[1]), jnp.exp(e[2]))
        return h

    def res(x):
        return obj.residuals_from_response(resp(x))

    return jax.jit(res), jax.jit(jax.jacfwd(res))


def fit_j(obj, x_nom, sname, ename, effect_starts=None):
    """Best ``(J, x)`` over the grid of structure and effect starts (paper parameters within x8 of the nominal);
    ``None`` where every start raised or ended at a non-finite ``J``.  ``effect_starts`` replaces the
    effect's own grid of starts (a delay-aware start's delay)."""
    r, jf = make(obj, sname, ename)
    slo, shi, sst = STRUCT[sname]
    elo, ehi, est = EFF[ename]
    est = est if effect_starts is None else effect_starts
    lo, hi = np.r_[x_nom - math.log(8), slo, elo], np.r_[x_nom + math.log(8), shi, ehi]
    best = None
    for s0 in sst:
        for e0 in est:
            x0 = np.clip(np.r_[x_nom, s0, e0], lo + 1e-9, hi - 1e-9)
            try:
                sol = least_squares(lambda v: np.asarray(r(jnp.asarray(v))), x0,
                                    jac=lambda v: np.asarray(jf(jnp.asarray(v))), bounds=(lo, hi), method="trf",
                                    max_nfev=100)  # fmt: skip
            except (ValueError, np.linalg.LinAlgError):
                continue
            j = float(np.sum(sol.fun**2))
            if np.isfinite(j) and (best is None or j < best[0]):
                best = (j, sol.x)
    return best


_PARAM_TEXT = {"sensor_lag": lambda v: f"{math.exp(v[0]):.1f} Hz", "time_delay": lambda v: f"{1000 * v[0]:.1f} ms",
               "rotor_flapping": lambda v: f"{1000 * v[0]:.1f} ms", "structural_mode": lambda v: f"{math.exp(v[0]):.1f} Hz"}
_TRUTH_TEXT = {"sensor_lag": lambda p: f"{p['cutoff_hz']:.1f} Hz", "time_delay": lambda p: f"{1000 * p['delay_s']:.1f} ms",
               "rotor_flapping": lambda p: f"{1000 * p['tau_f']:.1f} ms",
               "structural_mode": lambda p: f"{p['freq_hz']:.1f} Hz"}  # fmt: skip


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("workdir")
    ap.add_argument("cases", nargs="*", help="case names (default: every R-50 case of --classes)")
    ap.add_argument("--classes", default="none,rotor_flapping", help="without case names: the R-50 cases of these")
    ap.add_argument("--effects", default=",".join(EFF), help=f"comma-separated, of {', '.join(EFF)}")
    ap.add_argument("--families", default=",".join(STRUCT), help=f"comma-separated, of {', '.join(STRUCT)}")
    ap.add_argument("--out", default=None, help="write the table here (markdown)")
    args = ap.parse_args()
    effects = [e for e in args.effects.split(",") if e]
    families = [f for f in args.families.split(",") if f]
    bad = [e for e in effects if e not in EFF] + [f for f in families if f not in STRUCT]
    if bad or "none" not in effects:
        ap.error(f"unknown effect(s) or family(ies) {bad}, or 'none' missing from --effects; effects: "
                 f"{', '.join(EFF)}; families: {', '.join(STRUCT)}")  # fmt: skip
    with open(os.path.join(args.workdir, "key.json")) as f:
        key = json.load(f)
    classes = set(args.classes.split(","))
    cases = args.cases or [c for c, k in key.items() if k["plant"] == "r50" and k["effect"] in classes]
    missing = [c for c in cases if c not in key]
    if missing:
        ap.error(f"no case(s) {missing} in {args.workdir}/key.json")
    rows = []
    t0 = time.perf_counter()
    for c in cases:
        tr = [load_record(os.path.join(args.workdir, c, "train.csv"))]
        nominal = identify_channels({"lateral": tr}, IDS)["lateral"]
        prep = _prepare(tr, "lateral", IDS)
        m_eff = max(independent_points(nominal.response), 1.0)  # as diagnose counts them
        x_nom = np.log(np.asarray(nominal.model.to_array(), float) * np.array([prep.sign, 1, 1, 1, 1]))
        ds = (delay_aware_start(prep.response, prep.objective, prep.sign, _DELAY_GRID_S, IDS.sk_iterations)
              if "time_delay" in effects else None)  # fmt: skip
        truth = key[c]
        t_text = _TRUTH_TEXT[truth["effect"]](truth["params"]) if truth["effect"] in _TRUTH_TEXT else ""
        for sname in families:
            ns = STRUCT[sname][0].size
            fits = {e: fit_j(prep.objective, x_nom, sname, e) for e in effects}
            if "time_delay" in fits and ds is not None:
                # a long delay throws the delay-free nominal: start the paper parameters where the diagnosis
                # does as well (its delay-aware start), and keep the better J (J against -H of a model is
                # that of its negative against H, so both objectives' J compare)
                obj = prep.objective if ds.sign == prep.sign else _flipped_objective(prep.objective)
                alt = fit_j(obj, ds.x, sname, "time_delay", effect_starts=[np.array([ds.delay_s])])
                if alt is not None and (fits["time_delay"] is None or alt[0] < fits["time_delay"][0]):
                    fits["time_delay"] = alt
            cells = []
            for e in effects:
                if fits[e] is None:  # every start raised or ended at a non-finite J: say so, keep the row
                    cells.append("no finite fit")
                    continue
                j, x = fits[e]
                if e == "none":
                    cells.append(f"{j:.2f}")
                    continue
                p = "" if fits["none"] is None else f"; p {j_f_test_p(fits['none'][0], j, len(EFF[e][0]), m_eff):.1g}"
                cells.append(f"{j:.2f} ({_PARAM_TEXT[e](x[5 + ns :])}{p})")
            rows.append((c, truth["effect"], t_text, float(nominal.cost_J), sname, cells))
            print(c, truth["effect"], t_text, sname, " ".join(f"{e}: {x}" for e, x in zip(effects, cells)), flush=True)
    if args.out:
        lines = ["# R-50 structure families on noisy blind-study cases", "",
                 f"`python benchmarks/r50_structure_noisy.py {' '.join(sys.argv[1:])}` "
                 f"({(time.perf_counter() - t0) / 60:.1f} min).", "",
                 "`J` on TRAIN (the blind study's 80 analysis frequencies) of the paper model x each structure family "
                 "alone (`none`) and x each effect, its fitted parameter and the p of the `J` F-test the diagnosis "
                 "applies beside a base (the family alone as the base, the case's independent frequencies) in "
                 "brackets. Frequency domain only: no held-out scoring.", "",
                 "| case | truth | true value | nominal J | family | " + " | ".join(effects) + " |",
                 "|---|---|---|---|---|" + "---|" * len(effects)]  # fmt: skip
        lines += [f"| {c} | {t} | {tv} | {jn:.2f} | {f} | " + " | ".join(cells) + " |" for c, t, tv, jn, f, cells in rows]
        from jaxgwo._atomic import atomic_write_text

        atomic_write_text(args.out, "\n".join(lines) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
