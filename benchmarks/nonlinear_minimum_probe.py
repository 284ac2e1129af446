"""How deep is a blind case's true nonlinearity, and did the search reach it?

    python benchmarks/blind_diagnosis.py --seed 41 --r50-fraction 0.25 --simulate-only --workdir W
    python benchmarks/nonlinear_minimum_probe.py W case_001 case_045

For each case (a ``rate_limit``, ``backlash`` or ``saturation`` case of the key) it
identifies the nominal model on TRAIN as the blind study does, runs
``fit_nonlinear_candidates`` for that effect with the null refit, and then holds the
effect's value at 0.7, 1 and 1.4 times the truth and polishes the servo and rotor term
from the null refit's (Nelder-Mead, then L-BFGS-B, as the search's own polish).  It prints
the null refit's output error over each, the ratio ``min_error_ratio`` is compared with:
where the truth's ratio exceeds the search's, the search stepped over the minimum.  Reads
the key (development use only; never on a reporting seed before its blind run).
"""

from __future__ import annotations

import argparse
import json
import math
import os

import numpy as np


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("workdir")
    ap.add_argument("cases", nargs="+")
    args = ap.parse_args()

    import jax

    import jaxgwo  # noqa: F401  (float64)
    from jaxgwo._data import load_record
    from jaxgwo._diagnose import _time_pairs
    from jaxgwo._diagnose_which import (_NL_PARAM, ModelSpec, _nl_mse, _polish_nonlinear, fit_nonlinear_candidates,
                                        nonlinear_objectives)  # fmt: skip
    from jaxgwo._identify import IdentifySettings, identify_channels

    ids = IdentifySettings(method="wls-igwo+polish", wolves=12, iterations=30, n_frequencies=80, polish_steps=40,
                           w_max=120.0)  # fmt: skip  (the blind study's settings)
    with open(os.path.join(args.workdir, "key.json")) as f:
        key = json.load(f)
    for case in args.cases:
        effect = key[case]["effect"]
        if effect not in _NL_PARAM:
            print(f"{case}: {effect} is no servo nonlinearity; skipped")
            continue
        truth = key[case]["params"][_NL_PARAM[effect]]
        train = [load_record(os.path.join(args.workdir, case, "train.csv"))]
        nominal = identify_channels({"lateral": train}, ids)["lateral"]
        tt = _time_pairs(train, "lateral", ids)
        base = ModelSpec(np.asarray(nominal.model.to_array(), float))
        fit, null = fit_nonlinear_candidates(base, tt, [effect], jax.random.key(0), wolves=12, iterations=15,
                                             include_null=True)  # fmt: skip
        obj, null_obj = nonlinear_objectives(base, tt, [effect, "null"])
        r = null.refit
        x_null = np.r_[0.0, np.log([r["omega_s"], r["zeta_s"], r["tau"], r["M"]])]
        e_null = _nl_mse(null_obj, x_null)
        found = fit.params[effect][_NL_PARAM[effect]]
        print(f"{case} {effect} truth {truth:.4g}: search found {found:.4g}, null/error x{null.train_mse / fit.train_mse:.4f}")
        for scale in (0.7, 1.0, 1.4):
            v = math.log(truth * scale)
            x0 = np.r_[v, x_null[1:]]
            lo = np.r_[v, x_null[1:] - math.log(2.0)]
            hi = np.r_[v + 1e-9, x_null[1:] + math.log(2.0)]
            x = _polish_nonlinear(obj, x0, lo, hi, False)
            x = _polish_nonlinear(obj, x, lo, hi, False, "L-BFGS-B")
            print(f"   held at {scale:.1f} x truth ({truth * scale:.4g}): null/error x{e_null / _nl_mse(obj, x):.4f}")


if __name__ == "__main__":
    main()
