"""Signed parameter errors of the blind study's right verdicts (benchmarks/blind_bias.py)."""

import json

import pytest
from _benchmarks import load_benchmark


@pytest.fixture(scope="module")
def bias():
    return load_benchmark("blind_bias")


def _draw(tmp_path, name, seed, cases):
    """A diagnosed workdir: ``cases`` maps a case to (plant, truth effect, truth params,
    verdict, fitted params, quoted sigma, structure finding or not)."""
    w = tmp_path / name
    w.mkdir()
    key, diag = {}, {}
    for case, (plant, effect, truth, verdict, fit, sigma, structure) in cases.items():
        key[case] = {"effect": effect, "plant": plant, "params": truth}
        ranking = [] if verdict == "none" else [{"effect": verdict, "params": fit, "params_sigma": sigma}]
        diag[case] = {"verdict": verdict, "ranking": ranking, "structure": {"params": {}} if structure else None}
    (w / "draw.json").write_text(json.dumps({"seed": seed}))
    (w / "key.json").write_text(json.dumps(key))
    (w / "diagnoses.json").write_text(json.dumps(diag))
    return str(w)


def test_signed_errors_are_pooled_by_effect_and_plant_against_hand_counts(bias, tmp_path):
    rate = lambda fit: ("r50", "rate_limit", {"rate": 2.0}, "rate_limit", {"rate": fit}, {"rate": 0.1}, True)  # noqa: E731
    a = _draw(tmp_path, "a", 1, {
        "case_000": rate(2.2), "case_001": rate(2.6),
        "case_002": ("paper", "time_delay", {"delay_s": 0.030}, "time_delay", {"delay_s": 0.0315}, {"delay_s": 0.001}, False),
        "case_003": ("paper", "rate_limit", {"rate": 3.0}, "none", None, None, False),  # a miss: not counted
        "case_004": ("paper", "none", None, "none", None, None, False),
    })  # fmt: skip
    b = _draw(tmp_path, "b", 2, {
        "case_000": rate(1.95),
        "case_001": ("paper", "cross_coupling", {"gain": -0.1}, "cross_coupling", {"gain": -0.05}, {}, False),
        "case_002": ("paper", "structural_mode", {"freq_hz": 10.0, "zeta_p": 0.05, "zeta_z": 0.2}, "structural_mode",
                     {"freq_hz": 10.1, "zeta_p": 0.06, "zeta_z": 0.2}, {"freq_hz": 0.05, "zeta_p": 0.005, "zeta_z": 0.1},
                     False),
    })  # fmt: skip
    out = tmp_path / "bias.md"
    assert bias.main([a, b, "--out", str(out)]) == 0
    lines = out.read_text().splitlines()
    assert "2 draws, 6 right verdicts." in lines[4]
    # ratios 1.1, 1.3, 0.975: median 1.1; 10th and 90th percentiles by linear interpolation
    # between order statistics, 0.975 + 0.2 * 0.125 and 1.1 + 0.8 * 0.2; |error|/sigma 2, 6, 0.5
    assert "| rate_limit | rate: fit / truth | r50 | 3 | 3 | 1.1 | 1 | 1.26 | 2/3 | 2.00 | 1/3 |" in lines
    assert "| time_delay | delay_s: fit - truth (ms) | paper | 1 | 0 | 1.5 | 1.5 | 1.5 | 1/1 | 1.50 | 0/1 |" in lines
    # a coupling is a difference (its gain may change sign); no sigma quoted, no bound column
    assert "| cross_coupling | gain: fit - truth | paper | 1 | 0 | 0.05 | 0.05 | 0.05 | 1/1 | - | - |" in lines
    # every parameter of an effect, the one the report scores first
    mode = [ln for ln in lines if ln.startswith("| structural_mode")]
    assert mode == ["| structural_mode | freq_hz: fit / truth | paper | 1 | 0 | 1.01 | 1.01 | 1.01 | 1/1 | 2.00 | 0/1 |",
                    "| structural_mode | zeta_p: fit / truth | paper | 1 | 0 | 1.2 | 1.2 | 1.2 | 1/1 | 2.00 | 0/1 |",
                    "| structural_mode | zeta_z: fit / truth | paper | 1 | 0 | 1 | 1 | 1 | 0/1 | 0.00 | 1/1 |"]
    assert not any(ln.startswith("| saturation") for ln in lines)  # no right verdict, no row


def test_a_part_diagnosed_draw_and_a_repeated_seed_are_refused_and_nothing_is_written(bias, tmp_path):
    a = _draw(tmp_path, "a", 1, {"case_000": ("paper", "none", None, "none", None, None, False)})
    b = _draw(tmp_path, "b", 1, {"case_000": ("paper", "none", None, "none", None, None, False)})
    out = tmp_path / "bias.md"
    with pytest.raises(SystemExit, match=r"seed\(s\) \[1\] appear in more than one"):
        bias.main([a, b, "--out", str(out)])
    key = json.loads((tmp_path / "a" / "key.json").read_text())
    (tmp_path / "a" / "key.json").write_text(json.dumps(key | {"case_001": {"effect": "none", "plant": "paper"}}))
    with pytest.raises(SystemExit, match="1 of 2 cases have no diagnosis"):
        bias.main([a, "--out", str(out)])
    assert not out.exists()
