"""The failing tail's two orders replayed on stored draws (benchmarks/blind_tail_order.py)."""

import json

import pytest
from _benchmarks import load_benchmark


@pytest.fixture(scope="module")
def tail():
    return load_benchmark("blind_tail_order")


def _c(effect, score, p, ok=False, **detail):
    return {"effect": effect, "score": score, "train_p": p, "beats_noise": ok, "detail": detail}


def _draw(tmp_path, name, seed, cases):
    """A diagnosed workdir: ``cases`` maps a case to (plant, truth, ranking entries)."""
    w = tmp_path / name
    w.mkdir()
    key = {c: {"effect": e, "plant": plant, "params": None} for c, (plant, e, _r) in cases.items()}
    diag = {c: {"verdict": r[0]["effect"] if r and r[0]["beats_noise"] else "none", "ranking": r}
            for c, (_p, _e, r) in cases.items()}  # fmt: skip
    (w / "draw.json").write_text(json.dumps({"seed": seed}))
    (w / "key.json").write_text(json.dumps(key))
    (w / "diagnoses.json").write_text(json.dumps(diag))
    return str(w)


def test_the_tail_is_replayed_in_both_orders_against_hand_counts(tail, tmp_path):
    # stored in evidence order (as a draw after the change stores it): the score order is rebuilt
    mode_by_p = [_c("structural_mode", -10.2, 1e-4), _c("cross_coupling", -9.9, 0.3), _c("backlash", -9.95, 1.0)]
    # stored in score order, the truth (a rate limit) last by score but first by p
    rate_by_score = [_c("cross_coupling", -9.9, 0.2), _c("backlash", -9.95, 1.0), _c("rate_limit", -10.1, 1e-5)]
    a = _draw(tmp_path, "a", 1, {
        "case_000": ("paper", "structural_mode", mode_by_p),
        "case_001": ("r50", "rate_limit", rate_by_score),
        # a verdict: its passing head decides, the tail's order cannot move the top two
        "case_002": ("paper", "time_delay", [_c("time_delay", 1.0, 1e-9, True), _c("backlash", -9.0, 1e-6)]),
        # the coupling leads by score and trails by p: top-2 lost by evidence
        "case_003": ("paper", "cross_coupling", [_c("cross_coupling", -9.9, 0.5), _c("saturation", -9.95, 0.01)]),
        "case_004": ("paper", "none", [_c("saturation", -9.9, 0.5)]),  # no effect: not counted
    })  # fmt: skip
    b = _draw(tmp_path, "b", 2, {
        # a verdict whose second candidate beats noise too: top-2 over the candidates that do
        "case_000": ("paper", "backlash", [_c("saturation", 0.5, 1e-4, True), _c("backlash", 0.3, 1e-3, True),
                                           _c("rate_limit", -9.0, 1e-9)]),
    })  # fmt: skip
    out = tmp_path / "tail.md"
    assert tail.main([a, b, "--out", str(out)]) == 0
    lines = out.read_text().splitlines()
    assert "2 draws, 5 effect cases, 3 of them answered `none`." in lines[4]
    row = lambda plant, effect: next(ln for ln in lines if ln.startswith(f"| {plant} | {effect} |"))  # noqa: E731
    assert row("paper", "structural_mode").endswith("| 1 | 0 % (0/1; 0-79) | 100 % (1/1; 21-100) | 1 | 0/1 | 1/1 |")
    assert row("r50", "rate_limit").endswith("| 1 | 0 % (0/1; 0-79) | 100 % (1/1; 21-100) | 1 | 0/1 | 1/1 |")
    assert row("paper", "cross_coupling").endswith("| 1 | 100 % (1/1; 21-100) | 0 % (0/1; 0-79) | 1 | 1/1 | 0/1 |")
    assert row("paper", "time_delay").endswith("| 1 | 100 % (1/1; 21-100) | 100 % (1/1; 21-100) | 0 | 0/0 | 0/0 |")
    assert row("paper", "backlash").endswith("| 1 | 100 % (1/1; 21-100) | 100 % (1/1; 21-100) | 0 | 0/0 | 0/0 |")
    assert row("both", "all") == ("| both | all | 5 | 60 % (3/5; 23-88) | 80 % (4/5; 38-96) | 3 | 1/3 | 2/3 |")
    assert not any(ln.startswith("| paper | none |") for ln in lines)


def test_reorder_keeps_the_passing_head_and_sorts_only_the_tail(tail):
    ranking = [_c("saturation", 0.5, 1e-2, True), _c("cross_coupling", -9.9, 0.3), _c("rotor_flapping", -9.95, 1e-3),
               _c("sensor_lag", -9.96, 1e-3 * (1 - 1e-12)), _c("backlash", -9.0, None)]  # fmt: skip
    by_p = [c["effect"] for c in tail.reorder(ranking, "evidence")]
    # the lags share their p and keep their order; a p that is no number goes last
    assert by_p == ["saturation", "rotor_flapping", "sensor_lag", "cross_coupling", "backlash"]
    by_score = [c["effect"] for c in tail.reorder(ranking, "score")]
    assert by_score == ["saturation", "backlash", "cross_coupling", "rotor_flapping", "sensor_lag"]


def test_a_repeated_seed_is_refused_and_nothing_is_written(tail, tmp_path):
    a = _draw(tmp_path, "a", 1, {"case_000": ("paper", "none", [])})
    b = _draw(tmp_path, "b", 1, {"case_000": ("paper", "none", [])})
    out = tmp_path / "tail.md"
    with pytest.raises(SystemExit, match=r"seed\(s\) \[1\] appear in more than one"):
        tail.main([a, b, "--out", str(out)])
    assert not out.exists()


@pytest.mark.parametrize("gyro, held", [
    ({"tested": False}, None),
    ({"tested": True, "filter_found": False, "cutoff_hz": 30.0}, False),
    ({"tested": True, "filter_found": True, "cutoff_hz": 30.0}, True),
    ({"tested": True, "filter_found": True, "cutoff_hz": 150.0}, False),  # above the candidate's box
])  # fmt: skip
def test_the_gyro_path_read_back_orders_the_lags_as_the_diagnosis_did(tail, gyro, held):
    doc = {"where": {"gyro_path": gyro}}
    assert tail.filter_held(doc) is held
    ranking = [_c("sensor_lag", -9.8, 0.2), _c("rotor_flapping", -9.9, 0.2)]
    first = [c["effect"] for c in tail.reorder(ranking, "evidence", tail.filter_held(doc))][0]
    assert first == {None: "sensor_lag", False: "rotor_flapping", True: "sensor_lag"}[held]
