"""The blind study's reading of a report as an ordering of the classes (benchmarks/blind_diagnosis.py)."""

import importlib.util
import os

import pytest

_PATH = os.path.join(os.path.dirname(__file__), os.pardir, "benchmarks", "blind_diagnosis.py")


@pytest.fixture(scope="module")
def blind():
    spec = importlib.util.spec_from_file_location("blind_diagnosis", _PATH)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


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
