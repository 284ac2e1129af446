"""Pool several draws of the blind study (issue 5) into one table.

    python benchmarks/blind_pool.py W1 W2 ... [--out benchmarks/results/blind_pool.md] [--header NOTE.md]

Each ``W`` is a workdir of ``benchmarks/blind_diagnosis.py`` that holds its key and its
diagnoses (``key.json``, ``diagnoses.json``, ``draw.json``, the records), or the markdown
report that script wrote for one draw (``benchmarks/results/blind_diagnosis_seed*.md``).
A workdir is scored as that script scores it (:func:`blind_diagnosis.score`); a report is
read back from its case table (:func:`load_report`), so draws whose workdirs are gone
still pool, from files kept in the repository.  Nothing is diagnosed again: each draw
counts with the diagnoses stored in its workdir or report, made by whichever commit
diagnosed it (each draw's own report names it).  One draw of 64 effect cases
measures top-1 to about +-10 % (95 %); the pooled count, with its Wilson interval, says
whether a target is met or missed beyond that draw-to-draw spread, and the tables below it
say where the misses lie: by plant and effect, and whether the oracle found the effect
identifiable at all (``ORACLE_Z``; on an R-50, against the paper model with one extra
pole pair, the model the diagnosis ranks its effects on there).
"""

from __future__ import annotations

import argparse
import functools
import importlib.util
import json
import math
import os
import re
import sys
from collections import Counter

HERE = os.path.dirname(os.path.abspath(__file__))
TARGET_TOP1, TARGET_TOP2 = 0.85, 0.95  # issue 5


@functools.cache
def _blind():
    """``benchmarks/blind_diagnosis.py`` as a module (a script, not part of the package),
    executed once: :func:`load_draws` scores with it, :func:`pool_report` reads its classes."""
    spec = importlib.util.spec_from_file_location("blind_diagnosis", os.path.join(HERE, "blind_diagnosis.py"))
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def wilson_interval(hits: int, n: int, z: float = 1.959963984540054) -> tuple[float, float]:
    """Wilson's score interval for a binomial proportion ``hits``/``n`` (95 % by default):
    unlike the normal one it stays inside [0, 1] and gives 0 hits of ``n`` a non-zero
    upper bound.  ``(nan, nan)`` without cases."""
    if n <= 0:
        return math.nan, math.nan
    p = hits / n
    den = 1.0 + z * z / n
    mid = (p + z * z / (2 * n)) / den
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / den
    return max(0.0, mid - half), min(1.0, mid + half)


def identifiable(row: dict) -> bool:
    """Whether the oracle found the row's effect identifiable: on a paper plant against the
    paper model (``identifiable``), on an R-50 against the paper model with one extra pole
    pair (``identifiable_mode``) where the key has that oracle."""
    if row["truth"] == "none":
        return True
    if row.get("oracle_z_mode") is not None:
        return bool(row["identifiable_mode"])
    return bool(row["identifiable"])


def load_draws(workdirs, blind=None) -> list[dict]:
    """``[{"workdir", "seed", "attitude", "rows"}]``: each workdir's draw arguments and its
    scored rows (a ``.md`` path: a draw's report, :func:`load_report`).  A workdir without
    ``diagnoses.json`` (simulated, never diagnosed) or with cases the diagnoses lack is
    refused: a part-diagnosed draw would bias the pool toward its first cases."""
    blind = blind or _blind()
    draws = []
    for w in workdirs:
        if os.path.isfile(w) and w.endswith(".md"):
            draws.append(load_report(w, blind))
            continue
        draw, _key, results = read_workdir(w)
        rows = blind.score(w, results)["rows"]
        draws.append({"workdir": w, "seed": draw.get("seed"), "attitude": bool(draw.get("attitude")), "rows": rows,
                      "bounds": bound_counts(rows), "estimates": blind.estimate_counts(rows)})  # fmt: skip
    refuse_repeated_seeds([d["seed"] for d in draws])
    return draws


def refuse_repeated_seeds(seeds) -> None:
    """Exit naming any seed given more than once: a draw counts once in a pool."""
    dup = sorted({s for s in seeds if seeds.count(s) > 1 and s is not None})
    if dup:
        raise SystemExit(f"seed(s) {dup} appear in more than one workdir or report: a draw counts once in a pool.")


def read_workdir(w: str) -> tuple[dict, dict, dict]:
    """``(draw, key, diagnoses)``: the three JSON files of a whole draw's workdir.  A workdir
    without them (simulated, never diagnosed) or with cases the diagnoses lack is refused:
    a part-diagnosed draw would bias a pool toward its first cases."""
    missing = [f for f in ("key.json", "diagnoses.json", "draw.json") if not os.path.exists(os.path.join(w, f))]
    if missing:
        raise SystemExit(f"{w}: no {', '.join(missing)}; pass workdirs that blind_diagnosis.py simulated "
                         "and diagnosed (--simulate-only, then --reuse).")
    docs = []
    for name in ("draw.json", "key.json", "diagnoses.json"):
        with open(os.path.join(w, name)) as f:
            docs.append(json.load(f))
    draw, key, results = docs
    lacking = sorted(set(key) - set(results))
    if lacking:
        raise SystemExit(f"{w}: {len(lacking)} of {len(key)} cases have no diagnosis (first {lacking[0]}); "
                         "finish the draw (--reuse --resume) before pooling it.")
    return draw, key, results


def bound_counts(rows) -> dict:
    """``{(effect, plant): [cases with a bound, truth within 1-sigma, within 2-sigma]}`` over
    scored rows' ``bound_z`` (:func:`blind_diagnosis.bound_z`, right verdicts only), the
    counts of a report's "Quoted bounds" table."""
    out: dict = {}
    for r in rows:
        z = r.get("bound_z")
        if z is not None:
            c = out.setdefault((r["truth"], r["plant"]), [0, 0, 0])
            c[0], c[1], c[2] = c[0] + 1, c[1] + (z < 1.0), c[2] + (z < 2.0)
    return out


def _report_bounds(lines: list[str], path: str) -> dict | None:
    """:func:`bound_counts` read from a report's "## Quoted bounds" table; ``None`` where
    the report predates that table."""
    i = next((k for k, ln in enumerate(lines) if ln.startswith("| effect | plant | cases with a bound |")), None)
    if i is None:
        return None
    out = {}
    for ln in lines[i + 2 :]:
        if not ln.startswith("|"):
            break
        cells = [c.strip() for c in ln.strip().strip("|").split("|")]
        try:
            out[(cells[0], cells[1])] = [int(cells[2]), int(cells[3]), int(cells[4])]
        except (IndexError, ValueError):
            raise SystemExit(f"{path}: cannot read the quoted-bounds row {ln!r}; was the table edited by hand?") from None
    return out


def _report_estimates(lines: list[str], path: str, blind) -> dict:
    """:func:`blind_diagnosis.estimate_counts` read back from a report's target rows (the
    rows :func:`blind_diagnosis.estimate_rows` writes; the largest as printed, to three
    digits).  A row the report lacks is absent: a draw without that effect's cases, or a
    report from before the row."""
    heads = {effect: f"| {effect} estimated within {bound:g} {unit} (its candidate"
             for effect, bound, unit in blind.ESTIMATE_TARGETS}
    heads["val_r2"] = f"| the proposed model's VAL R^2 within {blind.R2_TARGET:g} of the true model's"
    out = {}
    for name, head in heads.items():
        ln = next((ln for ln in lines if ln.startswith(head)), None)
        if ln is None:
            continue
        m = re.search(r"\((\d+)/(\d+)\), largest (?:error|difference) (\S+)", ln)
        try:
            out[name] = (int(m.group(1)), int(m.group(2)), float(m.group(3)))
        except (AttributeError, ValueError):
            raise SystemExit(f"{path}: cannot read the target row {ln!r}; was the table edited by hand?") from None
    return out


_REPORT_COLUMNS = ("case", "plant", "truth", "verdict", "top-2", "second in ordering", "oracle z TRAIN, VAL")


def _oracle_cell(text: str) -> tuple[tuple | None, tuple | None]:
    """``((z_train, z_val) or None, (mode z_train, mode z_val) or None)`` from a report's
    ``oracle z`` cell: ``-``, ``a, b`` or ``a, b (mode: c, d; floor: e, f)``."""
    text = text.strip()
    if text == "-":
        return None, None
    head, _, rest = text.partition("(")
    z = tuple(float(v) for v in head.split(","))
    mode = None
    if rest.startswith("mode:"):
        mode = tuple(float(v) for v in rest[len("mode:") :].split(";")[0].rstrip(")").split(","))
    return z, mode


def load_report(path: str, blind=None) -> dict:
    """One draw read back from the markdown report ``blind_diagnosis.py`` wrote for it
    (``{"workdir": path, "seed", "attitude", "rows"}``, rows with the fields
    :func:`pool_report` reads).  The report's case table gives the plant, truth, verdict,
    top-2 and the second class of the ordering (``order2`` is the verdict and that class:
    :func:`blind_diagnosis.class_order` puts the verdict first, ``none`` when nothing beats
    noise); identifiable is read from the oracle z as printed, to 0.1
    (:func:`blind_diagnosis.oracle_identifies`, on an R-50 with the extra pole pair's), so a z within 0.05 of the
    threshold may count otherwise than from the key.  Where the verdict is ``none`` although
    a candidate further down beat noise (a rule put one that does not first), the ordering's
    first class is that candidate, which the report does not print, and a report reads
    ``none`` there.  Over the thirteen fresh draws 131-197 the two readings differ in four
    of 832 rows: two printed z of 3.0 that are above 3 in the key (seed 149, cases 040 and
    070), and two whole-ranking top-2 hits (733 from the workdirs, 731 from the reports);
    top-1, top-2, false alarms and the plant counts agree.  A report whose table lacks
    cases its headline counts (a ``--limit`` run) or these columns is refused."""
    blind = blind or _blind()
    with open(path) as f:
        lines = f.read().splitlines()
    head = next((ln for ln in lines if re.match(r"^\d+ cases \(", ln)), None)
    seed = re.search(r"\bseed (-?\d+)", head or "")
    if head is None or seed is None:
        raise SystemExit(f"{path}: no headline '<N> cases (...), seed <S>'; pass a report of blind_diagnosis.py.")
    i = next((k for k, ln in enumerate(lines) if ln.startswith("| case |")), None)
    cols = [c.strip() for c in lines[i].strip("|").split("|")] if i is not None else []
    lacking = [c for c in _REPORT_COLUMNS if c not in cols]
    if lacking:
        raise SystemExit(f"{path}: its case table lacks the column(s) {lacking} (has {cols}); "
                         "pass a report of blind_diagnosis.py from 2026-11 on.")  # fmt: skip
    rows = []
    for ln in lines[i + 2 :]:
        if not ln.startswith("| case_"):
            break
        cells = [c.strip() for c in ln.strip().strip("|").split("|")]
        try:
            if len(cells) != len(cols):
                raise ValueError(f"{len(cells)} cells for {len(cols)} columns")
            cell = dict(zip(cols, cells, strict=True))
            z, mode = _oracle_cell(cell["oracle z TRAIN, VAL"])
        except ValueError as err:
            raise SystemExit(f"{path}: cannot read the case row {ln!r} ({err}); was the table edited by hand?") from None
        truth, verdict, second = cell["truth"], cell["verdict"], cell["second in ordering"]
        rows.append({"case": cell["case"], "plant": cell["plant"], "truth": truth, "verdict": verdict,
                     "top1": verdict == truth, "top2": cell["top-2"] == "yes",
                     "order2": [verdict] + ([] if second == "-" else [second]),
                     "identifiable": truth == "none" or blind.oracle_identifies(z),
                     "oracle_z_mode": mode, "identifiable_mode": blind.oracle_identifies(mode)})  # fmt: skip
    n = int(head.split()[0])
    if len(rows) != n:
        raise SystemExit(f"{path}: its case table holds {len(rows)} of the {n} cases its headline counts; "
                         "pool only reports of whole draws.")  # fmt: skip
    # the draw's own command line (a hand note above it may name the flag in passing)
    attitude = any(ln.startswith("`python benchmarks/blind_diagnosis.py") and "--attitude" in ln for ln in lines[:i])
    return {"workdir": path, "seed": int(seed.group(1)), "attitude": attitude, "rows": rows,
            "bounds": _report_bounds(lines, path), "estimates": _report_estimates(lines, path, blind)}


def _cell(hits: int, n: int) -> str:
    if not n:
        return "-"
    lo, hi = wilson_interval(hits, n)
    return f"{100 * hits / n:.0f} % ({hits}/{n}; {100 * lo:.0f}-{100 * hi:.0f})"


def _count(rows, key: str = "top1") -> str:
    """``hits/n`` of the flag ``key`` over ``rows``."""
    return f"{sum(r[key] for r in rows)}/{len(rows)}"


def pool_report(draws: list[dict], argv: list[str], header: str | None = None) -> str:
    """The markdown of the pooled study; ``header`` (markdown, a hand note on the draws)
    stands verbatim between the title and the command line."""
    rows = [r for d in draws for r in d["rows"]]
    eff = [r for r in rows if r["truth"] != "none"]
    nones = [r for r in rows if r["truth"] == "none"]
    note = [header.strip("\n"), ""] if header and header.strip() else []
    L = ["# Blind diagnosis study, draws pooled", "", *note,
         f"`python benchmarks/blind_pool.py {' '.join(argv)}`", "",
         f"{len(draws)} draws, {len(rows)} cases ({len(eff)} with an effect, {len(nones)} without). Each draw is "
         "scored from the diagnoses stored in its workdir, so the draws may come from different commits (each "
         "draw's own report names its commit); a draw given by its report is read from the report's case table. "
         "Percentages with their 95 % Wilson interval.", "",
         "| seed | attitude | top-1 | top-2 | false alarms on none | top-1 paper | top-1 R-50 | top-1 identifiable |",
         "|---|---|---|---|---|---|---|---|"]
    for d in draws:
        e = [r for r in d["rows"] if r["truth"] != "none"]
        n = [r for r in d["rows"] if r["truth"] == "none"]
        fa_d = sum(r["verdict"] != "none" for r in n)
        L.append(f"| {d['seed']} | {'yes' if d['attitude'] else 'no'} | {_count(e)} | {_count(e, 'top2')} | "
                 f"{fa_d}/{len(n)} | {_count([r for r in e if r['plant'] == 'paper'])} | "
                 f"{_count([r for r in e if r['plant'] == 'r50'])} | {_count([r for r in e if identifiable(r)])} |")
    n1, n2 = sum(r["top1"] for r in eff), sum(r["top2"] for r in eff)
    n_ord = sum(r["truth"] in r["order2"] for r in eff)
    fa = sum(r["verdict"] != "none" for r in nones)
    idf = [r for r in eff if identifiable(r)]
    L += ["", "| pooled | value (95 % interval) | target |", "|---|---|---|",
          f"| top-1 over effects | {_cell(n1, len(eff))} | >= {100 * TARGET_TOP1:.0f} % |",
          f"| top-2 over effects (candidates that beat noise) | {_cell(n2, len(eff))} | >= {100 * TARGET_TOP2:.0f} % |",
          f"| top-2 over the whole ranking (`class_order`) | {_cell(n_ord, len(eff))} | |",
          f"| false alarms on none | {_cell(fa, len(nones))} | 0 % |",
          f"| top-1 over identifiable effects | {_cell(sum(r['top1'] for r in idf), len(idf))} | |",
          f"| top-1 over effects the oracle finds unidentifiable | "
          f"{_cell(sum(r['top1'] for r in eff if not identifiable(r)), len(eff) - len(idf))} | |"]
    for plant in ("paper", "r50"):
        pr = [r for r in eff if r["plant"] == plant]
        L.append(f"| top-1 on {plant} plants | {_cell(sum(r['top1'] for r in pr), len(pr))} | |")
    L += _estimates_section(draws)
    classes = [c for c in _blind().CLASSES if c != "none" and any(r["truth"] == c for r in rows)]
    L += ["", "## Top-1 by effect and plant (identifiable ones in brackets)", "",
          "| effect | paper | R-50 | all |", "|---|---|---|---|"]
    for c in classes:
        cells = []
        for sel in ("paper", "r50", None):
            rs = [r for r in eff if r["truth"] == c and (sel is None or r["plant"] == sel)]
            ri = [r for r in rs if identifiable(r)]
            cells.append(f"{sum(r['top1'] for r in rs)}/{len(rs)} ({sum(r['top1'] for r in ri)}/{len(ri)})"
                         if rs else "-")
        L.append(f"| {c} | " + " | ".join(cells) + " |")
    miss = [r for r in eff if not r["top1"]]
    L += ["", f"## The {len(miss)} misses", "",
          f"Answered `none`: {sum(r['verdict'] == 'none' for r in miss)}; another effect: "
          f"{sum(r['verdict'] != 'none' for r in miss)}; identifiable by the oracle: "
          f"{sum(identifiable(r) for r in miss)}.", "",
          "| plant | truth | verdict | misses | of them identifiable |", "|---|---|---|---|---|"]
    by = Counter((r["plant"], r["truth"], r["verdict"]) for r in miss)
    by_idf = Counter((r["plant"], r["truth"], r["verdict"]) for r in miss if identifiable(r))
    for (plant, truth, verdict), k in sorted(by.items(), key=lambda kv: (-kv[1], kv[0])):
        L.append(f"| {plant} | {truth} | {verdict} | {k} | {by_idf[(plant, truth, verdict)]} |")
    return "\n".join(L + _bounds_section(draws, classes)) + "\n"


def _estimates_section(draws: list[dict]) -> list[str]:
    """The pooled table's rows of the estimate targets (a delay within 3 ms, a gyro filter's
    cutoff within 15 %, the VAL R^2 within 0.02 of the true model's): the draws' counts
    summed and their largest errors' maximum, with a line naming the draws a row leaves
    out (a draw without that effect's cases, or one given by neither)."""
    blind = _blind()
    tot: dict = {}
    for d in draws:
        for name, (k, n, big) in (d.get("estimates") or {}).items():
            t = tot.setdefault(name, [0, 0, -math.inf, 0])
            t[0], t[1], t[3] = t[0] + k, t[1] + n, t[3] + 1
            t[2] = big if math.isnan(big) or math.isnan(t[2]) else max(t[2], big)  # a failed case stays nan
    if not tot:
        return []
    L = blind.estimate_rows({name: tuple(t[:3]) for name, t in tot.items()}, cell=_cell)
    short = [f"{name} over {t[3]} of the {len(draws)} draws" for name, t in tot.items() if t[3] < len(draws)]
    if short:
        L += ["", "Target rows pooled over fewer draws: " + "; ".join(short) + "."]
    return L


def _bounds_section(draws: list[dict], classes: list[str]) -> list[str]:
    """The quoted bounds' coverage pooled over the draws that report it: a calibrated
    1-sigma holds the truth on 68 % of right verdicts, a 2-sigma on 95 %."""
    have = [d for d in draws if d.get("bounds") is not None]
    if not have:
        return []
    tot: dict = {}
    for d in have:
        for k, c in d["bounds"].items():
            t = tot.setdefault(k, [0, 0, 0])
            for j in range(3):
                t[j] += c[j]
    L = ["", "## Quoted bounds", "",
         f"Pooled over the {len(have)} of {len(draws)} draws whose diagnoses or reports give them (seeds "
         f"{', '.join(str(d['seed']) for d in have)}): right verdicts only, the truth within the 1-sigma the "
         "diagnosis quotes for the verdict's parameter (68 % where calibrated) and within 2-sigma (95 %), each "
         "draw with the commit that diagnosed it.", "",
         "| effect | plant | cases with a bound | truth within 1-sigma | within 2-sigma |", "|---|---|---|---|---|"]
    for c in classes:
        for plant in ("paper", "r50"):
            if (c, plant) in tot:
                n, a, b = tot[(c, plant)]
                L.append(f"| {c} | {plant} | {n} | {_cell(a, n)} | {_cell(b, n)} |")
    for plant in ("paper", "r50", None):
        sel = [v for (_c, p), v in tot.items() if plant is None or p == plant]
        n, a, b = (sum(v[j] for v in sel) for j in range(3))
        if n:
            L.append(f"| all | {plant or 'both'} | {n} | {_cell(a, n)} | {_cell(b, n)} |")
    return L


def emit(text: str, out: str | None) -> None:
    """Write ``text`` whole to ``out`` (:func:`jaxgwo._atomic.atomic_write_text`: no half-written
    file), or print it where no file is named."""
    if out:
        from jaxgwo._atomic import atomic_write_text

        atomic_write_text(out, text)
        print(f"wrote {out}")
    else:
        print(text, end="")


def workdir_table_main(argv, description: str, rows_of, report) -> int:
    """The command line of a table over whole diagnosed workdirs (``blind_bias.py``,
    ``blind_tail_order.py``): ``W ... [--out F]``, each workdir read by :func:`read_workdir`,
    its rows ``rows_of(key, diagnoses)``, a seed given twice refused before anything is
    written, and ``report([(workdir, rows), ...], argv)`` emitted (:func:`emit`)."""
    argv = sys.argv[1:] if argv is None else list(argv)
    ap = argparse.ArgumentParser(description=description, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("workdirs", nargs="+", help="blind_diagnosis.py workdirs, each simulated and diagnosed")
    ap.add_argument("--out", default=None, help="write the markdown here (default: print it)")
    args = ap.parse_args(argv)
    draws, seeds = [], []
    for w in args.workdirs:
        draw, key, results = read_workdir(w)
        seeds.append(draw.get("seed"))
        draws.append((w, rows_of(key, results)))
    refuse_repeated_seeds(seeds)
    emit(report(draws, argv), args.out)
    return 0


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("workdirs", nargs="+",
                    help="blind_diagnosis.py workdirs, each simulated and diagnosed, or the .md reports it wrote")
    ap.add_argument("--out", default=None, help="write the markdown here (default: print it)")
    ap.add_argument("--header", default=None,
                    help="a markdown file placed verbatim under the title (a hand note on the draws pooled)")
    args = ap.parse_args(argv)
    header = None
    if args.header:
        try:
            with open(args.header) as f:
                header = f.read()
        except OSError as err:
            raise SystemExit(f"--header {args.header}: {err.strerror}; pass a markdown file, or leave --header out.") from None
    text = pool_report(load_draws(args.workdirs), argv, header)
    emit(text, args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
