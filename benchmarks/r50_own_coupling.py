"""The R-50's own roll/pitch mixing beside the ``cross_coupling`` gains a blind study fitted (issue 5).

    python benchmarks/r50_own_coupling.py W [W ...]

Each ``W`` is a workdir of ``benchmarks/blind_diagnosis.py`` that holds its diagnoses
(``diagnoses.json``).  For every R-50 ``cross_coupling`` and ``none`` case the R-50 variant is
drawn again from the seed's keys (as ``simulate_cases`` drew it) and its own mixing of the
longitudinal stick into the lateral flapping is printed: ``Blon/Blat`` and, with the
stabilizer bar's path, ``Blon/(Blat + Bd Dlat)``; beside it the key's gain, the gain the
diagnosis fitted for its ``cross_coupling`` candidate (wherever it ranks) and the verdict.
The summary gives the span of the gains fitted on the ``none`` cases, the fitted gain less
the key's on the coupling cases, and which couplings were named, split at ``--split``
(the least |gain| of a coupling named outside that span on the draws it was read on,
621-643: docs/diagnosis-record.md, session 86).  Uses the key only to score.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))


def _json(path: str):
    with open(path) as f:
        return json.load(f)


def _rows(workdir: str):
    """One row per R-50 coupling or ``none`` case of ``workdir``."""
    import jax

    from blind_diagnosis import CLASSES
    from jaxgwo._plants import R50_PARAM_NAMES, draw_r50_plant
    from jaxgwo._simulate import HoldLoop

    ix = {n: i for i, n in enumerate(R50_PARAM_NAMES)}
    draw, key, diagnoses = (_json(os.path.join(workdir, f"{name}.json")) for name in ("draw", "key", "diagnoses"))
    keys = jax.random.split(jax.random.key(draw["seed"]), len(CLASSES) * draw["cases_per_effect"])
    for case, k in key.items():
        if k["plant"] != "r50" or k["effect"] not in ("cross_coupling", "none") or case not in diagnoses:
            continue
        k_plant = jax.random.split(keys[int(case.split("_")[1])], 4)[0]
        effects = () if k["effect"] == "none" else ("cross_coupling",)
        p = draw_r50_plant(k_plant, effects=effects, axis="lateral", hold=HoldLoop.r50()).plant.params
        doc = diagnoses[case]
        cand = next((r for r in doc["ranking"] if r["effect"] == "cross_coupling"), None)
        yield {"case": f"{draw['seed']}/{case}", "effect": k["effect"], "gain": k["params"].get("gain", 0.0),
               "own": float(p[ix["Blon"]] / p[ix["Blat"]]),
               "own_bar": float(p[ix["Blon"]] / (p[ix["Blat"]] + p[ix["Bd"]] * p[ix["Dlat"]])),
               "fit": float("nan") if cand is None else cand["params"]["gain"], "verdict": doc["verdict"]}  # fmt: skip


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("workdirs", nargs="+")
    ap.add_argument("--split", type=float, default=0.136)
    args = ap.parse_args(argv)
    rows = [r for w in args.workdirs for r in _rows(w)]
    for r in rows:
        print(f"{r['case']} {r['effect']:14s} gain {r['gain']:+.3f} own {r['own']:.3f} own_bar {r['own_bar']:.3f} "
              f"fit {r['fit']:+.3f} fit-gain {r['fit'] - r['gain']:+.3f} verdict {r['verdict']}")  # fmt: skip
    none = [r["fit"] for r in rows if r["effect"] == "none"]
    cc = [r for r in rows if r["effect"] == "cross_coupling"]
    if none:
        print(f"R-50 none: {len(none)}, fitted gains {min(none):+.3f} to {max(none):+.3f}, "
              f"median {statistics.median(none):+.3f}")  # fmt: skip
    if cc:
        off = [r["fit"] - r["gain"] for r in cc]
        print(f"R-50 couplings: {len(cc)}, fitted less key median {statistics.median(off):+.3f} "
              f"({min(off):+.3f} to {max(off):+.3f})")  # fmt: skip
        for big in (True, False):
            part = [r for r in cc if (abs(r["gain"]) >= args.split) == big]
            named = sum(r["verdict"] == "cross_coupling" for r in part)
            print(f"  |gain| {'>=' if big else '<'} {args.split:g}: {len(part)}, named {named}, "
                  f"none {sum(r['verdict'] == 'none' for r in part)}")  # fmt: skip
    print(f"drawn airframes: Blon/Blat {min(r['own'] for r in rows):.3f}-{max(r['own'] for r in rows):.3f}, "
          f"with the bar {min(r['own_bar'] for r in rows):.3f}-{max(r['own_bar'] for r in rows):.3f}")  # fmt: skip


if __name__ == "__main__":
    main()
