"""Real logs in: ArduPilot DataFlash and PX4 ULog readers, the resampler and load_any.

The logs are written by the minimal encoders in ``tests/_logwriters.py`` from known
sinusoids and read back through pymavlink and pyulog themselves.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("pymavlink")
pytest.importorskip("pyulog")

from _logwriters import (  # noqa: E402
    ACTUATOR_CONTROLS,
    ANGULAR_VELOCITY,
    ATT,
    ATTITUDE,
    FMTU,
    RATE,
    SIDD,
    SIDS,
    TORQUE_SETPOINT,
    UNIT,
    DataFlashWriter,
    ULogWriter,
)
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from jaxgwo import FlightDataError, FlightRecord, load_record, make_record, save_record  # noqa: E402
from jaxgwo._logs import (  # noqa: E402
    FORMATS,
    SystemIdRun,
    ardupilot_runs,
    detect_format,
    load_any,
    load_ardupilot,
    load_px4,
)

DEG = np.pi / 180.0
TAU = 2.0 * np.pi

# -- the signals logged (t in seconds since boot) ----------------------------------------


def rout(t):  # RATE.ROut, normalised
    return 0.1 * np.sin(TAU * 1.1 * t)


def pout(t):  # RATE.POut
    return 0.08 * np.cos(TAU * 0.9 * t)


def r_deg(t):  # RATE.R, deg/s
    return 30.0 * np.sin(TAU * 0.7 * t + 0.3)


def p_deg(t):  # RATE.P, deg/s
    return -25.0 * np.sin(TAU * 0.5 * t)


def roll_deg(t):  # ATT.Roll, deg
    return 4.0 * np.sin(TAU * 0.6 * t)


def pitch_deg(t):  # ATT.Pitch, deg
    return -3.0 * np.cos(TAU * 0.4 * t)


def targ(t):  # SIDD.Targ: differs from ROut, so the input choice shows
    return 0.05 * np.sin(TAU * 1.7 * t)


def gx_deg(t):  # SIDD.Gx: differs from RATE.R, so the output choice shows
    return 1.1 * r_deg(t)


def gy_deg(t):
    return 1.1 * p_deg(t)


# Second derivative bounds |f''| (amplitude * omega^2) for the linear-interpolation error
# bound h^2/8 max|f''|, in the output's units.
CURVATURE = {
    "delta_lat": 0.1 * (TAU * 1.1) ** 2,
    "delta_lon": 0.08 * (TAU * 0.9) ** 2,
    "p": 30.0 * DEG * (TAU * 0.7) ** 2,
    "q": 25.0 * DEG * (TAU * 0.5) ** 2,
}

# Two runs: run 0 (SID_AXIS 10, Mixer Roll) enters at 3 s and the mode's own finish
# (3 + 1 + TFin + TC + TR + TFout = 9.5 s) ends it although SIDD goes on to 14 s; run 1
# (SID_AXIS 11, Mixer Pitch) enters at 16 s and the pilot leaves the mode at 21 s,
# before its nominal end at 26.5 s, so the last SIDD sample ends it.
RUNS = (
    dict(start=3.0, axis=10, TFin=0.5, TC=0.5, TR=4.0, TFout=0.5, sidd_until=14.0),
    dict(start=16.0, axis=11, TFin=1.0, TC=0.5, TR=7.0, TFout=1.0, sidd_until=21.0),
)


def write_dataflash(
    path: Path,
    *,
    runs=RUNS,
    span=(1.0, 30.0),
    rate_hz=200.0,
    jitter_us=0,
    sidd_every=2,
    drop=None,
    nan_at=None,
    rate_format=RATE,
    sids_format=SIDS,
    with_rate=True,
    att_every=None,
    seed=0,
) -> Path:
    """A System ID log: RATE every loop of ``rate_hz``, SIDD every ``sidd_every`` loops
    while in the mode, SIDS on entering it.  ``drop=(t0, t1)`` leaves RATE out there,
    ``nan_at`` writes one NaN roll rate; ``att_every`` logs ATT every that many loops."""
    rng = np.random.default_rng(seed)
    w = DataFlashWriter()
    for d in (sids_format, SIDD):
        w.define(*d)
    if with_rate:
        w.define(*rate_format)
    if att_every:
        w.define(*ATT)
    loops = np.arange(int(round(span[0] * rate_hz)), int(round(span[1] * rate_hz)))
    pending = sorted(runs, key=lambda r: r["start"])
    for k in loops:
        us = int(round(k * 1e6 / rate_hz)) + (
            int(rng.integers(-jitter_us, jitter_us + 1)) if jitter_us else 0
        )
        t = us * 1e-6
        while pending and t >= pending[0]["start"]:
            r = pending.pop(0)
            w.write(
                "SIDS",
                TimeUS=us,
                Ax=r["axis"],
                Mag=0.1,
                FSt=0.5,
                FSp=10.0,
                TFin=r["TFin"],
                TC=r["TC"],
                TR=r["TR"],
                TFout=r["TFout"],
            )
        if with_rate and not (drop and drop[0] <= t < drop[1]):
            r_value = np.nan if nan_at is not None and abs(t - nan_at) < 0.5 / rate_hz else r_deg(t)
            values = dict(TimeUS=us, R=r_value, ROut=rout(t), P=p_deg(t), POut=pout(t))
            if rate_format is not RATE:
                values = {k: v for k, v in values.items() if k in rate_format[2].split(",")}
            w.write("RATE", **values)
        if att_every and k % att_every == 0:
            w.write("ATT", TimeUS=us, Roll=roll_deg(t), Pitch=pitch_deg(t))
        in_mode = any(r["start"] <= t < r["sidd_until"] for r in runs)
        if in_mode and k % sidd_every == 0:
            w.write("SIDD", TimeUS=us + 20, Targ=targ(t), Gx=gx_deg(t), Gy=gy_deg(t))
    path.write_bytes(w.to_bytes())
    return path


def write_ulog(path: Path, *, old_firmware=False, span=(2.0, 8.0), rate_hz=250.0, gap=None, att_every=None) -> Path:
    """A PX4 log: angular velocity (timestamp_sample = t) and the torque setpoint (or
    actuator_controls_0), both at ``rate_hz``; ``gap=(t0, t1)`` drops the gyro there;
    ``att_every``: vehicle_attitude every that many samples (roll_deg, pitch_deg, no yaw)."""
    u = ULogWriter(start_us=1_000_000)
    u.info("sys_name", "PX4")
    u.topic("vehicle_angular_velocity", ANGULAR_VELOCITY)
    if old_firmware:
        u.topic("actuator_controls_0", ACTUATOR_CONTROLS)
    else:
        u.topic("vehicle_torque_setpoint", TORQUE_SETPOINT)
    if att_every:
        u.topic("vehicle_attitude", ATTITUDE)
    for k in range(int(round(span[0] * rate_hz)), int(round(span[1] * rate_hz))):
        us = int(round(k * 1e6 / rate_hz))
        t = us * 1e-6
        if not (gap and gap[0] <= t < gap[1]):
            u.write(
                "vehicle_angular_velocity",
                timestamp=us + 300,
                timestamp_sample=us,
                xyz_0=r_deg(t) * DEG,
                xyz_1=p_deg(t) * DEG,
            )
        if att_every and k % att_every == 0:
            hr, hp = roll_deg(t) * DEG / 2, pitch_deg(t) * DEG / 2  # ZYX Euler, yaw 0, as a quaternion
            u.write("vehicle_attitude", timestamp=us + 500, timestamp_sample=us, q_0=np.cos(hr) * np.cos(hp),
                    q_1=np.sin(hr) * np.cos(hp), q_2=np.cos(hr) * np.sin(hp), q_3=-np.sin(hr) * np.sin(hp))
        if old_firmware:
            u.write(
                "actuator_controls_0",
                timestamp=us,
                timestamp_sample=us,
                control_0=rout(t),
                control_1=pout(t),
            )
        else:
            u.write(
                "vehicle_torque_setpoint",
                timestamp=us,
                timestamp_sample=us,
                xyz_0=rout(t),
                xyz_1=pout(t),
            )
    path.write_bytes(u.to_bytes())
    return path


f32 = np.float32


@pytest.fixture(scope="module")
def logs(tmp_path_factory):
    d = tmp_path_factory.mktemp("logs")
    return {
        "exact": write_dataflash(d / "exact.bin"),
        "jitter": write_dataflash(d / "jitter.bin", jitter_us=400, seed=1),
        "ulog": write_ulog(d / "flight.ulg"),
    }


def interpolation_bound(h, column):
    """h^2/8 max|f''| for the longest logged step h, plus float32 storage rounding."""
    return h**2 / 8.0 * CURVATURE[column] + 1e-6


# -- ArduPilot -----------------------------------------------------------------------------


def test_mixer_round_trip_within_interpolation_error(logs):
    rec = load_ardupilot(logs["jitter"], run=0)
    assert isinstance(rec, FlightRecord)
    assert rec.columns == ("time", "delta_lat", "delta_lon", "p", "q")
    t = np.asarray(rec.time)
    # RATE's median logging period is 5 ms whatever the +-0.4 ms jitter
    assert rec.sample_rate == pytest.approx(200.0, rel=0.01)
    np.testing.assert_allclose(np.diff(t), 1.0 / rec.sample_rate, rtol=1e-9)
    assert t[0] == pytest.approx(3.0, abs=0.006) and t[-1] == pytest.approx(9.5, abs=0.006)
    h = 0.005 + 2 * 0.0004  # the longest logged step
    truths = {
        "delta_lat": (rout, 0.1 * TAU * 1.1),
        "delta_lon": (pout, 0.08 * TAU * 0.9),
        "p": (lambda s: r_deg(s) * DEG, 30 * DEG * TAU * 0.7),
        "q": (lambda s: p_deg(s) * DEG, 25 * DEG * TAU * 0.5),
    }
    for column, (truth, max_slope) in truths.items():
        err = np.max(np.abs(np.asarray(rec[column]) - truth(t)))
        # linear interpolation error h^2/8 max|f''|, plus the logged times rounded to
        # 1 us (max|f'| * 1 us) and float32 storage (relative 6e-8 of the amplitude)
        bound = h**2 / 8 * CURVATURE[column] + max_slope * 1e-6 + 1e-6
        assert err <= bound, (column, err, bound)
        assert err > 1e-7  # jitter really made it interpolate


def test_exact_grid_keeps_logged_samples_and_converts_deg_to_rad(logs):
    rec = load_ardupilot(logs["exact"], run=0)
    t = np.asarray(rec.time)
    assert rec.sample_rate == pytest.approx(200.0, rel=1e-9)
    assert t[0] == pytest.approx(3.0, abs=1e-9) and t[-1] == pytest.approx(9.5, abs=1e-9)
    # no jitter: the grid is the logged times, so values are the float32 samples exactly
    np.testing.assert_allclose(np.asarray(rec["delta_lat"]), f32(rout(t)), rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(
        np.asarray(rec["p"]), f32(r_deg(t)).astype(float) * DEG, rtol=1e-9, atol=1e-12
    )
    np.testing.assert_allclose(
        np.asarray(rec["q"]), f32(p_deg(t)).astype(float) * DEG, rtol=1e-9, atol=1e-12
    )
    # SIDD.Gx/Gy are deg/s too
    sidd = load_ardupilot(logs["exact"], run=0, output="sidd")
    ts = np.asarray(sidd.time)
    # SIDD is stamped 20 us after the loop it samples
    np.testing.assert_allclose(
        np.asarray(sidd["p"]), f32(gx_deg(ts - 20e-6)).astype(float) * DEG, rtol=1e-9, atol=1e-12
    )
    assert "SIDD.Gx -> p" in sidd.metadata["output"]
    assert "deg/s converted to rad/s" in sidd.metadata["output"]


def test_metadata_says_source_input_and_resampling(logs):
    meta = load_ardupilot(logs["exact"], run=0).metadata
    assert meta["source_format"] == "ardupilot"
    assert "exact.bin" in meta["source"]
    assert meta["input"].startswith("RATE.ROut -> delta_lat, RATE.POut -> delta_lon")
    assert "linear interpolation" in meta["resampling"] and "200 Hz" in meta["resampling"]
    assert "SID_AXIS 10 (Mixer Roll)" in meta["segment"]
    assert "TimeUS" in meta["time"]


def test_attitude_is_read_where_it_is_logged_fast_enough(logs, tmp_path):
    """ATT at the loop rate: phi, theta (rad) on the grid; at a tenth of it, or absent: no
    attitude columns, and the metadata says why."""
    fast = load_ardupilot(write_dataflash(tmp_path / "att.bin", att_every=1), run=0)
    assert fast.columns == ("time", "delta_lat", "delta_lon", "p", "q", "phi", "theta")
    t = np.asarray(fast.time)
    np.testing.assert_allclose(np.asarray(fast["phi"]), f32(roll_deg(t)).astype(float) * DEG, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(np.asarray(fast["theta"]), f32(pitch_deg(t)).astype(float) * DEG, rtol=1e-9, atol=1e-12)
    assert fast.metadata["attitude"].startswith("ATT.Roll -> phi, ATT.Pitch -> theta")
    slow = load_ardupilot(write_dataflash(tmp_path / "att_slow.bin", att_every=10), run=0)
    assert "phi" not in slow.columns and "below the record's 200 Hz" in slow.metadata["attitude"]
    assert "ATTITUDE_FAST" in slow.metadata["attitude"]
    none = load_ardupilot(logs["exact"], run=0)
    assert "phi" not in none.columns and none.metadata["attitude"].startswith("none (no ATT")


def test_sids_segments(logs):
    run0 = load_ardupilot(logs["exact"], run=0)
    assert float(run0.time[0]) == pytest.approx(3.0, abs=1e-9)
    assert float(run0.time[-1]) == pytest.approx(9.5, abs=1e-9)  # mode finished, SIDD went on
    run1 = load_ardupilot(logs["exact"], channel="longitudinal")
    assert float(run1.time[0]) == pytest.approx(16.0, abs=1e-9)
    # the pilot left the mode: last SIDD at 20.99 s (+20 us), the RATE sample before it
    assert float(run1.time[-1]) == pytest.approx(20.99, abs=0.006)
    assert "run 1" in run1.metadata["segment"]
    with pytest.raises(
        FlightDataError, match=r"2 system-ID runs.*run 0: SID_AXIS 10.*run 1: SID_AXIS 11"
    ):
        load_ardupilot(logs["exact"])
    with pytest.raises(FlightDataError, match="no system-ID run 5"):
        load_ardupilot(logs["exact"], run=5)
    with pytest.raises(FlightDataError, match="not the longitudinal channel"):
        load_ardupilot(logs["exact"], run=0, channel="longitudinal")
    win = load_ardupilot(logs["exact"], window=(24.0, 26.0))
    assert float(win.time[0]) == pytest.approx(24.0) and float(win.time[-1]) == pytest.approx(26.0)
    assert win.metadata["segment"].startswith("window 24-26 s")
    with pytest.raises(ValueError, match="not both"):
        load_ardupilot(logs["exact"], run=0, window=(1, 2))


def test_ardupilot_runs_lists_what_run_indexes(logs, tmp_path):
    runs = ardupilot_runs(logs["exact"])
    assert [type(r) for r in runs] == [SystemIdRun, SystemIdRun]
    assert [(r.index, r.axis, r.axis_name, r.channel) for r in runs] == [
        (0, 10, "Mixer Roll", "lateral"),
        (1, 11, "Mixer Pitch", "longitudinal"),
    ]
    assert runs[0].start_s == pytest.approx(3.0) and runs[0].stop_s == pytest.approx(9.5)
    assert runs[1].start_s == pytest.approx(16.0) and runs[1].stop_s == pytest.approx(20.99 + 20e-6)
    assert ardupilot_runs(write_dataflash(tmp_path / "none.bin", runs=())) == []


def test_no_sids_needs_a_window(tmp_path):
    path = write_dataflash(tmp_path / "nosids.bin", runs=())
    with pytest.raises(
        FlightDataError, match=r"no SIDS messages .*pass window=.*messages present: RATE"
    ):
        load_ardupilot(path)
    rec = load_ardupilot(path, window=(5.0, 6.0))
    assert rec.n_samples == 201


def test_targ_versus_mixer_input(logs):
    mixer = load_ardupilot(logs["exact"], run=0, input="mixer")
    t = np.asarray(mixer.time)
    np.testing.assert_allclose(np.asarray(mixer["delta_lat"]), f32(rout(t)), rtol=1e-9, atol=1e-12)

    sid = load_ardupilot(logs["exact"], run=0, input="targ")
    assert sid.columns == ("time", "delta_lat", "p")  # only the excited (roll) channel
    ts = np.asarray(sid.time)
    assert sid.sample_rate == pytest.approx(100.0, rel=1e-6)  # SIDD every other loop
    # SIDD is stamped 20 us after the loop time
    np.testing.assert_allclose(np.asarray(sid["delta_lat"]), f32(targ(ts - 20e-6)), atol=1e-6)
    assert sid.metadata["input"] == "SIDD.Targ -> delta_lat (injected chirp, normalised)"
    assert not np.allclose(np.asarray(sid["delta_lat"]), rout(ts), atol=1e-3)

    pitch = load_ardupilot(logs["exact"], run=1, input="targ")
    assert pitch.columns == ("time", "delta_lon", "q")
    with pytest.raises(
        FlightDataError, match=r"exact.bin: missing column delta_lat; .* input='mixer' gives both"
    ):
        load_ardupilot(logs["exact"], run=1, input="targ", required=("delta_lat", "p"))

    # input from SIDD, output from RATE: the grid takes the slower, SIDD's 100 Hz
    mixed = load_ardupilot(logs["exact"], run=0, input="targ", output="rate")
    assert mixed.sample_rate == pytest.approx(100.0, rel=1e-6)
    assert "median logged rate of SIDD" in mixed.metadata["resampling"]
    tm = np.asarray(mixed.time)
    np.testing.assert_allclose(
        np.asarray(mixed["p"]), r_deg(tm) * DEG, atol=interpolation_bound(0.005, "p")
    )


def test_targ_axis_rules(tmp_path, logs):
    yaw = write_dataflash(tmp_path / "yaw.bin", runs=(dict(RUNS[0], axis=3),))
    with pytest.raises(FlightDataError, match=r"SID_AXIS 3 \(Input Yaw Angle\) excites neither"):
        load_ardupilot(yaw, input="targ")
    load_ardupilot(yaw, input="mixer")  # the mixer outputs are fine on any axis
    with pytest.raises(FlightDataError, match="needs channel='lateral' or 'longitudinal'"):
        load_ardupilot(logs["exact"], input="targ", window=(1.0, 2.0))  # no run before it
    rec = load_ardupilot(logs["exact"], input="targ", window=(4.0, 5.0), channel="longitudinal")
    assert rec.columns == ("time", "delta_lon", "q")
    rec = load_ardupilot(logs["exact"], input="targ", window=(4.0, 5.0))  # run 0 before it: roll
    assert rec.columns == ("time", "delta_lat", "p")


def test_missing_message_and_field_are_named(tmp_path):
    no_rate = write_dataflash(tmp_path / "norate.bin", with_rate=False)
    with pytest.raises(
        FlightDataError, match=r"no RATE messages in the log .*; messages present: SIDD, SIDS"
    ):
        load_ardupilot(no_rate, run=0)
    old = ("RATE", "Qffffff", "TimeUS,RDes,R,PDes,P,YDes,Y")  # no mixer outputs logged
    path = write_dataflash(tmp_path / "old.bin", rate_format=old)
    with pytest.raises(
        FlightDataError, match=r"RATE has no field ROut, POut; its fields are: TimeUS, RDes, R,"
    ):
        load_ardupilot(path, run=0)
    rec = load_ardupilot(path, run=0, input="targ")  # the SIDD input needs no RATE.ROut
    assert rec.columns == ("time", "delta_lat", "p")
    odd_sids = ("SIDS", "QBff", "TimeUS,Ax,Mag,FSt")  # SIDS without the run timing fields
    path = write_dataflash(tmp_path / "odd_sids.bin", sids_format=odd_sids)
    with pytest.raises(FlightDataError, match=r"message SIDS has no field TFin, TC, TR, TFout"):
        load_ardupilot(path, run=0)
    rec = load_ardupilot(path, window=(4.0, 5.0), input="targ", channel="lateral")
    assert rec.columns == ("time", "delta_lat", "p")


def test_gap_is_an_error_naming_its_time(tmp_path):
    path = write_dataflash(tmp_path / "gap.bin", drop=(5.0, 5.2))
    with pytest.raises(FlightDataError, match=r"RATE has a gap of 0.205 s .* from t = 4.995000 s"):
        load_ardupilot(path, run=0)
    # a window that avoids it is fine; a tolerance that allows it interpolates over it
    assert load_ardupilot(path, window=(5.3, 9.0)).n_samples == 741
    assert load_ardupilot(path, run=0, max_gap=50).n_samples == 1301


def test_nan_and_backwards_time_are_errors(tmp_path):
    path = write_dataflash(tmp_path / "nan.bin", nan_at=4.0)
    with pytest.raises(FlightDataError, match=r"RATE.R is nan at t = 4.000000 s"):
        load_ardupilot(path, run=0)
    w = DataFlashWriter()
    w.define(*RATE)
    for us in (1000, 2000, 3000, 2500, 4000):
        w.write("RATE", TimeUS=us)
    back = tmp_path / "back.bin"
    back.write_bytes(w.to_bytes())
    with pytest.raises(FlightDataError, match=r"RATE time does not increase at t = 0.002500 s"):
        load_ardupilot(back, window=(0.0, 1.0))


@pytest.mark.parametrize(
    "unit_id, label, scale", [("k", "deg/s", DEG), ("E", "rad/s", 1.0), ("d", "deg", None)]
)
def test_units_the_log_declares(tmp_path, unit_id, label, scale):
    """UNIT/FMTU messages give RATE.R its unit: deg/s is converted, rad/s kept, others refused."""
    w = DataFlashWriter()
    for d in (UNIT, FMTU, RATE):
        w.define(*d)
    for uid, text in (("s", "s"), ("-", ""), (unit_id, label)):
        w.write("UNIT", Id=ord(uid), Label=text.encode())
    w.write(
        "FMTU",
        FmtType=w.type_id("RATE"),
        UnitIds=f"s{unit_id}{unit_id}-{unit_id}{unit_id}-".encode(),
        MultIds=b"F000000",
    )
    t = np.arange(101) / 100.0
    for ti in t:
        w.write(
            "RATE",
            TimeUS=int(round(ti * 1e6)),
            R=r_deg(ti),
            P=p_deg(ti),
            ROut=rout(ti),
            POut=pout(ti),
        )
    path = tmp_path / "units.bin"
    path.write_bytes(w.to_bytes())
    if scale is None:
        with pytest.raises(
            FlightDataError, match=r"RATE.R is logged in 'deg'; an angular rate in deg/s or rad/s"
        ):
            load_ardupilot(path, window=(0.0, 1.0))
        return
    rec = load_ardupilot(path, window=(0.0, 1.0))
    np.testing.assert_allclose(
        np.asarray(rec["p"]), f32(r_deg(t)).astype(float) * scale, rtol=1e-12
    )
    assert ("deg/s converted" if scale != 1.0 else "rad/s as logged") in rec.metadata["output"]


def test_empty_and_garbage_files(tmp_path):
    empty = tmp_path / "empty.bin"
    empty.write_bytes(b"")
    with pytest.raises(FlightDataError, match="the file is empty"):
        load_ardupilot(empty)
    junk = tmp_path / "junk.bin"
    junk.write_bytes(b"this is not a log\n" * 50)
    with pytest.raises(FlightDataError, match=r"no DataFlash messages found.*does not"):
        load_ardupilot(junk)
    with pytest.raises(FlightDataError, match="not a readable PX4 ULog"):
        load_px4(junk)
    with pytest.raises(FileNotFoundError):
        load_ardupilot(tmp_path / "missing.bin")


def test_damaged_dataflash_is_read_around_and_reported(logs, tmp_path, capfd):
    data = logs["exact"].read_bytes()
    middle = len(data) // 8  # inside run 0
    damaged = tmp_path / "damaged.bin"
    damaged.write_bytes(data[:middle] + b"utter garbage" + data[middle:])
    rec = load_ardupilot(damaged, run=0)
    assert "pymavlink skipped damaged data" in rec.metadata["log_warning"]
    assert "bad header" not in capfd.readouterr().err  # kept out of the terminal
    clean = load_ardupilot(logs["exact"], run=0)
    assert "log_warning" not in clean.metadata
    np.testing.assert_array_equal(np.asarray(rec["p"]), np.asarray(clean["p"]))


def test_truncated_dataflash_reads_what_is_there(logs, tmp_path):
    data = logs["exact"].read_bytes()
    cut = tmp_path / "cut.bin"
    cut.write_bytes(data[: len(data) // 2 + 7])  # ends mid-message, inside run 1
    rec = load_ardupilot(cut, run=0)
    assert float(rec.time[-1]) == pytest.approx(9.5, abs=1e-9)
    with pytest.raises(FlightDataError):
        load_ardupilot(cut, window=(28.0, 29.0))  # past the cut: no samples there


# -- PX4 -----------------------------------------------------------------------------------


def test_px4_round_trip(logs):
    rec = load_px4(logs["ulog"])
    assert rec.columns == ("time", "delta_lat", "delta_lon", "p", "q")
    assert rec.sample_rate == pytest.approx(250.0, rel=1e-6)
    t = np.asarray(rec.time)
    assert t[0] == pytest.approx(2.0) and t[-1] == pytest.approx(8.0 - 0.004)
    np.testing.assert_allclose(np.asarray(rec["delta_lat"]), f32(rout(t)), atol=1e-7)
    np.testing.assert_allclose(
        np.asarray(rec["p"]), f32(r_deg(t) * DEG), atol=1e-6
    )  # rad/s as logged
    np.testing.assert_allclose(np.asarray(rec["q"]), f32(p_deg(t) * DEG), atol=1e-6)
    meta = rec.metadata
    assert meta["input"].startswith("vehicle_torque_setpoint.xyz[0] -> delta_lat")
    assert "vehicle_angular_velocity.timestamp_sample" in meta["time"]
    win = load_px4(logs["ulog"], window=(3.0, 4.0))
    assert win.n_samples == 251 and float(win.time[0]) == pytest.approx(3.0)


def test_px4_attitude_from_the_quaternion(tmp_path):
    fast = load_px4(write_ulog(tmp_path / "att.ulg", att_every=1))
    assert fast.columns == ("time", "delta_lat", "delta_lon", "p", "q", "phi", "theta")
    t = np.asarray(fast.time)
    np.testing.assert_allclose(np.asarray(fast["phi"]), roll_deg(t) * DEG, rtol=0, atol=1e-6)  # float32 q
    np.testing.assert_allclose(np.asarray(fast["theta"]), pitch_deg(t) * DEG, rtol=0, atol=1e-6)
    assert "vehicle_attitude.q -> phi, theta" in fast.metadata["attitude"]
    slow = load_px4(write_ulog(tmp_path / "att_slow.ulg", att_every=5))
    assert "phi" not in slow.columns and "SDLOG_PROFILE" in slow.metadata["attitude"]
    assert load_px4(write_ulog(tmp_path / "noatt.ulg")).metadata["attitude"].startswith("none (no vehicle_attitude")


def test_px4_old_firmware_actuator_controls(tmp_path):
    path = write_ulog(tmp_path / "old.ulg", old_firmware=True)
    rec = load_px4(path)
    assert rec.metadata["input"].startswith("actuator_controls_0.control[0] -> delta_lat")
    t = np.asarray(rec.time)
    np.testing.assert_allclose(np.asarray(rec["delta_lon"]), f32(pout(t)), atol=1e-7)
    with pytest.raises(
        FlightDataError,
        match=r"no vehicle_torque_setpoint topic.*topics present: "
        r"actuator_controls_0, vehicle_angular_velocity",
    ):
        load_px4(path, input="torque_setpoint")


def test_px4_missing_field_and_gap(tmp_path):
    u = ULogWriter()
    u.topic("vehicle_angular_velocity", [("uint64_t", "timestamp"), ("float[3]", "rates")])
    u.topic("vehicle_torque_setpoint", TORQUE_SETPOINT)
    for k in range(10):
        u.write("vehicle_angular_velocity", timestamp=1000 * k)
        u.write("vehicle_torque_setpoint", timestamp=1000 * k)
    path = tmp_path / "odd.ulg"
    path.write_bytes(u.to_bytes())
    with pytest.raises(
        FlightDataError,
        match=r"vehicle_angular_velocity has no field xyz\[0\], xyz\[1\]; "
        r"its fields are: timestamp, rates\[0\]",
    ):
        load_px4(path)
    gap = write_ulog(tmp_path / "gap.ulg", gap=(4.0, 4.1))
    with pytest.raises(
        FlightDataError, match=r"vehicle_angular_velocity has a gap .* t = 3.996000 s"
    ):
        load_px4(gap)


# -- load_any --------------------------------------------------------------------------------


def _table_record():
    t = np.arange(40) / 50.0
    return make_record(t, {"delta_lat": np.sin(t), "delta_lon": np.cos(t), "p": t, "q": -t})


@pytest.mark.parametrize("suffix", [".csv", ".npz"])
def test_load_any_tables_delegate_to_load_record(tmp_path, suffix):
    path = save_record(_table_record(), tmp_path / f"rec{suffix}")
    got, want = load_any(path), load_record(path)
    for name in want.columns:
        np.testing.assert_array_equal(np.asarray(got[name]), np.asarray(want[name]))
    odd = tmp_path / "rec.dat"  # unknown extension: the content decides
    odd.write_bytes(path.read_bytes())
    again = load_any(odd)
    np.testing.assert_array_equal(np.asarray(again["p"]), np.asarray(want["p"]))
    assert detect_format(odd) == suffix[1:]


def test_load_any_never_unpickles(tmp_path, monkeypatch):
    path = save_record(_table_record(), tmp_path / "rec.npz")
    calls = []
    real = np.load

    def spy(*args, **kwargs):
        calls.append(kwargs.get("allow_pickle", False))
        return real(*args, **kwargs)

    monkeypatch.setattr(np, "load", spy)
    load_any(path)
    load_any(path, format="npz")
    assert calls and not any(calls)


def test_load_any_dispatch(logs, tmp_path):
    bin_upper = tmp_path / "LOG00042.BIN"
    bin_upper.write_bytes(logs["exact"].read_bytes())
    rec = load_any(bin_upper, run=0)
    assert rec.metadata["source_format"] == "ardupilot"
    no_ext = tmp_path / "00000042"
    no_ext.write_bytes(logs["exact"].read_bytes())
    assert detect_format(no_ext) == "ardupilot"
    assert load_any(no_ext, run=0).n_samples == rec.n_samples
    assert load_any(logs["ulog"]).metadata["source_format"] == "px4"
    ulg_renamed = tmp_path / "flight.log1"
    ulg_renamed.write_bytes(logs["ulog"].read_bytes())
    assert load_any(ulg_renamed, window=(3.0, 4.0)).n_samples == 251
    assert load_any(logs["ulog"], format="px4", required=("delta_lat", "p")).n_samples > 0


def test_load_any_errors(logs, tmp_path):
    with pytest.raises(
        ValueError, match="unknown format 'tlog'; expected one of auto, csv, npz, ardupilot, px4"
    ):
        load_any(logs["exact"], format="tlog")
    weird = tmp_path / "notes.txt"
    weird.write_bytes(b"\x00\x01 nothing to see")
    with pytest.raises(
        FlightDataError,
        match=r"extension '\.txt'.*csv \(\.csv\), npz \(\.npz\), "
        r"ardupilot \(\.bin\), px4 \(\.ulg\)",
    ):
        load_any(weird)
    with pytest.raises(
        ValueError, match=r"option\(s\) run do not apply to format 'px4'; it takes: input, window"
    ):
        load_any(logs["ulog"], run=0)
    with pytest.raises(ValueError, match="input must be one of 'mixer', 'targ'"):
        load_any(logs["exact"], input="sticks")
    garbage_csv = tmp_path / "garbage.csv"
    garbage_csv.write_bytes(bytes(range(256)))
    with pytest.raises(FlightDataError, match="garbage.csv"):
        load_any(garbage_csv)
    garbage_npz = tmp_path / "garbage.npz"
    garbage_npz.write_bytes(b"PK\x03\x04 truncated zip")
    with pytest.raises(FlightDataError, match="not a readable npz file"):
        load_any(garbage_npz)
    with pytest.raises(FileNotFoundError):
        load_any(tmp_path / "nope.bin")
    assert set(FORMATS) == {"auto", "csv", "npz", "ardupilot", "px4"}


@pytest.mark.parametrize("module, path_key", [("pymavlink", "exact"), ("pyulog", "ulog")])
def test_missing_library_says_how_to_install(logs, monkeypatch, module, path_key):
    monkeypatch.setitem(sys.modules, module, None)  # makes the import fail
    with pytest.raises(ImportError, match=r'pip install "jaxgwo\[logs\]"'):
        load_any(logs[path_key], **({"run": 0} if module == "pymavlink" else {}))


# -- damaged files: always FlightDataError (or a record), never anything else -----------------

_FUZZ = settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])


@pytest.fixture(scope="module")
def fuzz_dir(tmp_path_factory):
    d = tmp_path_factory.mktemp("fuzz")
    write_dataflash(d / "small.bin", runs=(RUNS[0],), span=(2.8, 6.0), rate_hz=50.0)
    write_ulog(d / "small.ulg", span=(2.0, 3.0), rate_hz=50.0)
    return d


def _load_or_flight_data_error(fuzz_dir: Path, data: bytes, suffix: str) -> None:
    path = fuzz_dir / f"fuzz{suffix}"
    path.write_bytes(data)
    try:
        out = load_any(path, **({"run": 0} if suffix == ".bin" else {}))
    except FlightDataError:
        return
    assert isinstance(out, FlightRecord)


@_FUZZ
@given(data=st.binary(max_size=600), suffix=st.sampled_from([".bin", ".ulg", ".csv", ".npz"]))
def test_garbage_bytes_only_raise_flight_data_error(fuzz_dir, data, suffix):
    # each starts with its format's magic bytes, so the parser gets past the first check
    magic = {
        ".bin": b"\xa3\x95\x80",
        ".ulg": b"ULog\x01\x12\x35\x01",
        ".csv": b"",
        ".npz": b"PK\x03\x04",
    }
    _load_or_flight_data_error(fuzz_dir, magic[suffix] + data, suffix)


@_FUZZ
@given(
    cut=st.floats(0.0, 1.0),
    flips=st.lists(st.tuples(st.floats(0.0, 1.0), st.integers(1, 255)), max_size=4),
    suffix=st.sampled_from([".bin", ".ulg"]),
)
def test_truncated_or_corrupted_logs_only_raise_flight_data_error(fuzz_dir, cut, flips, suffix):
    data = bytearray((fuzz_dir / f"small{suffix}").read_bytes())
    for where, xor in flips:
        data[int(where * (len(data) - 1))] ^= xor
    _load_or_flight_data_error(fuzz_dir, bytes(data[: int(cut * len(data))]), suffix)


def test_fast_decoding_matches_pymavlink_message_by_message(logs, tmp_path, monkeypatch):
    """The NumPy decoding of whole message types against pymavlink's own DFMessage values."""
    data = bytearray(logs["jitter"].read_bytes())
    data[len(data) // 3] ^= 0x5A  # damage one byte: both must skip the same message
    damaged = tmp_path / "damaged.bin"
    damaged.write_bytes(bytes(data[:-5]))  # and end inside a message
    for path, options in (
        (logs["jitter"], {"run": 0}),
        (logs["exact"], {"run": 1, "input": "targ"}),
        (damaged, {"window": (2.0, 29.0), "max_gap": 10}),
    ):
        fast = load_ardupilot(path, **options)
        monkeypatch.setattr("jaxgwo._logs._FAST_DECODE", False)
        slow = load_ardupilot(path, **options)
        monkeypatch.setattr("jaxgwo._logs._FAST_DECODE", True)
        assert fast.columns == slow.columns
        for name in fast.columns:
            np.testing.assert_array_equal(np.asarray(fast[name]), np.asarray(slow[name]))
