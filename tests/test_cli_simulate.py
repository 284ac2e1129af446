"""``jaxgwo simulate`` end to end (in process, so compilations are shared with other tests)."""

import numpy as np
import pytest

from jaxgwo._data import load_record
from jaxgwo.cli._main import main


def test_simulate_writes_a_valid_csv(tmp_path, capsys):
    out = tmp_path / "flight.csv"
    rc = main([
        "simulate", "--plant", "paper", "--channel", "both", "--excitation", "3211", "--duration", "4",
        "--effect", "time_delay:delay_s=0.03", "--effect", "sensor_lag:cutoff_hz=8,axis=lateral",
        "--seed", "3", "--truth", "--out", str(out),
    ])  # fmt: skip
    assert rc == 0
    assert "wrote" in capsys.readouterr().out
    rec = load_record(out)
    assert rec.sample_rate == pytest.approx(100.0)
    assert rec.duration == pytest.approx(3 + 4 + 5 + 4 + 3 - 0.01)
    meta = rec.metadata
    assert meta["plant"] == "paper" and meta["seed"] == "3" and meta["excitation"] == "3211"
    assert "time_delay: delay_s=(0.03, 0.03)" in meta["effects"] and "cutoff_hz=(8, inf)" in meta["effects"]
    assert "segment_2" in meta
    # the lateral 3-2-1-1 happens in segment 1 (3-7 s), the longitudinal one in segment 2
    t = np.asarray(rec.time)
    lat_exc, lon_exc = np.asarray(rec["exc_lat"]), np.asarray(rec["exc_lon"])
    assert np.all(lat_exc[(t > 8) & (t < 15)] == 0.0) and np.max(np.abs(lat_exc[t < 8])) == pytest.approx(0.1)
    assert np.max(np.abs(lon_exc[(t > 12) & (t < 17)])) == pytest.approx(0.1)
    # same seed, same file contents (apart from the command line)
    out2 = tmp_path / "again.csv"
    assert main(["simulate", "--plant", "paper", "--channel", "both", "--excitation", "3211", "--duration", "4",
                 "--effect", "time_delay:delay_s=0.03", "--effect", "sensor_lag:cutoff_hz=8,axis=lateral",
                 "--seed", "3", "--truth", "--out", str(out2)]) == 0
    np.testing.assert_array_equal(np.asarray(load_record(out2)["p"]), np.asarray(rec["p"]))


def test_simulate_r50_npz(tmp_path):
    out = tmp_path / "r50.npz"
    assert main(["simulate", "--plant", "r50", "--excitation", "multisine", "--duration", "20",
                 "--f-start", "0.5", "--f-stop", "5", "--attitude", "--out", str(out)]) == 0
    rec = load_record(out)
    # --attitude logs phi, theta: the roll attitude follows the integrated roll rate
    t, phi, p = (np.asarray(rec[c]) for c in ("time", "phi", "p"))
    dphi = np.gradient(phi, t)
    assert np.corrcoef(dphi, p)[0, 1] > 0.99
    assert rec.metadata["hold_loop"] == "on"
    assert "detection lines" in rec.metadata["segment_1"]
    assert np.all(np.isfinite(np.asarray(rec["p"])))


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--effect", "wobble"], "unknown effect 'wobble'"),
        (["--effect", "saturation:limit=-1"], "limit must be positive"),
        (["--sample-rate", "0"], "--sample-rate must be a positive number"),
        (["--f-stop", "80"], "Nyquist"),
        (["--effect", "time_delay:delay_s=0.5"], "longer than the simulator's 0.25 s buffer"),
    ],
)
def test_bad_input_exits_nonzero_without_output(tmp_path, capsys, argv, message):
    out = tmp_path / "never.csv"
    rc = main(["simulate", "--plant", "paper", "--excitation", "doublet", "--out", str(out), *argv])
    assert rc == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1
    assert list(tmp_path.iterdir()) == []


def test_bad_output_path(tmp_path, capsys):
    assert main(["simulate", "--out", str(tmp_path / "flight.txt")]) == 2
    assert ".csv or .npz" in capsys.readouterr().err
    assert main(["simulate", "--out", str(tmp_path / "missing" / "f.csv")]) == 2
    assert "directory does not exist" in capsys.readouterr().err
    assert main(["simulate"]) == 2
    assert "--out FILE is required" in capsys.readouterr().err
