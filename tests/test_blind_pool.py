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
