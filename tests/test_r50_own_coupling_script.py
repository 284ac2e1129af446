"""The R-50 own-coupling reader (benchmarks/r50_own_coupling.py) on a hand-built workdir."""

import json

import pytest
from _benchmarks import load_benchmark


def _workdir(tmp_path, seed=621):
    draw = {"seed": seed, "cases_per_effect": 8}
    key = {"case_001": {"effect": "cross_coupling", "plant": "r50", "params": {"gain": -0.1}},
           "case_002": {"effect": "none", "plant": "r50", "params": {}},
           "case_003": {"effect": "none", "plant": "paper", "params": {}},
           "case_004": {"effect": "cross_coupling", "plant": "r50", "params": {"gain": 0.25}}}  # fmt: skip

    def doc(verdict, gain):
        return {"verdict": verdict, "ranking": [{"effect": "time_delay", "params": {"delay_s": 0.0}},
                                                {"effect": "cross_coupling", "params": {"gain": gain}}]}  # fmt: skip

    diagnoses = {"case_001": doc("none", -0.04), "case_002": doc("none", 0.05), "case_003": doc("none", 0.0),
                 "case_004": doc("cross_coupling", 0.31)}  # fmt: skip
    for name, content in (("draw", draw), ("key", key), ("diagnoses", diagnoses)):
        (tmp_path / f"{name}.json").write_text(json.dumps(content))
    return str(tmp_path)


def test_own_mixing_of_the_redrawn_r50_variants_and_the_summary(tmp_path, capsys):
    """Only the R-50 coupling and ``none`` cases are read; each variant's ``Blon/Blat`` lies
    within the study's spread (every parameter scaled by 0.85-1.15) of the published R-50's,
    the bar's path lowers it, and the same seed redraws the same airframe."""
    from jaxgwo._plants import r50_reference

    mod = load_benchmark("r50_own_coupling")
    w = _workdir(tmp_path)
    rows = list(mod._rows(w))
    assert [r["case"] for r in rows] == ["621/case_001", "621/case_002", "621/case_004"]
    ref = r50_reference()["params"]
    published = ref["Blon"] / ref["Blat"]
    for r in rows:
        assert published * 0.85 / 1.15 <= r["own"] <= published * 1.15 / 0.85
        assert 0.0 < r["own_bar"] < r["own"]
    assert [r["fit"] - r["gain"] for r in rows] == pytest.approx([0.06, 0.05, 0.06])
    assert [r["own"] for r in mod._rows(w)] == [r["own"] for r in rows]
    mod.main([w])
    out = capsys.readouterr().out
    assert "R-50 none: 1, fitted gains +0.050 to +0.050" in out
    assert "|gain| >= 0.136: 1, named 1, none 0" in out and "|gain| < 0.136: 1, named 0, none 1" in out
