"""The airframe-bracket scorer (benchmarks/airframe_bracket.py) on hand-built reports."""

import json

import pytest
from _benchmarks import load_benchmark


@pytest.fixture(scope="module")
def mod():
    return load_benchmark("airframe_bracket")


def _doc(verdict, param=None, value=None, sigma=None, detail=None):
    top = {"effect": verdict, "params": {param: value} if param else {}, "params_sigma": {param: sigma} if param else {},
           "detail": detail or {}}  # fmt: skip
    return {"verdict": verdict, "ranking": [top]}


def test_bracket_rows_score_only_right_verdicts_with_both_readings(mod, tmp_path):
    key = {"case_000": {"effect": "rotor_flapping", "plant": "r50", "params": {"tau_f": 0.015}},
           "case_001": {"effect": "time_delay", "plant": "r50", "params": {"delay_s": 0.030}},
           "case_002": {"effect": "rotor_flapping", "plant": "r50", "params": {"tau_f": 0.020}},
           "case_003": {"effect": "rate_limit", "plant": "r50", "params": {"rate": 4.0}},
           "case_004": {"effect": "time_delay", "plant": "paper", "params": {"delay_s": 0.030}}}  # fmt: skip
    (tmp_path / "key.json").write_text(json.dumps(key))
    w = str(tmp_path)
    reports = {
        f"{w}:case_000": _doc("rotor_flapping", "tau_f", 0.014, 0.004,  # inside, |error| / sigma 0.25
                              {"tau_f_pair_s": 0.006, "tau_f_airframe_s": 0.022, "airframe_J_ratio": 0.7}),
        f"{w}:case_001": _doc("time_delay", "delay_s", 0.036, 0.002,  # outside the bracket, 3 sigma off
                              {"delay_pair_s": 0.034, "delay_airframe_s": 0.038, "airframe_J_ratio": 0.8}),
        f"{w}:case_002": _doc("none"),
        f"{w}:case_003": _doc("rate_limit", "rate", 5.0, 0.1),
        f"{w}:case_004": _doc("time_delay", "delay_s", 0.031, 0.001, {"airframe_J_ratio": 1.3}),
    }
    truths = {s: mod._truth(s) for s in reports}
    rows, skipped = mod.bracket_rows(reports, truths)
    assert [r["case"].split(":")[1] for r in rows] == ["case_000", "case_001"]
    assert rows[0]["z"] == pytest.approx(0.25) and rows[1]["z"] == pytest.approx(3.0)
    assert len(skipped) == 3 and any("no airframe reading" in s for s in skipped)
    text = mod.report(rows, skipped)
    assert "2 cases: truth inside the bracket 1, within 1-sigma 1, within 2-sigma 1" in text
    assert "pair reading below the truth 1, lead-lag above it 2" in text  # case_001 reads both long


def test_from_file_scores_without_diagnosing(mod, tmp_path, capsys):
    (tmp_path / "key.json").write_text(json.dumps({"case_000": {"effect": "none", "plant": "paper", "params": {}}}))
    out = tmp_path / "r.json"
    out.write_text(json.dumps({f"{tmp_path}:case_000": _doc("none")}))
    assert mod.main(["--from", str(out)]) == 0
    assert "0 cases" in capsys.readouterr().out
    with pytest.raises(SystemExit):
        mod.main([])


def test_named_lags_are_scored_at_the_centre_and_at_the_lead_lag(mod, tmp_path, capsys):
    """A flapping lag named between the airframe models: both readings scored against the
    truth under the quoted 1-sigma, read from a workdir's stored diagnoses (``--stored``)."""
    key = {"case_000": {"effect": "rotor_flapping", "plant": "r50", "params": {"tau_f": 0.020}},
           "case_001": {"effect": "rotor_flapping", "plant": "r50", "params": {"tau_f": 0.015}}}  # fmt: skip
    (tmp_path / "key.json").write_text(json.dumps(key))
    named = {"tau_f_pair_s": 0.002, "tau_f_airframe_s": 0.024, "airframe_J_ratio": 0.7, "named_between_airframes": 1.0}
    stored = {"case_000": _doc("rotor_flapping", "tau_f", 0.024, 0.005, named),  # centre 13 ms, lead-lag 24 ms
              "case_001": _doc("rotor_flapping", "tau_f", 0.016, 0.004,  # beat noise: not scored twice
                               {"tau_f_pair_s": 0.010, "tau_f_airframe_s": 0.022, "airframe_J_ratio": 0.8})}  # fmt: skip
    with pytest.raises(SystemExit, match="no diagnoses.json"):  # simulated, never diagnosed
        mod.stored_reports([str(tmp_path)])
    (tmp_path / "diagnoses.json").write_text(json.dumps(stored))
    (tmp_path / "draw.json").write_text(json.dumps({"seed": 1}))
    reports = mod.stored_reports([str(tmp_path)])
    rows, _skipped = mod.bracket_rows(reports, {s: mod._truth(s) for s in reports})
    assert [r["named"] for r in rows] == [True, False]
    text = mod.report(rows, [])
    assert "1 named between the airframe models" in text
    # centre (2 + 24) / 2 = 13 ms: 7 ms low, 1.4 sigma; lead-lag 4 ms long, 0.8 sigma
    assert "centre: error -7.0 to -7.0 ms, mean -7.0, rms 7.0; within 1-sigma 0, within 2-sigma 1" in text
    assert "lead-lag: error +4.0 to +4.0 ms, mean +4.0, rms 4.0; within 1-sigma 1, within 2-sigma 1" in text
    assert mod.main(["--stored", str(tmp_path)]) == 0
    assert "2 cases" in capsys.readouterr().out
