"""The lags read between two airframe models, on stored blind cases (issue 5).

    python benchmarks/airframe_bracket.py W:case_NNN [W:case_NNN ...] [--out OUT.json]
    python benchmarks/airframe_bracket.py --from OUT.json
    python benchmarks/airframe_bracket.py --stored W [W ...]

Each ``W`` is a workdir of ``benchmarks/blind_diagnosis.py`` (``--simulate-only`` writes one
from a seed; the key is read only to score).  Every case is diagnosed again with this
checkout's ``jaxgwo`` and the default settings, as the blind study diagnoses it, and the
reports go to ``--out`` (written after each case, so a long run can be read or resumed;
``--from`` scores such a file without diagnosing, ``--stored`` the diagnoses a workdir
keeps from its own run).  Where the verdict is the true effect
and it is one of the lags :data:`jaxgwo._diagnose_which.AIRFRAME_LAGS` reads twice beside a
structure finding (a ``time_delay`` or an R-50 ``rotor_flapping``), the table gives the truth,
the pair fit's reading, the lead-lag airframe's, the reported centre and its 1-sigma, and
counts how often the truth lies inside the bracket and within the quoted 1-sigma and
2-sigma.  The flapping lags named only because both models read one
(``named_between_airframes``; reported since session 84 at the lead-lag's reading) are
scored again both ways, the centre's error beside the lead-lag's under the same 1-sigma,
whichever the diagnosis reported.  Other cases are listed as skipped, with their verdict.
"""

from __future__ import annotations

import argparse
import functools
import json
import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))


@functools.cache
def _key(workdir: str) -> dict:
    """A workdir's key, its cases by name (read once per workdir)."""
    with open(os.path.join(workdir, "key.json")) as f:
        key = json.load(f)
    return key.get("cases", key)


def _truth(spec: str) -> dict:
    w, case = spec.split(":")
    return _key(w)[case]


def bracket_rows(reports: dict[str, dict], truths: dict[str, dict]) -> tuple[list[dict], list[str]]:
    """``(rows, skipped)``: one row per case whose right verdict carries both readings, with
    ``truth``, ``pair``, ``airframe``, ``reported``, ``sigma`` (the parameter's units) and
    ``z`` (``|reported - truth| / sigma``); ``skipped`` names the rest and why."""
    from jaxgwo._diagnose_which import AIRFRAME_LAGS

    rows, skipped = [], []
    for spec, doc in reports.items():
        k = truths[spec]
        effect = k["effect"]
        if effect not in AIRFRAME_LAGS or doc.get("verdict") != effect:
            skipped.append(f"{spec}: truth {effect}, verdict {doc.get('verdict')}")
            continue
        param, _i, stem = AIRFRAME_LAGS[effect]
        top = doc["ranking"][0]
        d = top.get("detail") or {}
        if f"{stem}_airframe_s" not in d:
            skipped.append(f"{spec}: {effect} named, no airframe reading (J ratio {d.get('airframe_J_ratio')})")
            continue
        t, v, s = k["params"][param], top["params"][param], top["params_sigma"][param]
        rows.append({"case": spec, "effect": effect, "plant": k.get("plant"), "truth": t, "pair": d[f"{stem}_pair_s"],
                     "airframe": d[f"{stem}_airframe_s"], "reported": v, "sigma": s,
                     "z": abs(v - t) / s if s > 0 else math.inf, "J_ratio": d.get("airframe_J_ratio"),
                     "named": bool(d.get("named_between_airframes"))})  # fmt: skip
    return rows, skipped


def report(rows: list[dict], skipped: list[str]) -> str:
    """The table and the counts, as printed."""
    L = ["| case | effect | plant | truth ms | pair ms | lead-lag ms | reported ms | 1-sigma ms | error / sigma | J ratio |",
         "|---|---|---|---|---|---|---|---|---|---|"]  # fmt: skip
    for r in rows:
        L.append(f"| {r['case']} | {r['effect']} | {r['plant']} | {1e3 * r['truth']:.1f} | {1e3 * r['pair']:.1f} | "
                 f"{1e3 * r['airframe']:.1f} | {1e3 * r['reported']:.1f} | {1e3 * r['sigma']:.1f} | {r['z']:.2f} | "
                 f"{r['J_ratio']:.2f} |")  # fmt: skip
    n = len(rows)
    inside = sum(min(r["pair"], r["airframe"]) <= r["truth"] <= max(r["pair"], r["airframe"]) for r in rows)
    L.append("")
    L.append(f"{n} cases: truth inside the bracket {inside}, within 1-sigma {sum(r['z'] <= 1 for r in rows)}, "
             f"within 2-sigma {sum(r['z'] <= 2 for r in rows)}; pair reading below the truth "
             f"{sum(r['pair'] < r['truth'] for r in rows)}, lead-lag above it {sum(r['airframe'] > r['truth'] for r in rows)}")  # fmt: skip
    if n:
        med = lambda xs: sorted(xs)[(len(xs) - 1) // 2]  # noqa: E731  (the lower median)
        L.append(f"median |error|: reported {1e3 * med([abs(r['reported'] - r['truth']) for r in rows]):.1f} ms, "
                 f"pair alone {1e3 * med([abs(r['pair'] - r['truth']) for r in rows]):.1f} ms; "
                 f"median error / sigma {med([r['z'] for r in rows]):.2f}")  # fmt: skip
    L += _named_lines([r for r in rows if r["named"]])
    L += [f"skipped {s}" for s in skipped]
    return "\n".join(L)


def _named_lines(named: list[dict]) -> list[str]:
    """The lags named between the airframe models scored at the bracket's centre and at the
    lead-lag's reading, each against the truth under the quoted 1-sigma (ms)."""
    if not named:
        return []
    L = [f"{len(named)} named between the airframe models (reported at the lead-lag's reading since session 84):"]
    for what, read in (("centre", lambda r: 0.5 * (r["pair"] + r["airframe"])), ("lead-lag", lambda r: r["airframe"])):
        err = [read(r) - r["truth"] for r in named]
        z = [abs(e) / r["sigma"] if r["sigma"] > 0 else math.inf for e, r in zip(err, named)]
        rms = math.sqrt(sum(e * e for e in err) / len(err))
        L.append(f"  {what}: error {1e3 * min(err):+.1f} to {1e3 * max(err):+.1f} ms, mean {1e3 * sum(err) / len(err):+.1f}, "
                 f"rms {1e3 * rms:.1f}; within 1-sigma {sum(x <= 1 for x in z)}, within 2-sigma {sum(x <= 2 for x in z)}")  # fmt: skip
    return L


def stored_reports(workdirs: list[str]) -> dict[str, dict]:
    """The diagnoses each blind-study workdir keeps (its ``diagnoses.json``), as ``W:case``;
    each workdir read by :func:`blind_pool.read_workdir`, which refuses one never diagnosed
    or diagnosed in part, saying which."""
    import blind_pool

    reports = {}
    for w in workdirs:
        _draw, _key, results = blind_pool.read_workdir(w)
        reports |= {f"{w}:{case}": doc for case, doc in results.items()}
    return reports


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("cases", nargs="*", help="W:case_NNN, W a blind-study workdir")
    ap.add_argument("--out", default=None, help="JSON file the reports are written to (and resumed from)")
    ap.add_argument("--from", dest="source", default=None, help="score the reports in this file; diagnose nothing")
    ap.add_argument("--stored", nargs="+", default=None, metavar="W",
                    help="score the diagnoses these workdirs keep (diagnoses.json); diagnose nothing")
    args = ap.parse_args(argv)
    if sum(map(bool, (args.cases, args.source, args.stored))) != 1:
        ap.error("give one of: W:case specs, --from FILE, --stored W [W ...]")
    if args.stored:
        reports = stored_reports(args.stored)
    elif args.source:
        with open(args.source) as f:
            reports = json.load(f)
    else:
        import blind_diagnosis
        from jaxgwo._atomic import atomic_write_text
        from jaxgwo._diagnose import DiagnoseSettings

        blind_diagnosis._compilation_cache()
        reports = {}
        if args.out and os.path.exists(args.out):
            with open(args.out) as f:
                reports = json.load(f)
        for spec in args.cases:
            if spec not in reports:
                reports[spec] = blind_diagnosis._diagnose_one(spec.replace(":", os.sep), DiagnoseSettings())
                print(f"{spec}: verdict {reports[spec]['verdict']} ({reports[spec]['wall_s']:.0f} s)", flush=True)
                if args.out:
                    atomic_write_text(args.out, json.dumps(reports))
    print(report(*bracket_rows(reports, {s: _truth(s) for s in reports})))
    return 0


if __name__ == "__main__":
    sys.exit(main())
