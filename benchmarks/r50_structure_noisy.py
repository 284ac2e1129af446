"""The structure families of ``r50_structure_families.py`` on noisy blind-study cases.

For each named case of a blind-study workdir (``benchmarks/blind_diagnosis.py
--simulate-only --workdir W``), the nominal paper model is identified on TRAIN as the
diagnosis does, and then the paper model x a structure (``mode``: the structure step's
wide-box mode; ``leadlag``: a first-order lead-lag) x each linear effect is refitted on
the CIFER cost ``J`` of the TRAIN response (bounded ``scipy.optimize.least_squares`` from a
grid of starts, JAX's Jacobian).  Prints ``J`` per pair and the fitted effect parameter,
beside the key's truth.  A development probe: frequency domain only, no held-out scoring.

Usage: ``python benchmarks/r50_structure_noisy.py WORKDIR case_019 case_063 ...``
"""

from __future__ import annotations

import json
import math
import os
import sys

import jax
import jax.numpy as jnp
import numpy as np
from scipy.optimize import least_squares

import jaxgwo  # noqa: F401  (float64)
from jaxgwo._data import load_record
from jaxgwo._diagnose_which import _SLOTS, _Z_HI, _Z_HI_STRUCTURE, _Z_LO
from jaxgwo._effects import rotor_flapping_response, sensor_lag_response, structural_mode_response, time_delay_response
from jaxgwo._identify import IdentifySettings, _prepare, identify_channels

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


def fit_j(obj, x_nom, sname, ename):
    """Best ``(J, x)`` over the grid of structure and effect starts (paper parameters within x8 of the nominal)."""
    r, jf = make(obj, sname, ename)
    slo, shi, sst = STRUCT[sname]
    elo, ehi, est = EFF[ename]
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


def main() -> int:
    if len(sys.argv) < 3:
        raise SystemExit(__doc__)
    wd, cases = sys.argv[1], sys.argv[2:]
    with open(os.path.join(wd, "key.json")) as f:
        key = json.load(f)
    for c in cases:
        tr = [load_record(os.path.join(wd, c, "train.csv"))]
        nominal = identify_channels({"lateral": tr}, IDS)["lateral"]
        prep = _prepare(tr, "lateral", IDS)
        x_nom = np.log(np.asarray(nominal.model.to_array(), float) * np.array([prep.sign, 1, 1, 1, 1]))
        out = {(s, e): fit_j(prep.objective, x_nom, s, e) for s in STRUCT for e in EFF}
        truth = key[c]
        line = f"{c} truth {truth['effect']} {json.dumps(truth['params'])} nominal J {float(nominal.cost_J):.2f}\n"
        for sname in STRUCT:
            ns = STRUCT[sname][0].size
            line += f"   {sname:8s}: " + "  ".join(f"{e[:6]} {out[(sname, e)][0]:7.2f}" for e in EFF) + "\n"
            for e in ("sensor_lag", "time_delay", "rotor_flapping", "structural_mode"):
                ev = out[(sname, e)][1][5 + ns :]
                val = {"sensor_lag": f"{math.exp(ev[0]):.1f}Hz", "time_delay": f"{1000 * ev[0]:.1f}ms",
                       "rotor_flapping": f"{ev[0]:.4f}s", "structural_mode": f"{math.exp(ev[0]):.1f}Hz"}[e]  # fmt: skip
                line += f"      {e} {val};"
            line += f"  struct {np.round(np.exp(out[(sname, 'none')][1][5 : 5 + ns]), 3)}\n"
        print(line, flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
