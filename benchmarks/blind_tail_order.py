"""The order of the candidates that do not beat noise, replayed on stored blind draws (issue 5).

    python benchmarks/blind_tail_order.py W1 W2 ... [--out benchmarks/results/blind_tail_order.md]

Each ``W`` is a workdir of ``benchmarks/blind_diagnosis.py``, simulated and diagnosed
(:func:`blind_pool.read_workdir`).  A ``none`` verdict still ranks every candidate, and
top-2 over the whole ranking (:func:`blind_diagnosis.class_order`: the candidates that beat
noise, then ``none``, then the rest) then counts the candidate that leads the rest.  This
script orders that tail both ways from each stored ranking, whatever order the commit
that diagnosed the draw stored: by the ranking's score (highest first, the order before
:func:`jaxgwo._diagnose._failing_by_evidence`) and by that function itself (the smallest
identification p first, the lags in the gyro path's order and ahead of a delay of like
evidence), and counts, per plant and true effect, the cases whose truth is
in the top two either way and the ``none`` verdicts whose tail the truth leads.  No
verdict and no candidate that beats noise moves, so top-1 and the headline top-2 (the
candidates that beat noise only) are the same under both.  Nothing is diagnosed again.
"""

from __future__ import annotations

import dataclasses
import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import blind_pool  # noqa: E402  (a sibling script, not a package)

ORDERS = ("score", "evidence")
"""The two orders of the failing tail this script compares."""


def _candidate(doc: dict):
    """A :class:`jaxgwo._diagnose_which.CandidateScore` holding what the tail's order reads
    from a stored ranking entry (its effect, ``train_p``, ``beats_noise``, ``score``,
    ``detail``); every other number NaN.  A missing number (JSON ``null``) is NaN."""
    from jaxgwo._diagnose_which import CandidateScore

    num = lambda v: math.nan if v is None else float(v)  # noqa: E731
    nan = {f.name: math.nan for f in dataclasses.fields(CandidateScore) if f.type in ("float", float)}
    return CandidateScore(**nan | {"effects": (doc["effect"],), "params": {}, "sigma": {},
                                   "train_p": num(doc.get("train_p")), "beats_noise": bool(doc["beats_noise"]),
                                   "agreement": 0.0, "score": num(doc.get("score")), "n_params": 0,
                                   "detail": dict(doc.get("detail") or {})})  # fmt: skip


def filter_held(doc: dict) -> bool | None:
    """What :func:`jaxgwo._diagnose._gyro_filter_held` decided for a stored diagnosis: ``None``
    where the gyro path was not tested, else whether it shows a filter (at the default
    ``alpha``, as the report's ``filter_found``) below the ``sensor_lag`` box's top."""
    from jaxgwo._diagnose_which import _Z_HI

    g = (doc.get("where") or {}).get("gyro_path") or {}
    if not g.get("tested"):
        return None
    cutoff = g.get("cutoff_hz")
    return bool(g.get("filter_found") and cutoff is not None and math.log(cutoff) < _Z_HI[1])


def reorder(ranking: list[dict], order: str, held: bool | None = None) -> list[dict]:
    """``ranking`` (stored entries, best first) with its tail of candidates that do not beat
    noise (after the last one that does) sorted by ``order``: ``"score"``, highest first,
    ties in their stored order; ``"evidence"``, :func:`jaxgwo._diagnose._failing_by_evidence`
    with the gyro path's ``held`` (:func:`filter_held`)."""
    if order == "score":
        from jaxgwo._diagnose import _best_first

        last = max((i for i, c in enumerate(ranking) if c["beats_noise"]), default=-1)
        return ranking[: last + 1] + sorted(ranking[last + 1 :], key=lambda c: _best_first(_candidate(c)))
    from jaxgwo._diagnose import _failing_by_evidence

    cands = [_candidate(c) for c in ranking]
    index = {id(c): i for i, c in enumerate(cands)}
    return [ranking[index[id(c)]] for c in _failing_by_evidence(cands, held)]


def tail_rows(key: dict, results: dict) -> list[dict]:
    """One row per effect case of a draw: ``{"case", "plant", "effect", "none_verdict",
    "top2_<order>", "leads_<order>"}`` for each of :data:`ORDERS`: the truth within the
    first two of the class order, and (``none`` verdicts only) first in the tail."""
    blind = blind_pool._blind()
    rows = []
    for case, doc in sorted(results.items()):
        k = key[case]
        if k["effect"] == "none":
            continue
        row = {"case": case, "plant": k["plant"], "effect": k["effect"], "none_verdict": doc.get("verdict") == "none"}
        for order in ORDERS:
            ranking = reorder(list(doc.get("ranking", [])), order, filter_held(doc))
            classes = blind.class_order(doc | {"ranking": ranking})
            row[f"top2_{order}"] = k["effect"] in classes[:2]
            row[f"leads_{order}"] = row["none_verdict"] and classes[1:2] == [k["effect"]]
        rows.append(row)
    return rows


def tail_report(draws: list[tuple[str, list[dict]]], argv: list[str]) -> str:
    """The markdown table over ``draws`` (``(workdir, rows of tail_rows)``)."""
    blind = blind_pool._blind()
    rows = [r for _w, rs in draws for r in rs]
    L = ["# Blind diagnosis study: the order of the candidates that do not beat noise", "",
         f"`python benchmarks/blind_tail_order.py {' '.join(argv)}`", "",
         f"{len(draws)} draws, {len(rows)} effect cases, {sum(r['none_verdict'] for r in rows)} of them answered "
         "`none`. Top-2 over the whole ranking (the candidates that beat noise, then `none`, then the rest) with "
         "the rest ordered by the ranking's score and by the identification evidence (`_failing_by_evidence`), "
         "and the `none` verdicts whose rest the truth leads; percentages with their 95 % Wilson interval. No "
         "verdict moves.", "",
         "| plant | effect | effect cases | top-2, rest by score | top-2, rest by evidence | answered `none` | "
         "truth leads the rest, by score | by evidence |",
         "|---|---|---|---|---|---|---|---|"]

    def line(plant: str, effect: str, rs: list[dict]) -> str:
        nones = [r for r in rs if r["none_verdict"]]
        cells = [blind_pool._cell(sum(r[f"top2_{o}"] for r in rs), len(rs)) for o in ORDERS]
        leads = [f"{sum(r[f'leads_{o}'] for r in nones)}/{len(nones)}" for o in ORDERS]
        return f"| {plant} | {effect} | {len(rs)} | {cells[0]} | {cells[1]} | {len(nones)} | {leads[0]} | {leads[1]} |"

    for plant in ("paper", "r50"):
        for effect in blind.CLASSES:
            rs = [r for r in rows if r["plant"] == plant and r["effect"] == effect]
            if rs:
                L.append(line(plant, effect, rs))
    for plant in ("paper", "r50"):
        L.append(line(plant, "all", [r for r in rows if r["plant"] == plant]))
    L.append(line("both", "all", rows))
    return "\n".join(L) + "\n"


def main(argv=None) -> int:
    return blind_pool.workdir_table_main(argv, __doc__, tail_rows, tail_report)


if __name__ == "__main__":
    sys.exit(main())
