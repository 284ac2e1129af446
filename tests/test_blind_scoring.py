"""The blind study's reading of a report as an ordering of the classes (benchmarks/blind_diagnosis.py)."""

import argparse

import numpy as np
import pytest
from _benchmarks import load_benchmark


@pytest.fixture(scope="module")
def blind():
    return load_benchmark("blind_diagnosis")


def _doc(*entries):
    return {"ranking": [{"effect": e, "beats_noise": ok} for e, ok in entries]}


def test_none_sits_after_the_candidates_that_beat_noise(blind):
    doc = _doc(("time_delay", True), ("sensor_lag", True), ("rate_limit", False), ("backlash", False))
    assert blind.class_order(doc) == ["time_delay", "sensor_lag", "none", "rate_limit", "backlash"]
    # one passing candidate: none is second, the best failing one third
    doc = _doc(("saturation", True), ("rate_limit", False))
    assert blind.class_order(doc)[:2] == ["saturation", "none"]


def test_a_none_verdict_is_first_and_the_best_candidate_below_noise_second(blind):
    doc = _doc(("rotor_flapping", False), ("sensor_lag", False))
    assert blind.class_order(doc) == ["none", "rotor_flapping", "sensor_lag"]


def test_combined_entries_and_failed_cases(blind):
    doc = _doc(("time_delay+sensor_lag", True), ("time_delay", True), ("unknown", False))
    assert blind.class_order(doc) == ["time_delay", "none"]
    assert blind.class_order({"verdict": "error", "ranking": []}) == ["none"]


def _row(case, truth, verdict, *, order2=("none",), perr=None, r2_after=0.99, r2_true=0.99, r2_refit=float("nan"),
         bound_z=None, plant="paper"):
    return {"case": case, "truth": truth, "verdict": verdict, "top1": verdict == truth,
            "top2": verdict == truth, "order2": list(order2),
            "identifiable": True, "oracle_z": (5.0, 5.0), "oracle_z_mode": None, "floor_z": None,
            "identifiable_mode": False, "observable": True, "r2_nominal": 0.9, "r2_after": r2_after,
            "r2_true": r2_true, "r2_refit": r2_refit, "param_error": perr, "bound_z": bound_z, "exercised": None,
            "plant": plant, "snr_db": 30.0,
            "wall_s": 10.0, "structure_hz": None}  # fmt: skip


def _write(blind, tmp_path, rows):
    """The report of ``rows`` (an all-zero confusion matrix) in ``tmp_path``/r.md and r.png."""
    conf = np.zeros((len(blind.CLASSES), len(blind.CLASSES)), int)
    args = argparse.Namespace(classes=",".join(blind.CLASSES), reuse=False, resume=False, seed=1,
                              cases_per_effect=1, r50_fraction=0.0, attitude=False, report_name="r")  # fmt: skip
    blind.write_report({"rows": rows, "confusion": conf}, args, str(tmp_path), 60.0)


def test_the_report_counts_each_target_against_its_bound(blind, tmp_path):
    rows = [
        _row("case_000", "time_delay", "time_delay", order2=("time_delay", "none"), perr=("abs error (ms)", 1.0)),
        _row("case_001", "time_delay", "none", order2=("none", "time_delay"), perr=("abs error (ms)", 4.5),
             r2_after=0.95, r2_true=0.98),
        _row("case_002", "sensor_lag", "rotor_flapping", order2=("rotor_flapping", "none"),
             perr=("rel error of cutoff_hz (%)", 14.0)),
        _row("case_003", "none", "none", r2_after=0.99, r2_true=0.999),
    ]
    _write(blind, tmp_path, rows)
    text = (tmp_path / "r.md").read_text()
    assert "| time_delay estimated within 3 ms (its candidate, wherever it ranks) | 50 % (1/2), largest error 4.5 ms |" in text
    assert "| sensor_lag estimated within 15 % (its candidate, wherever it ranks) | 100 % (1/1), largest error 14 % |" in text
    assert "within 0.02 of the true model's (every case) | 75 % (3/4), largest difference 0.030 |" in text
    # top-1 1/3; the none verdict whose best candidate below noise is the truth counts over the ranking
    assert "| top-1 accuracy over effects | 33 % (1/3) |" in text
    assert "read over the whole ranking" in text and "`class_order`) | 67 % (2/3) |" in text
    assert (tmp_path / "r.png").stat().st_size > 0


def test_a_failed_case_shows_in_the_r2_target_row(blind, tmp_path):
    rows = [_row("case_000", "backlash", "backlash", order2=("backlash", "none")),
            _row("case_001", "saturation", "error", r2_after=float("nan"))]  # a diagnosis that raised
    _write(blind, tmp_path, rows)
    assert "(every case) | 50 % (1/2), largest difference nan |" in (tmp_path / "r.md").read_text()


def test_the_report_counts_the_none_verdicts_whose_summary_names_the_null_refit(blind, tmp_path):
    """The summary's rule (REFIT_MARGIN_R2 = 1e-3): 0.0009 above the frequency-domain fit
    is level, 0.0011 above is named; an effect verdict and a report without the refit (nan)
    are not counted."""
    rows = [
        _row("case_000", "none", "none", r2_after=0.990, r2_true=0.998, r2_refit=0.9911),  # named: 0.008 -> 0.0069
        _row("case_001", "rotor_flapping", "none", r2_after=0.975, r2_true=0.993, r2_refit=0.992),  # 0.018 -> 0.001
        _row("case_002", "none", "none", r2_after=0.990, r2_true=0.995, r2_refit=0.9909),  # level
        _row("case_003", "none", "none", r2_after=0.990, r2_true=0.995),  # no refit in the report
        _row("case_004", "time_delay", "time_delay", r2_after=0.95, r2_true=0.99, r2_refit=0.99),
    ]
    _write(blind, tmp_path, rows)
    text = (tmp_path / "r.md").read_text()
    assert ("as the better model, its VAL R^2 0.001 or more above the frequency-domain fit's: \\|R^2 - the true "
            "model's\\|, median / max | 2/4; frequency-domain fit 0.0130 / 0.0180 -> refit 0.0040 / 0.0069 | |") in text


def test_bound_z_is_the_error_in_quoted_sigmas(blind):
    """|fit - truth| / sigma of the effect's own parameter; no finite positive sigma, no number."""
    assert blind.bound_z("time_delay", {"delay_s": 0.030}, {"delay_s": 0.033}, {"delay_s": 0.002}) == pytest.approx(1.5)
    assert blind.bound_z("structural_mode", {"freq_hz": 10.0, "zeta_p": 0.05},
                         {"freq_hz": 9.0, "zeta_p": 0.2}, {"freq_hz": 0.25, "zeta_p": 1e-4}) == pytest.approx(4.0)
    for sigma in (None, {}, {"rate": 0.0}, {"rate": float("nan")}, {"rate": float("inf")}):
        assert blind.bound_z("rate_limit", {"rate": 2.0}, {"rate": 2.1}, sigma) is None


def test_the_report_counts_the_truth_within_the_quoted_bounds_per_effect_and_plant(blind, tmp_path):
    rows = [_row(f"case_{i:03d}", "time_delay", "time_delay", bound_z=z) for i, z in enumerate((0.5, 1.5, 2.5))]
    rows += [_row("case_010", "time_delay", "time_delay", bound_z=3.0, plant="r50"),
             _row("case_011", "time_delay", "none"),  # no verdict, no bound
             _row("case_012", "backlash", "backlash")]  # a right verdict without a quoted sigma
    _write(blind, tmp_path, rows)
    text = (tmp_path / "r.md").read_text()
    section = text.split("## Quoted bounds")[1].split("\n## ")[0]
    assert "| time_delay | paper | 3 | 1 | 2 | 1.50 |" in section
    assert "| time_delay | r50 | 1 | 0 | 0 | 3.00 |" in section
    assert "| backlash |" not in section
