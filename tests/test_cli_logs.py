"""``jaxgwo identify`` and ``jaxgwo diagnose`` read flight logs directly (``--format``).

A paper-plant lateral sweep is written once as a jaxgwo CSV and once as an ArduPilot
DataFlash log (mixer input ``RATE.ROut``, roll rate ``RATE.R`` in deg/s, one System ID
run on the mixer-roll axis) by the minimal encoder of ``tests/_logwriters.py``; both
identify to the same model.
"""

from __future__ import annotations

import json

import jax.numpy as jnp
import numpy as np
import pytest

pytest.importorskip("pymavlink")

from _logwriters import RATE, SIDD, SIDS, DataFlashWriter  # noqa: E402

from jaxgwo import make_record, save_record  # noqa: E402
from jaxgwo._models import PaperModel  # noqa: E402
from jaxgwo.cli._main import main  # noqa: E402

TRUTH = (-500.0, 0.1, 150.0, 40.0, 0.7)
FS = 100.0
SMALL = ["--wolves", "8", "--iterations", "10", "--method", "wls-igwo+polish"]


def _sweep(t0=2.0, duration=40.0):
    """Boot time, cyclic and roll rate of a 0.2-8 Hz exponential sweep through the paper
    plant, starting at ``t0`` s since boot."""
    t = np.arange(0.0, duration, 1.0 / FS)
    f0, f1 = 0.2, 8.0
    u = 0.1 * np.sin(2 * np.pi * f0 * duration / np.log(f1 / f0)
                     * (np.exp(t / duration * np.log(f1 / f0)) - 1))
    y = np.asarray(PaperModel.from_array(jnp.asarray(TRUTH)).simulate(jnp.asarray(t), jnp.asarray(u)))
    return t0 + t, u, y


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("cli_logs")
    t, u, y = _sweep()
    csv = save_record(make_record(t, {"delta_lat": u, "p": y}), d / "sweep.csv")
    w = DataFlashWriter()
    for fmt in (SIDS, SIDD, RATE):
        w.define(*fmt)
    zero = dict(RDes=0.0, PDes=0.0, P=0.0, POut=0.0, YDes=0.0, Y=0.0, YOut=0.0,
                ADes=0.0, A=0.0, AOut=0.0, AOutSlew=0.0)
    for k, (tk, uk, yk) in enumerate(zip(t, u, y)):
        us = int(round(tk * 1e6))
        if k == 0:  # enter System ID mode, mixer roll (SID_AXIS 10), for the whole sweep
            w.write("SIDS", TimeUS=us, Ax=10, Mag=0.1, FSt=0.2, FSp=8.0, TFin=0.0, TC=0.0,
                    TR=float(t[-1] - t[0]), TFout=0.0)
        w.write("RATE", TimeUS=us, R=float(np.degrees(yk)), ROut=float(uk), **zero)
        w.write("SIDD", TimeUS=us, Time=0.0, Targ=float(uk), F=0.0, Gx=float(np.degrees(yk)),
                Gy=0.0, Gz=0.0, Ax=0.0, Ay=0.0, Az=0.0)
    log = d / "sid.bin"
    log.write_bytes(w.to_bytes())
    return {"csv": csv, "bin": log, "dir": d}


def _identify(path, out, *extra):
    assert main(["identify", str(path), "--channel", "lateral", *SMALL, "--json", str(out), *extra]) == 0
    return json.loads(out.read_text())["channels"]["lateral"]["model"]["params"]


def test_identify_reads_an_ardupilot_log_like_the_csv(files):
    from_csv = _identify(files["csv"], files["dir"] / "csv.json")
    from_log = _identify(files["bin"], files["dir"] / "bin.json")  # --format auto: by extension
    forced = _identify(files["bin"], files["dir"] / "forced.json", "--format", "ardupilot", "--run", "0")
    for name, value in from_csv.items():
        # the log resamples the deg/s float32 samples onto its own grid: close, not equal
        assert from_log[name] == pytest.approx(value, rel=0.02), name
        assert forced[name] == from_log[name], name


def test_wrong_format_and_log_options_are_one_line_errors(files, capsys):
    assert main(["identify", str(files["csv"]), "--channel", "lateral", "--format", "px4", *SMALL]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("jaxgwo identify: error:") and "\n" not in err
    assert main(["identify", str(files["csv"]), "--channel", "lateral", "--run", "0", *SMALL]) == 2
    assert "--run and --window apply to flight logs" in capsys.readouterr().err
    assert main(["identify", str(files["bin"]), "--channel", "longitudinal", *SMALL]) == 2
    err = capsys.readouterr().err
    assert "run" in err.lower() and "\n" not in err.strip()
