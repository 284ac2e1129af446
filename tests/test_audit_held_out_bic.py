"""The held-out BIC audit (benchmarks/audit_held_out_bic.py) on a hand-built workdir."""

import json

import pytest
from _benchmarks import load_benchmark


@pytest.fixture(scope="module")
def audit_mod():
    return load_benchmark("audit_held_out_bic")


def _c(effect, cut, dbic, passes, acts=1.0, amplitude=0.0, ok=False):
    """A ranked candidate whose null refit's error is ``cut`` times its own."""
    detail = {"train_mse": 1.0, "null_train_mse": cut, "amplitude_corroborates": amplitude, "acts_on_held_out": acts,
              "p_output_error": 1e-4}  # fmt: skip
    if passes is not None:
        detail["effect_size_passes"] = passes
    return {"effect": effect, "train_p": 1e-4, "z_score": 1.0, "delta_bic_val": dbic, "beats_noise": ok,
            "detail": detail}  # fmt: skip


def _workdir(tmp_path, cases):
    w = tmp_path / "w1"
    w.mkdir()
    key = {c: {"effect": truth, "plant": "paper"} for c, (truth, _r) in cases.items()}
    diag = {c: {"verdict": "none", "ranking": r[:1], "ranking_paper_model": r[1:]} for c, (_t, r) in cases.items()}
    (w / "key.json").write_text(json.dumps(key))
    (w / "diagnoses.json").write_text(json.dumps(diag))
    return w


def test_audit_sorts_small_cut_candidates_into_sized_and_refused_by_hand(audit_mod, tmp_path):
    w = _workdir(tmp_path, {
        "case_000": ("none", [_c("saturation", 1.02, -1.4, True, ok=True),  # sized on a small cut: listed
                              _c("backlash", 1.03, -1.5, False)]),  # refused at level 2, not at 1
        "case_001": ("saturation", [_c("saturation", 1.30, -40.0, True),  # cut beyond 1.05: neither
                                    _c("rate_limit", 1.01, -0.5, False, acts=0.0)]),  # not acting on VAL
        "case_002": ("rate_limit", [_c("rate_limit", 1.01, -1.0, False, amplitude=1.0),  # amplitude-backed
                                    _c("time_delay", 1.01, -1.0, False),  # linear: never
                                    _c("backlash", 1.01, -3.0, False)]),  # short by more than the level
        "case_003": ("backlash", [_c("backlash", 1.01, -1.0, None)]),  # no size test stored
    })  # fmt: skip
    sized, refused = audit_mod.audit([w], level=2.0, min_error_ratio=1.05)
    assert len(sized) == 1 and "case_000" in sized[0] and "saturation" in sized[0] and "beats_noise True" in sized[0]
    assert len(refused) == 1 and "case_000" in refused[0] and "backlash" in refused[0]
    assert "dBIC_val -1.50" in refused[0]
    assert audit_mod.audit([w], level=1.0, min_error_ratio=1.05)[1] == []
    assert len(audit_mod.audit([w], level=3.5, min_error_ratio=1.05)[1]) == 2  # case_002's backlash joins
    # the cut's bound moves case_001's saturation in
    assert len(audit_mod.audit([w], level=2.0, min_error_ratio=1.5)[0]) == 2


def test_audit_refuses_a_report_for_a_workdir(audit_mod, tmp_path):
    with pytest.raises(SystemExit, match="no diagnoses.json"):
        audit_mod.audit([tmp_path], level=2.0, min_error_ratio=1.05)
    with pytest.raises(SystemExit):
        audit_mod.main([str(tmp_path), "--level", "-1"])
