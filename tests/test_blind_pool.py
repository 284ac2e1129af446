"""Pooling draws of the blind study (benchmarks/blind_pool.py)."""

import json
import os

import pytest
import scipy.stats
from _benchmarks import load_benchmark


@pytest.fixture(scope="module")
def pool():
    return load_benchmark("blind_pool")


@pytest.mark.parametrize("hits,n", [(0, 56), (3, 56), (365, 448), (64, 64), (1, 1)])
def test_wilson_interval_matches_scipy(pool, hits, n):
    ci = scipy.stats.binomtest(hits, n).proportion_ci(confidence_level=0.95, method="wilson")
    lo, hi = pool.wilson_interval(hits, n)
    assert lo == pytest.approx(ci.low, abs=1e-12)
    assert hi == pytest.approx(ci.high, abs=1e-12)


def test_wilson_interval_of_no_cases_is_undefined(pool):
    lo, hi = pool.wilson_interval(0, 0)
    assert lo != lo and hi != hi  # nan


def _row(truth, verdict, plant="paper", identifiable=True, mode=None, top2=None, order2=None):
    """A scored row as blind_diagnosis.score makes it (the fields the pool reads)."""
    return {"truth": truth, "verdict": verdict, "plant": plant, "top1": verdict == truth,
            "top2": verdict == truth if top2 is None else top2, "order2": order2 or [verdict, "none"],
            "identifiable": identifiable, "oracle_z_mode": None if mode is None else (5.0, 5.0),
            "identifiable_mode": bool(mode)}  # fmt: skip


def test_an_r50_row_is_identifiable_by_its_mode_oracle(pool):
    # the paper-model oracle says yes, the one with the extra pole pair says no: the latter counts
    assert not pool.identifiable(_row("rate_limit", "none", "r50", identifiable=True, mode=False))
    assert pool.identifiable(_row("rate_limit", "none", "r50", identifiable=False, mode=True))
    assert pool.identifiable(_row("rate_limit", "none", "paper", identifiable=True))
    assert pool.identifiable(_row("none", "none", identifiable=False))


def test_the_pooled_report_adds_the_draws_counts(pool):
    a = [_row("time_delay", "time_delay"), _row("time_delay", "none", order2=["none", "time_delay"]),
         _row("rate_limit", "none", "r50", mode=False), _row("none", "none")]
    b = [_row("time_delay", "time_delay"), _row("rate_limit", "rate_limit", "r50", mode=True),
         _row("rate_limit", "none", "paper", identifiable=True), _row("none", "time_delay")]
    draws = [{"workdir": "A", "seed": 1, "attitude": True, "rows": a},
             {"workdir": "B", "seed": 2, "attitude": False, "rows": b}]
    text = pool.pool_report(draws, ["A", "B"])
    lines = text.splitlines()
    # per draw: top-1 over effects, false alarms
    assert "| 1 | yes | 1/3 | 1/3 | 0/1 | 1/2 | 0/1 | 1/2 |" in lines
    assert "| 2 | no | 2/3 | 2/3 | 1/1 | 1/2 | 1/1 | 2/3 |" in lines
    lo, hi = pool.wilson_interval(3, 6)
    assert f"| top-1 over effects | 50 % (3/6; {100 * lo:.0f}-{100 * hi:.0f}) | >= 85 % |" in lines
    # the whole-ranking top-2 also counts the delay second behind `none`
    assert any(ln.startswith("| top-2 over the whole ranking (`class_order`) | 67 % (4/6;") for ln in lines)
    assert any(ln.startswith("| false alarms on none | 50 % (1/2;") for ln in lines)
    assert "| rate_limit | 0/1 (0/1) | 1/2 (1/1) | 1/3 (1/2) |" in lines
    # misses: three answered none, of which the R-50 rate limit is not identifiable (its mode oracle)
    assert "Answered `none`: 3; another effect: 0; identifiable by the oracle: 2." in lines
    assert "| paper | rate_limit | none | 1 | 1 |" in lines
    assert "| r50 | rate_limit | none | 1 | 0 |" in lines


def _workdir(tmp_path, name, seed, cases, diagnosed):
    w = tmp_path / name
    w.mkdir()
    (w / "draw.json").write_text(json.dumps({"seed": seed, "attitude": True}))
    (w / "key.json").write_text(json.dumps({c: {"effect": "none"} for c in cases}))
    (w / "diagnoses.json").write_text(json.dumps({c: {"verdict": "none"} for c in diagnosed}))
    return str(w)


class _Scorer:
    """Stands in for blind_diagnosis (its score reads the records, which these workdirs lack)."""

    @staticmethod
    def score(workdir, results):
        return {"rows": [_row("none", doc["verdict"]) for doc in results.values()]}

    @staticmethod
    def estimate_counts(rows):
        return {}


def test_load_draws_refuses_a_part_diagnosed_draw_and_a_repeated_seed(pool, tmp_path):
    full = _workdir(tmp_path, "w1", 7, ["case_000", "case_001"], ["case_000", "case_001"])
    draws = pool.load_draws([full], blind=_Scorer)
    assert [d["seed"] for d in draws] == [7] and len(draws[0]["rows"]) == 2
    part = _workdir(tmp_path, "w2", 8, ["case_000", "case_001"], ["case_000"])
    with pytest.raises(SystemExit, match="1 of 2 cases have no diagnosis"):
        pool.load_draws([part], blind=_Scorer)
    again = _workdir(tmp_path, "w3", 7, ["case_000"], ["case_000"])
    with pytest.raises(SystemExit, match=r"seed\(s\) \[7\] appear in more than one workdir"):
        pool.load_draws([full, again], blind=_Scorer)
    never = _workdir(tmp_path, "w4", 9, ["case_000"], [])
    os.remove(os.path.join(never, "diagnoses.json"))  # simulated, never diagnosed
    with pytest.raises(SystemExit, match="w4: no diagnoses.json"):
        pool.load_draws([never], blind=_Scorer)


def _full_row(case, truth, verdict, plant="paper", z=(8.0, 5.0), mode=None, second="none", top2=None):
    """A row with every field blind_diagnosis.write_report prints."""
    r50 = plant == "r50"
    return {"case": case, "plant": plant, "truth": truth, "verdict": verdict, "top1": verdict == truth,
            "top2": verdict == truth if top2 is None else top2, "order2": [verdict, second],
            "oracle_z": (None, None) if truth == "none" else z,
            "identifiable": truth == "none" or min(z) > 3.0, "oracle_z_mode": mode if r50 else None,
            "identifiable_mode": bool(r50 and mode and min(mode) > 3.0), "floor_z": (20.0, 10.0) if r50 else None,
            "observable": True, "param_error": None if truth == "none" else ("rel error (%)", 5.0),
            "exercised": None, "snr_db": 30.0, "r2_nominal": 0.9, "r2_after": 0.95, "r2_true": 0.96,
            "r2_refit": 0.95, "wall_s": 40.0, "structure_hz": 1.7 if r50 else None}  # fmt: skip


def test_a_report_reads_back_as_the_rows_it_was_written_from(pool, tmp_path):
    """blind_diagnosis.write_report's case table, read back by load_report, gives the rows
    the pool counts: plant, truth, verdict, top-1, top-2, the ordering's first two classes
    and the oracle's identifiability, the R-50's by its extra-pair oracle; a z printed as
    3.0 (3.04 here) reads as not above the threshold.  A report cut short is refused."""
    import types

    import numpy as np

    blind = pool._blind()
    rows = [_full_row("case_000", "time_delay", "time_delay", second="rotor_flapping"),
            _full_row("case_001", "rate_limit", "none", "r50", z=(40.0, 20.0), mode=(2.5, 6.0), second="rate_limit"),
            _full_row("case_002", "structural_mode", "structural_mode", "r50", z=(40.0, 9.0), mode=(7.0, 4.0)),
            _full_row("case_003", "none", "none", second="cross_coupling"),
            _full_row("case_004", "saturation", "backlash", z=(3.04, 9.0), second="saturation", top2=True)]
    classes = [r["truth"] for r in rows]
    conf = np.zeros((len(blind.CLASSES), len(blind.CLASSES)), int)
    args = types.SimpleNamespace(classes=",".join(classes), reuse=True, seed=5, cases_per_effect=1, r50_fraction=0.25,
                                 attitude=True, resume=False, out=str(tmp_path), report_name="rt")  # fmt: skip
    blind.write_report({"rows": rows, "confusion": conf}, args, str(tmp_path), 60.0)
    path = str(tmp_path / "rt.md")
    draw = pool.load_report(path, blind)
    assert (draw["seed"], draw["attitude"], len(draw["rows"])) == (5, True, 5)
    for got, want in zip(draw["rows"], rows, strict=True):
        for k in ("case", "plant", "truth", "verdict", "top1", "top2", "order2", "identifiable_mode"):
            assert got[k] == want[k], (want["case"], k)
        assert pool.identifiable(got) == (pool.identifiable(want) and want["case"] != "case_004"), want["case"]
    text = open(path).read()
    cut = tmp_path / "cut.md"
    cut.write_text(text.replace(next(ln for ln in text.splitlines() if ln.startswith("| case_004")) + "\n", ""))
    with pytest.raises(SystemExit, match="holds 4 of the 5 cases"):
        pool.load_report(str(cut), blind)
    bad = tmp_path / "bad.md"
    row = next(ln for ln in text.splitlines() if ln.startswith("| case_002"))
    bad.write_text(text.replace(row, row.replace("40.0, 9.0 (mode", "40.0, nine (mode")))
    with pytest.raises(SystemExit, match="cannot read the case row"):
        pool.load_report(str(bad), blind)
    with pytest.raises(SystemExit, match="no headline"):
        pool.load_report(_plain(tmp_path), blind)
    again = tmp_path / "again.md"
    again.write_text(text)
    with pytest.raises(SystemExit, match=r"seed\(s\) \[5\] appear in more than one"):
        pool.load_draws([path, str(again)], blind=blind)


def _plain(tmp_path) -> str:
    p = tmp_path / "plain.md"
    p.write_text("# not a report\n")
    return str(p)


def test_quoted_bounds_read_back_from_a_report_and_pool_over_the_draws_that_give_them(pool, tmp_path):
    """The report's "Quoted bounds" counts read back as bound_counts of the rows it was
    written from; the pool sums them over the draws that give them (a draw from before that
    table is named as left out) and prints the coverage with its Wilson interval."""
    import types

    import numpy as np

    blind = pool._blind()
    rows = [_full_row("case_000", "time_delay", "time_delay") | {"bound_z": 0.4},
            _full_row("case_001", "time_delay", "time_delay") | {"bound_z": 1.5},
            _full_row("case_002", "backlash", "backlash", "r50", mode=(7.0, 4.0)) | {"bound_z": 2.5},
            _full_row("case_003", "none", "none") | {"bound_z": None}]
    conf = np.zeros((len(blind.CLASSES), len(blind.CLASSES)), int)
    args = types.SimpleNamespace(classes=",".join(r["truth"] for r in rows), reuse=True, seed=9, cases_per_effect=1,
                                 r50_fraction=0.25, attitude=True, resume=False, out=str(tmp_path), report_name="qb")  # fmt: skip
    blind.write_report({"rows": rows, "confusion": conf}, args, str(tmp_path), 60.0)
    draw = pool.load_report(str(tmp_path / "qb.md"), blind)
    assert draw["bounds"] == pool.bound_counts(rows) == {("time_delay", "paper"): [2, 1, 2], ("backlash", "r50"): [1, 0, 0]}
    older = {"workdir": "old", "seed": 1, "attitude": True, "rows": [_row("time_delay", "time_delay")], "bounds": None}
    other = {"workdir": "B", "seed": 2, "attitude": True, "rows": [_row("time_delay", "time_delay")],
             "bounds": {("time_delay", "paper"): [3, 3, 3]}}
    lines = pool.pool_report([older, draw, other], ["old", "qb.md", "B"]).splitlines()
    assert any(ln.startswith("Pooled over the 2 of 3 draws") and "(seeds 9, 2)" in ln for ln in lines)
    lo, hi = pool.wilson_interval(4, 5)
    assert f"| time_delay | paper | 5 | 80 % (4/5; {100 * lo:.0f}-{100 * hi:.0f}) | 100 % (5/5; 57-100) |" in lines
    assert any(ln.startswith("| all | both | 6 | 67 % (4/6;") for ln in lines)


def test_estimate_targets_read_back_from_a_report_and_pool_over_the_draws(pool, tmp_path):
    """The report's rows for a delay within 3 ms, a cutoff within 15 % and the VAL R^2
    within 0.02 read back as estimate_counts of the rows they were written from (counted
    here by hand); the pool sums the counts, takes the largest error over the draws, and
    names a draw that lacks a row."""
    import types

    import numpy as np

    blind = pool._blind()

    def est(row, err, r2_after):
        return row | {"param_error": ("abs error (ms)", err), "r2_after": r2_after}

    rows = [est(_full_row("case_000", "time_delay", "time_delay"), 1.25, 0.95),  # |0.95 - 0.96| within 0.02
            est(_full_row("case_001", "time_delay", "none"), 3.5, 0.93),  # 3.5 ms and 0.03: both out
            est(_full_row("case_002", "sensor_lag", "sensor_lag"), 14.0, 0.955),
            _full_row("case_003", "none", "none")]
    want = {"time_delay": (1, 2, 3.5), "sensor_lag": (1, 1, 14.0), "val_r2": (3, 4, 0.03)}
    got = blind.estimate_counts(rows)
    assert got.keys() == want.keys()
    for k, (a, n, big) in want.items():
        assert got[k][:2] == (a, n) and got[k][2] == pytest.approx(big, abs=1e-12), k
    conf = np.zeros((len(blind.CLASSES), len(blind.CLASSES)), int)
    args = types.SimpleNamespace(classes=",".join(r["truth"] for r in rows), reuse=True, seed=11, cases_per_effect=1,
                                 r50_fraction=0.25, attitude=True, resume=False, out=str(tmp_path), report_name="es")  # fmt: skip
    blind.write_report({"rows": rows, "confusion": conf}, args, str(tmp_path), 60.0)
    draw = pool.load_report(str(tmp_path / "es.md"), blind)
    assert draw["estimates"] == {"time_delay": (1, 2, 3.5), "sensor_lag": (1, 1, 14.0), "val_r2": (3, 4, 0.03)}
    other = {"workdir": "B", "seed": 2, "attitude": True, "rows": [_row("time_delay", "time_delay")],
             "estimates": {"time_delay": (4, 4, 2.0), "val_r2": (5, 5, 0.011)}}
    lines = pool.pool_report([draw, other], ["es.md", "B"]).splitlines()
    assert any(ln.startswith("| time_delay estimated within 3 ms") and "(5/6;" in ln and "largest error 3.5 ms" in ln
               for ln in lines)  # fmt: skip
    assert any(ln.startswith("| sensor_lag estimated within 15 %") and "(1/1;" in ln for ln in lines)
    assert any(ln.startswith("| the proposed model's VAL R^2 within 0.02") and "(8/9;" in ln
               and "largest difference 0.030" in ln for ln in lines)  # fmt: skip
    assert "Target rows pooled over fewer draws: sensor_lag over 1 of the 2 draws." in lines
    bad = tmp_path / "bad_es.md"
    text = (tmp_path / "es.md").read_text()
    bad.write_text(text.replace("largest error 3.5 ms", "largest error ? ms"))
    with pytest.raises(SystemExit, match="cannot read the target row"):
        pool.load_report(str(bad), blind)


def test_a_hand_note_stands_under_the_title_and_a_missing_one_writes_nothing(pool, tmp_path):
    """--header puts a markdown note verbatim between the title and the command line, so
    the command a pooled file prints makes that file again; a note that is not there is
    refused before anything is written."""
    draws = [{"workdir": "A", "seed": 1, "attitude": True, "rows": [_row("time_delay", "time_delay")]}]
    note = "> Added by hand: seed 1 on abc1234.\n> A second line.\n"
    lines = pool.pool_report(draws, ["A"], header=note).splitlines()
    assert lines[:5] == ["# Blind diagnosis study, draws pooled", "", "> Added by hand: seed 1 on abc1234.",
                         "> A second line.", ""]  # fmt: skip
    assert lines[5] == "`python benchmarks/blind_pool.py A`"
    assert pool.pool_report(draws, ["A"]).splitlines()[2] == "`python benchmarks/blind_pool.py A`"
    out = tmp_path / "pool.md"
    with pytest.raises(SystemExit, match="--header .*missing.md"):
        pool.main([str(tmp_path / "w"), "--header", str(tmp_path / "missing.md"), "--out", str(out)])
    assert not out.exists()
