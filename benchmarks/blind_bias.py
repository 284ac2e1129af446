"""Signed parameter errors of the blind study's right verdicts (issue 5), pooled over draws.

    python benchmarks/blind_bias.py W1 W2 ... [--out benchmarks/results/blind_bias.md]

Each ``W`` is a workdir of ``benchmarks/blind_diagnosis.py``, simulated and diagnosed
(:func:`blind_pool.read_workdir`).  The draw's report counts a parameter's error without
its sign (``param error``) and how often the quoted 1-sigma holds the truth ("Quoted
bounds"); neither says whether an effect is read high or low.  This table does: for each
right verdict, each of the verdict's parameters against the key's (the one the report
scores, :data:`blind_diagnosis._MAIN_PARAM`, first), as a ratio for the parameters that
scale (a gyro filter's cutoff, a lag, a mode's frequency and dampings, a rate, a width, a
limit) and as a difference for a delay (ms) and a coupling gain (which may be zero or
change sign).  A ratio whose middle lies away from 1 well
beyond the spread the quoted bounds allow is a bias of the model the effect was fitted
on, not noise: on an R-50, the paper model with one extra pole pair (README, "What limits
it").  Nothing is diagnosed again; each draw counts with the diagnoses stored in its
workdir, made by the commit that diagnosed it.
"""

from __future__ import annotations

import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import blind_pool  # noqa: E402  (a sibling script, not a package)

DIFFERENCE = {"delay_s": ("fit - truth (ms)", 1e3), "gain": ("fit - truth", 1.0)}
"""The parameters read as a difference, with its label and scale; the others as fit / truth."""


def signed_errors(key: dict, results: dict) -> list[dict]:
    """One row per parameter of each right verdict of a draw: ``{"case", "effect",
    "param", "plant", "structure", "error", "z"}``, ``error`` the ratio or scaled
    difference (:data:`DIFFERENCE`) and ``z`` the error in units of the quoted 1-sigma
    (:func:`blind_diagnosis.bound_z`; ``None`` where none was quoted)."""
    blind = blind_pool._blind()
    rows = []
    for case, doc in sorted(results.items()):
        k = key[case]
        effect = k["effect"]
        if effect == "none" or doc.get("verdict") != effect:
            continue
        top = doc["ranking"][0]
        for p, truth in k["params"].items():
            fit = float(top["params"][p])
            err = DIFFERENCE[p][1] * (fit - truth) if p in DIFFERENCE else fit / truth
            z = blind.bound_z(effect, k["params"], top["params"], top.get("params_sigma"), param=p)
            rows.append({"case": case, "effect": effect, "param": p, "plant": k["plant"],
                         "structure": doc.get("structure") is not None, "error": err, "z": z})
    return rows


def _quantiles(values) -> str:
    q10, q50, q90 = np.percentile(np.asarray(values, float), [10, 50, 90])
    return f"{q50:.4g} | {q10:.4g} | {q90:.4g}"


def bias_report(draws: list[tuple[str, list[dict]]], argv: list[str]) -> str:
    """The markdown table over ``draws`` (``(workdir, rows of signed_errors)``)."""
    blind = blind_pool._blind()
    rows = [r for _w, rs in draws for r in rs]
    L = ["# Blind diagnosis study: signed parameter errors of the right verdicts", "",
         f"`python benchmarks/blind_bias.py {' '.join(argv)}`", "",
         f"{len(draws)} draws, {len({(w, r['case']) for w, rs in draws for r in rs})} right verdicts. Per effect, "
         "parameter and plant: the verdict's parameter against "
         "the truth, as fit / truth (1 is unbiased) or, for a delay and a coupling gain, as fit - truth (0 is "
         "unbiased); its median and its 10th and 90th percentiles over the cases; the cases read high (ratio above "
         "1, difference above 0); and the median error in units of the 1-sigma the diagnosis quoted, with the "
         "share of cases within it (68 % where calibrated).", "",
         "| effect | parameter | plant | right verdicts | on a structure finding | median | 10 % | 90 % | read high "
         "| median \\|error\\|/sigma | within 1-sigma |",
         "|---|---|---|---|---|---|---|---|---|---|---|"]
    for effect in blind.CLASSES:
        params = list(dict.fromkeys(r["param"] for r in rows if r["effect"] == effect))
        for p in sorted(params, key=lambda q: q != blind._MAIN_PARAM[effect]):  # the scored one first
            label, centre = (DIFFERENCE[p][0], 0.0) if p in DIFFERENCE else ("fit / truth", 1.0)
            for plant in ("paper", "r50"):
                rs = [r for r in rows if r["effect"] == effect and r["param"] == p and r["plant"] == plant]
                if not rs:
                    continue
                zs = [r["z"] for r in rs if r["z"] is not None]
                zcell = f"{np.median(zs):.2f} | {sum(z < 1.0 for z in zs)}/{len(zs)}" if zs else "- | -"
                high = sum(r["error"] > centre for r in rs)
                L.append(f"| {effect} | {p}: {label} | {plant} | {len(rs)} | {sum(r['structure'] for r in rs)} | "
                         f"{_quantiles([r['error'] for r in rs])} | {high}/{len(rs)} | {zcell} |")
    return "\n".join(L) + "\n"


def main(argv=None) -> int:
    return blind_pool.workdir_table_main(argv, __doc__, signed_errors, bias_report)


if __name__ == "__main__":
    sys.exit(main())
