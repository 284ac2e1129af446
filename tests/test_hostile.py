"""Hostile and broken input (issue 7): property-based tests of the loaders, ``identify``
and ``diagnose`` (Python API and CLI).

Every hostile input must end in a clear error -- a ``ValueError`` subclass that names the
column, the row or the field and says what to do; for the CLI exit status 2 and one line on
stderr, with no file left in the output directory -- or in a documented result.  Never a
traceback from deep inside JAX/NumPy, a hang, NaN results, or a partial output file.

Speed: the records have one fixed shape (40 s at 50 Hz) and identification runs use
``method="wls"`` with 40 frequencies, so JAX compiles the WLS start once and every later
example reuses it; hypothesis varies contents, not shapes.  Hypothesis runs derandomized
without an example database, so CI sees the same examples every time.
"""

from __future__ import annotations

import contextlib
import dataclasses
import io
import json
import math
import os
import signal
import tempfile
from pathlib import Path

import jax.numpy as jnp
import numpy as np
import pytest
import scipy.signal
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import jaxgwo._identify as identify_module
from jaxgwo._data import FlightDataError, FlightRecord, load_record, make_record
from jaxgwo._diagnose import DiagnoseSettings, diagnose
from jaxgwo._identify import (
    IdentificationError,
    IdentifySettings,
    identify_channels,
    identify_responses,
)
from jaxgwo._models import PaperModel
from jaxgwo._spectral import FrequencyResponse
from jaxgwo.cli._main import main

HYPOTHESIS = settings(
    max_examples=15,
    deadline=None,
    derandomize=True,
    database=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)
FEW = settings(HYPOTHESIS, max_examples=8)

FS, DURATION = 50.0, 40.0
N = int(FS * DURATION)
TRUTH = np.array([-500.0, 0.1, 150.0, 40.0, 0.7])  # K, tau, M, omega_s, zeta_s
COLUMNS = ("time", "delta_lat", "delta_lon", "p", "q")
SETTINGS = IdentifySettings(method="wls", wolves=8, iterations=5, w_min=1.0, w_max=40.0,
                            n_frequencies=40)


def _paper_output(u: np.ndarray, t: np.ndarray) -> np.ndarray:
    """The paper model's rate response to ``u`` (scipy.signal.lsim; no JAX compile)."""
    k, tau, m, ws, zs = TRUTH
    den = np.polymul([1.0, 1.0 / tau, m], [1.0, 2.0 * zs * ws, ws**2])
    return scipy.signal.lsim((k * ws**2, den), u, t)[1]


def _base_columns() -> dict[str, np.ndarray]:
    t = np.arange(N) / FS
    f0, f1 = 0.15, 10.0
    sweep = 0.1 * np.sin(2 * np.pi * f0 * DURATION / np.log(f1 / f0)
                         * (np.exp(t / DURATION * np.log(f1 / f0)) - 1.0))
    rng = np.random.default_rng(7)
    lon = 0.02 * rng.standard_normal(N)
    p = _paper_output(sweep, t)
    p = p + 0.02 * np.std(p) * rng.standard_normal(N)
    q = _paper_output(lon, t)
    return {"time": t, "delta_lat": sweep, "delta_lon": lon, "p": p, "q": q}


BASE = _base_columns()


def _record(**replace: np.ndarray):
    cols = {k: v for k, v in BASE.items() if k != "time"} | replace
    return make_record(replace.get("time", BASE["time"]), {k: v for k, v in cols.items() if k != "time"})


def _write_csv(path: Path, cols: dict, header: str | None = None, comments=("# source: test",)) -> Path:
    names = list(cols)
    lines = [*comments, header if header is not None else ",".join(names)]
    n = len(next(iter(cols.values())))
    for i in range(n):
        lines.append(",".join(str(cols[k][i]) for k in names))
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.fixture(autouse=True)
def _no_hang():
    """A hang is a failure: each test must finish within two minutes."""

    if not hasattr(signal, "SIGALRM"):  # not on Windows
        yield
        return

    def timeout(signum, frame):
        raise TimeoutError("hostile-input test took over 120 s: a hang?")

    old = signal.signal(signal.SIGALRM, timeout)
    signal.alarm(120)
    yield
    signal.alarm(0)
    signal.signal(signal.SIGALRM, old)


@pytest.fixture(autouse=True)
def _never_pickle(monkeypatch):
    """No code path may load an .npz with pickles allowed."""
    real = np.load

    def load(*args, **kwargs):
        assert not kwargs.get("allow_pickle", False), "np.load called with allow_pickle=True"
        return real(*args, **kwargs)

    monkeypatch.setattr(np, "load", load)


def _one_line(message: str) -> str:
    assert message and "\n" not in message.strip(), message
    assert "Traceback" not in message
    return message


# -- loaders: random NaN / inf ------------------------------------------------------------

_small = {k: v[:12] for k, v in BASE.items()}
cells = st.lists(st.tuples(st.integers(0, 11), st.sampled_from(COLUMNS)), min_size=1, max_size=6,
                 unique=True)
bad_values = st.sampled_from(["nan", "inf", "-inf", "NaN", "1e999", "-1e999"])


def _first_bad(picked):
    """The (column, row) the loader must report: columns in canonical order, first row."""
    for col in COLUMNS:
        rows = sorted(r for r, c in picked if c == col)
        if rows:
            return col, rows[0]


@HYPOTHESIS
@given(picked=cells, value=bad_values)
def test_csv_non_finite_names_column_row_and_line(picked, value):
    cols = {k: list(v) for k, v in _small.items()}
    for r, c in picked:
        cols[c][r] = value
    col, row = _first_bad(picked)
    with tempfile.TemporaryDirectory() as d:
        path = _write_csv(Path(d) / "f.csv", cols)
        with pytest.raises(FlightDataError) as err:
            load_record(path)
    msg = _one_line(str(err.value))
    # one comment line and the header come first: data row r is on line r + 3
    assert f"column {col!r} has a non-finite value" in msg
    assert f"at row {row} (line {row + 3})" in msg


@HYPOTHESIS
@given(picked=cells, value=st.sampled_from([np.nan, np.inf, -np.inf]))
def test_npz_and_arrays_non_finite_names_column_and_row(picked, value):
    cols = {k: v.copy() for k, v in _small.items()}
    for r, c in picked:
        cols[c][r] = value
    col, row = _first_bad(picked)
    with tempfile.TemporaryDirectory() as d:
        np.savez(Path(d) / "f.npz", **cols)
        with pytest.raises(FlightDataError, match=rf"column '{col}' has a non-finite value .* at row {row}$"):
            load_record(Path(d) / "f.npz")
    with pytest.raises(FlightDataError, match=rf"column '{col}' has a non-finite value .* at row {row}$"):
        make_record(cols["time"], {k: v for k, v in cols.items() if k != "time"})


# -- loaders: duplicated or decreasing time ------------------------------------------------


@HYPOTHESIS
@given(row=st.integers(1, 11), back=st.sampled_from([0.0, 0.001, 0.02, 1.0, 1e6]),
       suffix=st.sampled_from([".csv", ".npz"]))
def test_duplicated_or_decreasing_time_names_the_row(row, back, suffix):
    cols = {k: v.copy() for k, v in _small.items()}
    cols["time"][row] = cols["time"][row - 1] - back  # back == 0: a duplicated timestamp
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / f"f{suffix}"
        _write_csv(path, cols) if suffix == ".csv" else np.savez(path, **cols)
        with pytest.raises(FlightDataError, match=rf"time is not strictly increasing at row {row}\b"):
            load_record(path)


# -- loaders: mismatched lengths, unknown names --------------------------------------------


@HYPOTHESIS
@given(lengths=st.lists(st.integers(0, 14), min_size=5, max_size=5).filter(lambda v: len(set(v)) > 1))
def test_npz_mismatched_lengths_are_listed(lengths):
    cols = {k: np.arange(n) / FS for k, n in zip(COLUMNS, lengths)}
    with tempfile.TemporaryDirectory() as d:
        np.savez(Path(d) / "f.npz", **cols)
        with pytest.raises(FlightDataError) as err:
            load_record(Path(d) / "f.npz")
    msg = _one_line(str(err.value))
    assert "columns have different lengths" in msg
    for k, n in zip(COLUMNS, lengths):
        assert f"'{k}': {n}" in msg


@HYPOTHESIS
@given(cut=st.integers(0, 11), col=st.sampled_from(COLUMNS[1:]))
def test_make_record_mismatched_length_names_the_column(cut, col):
    cols = {k: v for k, v in _small.items() if k != "time"}
    cols[col] = cols[col][:cut]
    with pytest.raises(FlightDataError, match=rf"column '{col}' has shape \({cut},\), time has \(12,\)"):
        make_record(_small["time"], cols)


@HYPOTHESIS
@given(line=st.integers(0, 11), keep=st.integers(1, 4))
def test_csv_ragged_row_names_the_line(line, keep):
    with tempfile.TemporaryDirectory() as d:
        path = _write_csv(Path(d) / "f.csv", _small)
        lines = path.read_text().splitlines()
        lines[line + 2] = ",".join(lines[line + 2].split(",")[:keep])
        path.write_text("\n".join(lines) + "\n")
        with pytest.raises(FlightDataError, match=rf"line {line + 3} has {keep} fields, the header has 5"):
            load_record(path)


def test_decimal_commas_are_hinted(tmp_path):
    path = tmp_path / "f.csv"
    path.write_text("time,delta_lat,delta_lon,p,q\n0,0,0,0,0\n0,01,0,5,0,0,0\n")
    with pytest.raises(FlightDataError, match=r"line 3 has 7 fields, the header has 5 \(decimal commas\?"):
        load_record(path)


names = st.text(st.sampled_from("abcdefghijklmnopqrstuvwxyz_ABCXYZ0123456789 .-"), min_size=1, max_size=10)


@HYPOTHESIS
@given(header=st.lists(names.map(str.strip).filter(lambda s: s and s not in COLUMNS), min_size=1,
                       max_size=6, unique=True))
def test_unknown_columns_are_listed(header):
    cols = {h: _small["time"] for h in header}
    with tempfile.TemporaryDirectory() as d:
        for path in (_write_csv(Path(d) / "f.csv", cols), Path(d) / "f.npz"):
            if path.suffix == ".npz":
                np.savez(path, **cols)
            with pytest.raises(FlightDataError) as err:
                load_record(path)
            msg = _one_line(str(err.value))
            assert "missing column time; the columns are: " + ", ".join(header) in msg


def test_wrong_separator_and_mapping_to_a_missing_name(tmp_path):
    path = _write_csv(tmp_path / "f.csv", _small, header=";".join(COLUMNS))
    text = path.read_text().replace(",", ";")
    path.write_text(text)
    with pytest.raises(FlightDataError, match="the header looks like one column: separate the columns by commas"):
        load_record(path)
    good = _write_csv(tmp_path / "g.csv", _small)
    with pytest.raises(FlightDataError, match=r"missing column 'gyro_x' \(for p\); the columns are: time, delta_lat"):
        load_record(good, columns={"p": "gyro_x"})
    with pytest.raises(FlightDataError, match=r"unknown canonical column\(s\) \['roll'\]"):
        load_record(good, columns={"roll": "p"})


# -- loaders: empty files ------------------------------------------------------------------


@pytest.mark.parametrize(
    "name, content, message",
    [
        ("zero.csv", b"", "no header row"),
        ("blank.csv", b"\n  \n\n", "no header row"),
        ("comments.csv", b"# sample_rate_hz: 50\n# only comments\n", "no header row"),
        ("header.csv", b"time,delta_lat,delta_lon,p,q\n", r"fewer than two samples \(0\)"),
        ("one.csv", b"time,delta_lat,delta_lon,p,q\n0,0,0,0,0\n", r"fewer than two samples \(1\)"),
        ("zero.npz", b"", "an empty file; write it with numpy.savez"),
        ("text.npz", b"time,p\n0,1\n", r"not a NumPy .npz archive"),
    ],
)
def test_empty_files(tmp_path, name, content, message):
    (tmp_path / name).write_bytes(content)
    with pytest.raises(FlightDataError, match=message):
        load_record(tmp_path / name)


def test_empty_npz_archives(tmp_path):
    np.savez(tmp_path / "none.npz")
    with pytest.raises(FlightDataError, match=r"missing column time; the columns are: \(none\)"):
        load_record(tmp_path / "none.npz")
    np.savez(tmp_path / "zero.npz", **{k: np.zeros(0) for k in COLUMNS})
    with pytest.raises(FlightDataError, match=r"fewer than two samples \(0\)"):
        load_record(tmp_path / "zero.npz")
    np.save(tmp_path / "bare.npy", np.arange(4.0))
    os.replace(tmp_path / "bare.npy", tmp_path / "bare.npz")  # a lone array, not an archive
    with pytest.raises(FlightDataError, match=r"not a NumPy .npz archive"):
        load_record(tmp_path / "bare.npz")


# -- loaders: wrong types ------------------------------------------------------------------

not_a_number = st.one_of(
    st.sampled_from(["n/a", "NULL", "None", "--", "1,5", "0x1F", "1e", "1.2.3", "+-1", "∞", "١٢",
                     "'3'", "TRUE", "12 34", "\t?", "é", "1e5e5", "nan%"]),
    st.text("abcdefghijklmnopqrstuvwxyzÄÖÜ!?%&()", min_size=1, max_size=6).filter(
        lambda s: s.strip().lower() not in ("nan", "inf", "infinity")),
)


@HYPOTHESIS
@given(row=st.integers(0, 11), col=st.sampled_from(COLUMNS), text=not_a_number)
def test_text_in_a_numeric_column_names_column_row_and_value(row, col, text):
    cols = {k: list(v) for k, v in _small.items()}
    cols[col][row] = text
    with tempfile.TemporaryDirectory() as d:
        path = _write_csv(Path(d) / "f.csv", cols)
        with pytest.raises(FlightDataError) as err:
            load_record(path)
    msg = str(err.value)
    assert f"column {col!r} has a non-numeric value {text.strip()!r} at row {row} (line {row + 3})" in msg


def test_text_in_an_extra_column_is_dropped_and_noted(tmp_path):
    cols = dict(_small, mode=["HOVER"] * 12)
    rec = load_record(_write_csv(tmp_path / "f.csv", cols))
    assert "mode" not in rec.columns and rec.metadata["dropped_text_columns"] == "mode"


@pytest.mark.parametrize(
    "array, message",
    [
        (np.array([{"x": 1}] * 12, dtype=object), "cannot read without pickle"),
        (np.array(["1.0"] * 12), "has dtype <U3; columns must be real numbers"),
        (np.arange(12) * (1 + 1j), "has dtype complex128; columns must be real numbers"),
        (np.ones(12, bool), "has dtype bool; columns must be real numbers"),
        (np.ones((2, 12)), r"has shape \(2, 12\); columns must be 1-D"),
        (np.float64(3.0), r"has shape \(\); columns must be 1-D"),
    ],
    ids=["object", "str", "complex", "bool", "2-D", "0-D"],
)
def test_npz_wrong_types(tmp_path, array, message):
    np.savez(tmp_path / "f.npz", **dict(_small, p=array))
    with pytest.raises(FlightDataError, match=rf"array 'p' {message}|{message}"):
        load_record(tmp_path / "f.npz")


@pytest.mark.parametrize(
    "time, column, message",
    [
        (["a"] * 12, np.zeros(12), "column 'time' has dtype <U1"),
        (_small["time"], [{}] * 12, "column 'p' has dtype object"),
        (_small["time"], [[1.0], [1.0, 2.0]] * 6, "column 'p' is not a rectangular array"),
        (_small["time"], np.zeros(12) * 1j, "column 'p' has dtype complex128"),
        (_small["time"], None, "column 'p' has dtype object"),
        (np.zeros((2, 12)), np.zeros((2, 12)), r"time has shape \(2, 12\); it must be 1-D"),
        (0.5, 1.0, r"time has shape \(\); it must be 1-D"),
    ],
)
def test_make_record_wrong_types(time, column, message):
    with pytest.raises(FlightDataError, match=message):
        make_record(time, {"p": column})


@FEW
@given(data=st.binary(max_size=300), suffix=st.sampled_from([".csv", ".npz"]))
def test_random_bytes_never_escape_as_another_exception(data, suffix):
    """Any byte string: a record, or a FlightDataError -- nothing else."""
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / f"f{suffix}"
        path.write_bytes(data)
        try:
            load_record(path, required=())
        except FlightDataError as err:
            _one_line(str(err))


cell = st.one_of(st.floats(allow_nan=True, allow_infinity=True).map(repr),
                 st.integers(-10, 10).map(str),
                 st.sampled_from(["", " ", "nan", "x", "1e999", "0x1", '"1"', "# c", "1;2"]))


@settings(HYPOTHESIS, max_examples=30)
@given(header=st.lists(st.sampled_from([*COLUMNS, "rpm", "mode", "", "p "]), min_size=1, max_size=7),
       rows=st.lists(st.lists(cell, min_size=1, max_size=8), max_size=6),
       comments=st.lists(st.sampled_from(["# sample_rate_hz: 100", "# a: b", "#", "# sample_rate_hz: x"]),
                         max_size=2))
def test_random_csv_text_gives_a_valid_record_or_a_flight_data_error(header, rows, comments):
    """Whatever the text: a record whose time is finite, increasing and uniform and whose
    data columns are finite, or a one-line FlightDataError -- never another exception."""
    text = "\n".join([*comments, ",".join(header), *(",".join(r) for r in rows)]) + "\n"
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "f.csv"
        path.write_text(text)
        try:
            rec = load_record(path, required=())
        except FlightDataError as err:
            _one_line(str(err))
            return
    t = np.asarray(rec.time)
    assert t.size >= 2 and np.all(np.isfinite(t)) and np.all(np.diff(t) > 0)
    for name in (*rec.inputs, *rec.outputs):
        assert np.all(np.isfinite(np.asarray(rec[name])))


def test_undecodable_bytes_bom_and_nul(tmp_path):
    good = _write_csv(tmp_path / "g.csv", _small).read_bytes()
    (tmp_path / "bom.csv").write_bytes(b"\xef\xbb\xbf" + good)  # Excel's UTF-8 BOM
    assert load_record(tmp_path / "bom.csv").columns[0] == "time"
    (tmp_path / "latin1.csv").write_bytes(good + b"0.3,\xe9,0,0,0\n")
    with pytest.raises(FlightDataError, match="line 15 is not UTF-8 text"):
        load_record(tmp_path / "latin1.csv")
    (tmp_path / "nul.csv").write_bytes(good + b"0.3,0\x00,0,0,0\n")
    with pytest.raises(FlightDataError, match="line 15 holds a NUL byte"):
        load_record(tmp_path / "nul.csv")


def test_trailing_commas_are_tolerated_but_nameless_data_is_not(tmp_path):
    path = _write_csv(tmp_path / "f.csv", _small)
    lines = path.read_text().splitlines()
    path.write_text("\n".join(line + "," for line in lines[1:]) + "\n")
    assert load_record(path).columns == COLUMNS
    lines = path.read_text().splitlines()
    lines[4] = lines[4] + "7"
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(FlightDataError, match=r"last column has no name .* '7' at row 3 \(line 5\)"):
        load_record(path)
    path.write_text(",".join(["time", "", "p"]) + "\n0,1,2\n")
    with pytest.raises(FlightDataError, match="empty column name at position 2"):
        load_record(path)


def test_directory_bad_mapping_and_bad_metadata(tmp_path):
    with pytest.raises(FlightDataError, match="is a directory; pass a .csv or .npz"):
        load_record(tmp_path)
    good = _write_csv(tmp_path / "g.csv", _small)
    for columns in (["p", "gyro_x"], {"p": 3}):
        with pytest.raises(FlightDataError, match="columns must map canonical names"):
            load_record(good, columns=columns)
    with pytest.raises(FlightDataError, match="metadata must be a mapping, not list"):
        make_record(_small["time"], {"p": _small["p"]}, ["source"])


def test_time_in_milliseconds_hints_at_the_unit():
    """Documented result: the loader cannot know the unit; identification says where to look."""
    rec = make_record(BASE["time"] * 1000.0, {k: BASE[k] for k in ("delta_lat", "p")})
    assert rec.sample_rate == pytest.approx(FS / 1000.0)
    with pytest.raises(IdentificationError, match="check that the time column is in seconds"):
        _identify(rec)


def test_metadata_errors_name_the_file(tmp_path):
    np.savez(tmp_path / "f.npz", **_small, __metadata__=np.array('{"a:b": "x"}'))
    with pytest.raises(FlightDataError, match=r"f\.npz: metadata key 'a:b'"):
        load_record(tmp_path / "f.npz")
    np.savez(tmp_path / "g.npz", **_small, __metadata__=np.array("[1, 2]"))
    with pytest.raises(FlightDataError, match=r"g\.npz: __metadata__ is not a JSON object"):
        load_record(tmp_path / "g.npz")


# -- identify: the Python API --------------------------------------------------------------


def _identify(rec, settings=SETTINGS, validation=None):
    out = identify_channels({"lateral": [rec]}, settings, validation)["lateral"]
    p = np.asarray(out.model.to_array())
    assert np.all(np.isfinite(p)) and math.isfinite(out.cost_J), "a non-finite result was returned"
    return out


@pytest.fixture(scope="module")
def reference():
    return _identify(_record())


@HYPOTHESIS
@given(level=st.floats(-1e6, 1e6, allow_nan=False), slope=st.sampled_from([0.0, 1e-3, -2.0, 1e4]),
       col=st.sampled_from(["delta_lat", "p"]))
def test_constant_or_straight_line_input_or_output(level, slope, col):
    flat = level + slope * BASE["time"]
    with pytest.raises(IdentificationError) as err:
        _identify(_record(**{col: flat}))
    msg = _one_line(str(err.value))
    role = "input" if col == "delta_lat" else "output"
    assert f"identification record 0 (lateral channel): the {role} is constant (column {col!r}" in msg


@FEW
@given(seed=st.integers(0, 2**32 - 1), scale=st.sampled_from([1e-6, 1.0, 1e6]))
def test_pure_noise_output_has_no_usable_coherence(seed, scale):
    noise = scale * np.random.default_rng(seed).standard_normal(N)
    with pytest.raises(IdentificationError, match=r"(frequencies have coherence >= 0.6|no usable coherence)"):
        _identify(_record(p=noise))


_T = BASE["time"]
_SPIKES = np.where(np.random.default_rng(3).random(N) < 0.01, 1.0, 0.0)
INPUTS = {
    "sweep": BASE["delta_lat"],
    "square": 0.1 * np.sign(np.sin(2 * np.pi * 0.5 * _T)),
    "step": np.where(_T > 10.0, 1.0, 0.0),
    "noise": np.random.default_rng(1).standard_normal(N),
    "quantised": np.round(BASE["delta_lat"] * 20.0) / 20.0,
    "clipped": np.clip(BASE["delta_lat"], -0.03, 0.03),
    "offset": BASE["delta_lat"] + 1e6,
    "impulse": np.where(np.arange(N) == 500, 1.0, 0.0),
    "spikes": _SPIKES,
}
OUTPUTS = {
    "true": lambda u: BASE["p"],
    "noise": lambda u: np.random.default_rng(2).standard_normal(N),
    "same": lambda u: u.copy(),
    "negated": lambda u: -u,
    "delayed": lambda u: np.roll(u, 5),
    "integrated": lambda u: np.cumsum(u) / FS,
    "clipped": lambda u: np.clip(BASE["p"], -0.1, 0.1),
    "quantised": lambda u: np.round(BASE["p"] * 2.0) / 2.0,
    "spike": lambda u: BASE["p"] + np.where(np.arange(N) == 900, 1e6, 0.0),
}


@settings(HYPOTHESIS, max_examples=25)
@given(u_kind=st.sampled_from(sorted(INPUTS)), y_kind=st.sampled_from(sorted(OUTPUTS)))
def test_odd_signals_end_in_a_clear_error_or_a_finite_fit(u_kind, y_kind):
    """Steps, squares, impulses, quantised, clipped, delayed, integrated, spiky signals:
    a one-line IdentificationError or finite parameters, cost and time-domain error (a bad
    model is a documented result: its J says so)."""
    u = INPUTS[u_kind]
    try:
        out = _identify(_record(delta_lat=u, p=OUTPUTS[y_kind](u)))
    except IdentificationError as err:
        _one_line(str(err))
        return
    assert math.isfinite(out.mse) and out.response.n_passing >= 20


def test_an_input_of_isolated_pulses_is_not_called_constant():
    """Regression: single-sample pulses are wild values to the preprocessing; the input left
    flat was reported as 'constant', which it is not."""
    with pytest.raises(IdentificationError, match=r"the input \(column 'delta_lat'\) varies only in 1 "
                                                  r"isolated sample.*wild_values=False"):
        _identify(_record(delta_lat=INPUTS["impulse"]))


AMPLITUDES = [1e-300, 1e-150, 1e-100, 1e-12, 1.0, 1e12, 1e100, 1e150, 1e200, 1e300]


@HYPOTHESIS
@given(su=st.sampled_from(AMPLITUDES), sy=st.sampled_from(AMPLITUDES))
def test_huge_or_tiny_amplitudes(reference, su, sy):
    """Documented result: identification is scale-equivariant (K scales by sy/su, the other
    parameters stay) while every sample is within 1e150 and the gain |H| within 1e-100..1e100;
    beyond that a clear 'rescale' error."""
    rec = _record(delta_lat=BASE["delta_lat"] * su, p=BASE["p"] * sy)
    decades = math.log10(abs(TRUTH[0] / TRUTH[2])) + math.log10(sy) - math.log10(su)  # of |H|
    fits = max(su, sy) * 0.2 <= identify_module.MAX_ABS_SAMPLE and abs(decades) <= 95
    try:
        out = _identify(rec)
    except IdentificationError as err:
        assert "rescale" in _one_line(str(err))
        assert not fits, f"su={su:g}, sy={sy:g} should be identifiable: {err}"
        return
    p, p_ref = np.asarray(out.model.to_array()), np.asarray(reference.model.to_array())
    # rel 1e-6: the detrend and the spectra round differently at other scales
    np.testing.assert_allclose(p, p_ref * [sy / su, 1, 1, 1, 1], rtol=1e-6)


@HYPOTHESIS
@given(seconds=st.floats(0.0, 31.0))
def test_record_shorter_than_the_band_needs(seconds):
    """w_min = 1 rad/s needs 2 periods per window and 4 averages: 31.4 s."""
    n = max(2, int(seconds * FS))
    rec = make_record(BASE["time"][:n], {k: BASE[k][:n] for k in ("delta_lat", "p")})
    with pytest.raises(IdentificationError) as err:
        _identify(rec)
    msg = _one_line(str(err.value))
    assert ("needs at least 5" in msg) if n < 5 else ("at least 31.4 s of record" in msg)


@HYPOTHESIS
@given(row=st.integers(0, N - 1), col=st.sampled_from(["time", "delta_lat", "p"]),
       value=st.sampled_from([np.nan, np.inf, -np.inf]))
def test_non_finite_samples_in_a_hand_built_record(row, col, value):
    """A FlightRecord built directly (bypassing the loader's checks) with a NaN or inf."""
    cols = {k: BASE[k].copy() for k in ("time", "delta_lat", "p")}
    cols[col][row] = value
    rec = FlightRecord(time=jnp.asarray(cols["time"]), inputs={"delta_lat": jnp.asarray(cols["delta_lat"])},
                       outputs={"p": jnp.asarray(cols["p"])}, extras={}, sample_rate=FS)
    with pytest.raises(IdentificationError) as err:
        _identify(rec)
    msg = _one_line(str(err.value))
    assert f"column {col!r} has a non-finite value ({float(value)!r}) at row {row}" in msg


def test_records_at_different_sample_rates():
    half = make_record(BASE["time"][::2], {k: BASE[k][::2] for k in ("delta_lat", "p")})
    with pytest.raises(IdentificationError, match=r"different sample rates \[25.0, 50.0\] Hz; resample"):
        identify_channels({"lateral": [_record(), half]}, SETTINGS)


def test_identification_accepts_the_time_jitter_the_loader_accepts(reference):
    """Regression: the loader allows 1 % jitter, preprocessing used to reject 1e-6."""
    t = BASE["time"].copy()
    t[100] += 0.005 / FS
    out = _identify(_record(time=t))
    np.testing.assert_allclose(out.model.to_array(), reference.model.to_array(), rtol=1e-3)


def test_missing_channel_columns_are_listed():
    rec = make_record(BASE["time"], {"roll_in": BASE["delta_lat"], "gyro_x": BASE["p"]})
    with pytest.raises(IdentificationError, match=r"needs columns 'delta_lat' and 'p'; missing 'delta_lat', 'p'\. "
                                                    r"The record has: time, roll_in, gyro_x"):
        _identify(rec)


@pytest.mark.parametrize(
    "records, message",
    [
        ({}, "no channel to identify"),
        ([], "must be a dict"),
        ({"lateral": []}, "no identification records for the lateral channel"),
        ({"lateral": "f.csv"}, r"must be a list of FlightRecord, not str"),
        ({"lateral": [np.zeros(3)]}, r"\['lateral'\]\[0\] is a ndarray, not a FlightRecord"),
        ({"sideways": [None]}, "is a NoneType"),
    ],
)
def test_wrong_record_containers(records, message):
    with pytest.raises(IdentificationError, match=message):
        identify_channels(records, SETTINGS)


def test_unknown_channel():
    with pytest.raises(ValueError, match="unknown channel 'sideways'; choose lateral or longitudinal"):
        identify_channels({"sideways": [_record()]}, SETTINGS)


bad_settings = st.one_of(
    st.fixed_dictionaries({"wolves": st.one_of(st.integers(-5, 3), st.just(8.0), st.just("8"), st.just(True))}),
    st.fixed_dictionaries({"iterations": st.one_of(st.integers(-5, 0), st.just(5.5), st.none())}),
    st.tuples(st.floats(0.5, 100.0), st.floats(0.0, 1.0)).map(
        lambda a: {"w_min": a[0], "w_max": a[0] * a[1]}),  # inverted or empty band
    st.fixed_dictionaries({"w_min": st.sampled_from([0.0, -1.0, math.nan, math.inf])}),
    st.fixed_dictionaries({"w_max": st.sampled_from([math.nan, math.inf])}),
    st.fixed_dictionaries({"coherence_threshold": st.sampled_from([-0.1, 1.0, 1.5, math.nan])}),
    st.fixed_dictionaries({"n_frequencies": st.sampled_from([0, 19, 30.5])}),
    st.fixed_dictionaries({"search_factor": st.sampled_from([1.0, 0.5, math.nan, math.inf])}),
    st.fixed_dictionaries({"seed_spread": st.sampled_from([-1.0, math.nan])}),
    st.fixed_dictionaries({"seeded_fraction": st.sampled_from([-0.1, 1.5])}),
    st.fixed_dictionaries({"seed": st.sampled_from(["x", 1.5, 2**63, -(2**63) - 1, 10**30])}),
    st.fixed_dictionaries({"sk_iterations": st.just(-1)}),
    st.fixed_dictionaries({"polish_steps": st.just(-3)}),
    st.fixed_dictionaries({"detrend": st.just("quadratic")}),
    st.fixed_dictionaries({"lowpass_hz": st.sampled_from([0.0, -2.0, math.nan])}),
    st.fixed_dictionaries({"method": st.just("genetic")}),
    st.fixed_dictionaries({"zoh_correction": st.sampled_from(["no", 0, None])}),
    st.fixed_dictionaries({"wild_values": st.sampled_from(["yes", 1])}),
)


@HYPOTHESIS
@given(change=bad_settings)
def test_bad_settings_name_the_field(change):
    """Too few wolves, iterations < 1, an inverted band, NaN, wrong types: one ValueError
    that names the field, raised when the settings are made (before any data work)."""
    with pytest.raises(ValueError) as err:
        dataclasses.replace(SETTINGS, **change)
    msg = _one_line(str(err.value))
    field = next(iter(change))
    assert field in msg or ("frequency band" in msg and field in ("w_min", "w_max")), msg


def test_preprocessing_errors_name_the_record():
    """A low-pass cutoff above the record's Nyquist frequency (25 Hz here)."""
    with pytest.raises(IdentificationError, match=r"identification record 0 \(lateral channel\): "
                                                  r"preprocessing: low-pass cutoff 40.0 Hz"):
        _identify(_record(), dataclasses.replace(SETTINGS, lowpass_hz=40.0))


def test_validation_is_checked_before_the_fit(monkeypatch):
    """A constant, short or wrong validation record fails before the optimiser runs."""

    def no_fit(*args, **kwargs):
        raise AssertionError("the fit ran before the validation records were checked")

    monkeypatch.setattr(identify_module, "_identify_prepared", no_fit)
    short = make_record(BASE["time"][:4], {"delta_lat": BASE["delta_lat"][:4], "p": BASE["p"][:4]})
    cases = [
        ([_record(p=np.full(N, 0.25))], r"validation record 0 \(lateral channel\): the output is constant \(column 'p'"),
        ([_record(), short], r"validation record 1 \(lateral channel\) has 4 samples; .* at least 5"),
        ({"lateral": [_record(delta_lat=np.zeros(N))]}, r"the input is constant \(column 'delta_lat'"),
        ([make_record(BASE["time"], {"delta_lat": BASE["delta_lat"]})], "missing 'p'"),
        ([BASE["p"]], r"validation\['any channel'\]\[0\] is a ndarray"),
    ]
    for validation, message in cases:
        with pytest.raises(IdentificationError, match=message):
            identify_channels({"lateral": [_record()]}, SETTINGS, validation)


# -- identify_responses: hostile frequency responses ---------------------------------------

W = np.geomspace(1.0, 40.0, 40)
H_TRUE = np.asarray(PaperModel.from_array(jnp.asarray(TRUTH)).frequency_response(jnp.asarray(W)))


@HYPOTHESIS
@given(points=st.lists(st.integers(0, 39), min_size=1, max_size=15, unique=True),
       value=st.sampled_from([complex(np.nan, 0), complex(np.inf, 0), complex(0, -np.inf),
                              complex(np.nan, np.nan)]))
def test_non_finite_response_points_are_masked(points, value):
    """Documented result: non-finite H is masked out; with >= 20 points left the fit is
    finite, otherwise the error says how many frequencies pass."""
    H = H_TRUE.copy()
    H[points] = value
    fr = FrequencyResponse.from_complex(jnp.asarray(W), jnp.asarray(H))
    assert not np.any(np.asarray(fr.mask)[points])
    if 40 - len(points) < 20:
        with pytest.raises(IdentificationError, match=rf"only {40 - len(points)} of 40 frequencies"):
            identify_responses({"lateral": fr}, SETTINGS)
        return
    out = identify_responses({"lateral": fr}, SETTINGS)["lateral"]
    np.testing.assert_allclose(out.model.to_array(), TRUTH, rtol=1e-6)


def _response(w=W, H=H_TRUE, coherence=None):
    coh = jnp.ones(len(w)) if coherence is None else jnp.asarray(coherence)
    return FrequencyResponse(w=jnp.asarray(w), H=jnp.asarray(H, dtype=complex), coherence=coh,
                             random_error=jnp.zeros(len(w)), n_averages=jnp.full(len(w), 10.0),
                             mask=jnp.ones(len(w), bool), window_s=jnp.full(len(w), np.nan))


@HYPOTHESIS
@given(i=st.integers(1, 39), how=st.sampled_from(["duplicate", "decrease", "negative", "nan", "inf"]))
def test_bad_frequency_grid_names_the_point(i, how):
    w = W.copy()
    if how == "duplicate":
        w[i] = w[i - 1]
    elif how == "decrease":
        w[i] = w[i - 1] * 0.5
    else:
        w[i] = {"negative": -w[i], "nan": np.nan, "inf": np.inf}[how]
    with pytest.raises(IdentificationError, match=rf"w\[{i}\]"):
        identify_responses({"lateral": _response(w=w)}, SETTINGS)


@pytest.mark.parametrize(
    "change, message",
    [
        (dict(H=np.where(np.arange(40) == 5, 0.0, H_TRUE)), r"gain \|H\| at w\[5\] .* is 0, outside"),
        (dict(H=H_TRUE * 1e120), r"outside 1e-100\.\.1e100; rescale"),
        (dict(coherence=np.full(40, 1.5)), r"coherence at w\[0\] .* is 1\.5"),
        (dict(coherence=np.full(40, np.nan)), r"coherence at w\[0\] .* is nan"),
        (dict(H=H_TRUE[:30]), r"H has shape \(30,\) but w has \(40,\)"),
        (dict(coherence=np.zeros(40)), r"w\[0\] = 1 rad/s is in the mask with coherence 0, below"),
    ],
    ids=["zero-gain", "huge-gain", "coherence>1", "nan-coherence", "short-H", "mask-ignores-coherence"],
)
def test_bad_response_values(change, message):
    with pytest.raises(IdentificationError, match=message):
        identify_responses({"lateral": _response(**change)}, SETTINGS)


def test_wrong_response_containers():
    with pytest.raises(IdentificationError, match="non-empty dict"):
        identify_responses({}, SETTINGS)
    with pytest.raises(IdentificationError, match="expected a FrequencyResponse, got ndarray"):
        identify_responses({"lateral": H_TRUE}, SETTINGS)


def test_a_non_finite_fit_is_an_error_not_a_result(reference):
    """Regression: ``--method paper`` on a white-noise response returned K = NaN, J = inf."""
    prep = identify_module._prepare_response(_response(), "lateral", SETTINGS)
    with pytest.raises(IdentificationError, match=r"lateral: the wls fit ended at non-finite parameters"):
        identify_module._finish(prep, jnp.full(5, jnp.nan), np.zeros(0), 0, 0.0, SETTINGS, None)


# -- diagnose: the Python API --------------------------------------------------------------

DIAGNOSE = DiagnoseSettings(identify=SETTINGS, wolves=8, iterations=5)


@FEW
@given(which=st.sampled_from(["train", "validation"]), col=st.sampled_from(["delta_lat", "p"]))
def test_diagnose_rejects_flat_records_before_fitting(which, col):
    bad = _record(**{col: np.full(N, 0.1)})
    train, val = ([bad], [_record()]) if which == "train" else ([_record()], [bad])
    role = "identification" if which == "train" else "validation"
    with pytest.raises(IdentificationError, match=rf"{role} record 0 \(lateral channel\): the \w+ is constant \(column '{col}'"):
        diagnose(train, val, "lateral", DIAGNOSE)


def test_diagnose_needs_records():
    with pytest.raises(ValueError, match="needs held-out validation records"):
        diagnose([_record()], [], "lateral", DIAGNOSE)
    with pytest.raises(ValueError, match="at least one identification record"):
        diagnose([], [_record()], "lateral", DIAGNOSE)


class _FitStarted(Exception):
    pass


def test_diagnose_checks_its_settings_before_fitting(monkeypatch):
    import jaxgwo._diagnose as diagnose_module

    def started(*args, **kwargs):
        raise _FitStarted

    monkeypatch.setattr(diagnose_module, "identify_channels", started)
    for bad in (dict(wolves=2), dict(iterations=0), dict(nonlinear_wolves=3),
                dict(candidates=("time_delay", "gremlins")), dict(nonlinear_profile_points=1),
                dict(nonlinear_refine_rows=0), dict(nonlinear_polish_steps=2.5)):  # fmt: skip
        name = next(iter(bad))
        with pytest.raises(ValueError, match="gremlins" if name == "candidates" else f"{name}="):
            diagnose([_record()], [_record()], "lateral", dataclasses.replace(DIAGNOSE, **bad))


def test_diagnose_rejects_validation_at_another_sample_rate(monkeypatch):
    import jaxgwo._diagnose as diagnose_module

    def started(*args, **kwargs):
        raise _FitStarted

    monkeypatch.setattr(diagnose_module, "identify_channels", started)
    slow = make_record(BASE["time"][::2] * 1.0, {k: BASE[k][::2] for k in ("delta_lat", "p")})
    with pytest.raises(ValueError, match="sample rate"):
        diagnose([_record()], [slow], "lateral", DIAGNOSE)


# -- the CLI -------------------------------------------------------------------------------


def _hostile_files(d: Path) -> dict[str, tuple[Path, str]]:
    """name -> (file, a fragment the one-line error must contain)."""
    out = {}

    def csv(name, cols, fragment, **kw):
        out[name] = (_write_csv(d / f"{name}.csv", cols, **kw), fragment)

    cols = {k: list(v) for k, v in BASE.items()}
    csv("good", cols, "")
    nan = {k: list(v) for k, v in cols.items()}
    nan["p"][1234] = "nan"
    csv("nan", nan, "column 'p' has a non-finite value (nan) at row 1234 (line 1237)")
    dup = {k: list(v) for k, v in cols.items()}
    dup["time"][77] = dup["time"][76]
    csv("duplicate_time", dup, "time is not strictly increasing at row 77 (line 80)")
    text = {k: list(v) for k, v in cols.items()}
    text["delta_lat"][9] = "n/a"
    csv("text", text, "column 'delta_lat' has a non-numeric value 'n/a' at row 9 (line 12)")
    csv("wrong_names", cols, "missing column delta_lat; the columns are: time, ail, ele, gx, gy",
        header="time,ail,ele,gx,gy")
    csv("constant_output", dict(cols, p=[0.5] * N), "the output is constant (column 'p'")
    csv("zero_input", dict(cols, delta_lat=[0.0] * N), "the input is constant (column 'delta_lat'")
    csv("short", {k: v[:300] for k, v in cols.items()}, "record too short for the band")
    (d / "empty.csv").write_bytes(b"")
    out["empty"] = (d / "empty.csv", "no header row")
    (d / "header_only.csv").write_text(",".join(COLUMNS) + "\n")
    out["header_only"] = (d / "header_only.csv", "fewer than two samples (0)")
    np.savez(d / "object.npz", **dict(BASE, p=np.array([None] * N, dtype=object)))
    out["object_npz"] = (d / "object.npz", "cannot read without pickle")
    np.savez(d / "ragged.npz", **dict(BASE, q=BASE["q"][:-1]))
    out["ragged_npz"] = (d / "ragged.npz", "columns have different lengths")
    big = dict(BASE, p=BASE["p"] * 1e300)
    np.savez(d / "huge.npz", **big)
    out["huge"] = (d / "huge.npz", "beyond 1e+150; rescale the column")
    return out


@pytest.fixture(scope="module")
def hostile_dir(tmp_path_factory):
    d = tmp_path_factory.mktemp("hostile")
    return d, _hostile_files(d)


def _cli(argv: list[str]) -> tuple[int, str]:
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        try:
            status = main(argv)
        except SystemExit as exc:  # argparse
            status = exc.code
    return status, err.getvalue()


LOADER_FAILURES = ["nan", "duplicate_time", "text", "empty", "header_only", "object_npz", "ragged_npz"]
CONTENT_FAILURES = ["constant_output", "zero_input", "huge"]  # load, then fail the checks


@HYPOTHESIS
@given(case=st.one_of(
    st.tuples(st.just("identify"), st.just("train"), st.sampled_from(LOADER_FAILURES + CONTENT_FAILURES + ["short"])),
    # identify's CLI checks the validation contents after the (200-frequency) WLS start:
    # only the loader's rejections here, to keep the suite fast
    st.tuples(st.just("identify"), st.just("validate"), st.sampled_from(LOADER_FAILURES)),
    st.tuples(st.just("diagnose"), st.sampled_from(["train", "validate"]),
              st.sampled_from(LOADER_FAILURES + CONTENT_FAILURES)),
    st.tuples(st.just("diagnose"), st.just("train"), st.just("short")),
))
def test_cli_hostile_file_exit_2_one_line_no_output(hostile_dir, case):
    command, role, name = case
    d, files = hostile_dir
    path, fragment = files[name]
    good = str(files["good"][0])
    train, val = (str(path), good) if role == "train" else (good, str(path))
    with tempfile.TemporaryDirectory() as out:
        argv = [command, train, "--channel", "lateral", "--wolves", "8", "--iterations", "5",
                "--json", f"{out}/r.json", "--plot", f"{out}/r.png"]
        if command == "diagnose" or role == "validate":
            argv += ["--validate", val]
        status, err = _cli(argv)
        assert os.listdir(out) == [], "a failing run left files in the output directory"
    assert status == 2, err
    line = _one_line(err)
    assert line.startswith(f"jaxgwo {command}: error: ")
    assert fragment in line, line


@pytest.mark.parametrize(
    "args, fragment",
    [
        (["--wolves", "2"], "wolves"),
        (["--iterations", "0"], "iterations"),
        (["--w-min", "5", "--w-max", "2"], "[5.0, 2.0] rad/s is empty or inverted"),
        (["--coherence", "nan"], "coherence_threshold is NaN"),
        (["--coherence", "1.2"], "coherence_threshold 1.2: pass a value in [0, 1)"),
        (["--w-max", "inf"], "empty or inverted, or not finite"),
        (["--wolves", "many"], "argument --wolves: invalid int value: 'many'"),
        (["--seed", str(10**20)], "pass seed < 2**63"),  # was an OverflowError traceback
    ],
)
def test_cli_bad_options_exit_2_one_line(hostile_dir, args, fragment):
    d, files = hostile_dir
    with tempfile.TemporaryDirectory() as out:
        status, err = _cli(["identify", str(files["good"][0]), "--channel", "lateral", *args,
                            "--json", f"{out}/r.json", "--plot", f"{out}/r.png"])
        assert os.listdir(out) == []
    assert status == 2
    last = err.strip().splitlines()[-1]  # argparse prints its usage first, then one error line
    assert fragment in last, err
    if "invalid int" not in fragment:
        _one_line(err)


@pytest.mark.parametrize(
    "args, fragment",
    [
        (["--wolves", "2"], "wolves"),
        (["--iterations", "0"], "iterations"),
        (["--w-max", "-5"], "is empty or inverted"),
        (["--w-max", "nan"], "w_max is NaN"),
    ],
)
def test_cli_diagnose_bad_options_exit_2_one_line(hostile_dir, args, fragment):
    d, files = hostile_dir
    good = str(files["good"][0])
    with tempfile.TemporaryDirectory() as out:
        status, err = _cli(["diagnose", good, "--validate", good, "--channel", "lateral", *args,
                            "--json", f"{out}/r.json", "--plot", f"{out}/r.png"])
        assert os.listdir(out) == []
    assert status == 2 and fragment in _one_line(err), err


def test_cli_validation_file_problems_exit_2(hostile_dir):
    d, files = hostile_dir
    for name in ("nan", "empty"):
        with tempfile.TemporaryDirectory() as out:
            status, err = _cli(["identify", str(files["good"][0]), "--channel", "lateral",
                                "--validate", str(files[name][0]), "--json", f"{out}/r.json"])
            assert os.listdir(out) == []
        assert status == 2 and files[name][1] in _one_line(err), err


@pytest.mark.parametrize("command, role", [("identify", "train"), ("identify", "validate"),
                                           ("diagnose", "train"), ("diagnose", "validate")])
def test_cli_wrong_column_names_list_the_columns_present(hostile_dir, command, role):
    """Unknown column names: the one-line error names the missing column and lists those the
    file has, so the user can map or rename them."""
    d, files = hostile_dir
    good, wrong = str(files["good"][0]), str(files["wrong_names"][0])
    train, val = (wrong, good) if role == "train" else (good, wrong)
    argv = [command, train, "--channel", "lateral", "--validate", val]
    status, err = _cli(argv)
    line = _one_line(err)
    assert status == 2 and "delta_lat" in line, line
    assert "time, ail, ele, gx, gy" in line, f"the columns the file has are not listed: {line}"


def test_cli_missing_output_directory_exit_2(hostile_dir):
    d, files = hostile_dir
    status, err = _cli(["identify", str(files["constant_output"][0]), "--channel", "lateral",
                        "--json", str(d / "no" / "such" / "dir" / "r.json")])
    assert status == 2 and not (d / "no").exists()


def test_cli_unsupported_plot_format_leaves_no_json(hostile_dir, reference, monkeypatch):
    """Regression: the JSON was written, then the plot failed on its format: r.json stayed."""
    d, files = hostile_dir
    # the identification itself is not under test: hand the CLI the module's reference fit
    # instead of compiling the 200-frequency pipeline again
    monkeypatch.setattr(identify_module, "_prepare", lambda *args, **kwargs: None)
    monkeypatch.setattr(identify_module, "_identify_prepared", lambda *args, **kwargs: {"lateral": reference})
    monkeypatch.setattr(identify_module, "identify_channels", lambda *args, **kwargs: {"lateral": reference})
    with tempfile.TemporaryDirectory() as out:
        status, err = _cli(["identify", str(files["good"][0]), "--channel", "lateral", "--method", "wls",
                            "--json", f"{out}/r.json", "--plot", f"{out}/r.xyz"])
        assert os.listdir(out) == [], "the failing run left r.json behind"
    assert status == 2 and "xyz" in _one_line(err)


def test_cli_directory_as_input_exit_2(hostile_dir):
    """Regression: IsADirectoryError is no ValueError, so it escaped the CLI as a traceback."""
    d, files = hostile_dir
    for command in ("identify", "diagnose"):
        status, err = _cli([command, str(d), "--channel", "lateral", "--validate", str(files["good"][0])])
        assert status == 2 and "is a directory" in _one_line(err), err


def test_cli_json_path_that_is_a_directory_exit_2(hostile_dir, reference, monkeypatch):
    """--json naming a directory: IsADirectoryError (an OSError) ends in exit 2, one line."""
    d, files = hostile_dir
    monkeypatch.setattr(identify_module, "_prepare", lambda *args, **kwargs: None)
    monkeypatch.setattr(identify_module, "_identify_prepared", lambda *args, **kwargs: {"lateral": reference})
    monkeypatch.setattr(identify_module, "identify_channels", lambda *args, **kwargs: {"lateral": reference})
    with tempfile.TemporaryDirectory() as out:
        status, err = _cli(["identify", str(files["good"][0]), "--channel", "lateral", "--method", "wls",
                            "--json", out])
        assert os.listdir(out) == []
    assert status == 2 and "directory" in _one_line(err)


# -- JSON model files (jaxgwo._export): wrong types ----------------------------------------

export = pytest.importorskip("jaxgwo._export")

json_values = st.recursive(
    st.none() | st.booleans() | st.floats(allow_nan=False, allow_infinity=False)
    | st.integers(-(2**53), 2**53) | st.text(max_size=5),
    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=3), inner, max_size=3),
    max_leaves=6,
)
FIELDS = [("format",), ("schema_version",), ("models",), ("models", 0), ("models", 0, "kind"),
          ("models", 0, "channel"), ("models", 0, "parameter_names"), ("models", 0, "parameters"),
          ("models", 0, "parameters", "K"), ("models", 0, "parameters", "zeta_s"),
          ("models", 0, "numerator"), ("models", 0, "denominator", 2), ("models", 0, "metadata"),
          ("provenance",)]


@pytest.fixture(scope="module")
def model_document(tmp_path_factory):
    path = tmp_path_factory.mktemp("model") / "m.json"
    export.save_model(PaperModel.from_array(jnp.asarray(TRUTH)), path, channel="lateral")
    return json.loads(path.read_text())


@HYPOTHESIS
@given(field=st.sampled_from(FIELDS), value=json_values)
def test_model_file_wrong_types_are_value_errors(model_document, field, value):
    """Any JSON value in any field: the model loads (the value was acceptable, e.g. metadata
    or an equal number) or a one-line ValueError names the field."""
    doc = json.loads(json.dumps(model_document))
    target = doc
    for key in field[:-1]:
        target = target[key]
    target[field[-1]] = value
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "m.json"
        path.write_text(json.dumps(doc))
        try:
            model = export.load_model(path)
        except ValueError as err:
            msg = _one_line(str(err))
            named = [str(k) for k in field if isinstance(k, str)]
            assert any(k in msg for k in named) or "models[0]" in msg or "model file" in msg, msg
            return
    assert np.all(np.isfinite(np.asarray(model.to_array())))


@pytest.mark.parametrize(
    "text, message",
    [
        ("", "is empty"),
        ("{", "is not valid JSON"),
        ("[1, 2]", "is not a jaxgwo model file"),
        ('{"format": "jaxgwo-model", "schema_version": 1, "models": []}', "non-empty list"),
        ('{"format": "jaxgwo-model", "schema_version": "1", "models": [{}]}', "must be an integer"),
    ],
)
def test_model_file_broken_documents(tmp_path, text, message):
    (tmp_path / "m.json").write_text(text)
    with pytest.raises(ValueError, match=message):
        export.load_model(tmp_path / "m.json")


@pytest.mark.parametrize("case", ["huge-int-parameter", "huge-int-coefficient", "deep-nesting"])
def test_model_file_overflow_and_nesting(tmp_path, model_document, case):
    """Regression: OverflowError (float(10**400)) and RecursionError escaped as such."""
    doc = json.loads(json.dumps(model_document))
    if case == "huge-int-parameter":
        doc["models"][0]["parameters"]["K"] = 10**400
        text = json.dumps(doc)
    elif case == "huge-int-coefficient":
        doc["models"][0]["numerator"] = [10**400]
        text = json.dumps(doc)
    else:
        text = "[" * 100_000 + "]" * 100_000
    (tmp_path / "m.json").write_text(text)
    with pytest.raises(ValueError):
        export.load_model(tmp_path / "m.json")


def test_model_file_with_an_infinite_coefficient_is_rejected(tmp_path, model_document):
    """Regression: tau = 0 loaded into a model whose coefficients are inf."""
    doc = json.loads(json.dumps(model_document))
    doc["models"][0]["parameters"]["tau"] = 0.0
    del doc["models"][0]["numerator"], doc["models"][0]["denominator"]
    (tmp_path / "m.json").write_text(json.dumps(doc))
    with pytest.raises(ValueError, match="tau"):
        export.load_model(tmp_path / "m.json")
