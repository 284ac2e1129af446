"""Flight logs in: ArduPilot DataFlash ``.bin`` and PX4 ``.ulg`` logs as a :class:`FlightRecord`.

Three entry points:

* :func:`load_ardupilot` reads a DataFlash log written in ArduPilot's System ID mode
  (``SID_AXIS``), with ``pymavlink`` (``DFReader``).
* :func:`load_px4` reads a PX4 ULog with ``pyulog``.
* :func:`load_any` chooses by format or extension and also reads jaxgwo's own CSV/NPZ
  (through :func:`jaxgwo._data.load_record`).

Both log readers **resample** onto a uniform grid the same way (:func:`_resample`):
each logged field is linearly interpolated (``numpy.interp``) onto a uniform grid at the
*median logged rate* (the lowest of the used messages' median rates when input and output
come from different messages, so no stream is up-sampled past what was logged; override
with ``sample_rate=``).  The grid spans the part of the segment that every used message
covers.  A gap between two logged samples longer than ``max_gap`` median periods (3 by
default) is an error that names the message and the time: it is never interpolated over.
Time steps that go backwards or repeat, and NaN or infinite values, are errors too.
Linear interpolation does not low-pass: down-sampling a faster message aliases whatever it
holds above the new Nyquist frequency.  The defaults avoid that for ArduPilot (input and
output from one message, ``RATE`` or ``SIDD``, so the grid is that message's own rate and
only the logging jitter is interpolated away); PX4 topics logged at different rates are
brought down to the slower one.

The record's ``time`` is seconds since the autopilot booted (``TimeUS / 1e6`` for
ArduPilot, the ULog ``timestamp``/``timestamp_sample`` / 1e6 for PX4), so times match the
log and the ground station.
Its metadata says where each column came from, the segment and the resampling.

Everything wrong with a file is a :class:`~jaxgwo._data.FlightDataError` (a
``ValueError``) whose message names the missing message or field and lists those the log
holds.  A missing ``pymavlink``/``pyulog`` is an ``ImportError`` that says
``pip install "jaxgwo[logs]"``.
"""

from __future__ import annotations

import contextlib
import inspect
import io
import math
import os
import re
import shutil
import struct
import sys
import tempfile
import zipfile
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import NamedTuple

import numpy as np

from . import _data
from ._data import CHANNELS, INPUT_NAMES, OUTPUT_NAMES, FlightDataError, FlightRecord, make_record

FORMATS: tuple[str, ...] = ("auto", "csv", "npz", "ardupilot", "px4")
"""Values of ``load_any(format=...)``."""

EXTENSIONS: dict[str, str] = {".csv": "csv", ".npz": "npz", ".bin": "ardupilot", ".ulg": "px4"}
"""File extension (compared in lower case, so ``.BIN`` too) -> format, for ``format="auto"``."""

MAX_GAP_PERIODS = 3.0
"""Default longest gap between logged samples, in median logging periods, that the
resampler interpolates across; a longer gap is an error."""

INSTALL_HINT = 'pip install "jaxgwo[logs]"'

_DATAFLASH_MAGIC = b"\xa3\x95"
_ULOG_MAGIC = b"ULog\x01\x12\x35"
_ZIP_MAGIC = b"PK\x03\x04"
_DEG = math.pi / 180.0

# ArduCopter's SID_AXIS values (ArduCopter/mode_systemid.cpp, 4.x): which of them excite
# roll (lateral cyclic) and which pitch (longitudinal cyclic).
SID_AXES: dict[int, str] = {
    1: "Input Roll Angle",
    2: "Input Pitch Angle",
    3: "Input Yaw Angle",
    4: "Recovery Roll Angle",
    5: "Recovery Pitch Angle",
    6: "Recovery Yaw Angle",
    7: "Rate Roll",
    8: "Rate Pitch",
    9: "Rate Yaw",
    10: "Mixer Roll",
    11: "Mixer Pitch",
    12: "Mixer Yaw",
    13: "Mixer Thrust",
}
"""``SIDS.Ax`` (``SID_AXIS``) -> name, as in ArduCopter's parameter documentation."""

_AXIS_CHANNEL = {
    1: "lateral",
    4: "lateral",
    7: "lateral",
    10: "lateral",
    2: "longitudinal",
    5: "longitudinal",
    8: "longitudinal",
    11: "longitudinal",
}
# Units of SIDD.Targ by axis (SID_MAGNITUDE: "deg, deg/s and 0-1 for mixer outputs").
_TARG_UNITS = {
    1: "deg",
    2: "deg",
    3: "deg/s",
    4: "deg",
    5: "deg",
    6: "deg/s",
    7: "deg/s",
    8: "deg/s",
    9: "deg/s",
    10: "normalised",
    11: "normalised",
    12: "normalised",
    13: "normalised",
}

# ArduCopter waits this long after entering System ID mode before the chirp starts
# (SYSTEM_ID_DELAY in mode_systemid.cpp); the mode's test ends at
# SYSTEM_ID_DELAY + TFin + TC + TR + TFout after the SIDS message.
_SYSID_DELAY_S = 1.0


# -- resampling ---------------------------------------------------------------------------


class _Field(NamedTuple):
    """One logged field: its label (``"RATE.ROut"``), times (s) and values, and the
    factor that converts it to the canonical unit."""

    message: str
    field: str
    time: np.ndarray
    values: np.ndarray
    scale: float = 1.0

    @property
    def label(self) -> str:
        return f"{self.message}.{self.field}"


def _check_stream(message: str, t: np.ndarray, max_gap: float, where: str) -> float:
    """Check one message's times; return its median logged period (s)."""
    steps = np.diff(t)
    back = np.flatnonzero(steps <= 0.0)
    if back.size:
        i = int(back[0])
        raise FlightDataError(
            f"{where}: {message} time does not increase at t = {t[i + 1]:.6f} s "
            f"(previous sample at {t[i]:.6f} s)"
        )
    period = float(np.median(steps))
    gaps = np.flatnonzero(steps > max_gap * period)
    if gaps.size:
        i = int(gaps[0])
        raise FlightDataError(
            f"{where}: {message} has a gap of {steps[i]:.4g} s ({steps[i] / period:.1f} logging "
            f"periods of {period * 1e3:.4g} ms) from t = {t[i]:.6f} s to t = {t[i + 1]:.6f} s; "
            f"gaps longer than {max_gap:g} periods are not interpolated over: choose a "
            f"window that avoids it"
        )
    return period


def _resample(
    fields: Mapping[str, _Field],
    *,
    start_s: float,
    stop_s: float,
    sample_rate: float | None,
    max_gap: float,
    where: str,
) -> tuple[np.ndarray, dict[str, np.ndarray], str]:
    """Linear interpolation of each field onto one uniform grid inside ``[start_s, stop_s]``.

    Returns ``(grid, {column: values in canonical units}, description)``.  The grid rate is
    ``sample_rate`` or else the lowest median logged rate among the messages used; the grid
    starts at the latest first sample and ends by the earliest last sample, so every value
    is an interpolation between two logged samples at most ``max_gap`` periods apart.
    """
    if sample_rate is not None and not (np.isfinite(sample_rate) and sample_rate > 0.0):
        raise ValueError(f"sample_rate must be a positive number of Hz, got {sample_rate!r}")
    if not max_gap > 0.0:
        raise ValueError(f"max_gap must be a positive number of logging periods, got {max_gap!r}")
    cut: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    periods: dict[str, float] = {}
    for name, f in fields.items():
        keep = (f.time >= start_s) & (f.time <= stop_s)
        t, v = f.time[keep], f.values[keep]
        if t.size < 2:
            raise FlightDataError(
                f"{where}: {f.label} has {t.size} sample(s) between {start_s:.6f} s and "
                f"{stop_s:.6f} s; need at least 2"
            )
        bad = np.flatnonzero(~np.isfinite(v))
        if bad.size:
            i = int(bad[0])
            raise FlightDataError(f"{where}: {f.label} is {float(v[i])!r} at t = {t[i]:.6f} s")
        if f.message not in periods:
            periods[f.message] = _check_stream(f.message, t, max_gap, where)
        cut[name] = (t, v * f.scale)
    lo = max(t[0] for t, _ in cut.values())
    hi = min(t[-1] for t, _ in cut.values())
    slowest = max(periods, key=periods.__getitem__)
    rate = float(sample_rate) if sample_rate is not None else 1.0 / periods[slowest]
    n = int(math.floor((hi - lo) * rate + 1e-9)) + 1 if hi > lo else 0
    if n < 2:
        raise FlightDataError(
            f"{where}: the messages used ({', '.join(sorted(periods))}) overlap for "
            f"{max(hi - lo, 0.0):.6g} s, too short for two samples at {rate:.6g} Hz"
        )
    grid = lo + np.arange(n, dtype=np.float64) / rate
    out = {name: np.interp(grid, t, v) for name, (t, v) in cut.items()}
    logged = ", ".join(f"{m} {1.0 / p:.6g} Hz" for m, p in sorted(periods.items()))
    why = "requested" if sample_rate is not None else f"median logged rate of {slowest}"
    how = (
        f"linear interpolation (numpy.interp) onto a uniform {rate:.6g} Hz grid ({why}; "
        f"logged: {logged}) from {grid[0]:.6f} s to {grid[-1]:.6f} s; gaps over "
        f"{max_gap:g} logging periods rejected, not bridged"
    )
    return grid, out, how


def _record(grid, columns, metadata, required, where: str, hint: str) -> FlightRecord:
    """:func:`make_record`, with its errors naming the log file instead of "record"."""
    try:
        return make_record(grid, columns, metadata, required=required)
    except FlightDataError as err:
        text = str(err)
        text = (
            f"{where}:{text[len('record:') :]}"
            if text.startswith("record:")
            else f"{where}: {text}"
        )
        raise FlightDataError(text + hint) from None


def _window(window: Sequence[float] | None) -> tuple[float, float] | None:
    if window is None:
        return None
    try:
        start, stop = (float(x) for x in window)
    except (TypeError, ValueError):
        raise ValueError(f"window must be (start_s, stop_s), got {window!r}") from None
    if not (np.isfinite(start) and np.isfinite(stop) and stop > start):
        raise ValueError(f"window must be (start_s, stop_s) with start_s < stop_s, got {window!r}")
    return start, stop


def _check_choice(name: str, value: object, choices: Sequence[object]) -> None:
    if value not in choices:
        raise ValueError(f"{name} must be one of {', '.join(map(repr, choices))}; got {value!r}")


def _file_size(p: Path) -> int:
    if not p.exists():
        raise FileNotFoundError(f"no such flight-data file: {p}")
    if p.is_dir():
        raise FlightDataError(f"{p}: is a directory, not a log file")
    size = p.stat().st_size
    if size == 0:
        raise FlightDataError(f"{p}: the file is empty")
    return size


def _head(p: Path, n: int) -> bytes:
    with open(p, "rb") as fh:
        return fh.read(n)


def _listing(names: Sequence[str]) -> str:
    return ", ".join(sorted(names)) if names else "(none)"


# -- ArduPilot DataFlash ------------------------------------------------------------------


class SystemIdRun(NamedTuple):
    """One run of ArduPilot's System ID mode, marked in the log by a ``SIDS`` message.

    Attributes:
        index: position among the log's ``SIDS`` messages, from 0.
        start_s: ``SIDS.TimeUS`` in seconds since boot (the mode was entered).
        stop_s: the end of the run: the earliest of the mode's own finish time
            (``start + 1 s + TFin + TC + TR + TFout``, all ``SIDS`` fields in seconds),
            the last ``SIDD`` sample before the next run (the pilot left the mode), and the
            next ``SIDS``.
        axis: ``SIDS.Ax`` (``SID_AXIS``), see :data:`SID_AXES`.
    """

    index: int
    start_s: float
    stop_s: float
    axis: int

    @property
    def axis_name(self) -> str:
        return SID_AXES.get(self.axis, f"axis {self.axis}")

    @property
    def channel(self) -> str | None:
        """``"lateral"`` (roll axes), ``"longitudinal"`` (pitch axes) or ``None``."""
        return _AXIS_CHANNEL.get(self.axis)

    def describe(self) -> str:
        return (
            f"run {self.index}: SID_AXIS {self.axis} ({self.axis_name}), "
            f"{self.start_s:.3f}-{self.stop_s:.3f} s"
        )


class _DataFlash(NamedTuple):
    present: dict[str, tuple[str, ...]]  # message type -> its fields, for types with data
    columns: dict[str, dict[str, np.ndarray]]  # message type -> field -> values
    units: dict[str, dict[str, str]]  # message type -> field -> unit the log declares, or ""
    damage: str  # what pymavlink reported skipping, or ""


def _import_dfreader():
    try:
        from pymavlink import DFReader
    except ImportError:
        raise ImportError(
            f"reading ArduPilot DataFlash (.bin) logs needs pymavlink: {INSTALL_HINT}"
        ) from None
    return DFReader


_FAST_DECODE = True  # tests switch it off to compare against pymavlink's own decoding

# struct codes of DataFlash fields (pymavlink FORMAT_TO_STRUCT) as NumPy dtypes
_NUMPY_CODES = {
    "b": "i1",
    "B": "u1",
    "h": "i2",
    "H": "u2",
    "i": "i4",
    "I": "u4",
    "q": "i8",
    "Q": "u8",
    "e": "f2",
    "f": "f4",
    "d": "f8",
}


def _decode_dataflash(
    data: bytes, offsets, fmt, fields: Sequence[str]
) -> dict[str, np.ndarray] | None:
    """Decode ``fields`` of every message of one type at once with NumPy.

    ``offsets`` are where pymavlink's index found the messages, ``fmt`` its ``DFFormat``
    (``msg_struct``, ``colhash``, ``msg_mults``).  Gives the values ``DFMessage`` would
    (multipliers applied) without a Python call per message; ``None`` where a field
    type is not plain numeric, and the caller then asks pymavlink message by message.
    """
    tokens = re.findall(r"(\d*)([a-zA-Z?])", fmt.msg_struct.lstrip("<"))
    layout = []
    for j, (count, code) in enumerate(tokens):
        if code == "s":
            layout.append((f"f{j}", f"S{count or 1}"))
        elif code in _NUMPY_CODES and not count:
            layout.append((f"f{j}", "<" + _NUMPY_CODES[code]))
        else:
            return None
    dtype = np.dtype(layout)  # packed like the C struct: no alignment padding
    if dtype.itemsize != struct.calcsize(fmt.msg_struct):
        return None
    index = [fmt.colhash[f] for f in fields]
    if any(i >= len(layout) or layout[i][1].startswith("S") for i in index):
        return None
    starts = np.asarray(offsets, dtype=np.int64).reshape(-1) + 3  # after A3 95 <type>
    starts = starts[starts + dtype.itemsize <= len(data)]  # a message cut by the file end
    raw = np.frombuffer(data, dtype=np.uint8)
    records = raw[starts[:, None] + np.arange(dtype.itemsize)].view(dtype).reshape(-1)
    out = {}
    for name, i in zip(fields, index, strict=True):
        values = records[f"f{i}"].astype(np.float64)
        mult = fmt.msg_mults[i]
        if mult is not None:  # as DFMessage: divide by 1/mult for the decimal multipliers
            values = values / (1.0 / mult) if 0.0 < mult < 1.0 else values * mult
        out[name] = values
    return out


def _declared_unit(fmt, field: str) -> str:
    """The unit the log's own ``UNIT``/``FMTU`` messages give ``field``, or ``""``."""
    try:
        return str(fmt.get_unit(field) or "")
    except Exception:  # no FMTU for the type, or one shorter than its columns
        return ""


def _rate_scale(log: _DataFlash, message: str, field: str, where: str) -> tuple[float, str]:
    """Factor to rad/s for an angular-rate field, and what was done, from its declared unit.

    ArduPilot defines ``RATE.R/P`` and ``SIDD.Gx/Gy`` in deg/s (unit id ``k``); a log
    that declares rad/s (``E``) is taken as it is, and any other unit is an error rather
    than a silent mis-scaling.  Logs without ``FMTU`` messages are taken as deg/s.
    """
    unit = log.units.get(message, {}).get(field, "")
    if unit in ("", "deg/s"):
        return _DEG, "deg/s converted to rad/s"
    if unit == "rad/s":
        return 1.0, "rad/s as logged"
    raise FlightDataError(
        f"{where}: {message}.{field} is logged in {unit!r}; an angular rate in deg/s or "
        f"rad/s is expected"
    )


def _collect_dataflash(
    reader, wanted: Mapping[str, Sequence[str]]
) -> dict[str, dict[str, np.ndarray]]:
    """The same through pymavlink's ``recv_match``, one message at a time."""
    rows: dict[str, list[tuple[float, ...]]] = {name: [] for name in wanted}
    while True:
        m = reader.recv_match(type=set(wanted), strict=True)
        if m is None:
            break
        name = m.get_type()
        rows[name].append(tuple(float(getattr(m, f)) for f in ("TimeUS", *wanted[name])))
    columns = {}
    for name, fields in wanted.items():
        a = np.asarray(rows[name], dtype=np.float64).reshape(-1, 1 + len(fields))
        columns[name] = {"TimeUS": a[:, 0], **{f: a[:, 1 + j] for j, f in enumerate(fields)}}
    return columns


_WHY_NEEDED = {
    "SIDS": " (no System ID mode run to take; pass window=(start_s, stop_s) to take the data "
    "by time instead)",
    "RATE": " (RATE holds the mixer inputs ROut/POut and the rates R/P)",
    "SIDD": " (SIDD holds the injected chirp Targ and the gyro rates Gx/Gy)",
}


@contextlib.contextmanager
def _native_stderr_to(sink: io.StringIO):
    """Send what native code writes to file descriptor 2 into ``sink`` for the duration.

    pymavlink's compiled indexer reports every bad byte of a damaged log there, one line
    each, past ``sys.stderr``; the lines are kept (and summarised in the record's
    metadata) instead of flooding the terminal.  Descriptor 2 is restored on exit.
    """
    try:
        sys.stderr.flush()
        saved = os.dup(2)
    except (OSError, ValueError, AttributeError):  # no usable descriptor 2: leave it be
        yield
        return
    with tempfile.TemporaryFile() as tmp:
        os.dup2(tmp.fileno(), 2)
        try:
            yield
        finally:
            os.dup2(saved, 2)
            os.close(saved)
            tmp.seek(0)
            sink.write(tmp.read().decode("utf-8", "replace"))


def _dataflash_reader(DFReader):
    """``DFReader_binary`` without its search for a GPS time base.

    Its ``init_clock`` parses message after message until a GPS fix gives absolute time,
    the whole log when there is none; these readers use ``TimeUS`` (time since boot)
    directly, so the microsecond clock pymavlink falls back to is set at once.
    """

    class Reader(DFReader.DFReader_binary):
        def init_clock(self):
            if not hasattr(self, "init_clock_usec"):
                return super().init_clock()
            self._rewind(keep_messages=True)
            self.init_clock_usec()
            self._rewind(keep_messages=True)

    return Reader


def _read_dataflash(
    p: Path, needed: Mapping[str, Sequence[str]], optional: Mapping[str, Sequence[str]]
) -> _DataFlash:
    """Read the listed fields of the listed message types (``TimeUS`` always)."""
    DFReader = _import_dfreader()
    _file_size(p)
    where = str(p)
    reader = None
    notes = io.StringIO()  # pymavlink's notes about damaged data, summarised in the metadata
    try:
        with contextlib.redirect_stdout(notes), contextlib.redirect_stderr(notes):
            with _native_stderr_to(notes):
                reader = _dataflash_reader(DFReader)(str(p), zero_time_base=True)
            present = {
                name: tuple(reader.formats[type_id].columns)
                for name, type_id in reader.name_to_id.items()
                if name != "FMT" and reader.counts[type_id] > 0
            }
            if not present:
                raise FlightDataError(
                    f"{where}: no DataFlash messages found; an ArduPilot .bin log starts with "
                    f"the bytes 0xA3 0x95 and FMT messages; this file "
                    f"{'does' if _head(p, 2) == _DATAFLASH_MAGIC else 'does not'}"
                )
            for name in needed:
                if name not in present:
                    raise FlightDataError(
                        f"{where}: no {name} messages in the log{_WHY_NEEDED.get(name, '')}; "
                        f"messages present: {_listing(list(present))}"
                    )
            # an optional message with other fields (another firmware) is left out, not an error
            usable = {
                k: v
                for k, v in optional.items()
                if k in present and all(f in present[k] for f in ("TimeUS", *v))
            }
            wanted = {**usable, **needed}
            for name, fields in wanted.items():
                missing = [f for f in ("TimeUS", *fields) if f not in present[name]]
                if missing:
                    raise FlightDataError(
                        f"{where}: message {name} has no field {', '.join(missing)}; its "
                        f"fields are: {', '.join(present[name])}"
                    )
            columns: dict[str, dict[str, np.ndarray]] = {}
            if _FAST_DECODE:
                data = p.read_bytes()
                for name in wanted:
                    type_id = reader.name_to_id[name]
                    decoded = _decode_dataflash(
                        data,
                        reader.offsets[type_id],
                        reader.formats[type_id],
                        ("TimeUS", *wanted[name]),
                    )
                    if decoded is not None:
                        columns[name] = decoded
            slow = {name: wanted[name] for name in wanted if name not in columns}
            if slow:
                columns.update(_collect_dataflash(reader, slow))
            units = {
                name: {
                    f: _declared_unit(reader.formats[reader.name_to_id[name]], f) for f in fields
                }
                for name, fields in wanted.items()
            }
    except (FlightDataError, ImportError):
        raise
    except Exception as err:  # pymavlink raises anything on a damaged file
        raise FlightDataError(
            f"{where}: not a readable ArduPilot DataFlash log ({type(err).__name__}: {err})"
        ) from None
    finally:
        if reader is not None:
            with contextlib.suppress(Exception):
                reader.close()
    lines = [line.strip() for line in notes.getvalue().splitlines() if line.strip()]
    damage = (
        f"pymavlink skipped damaged data ({len(lines)} notes; first: {lines[0]})" if lines else ""
    )
    return _DataFlash(present, columns, units, damage)


def _sysid_runs(log: _DataFlash) -> list[SystemIdRun]:
    sids = log.columns.get("SIDS")
    if sids is None:
        return []
    starts = sids["TimeUS"] * 1e-6
    sidd = log.columns.get("SIDD", {}).get("TimeUS", np.empty(0)) * 1e-6
    runs = []
    for i, start in enumerate(starts):
        nominal = _SYSID_DELAY_S + sum(float(sids[k][i]) for k in ("TFin", "TC", "TR", "TFout"))
        stop = start + nominal if np.isfinite(nominal) and nominal > 0 else np.inf
        following = starts[i + 1] if i + 1 < starts.size else np.inf
        in_run = sidd[(sidd >= start) & (sidd < following)]
        if in_run.size:
            stop = min(stop, float(in_run[-1]))
        stop = min(stop, following)
        if not np.isfinite(stop):
            stop = start
        runs.append(SystemIdRun(i, float(start), float(stop), int(sids["Ax"][i])))
    return runs


def ardupilot_runs(path: str | os.PathLike) -> list[SystemIdRun]:
    """The System ID runs in an ArduPilot DataFlash log, one per ``SIDS`` message, in log
    order: what :func:`load_ardupilot`'s ``run=`` indexes.  Empty when there are none.

    Raises:
        FlightDataError: an empty or unreadable file, or ``SIDS`` without its fields.
        ImportError: ``pymavlink`` is not installed (``pip install "jaxgwo[logs]"``).
    """
    log = _read_dataflash(Path(path), {}, {"SIDS": ["Ax", "TFin", "TC", "TR", "TFout"], "SIDD": []})
    return _sysid_runs(log)


def _pick_run(
    runs: list[SystemIdRun], run: int | None, channel: str | None, where: str
) -> SystemIdRun:
    listing = "; ".join(r.describe() for r in runs)
    if run is not None:
        if not 0 <= run < len(runs):
            raise FlightDataError(f"{where}: no system-ID run {run}; the log holds {listing}")
        chosen = runs[run]
        if channel is not None and chosen.channel != channel:
            raise FlightDataError(
                f"{where}: run {run} excites SID_AXIS {chosen.axis} ({chosen.axis_name}), "
                f"not the {channel} channel"
            )
        return chosen
    candidates = [r for r in runs if channel is None or r.channel == channel]
    if len(candidates) == 1:
        return candidates[0]
    if not candidates:
        raise FlightDataError(
            f"{where}: no system-ID run on the {channel} channel; the log holds {listing}"
        )
    raise FlightDataError(
        f"{where}: the log holds {len(candidates)} system-ID runs"
        f"{'' if channel is None else ' on the ' + channel + ' channel'}; choose one with "
        f"run=INDEX (or channel=, or window=(start_s, stop_s)): {listing}"
    )


def load_ardupilot(
    path: str | os.PathLike,
    *,
    input: str = "mixer",
    output: str | None = None,
    run: int | None = None,
    channel: str | None = None,
    window: Sequence[float] | None = None,
    sample_rate: float | None = None,
    max_gap: float = MAX_GAP_PERIODS,
    required: Sequence[str] | None = None,
) -> FlightRecord:
    """Read an ArduPilot DataFlash ``.bin`` log from System ID mode into a flight record.

    Messages and fields (ArduCopter ``Log.cpp`` and ``AC_AttitudeControl`` log structures):

    * ``SIDS`` (one per System ID run, written on entering the mode): ``TimeUS`` (us since
      boot), ``Ax`` (``SID_AXIS``: 1/4/7/10 roll angle/recovery/rate/mixer, 2/5/8/11 the
      same for pitch, see :data:`SID_AXES`), ``TFin``, ``TC``, ``TR``, ``TFout`` (s).
    * ``SIDD`` (each logged loop while in the mode): ``Targ`` (the injected chirp sample, in
      deg, deg/s or normalised mixer units by axis), ``Gx``, ``Gy`` (body roll and pitch
      rate, deg/s).
    * ``RATE``: ``ROut``, ``POut`` (roll and pitch rate-controller outputs to the mixer,
      normalised), ``R``, ``P`` (measured roll and pitch rate, deg/s).
    * ``ATT`` (optional): ``Roll``, ``Pitch`` (deg), the attitude estimate, which integrates
      the raw IMU rather than the filtered gyro the rate controller sees.  Where it is
      logged at least as fast as the record's grid (``LOG_BITMASK`` with
      ``ATTITUDE_FAST``), it is interpolated onto the grid as ``phi, theta`` (rad), and
      ``jaxgwo diagnose`` reads the gyro filter against it; otherwise the metadata's
      ``attitude`` says why it was left out.

    Args:
        path: the ``.bin`` file.
        input: ``"mixer"`` (default): ``RATE.ROut -> delta_lat`` and
            ``RATE.POut -> delta_lon``, the swashplate mixer inputs, which give a
            bare-airframe model whatever axis was excited (what ArduPilot's helicopter
            maintainers recommend for identification).  ``"targ"``: ``SIDD.Targ`` as the
            input of the excited channel only (``delta_lat`` for a roll ``SID_AXIS``,
            ``delta_lon`` for pitch), in the units ``SID_AXIS`` gives it (recorded in the
            metadata); for an angle or rate axis this is a closed-loop response.
        output: ``"rate"``: ``RATE.R -> p``, ``RATE.P -> q``; ``"sidd"``: ``SIDD.Gx -> p``,
            ``SIDD.Gy -> q``.  Both in deg/s, converted to rad/s.  Default: ``"rate"`` for
            the mixer input and ``"sidd"`` for ``"targ"``, so input and output come from the
            same message and share timestamps.
        run: which ``SIDS`` run to take (0 is the first in the log).  Without ``run`` or
            ``window`` the log must hold exactly one run (on ``channel``, if given).  See
            :class:`SystemIdRun` for where a run ends.
        channel: ``"lateral"`` or ``"longitudinal"``: only runs on that channel's axes;
            with ``input="targ"`` and a ``window`` it says which column ``Targ`` drives.
        window: ``(start_s, stop_s)`` in seconds since boot (``TimeUS / 1e6``), instead of a
            ``SIDS`` run.
        sample_rate: grid rate in Hz; default the median logged rate (see the module
            docstring for the resampling).
        max_gap: longest gap between logged samples, in median logging periods, that is
            interpolated over; a longer one is an error naming its time.
        required: canonical columns that must be present (default: the columns this input
            choice makes), checked by :func:`jaxgwo.make_record`.

    Raises:
        FlightDataError: empty, truncated beyond use or garbage file; a missing message or
            field (listing those the log holds); no ``SIDS`` run and no ``window``; several
            runs and no choice; a run on a yaw/thrust axis with ``input="targ"``; a gap,
            NaN or backwards time step inside the segment.
        ImportError: ``pymavlink`` is not installed (``pip install "jaxgwo[logs]"``).
        ValueError: an option outside its choices.
    """
    _check_choice("input", input, ("mixer", "targ"))
    output = output if output is not None else ("rate" if input == "mixer" else "sidd")
    _check_choice("output", output, ("rate", "sidd"))
    _check_choice("channel", channel, (None, *CHANNELS))
    span = _window(window)
    if span is not None and run is not None:
        raise ValueError("give run= or window=, not both")
    p = Path(path)
    where = str(p)

    needed: dict[str, list[str]] = {}
    if input == "mixer":
        needed.setdefault("RATE", []).extend(["ROut", "POut"])
    else:
        needed.setdefault("SIDD", []).append("Targ")
    if output == "rate":
        needed.setdefault("RATE", []).extend(["R", "P"])
    else:
        needed.setdefault("SIDD", []).extend(["Gx", "Gy"])
    optional = {"SIDS": ["Ax", "TFin", "TC", "TR", "TFout"], "SIDD": [], "ATT": ["Roll", "Pitch"]}
    if span is None:
        needed["SIDS"] = optional.pop("SIDS")
    log = _read_dataflash(p, needed, optional)
    runs = _sysid_runs(log)

    if span is None:
        chosen = _pick_run(runs, run, channel, where)
        start_s, stop_s = chosen.start_s, chosen.stop_s
        segment = f"SIDS {chosen.describe()}"
    else:
        chosen = None
        start_s, stop_s = span
        segment = f"window {start_s:.6g}-{stop_s:.6g} s since boot"

    fields: dict[str, _Field] = {}

    def field(column: str, message: str, name: str, scale: float = 1.0) -> None:
        cols = log.columns[message]
        fields[column] = _Field(message, name, cols["TimeUS"] * 1e-6, cols[name], scale)

    if input == "mixer":
        field("delta_lat", "RATE", "ROut")
        field("delta_lon", "RATE", "POut")
        in_text = "RATE.ROut -> delta_lat, RATE.POut -> delta_lon (mixer inputs, normalised)"
        pairs = list(CHANNELS.values())
    else:
        if chosen is None:  # a window: the axis comes from channel= or the run before it
            before = [r for r in runs if r.start_s <= start_s]
            if channel is not None:
                targ_channel, axis = channel, None
            elif before:
                targ_channel, axis = before[-1].channel, before[-1].axis
            else:
                raise FlightDataError(
                    f"{where}: input='targ' with a window needs channel='lateral' or "
                    f"'longitudinal': no SIDS run before {start_s:.6g} s says which axis "
                    f"SIDD.Targ drives"
                )
        else:
            targ_channel, axis = chosen.channel, chosen.axis
        if targ_channel is None:
            raise FlightDataError(
                f"{where}: SID_AXIS {axis} ({SID_AXES.get(axis, 'unknown')}) excites neither "
                f"roll nor pitch; jaxgwo identifies the lateral (roll) and longitudinal "
                f"(pitch) channels; use input='mixer' or another run"
            )
        in_col = CHANNELS[targ_channel][0]
        field(in_col, "SIDD", "Targ")
        units = _TARG_UNITS.get(axis, "set by SID_AXIS") if axis is not None else "set by SID_AXIS"
        in_text = f"SIDD.Targ -> {in_col} (injected chirp, {units})"
        pairs = [CHANNELS[targ_channel]]

    out_columns = [out for _, out in pairs]
    src, names = {"rate": ("RATE", {"p": "R", "q": "P"}), "sidd": ("SIDD", {"p": "Gx", "q": "Gy"})}[
        output
    ]
    out_text = []
    for col in out_columns:
        scale, done = _rate_scale(log, src, names[col], where)
        field(col, src, names[col], scale)
        out_text.append(f"{src}.{names[col]} -> {col} ({done})")

    grid, values, how = _resample(
        fields,
        start_s=start_s,
        stop_s=stop_s,
        sample_rate=sample_rate,
        max_gap=max_gap,
        where=where,
    )
    metadata = {
        "source": f"ArduPilot DataFlash log {p.name}",
        "source_format": "ardupilot",
        "input": in_text,
        "output": ", ".join(out_text),
        "segment": segment,
        "resampling": how,
        "time": "seconds since autopilot boot (TimeUS / 1e6)",
    }
    if log.damage:
        metadata["log_warning"] = log.damage
    ordered = {c: values[c] for c in (*INPUT_NAMES, *OUTPUT_NAMES) if c in values}
    req = tuple(required) if required is not None else tuple(ordered)
    attitude, metadata["attitude"] = _ardupilot_attitude(log, grid, max_gap, where)
    ordered |= attitude
    hint = (
        " (input='targ' gives the excited channel only; input='mixer' gives both)"
        if input == "targ"
        else ""
    )
    return _record(grid, ordered, metadata, req, where, hint)


def _ardupilot_attitude(log: _DataFlash, grid: np.ndarray, max_gap: float, where: str) -> tuple[dict, str]:
    """``ATT.Roll, ATT.Pitch`` (deg) on ``grid`` as ``phi, theta`` (rad) with a note on where
    they came from, or none and why (:func:`_attitude_on_grid`)."""
    att = log.columns.get("ATT")
    if att is None:
        return {}, "none (no ATT messages with Roll and Pitch in the log)"
    return _attitude_on_grid("ATT", att["TimeUS"] * 1e-6, att["Roll"] * _DEG, att["Pitch"] * _DEG, grid, max_gap,
                             where, "ATT.Roll -> phi, ATT.Pitch -> theta (deg converted to rad",
                             "LOG_BITMASK with ATTITUDE_FAST")  # fmt: skip


def _attitude_on_grid(message: str, t: np.ndarray, roll: np.ndarray, pitch: np.ndarray, grid: np.ndarray,
                      max_gap: float, where: str, source: str, how_faster: str) -> tuple[dict, str]:
    """An attitude estimate (rad) interpolated onto the record's ``grid`` as ``phi, theta``,
    with a note saying where it came from; none, and the note says why, where it does not
    cover the grid, has a gap, a NaN or a backwards step there, or is logged slower than
    the grid (interpolating it up would invent the high frequencies the gyro path reads;
    ``how_faster`` says how to log it faster).  Optional data: left out, never an error."""
    keep = (t >= grid[0] - 1.0) & (t <= grid[-1] + 1.0)
    t, roll, pitch = t[keep], roll[keep], pitch[keep]
    if t.size < 2:
        return {}, f"none ({message} does not cover the segment)"
    rate = 1.0 / float(np.median(np.diff(grid))) if grid.size > 1 else math.inf
    try:
        period = _check_stream(message, t, max_gap, where)
    except FlightDataError as err:
        return {}, f"none ({message} left out: {err})"
    if 1.0 / period < 0.9 * rate:
        return {}, (f"none ({message} logged at {1.0 / period:.3g} Hz, below the record's {rate:.3g} Hz; log it "
                    f"at the gyro's rate ({how_faster}) to read the gyro filter against it)")  # fmt: skip
    if t[0] > grid[0] + 1e-6 or t[-1] < grid[-1] - 1e-6:  # timestamps are whole microseconds
        return {}, f"none ({message} does not cover the segment)"
    if not (np.all(np.isfinite(roll)) and np.all(np.isfinite(pitch))):
        return {}, f"none ({message} holds NaN or infinite values in the segment)"
    out = {"phi": np.interp(grid, t, roll), "theta": np.interp(grid, t, pitch)}
    return out, f"{source}; {message} logged at {1.0 / period:.3g} Hz)"


# -- PX4 ULog -----------------------------------------------------------------------------

_PX4_OUTPUT = ("vehicle_angular_velocity", {"p": "xyz[0]", "q": "xyz[1]"})
_PX4_ATTITUDE = "vehicle_attitude"
_PX4_INPUTS = {
    "torque_setpoint": ("vehicle_torque_setpoint", {"delta_lat": "xyz[0]", "delta_lon": "xyz[1]"}),
    "actuator_controls": (
        "actuator_controls_0",
        {"delta_lat": "control[0]", "delta_lon": "control[1]"},
    ),
}


def _import_ulog():
    try:
        from pyulog import ULog
    except ImportError:
        raise ImportError(f"reading PX4 ULog (.ulg) logs needs pyulog: {INSTALL_HINT}") from None
    return ULog


def _parse_ulog(ULog, p: Path, topics: Sequence[str] | None):
    quiet = io.StringIO()  # pyulog prints warnings about versions and corruption
    try:
        with contextlib.redirect_stdout(quiet):
            return ULog(str(p), message_name_filter_list=topics, disable_str_exceptions=True)
    except Exception as err:  # pyulog raises ULogException, struct.error, ... on damage
        raise FlightDataError(
            f"{p}: not a readable PX4 ULog ({type(err).__name__}: {err}); a ULog starts "
            f"with the bytes 'ULog' 01 12 35"
        ) from None


def load_px4(
    path: str | os.PathLike,
    *,
    input: str = "auto",
    window: Sequence[float] | None = None,
    sample_rate: float | None = None,
    max_gap: float = MAX_GAP_PERIODS,
    required: Sequence[str] | None = None,
) -> FlightRecord:
    """Read a PX4 ULog ``.ulg`` into a flight record (instance 0 of each topic).

    Topics and fields (PX4 ``msg/*.msg``; pyulog names array elements ``xyz[0]``):

    * ``vehicle_angular_velocity``: ``xyz[0]``, ``xyz[1]`` (body roll and pitch rate,
      rad/s) -> ``p``, ``q``; timed by ``timestamp_sample`` (when the gyro sampled), or
      ``timestamp`` where the topic lacks it.
    * ``vehicle_attitude`` (optional): ``q[0..3]`` (the estimator's attitude quaternion,
      Hamilton, body to NED; it integrates the raw IMU, not the filtered angular velocity
      above) -> ``phi, theta`` (rad, roll and pitch of the ZYX Euler angles), where it is
      logged at least as fast as the grid; otherwise the metadata's ``attitude`` says why
      it was left out.
    * ``vehicle_torque_setpoint``: ``xyz[0]``, ``xyz[1]`` (normalised roll and pitch
      torque demand, -1..1) -> ``delta_lat``, ``delta_lon``; or, on firmware before
      v1.14, ``actuator_controls_0``: ``control[0]``, ``control[1]`` (normalised roll and
      pitch control).  Timed by ``timestamp`` (when the command was published), so the
      controller's computation delay stays in the identified response.

    Args:
        path: the ``.ulg`` file.
        input: ``"auto"`` (the torque setpoint if logged, else ``actuator_controls_0``),
            ``"torque_setpoint"`` or ``"actuator_controls"``.
        window: ``(start_s, stop_s)`` in seconds since boot (``timestamp / 1e6``);
            default the whole span both topics cover.
        sample_rate: grid rate in Hz; default the lower median logged rate of the two
            topics (see the module docstring for the resampling).
        max_gap: longest gap between logged samples, in median logging periods, that is
            interpolated over; a longer one is an error naming its time.
        required: canonical columns that must be present (default all four).

    Raises:
        FlightDataError: empty, garbage or unreadable file; a missing topic or field
            (listing those the log holds); a gap, NaN or backwards time step.
        ImportError: ``pyulog`` is not installed (``pip install "jaxgwo[logs]"``).
        ValueError: an option outside its choices.
    """
    _check_choice("input", input, ("auto", *_PX4_INPUTS))
    span = _window(window)
    ULog = _import_ulog()
    p = Path(path)
    where = str(p)
    _file_size(p)
    candidates = list(_PX4_INPUTS) if input == "auto" else [input]
    topics = [_PX4_OUTPUT[0], *(_PX4_INPUTS[c][0] for c in candidates), _PX4_ATTITUDE]
    ulog = _parse_ulog(ULog, p, topics)

    def datasets(u) -> dict[str, dict[str, np.ndarray]]:
        found: dict[str, tuple[int, dict[str, np.ndarray]]] = {}
        for d in u.data_list:  # instance 0, or the lowest instance logged
            if d.name not in found or d.multi_id < found[d.name][0]:
                found[d.name] = (d.multi_id, d.data)
        return {name: data for name, (_, data) in found.items()}

    data = datasets(ulog)

    def missing(what: str) -> FlightDataError:
        everything = sorted(datasets(_parse_ulog(ULog, p, None)))
        return FlightDataError(f"{where}: {what}; topics present: {_listing(everything)}")

    chosen = next((c for c in candidates if _PX4_INPUTS[c][0] in data), None)
    if chosen is None:
        names = " or ".join(_PX4_INPUTS[c][0] for c in candidates)
        raise missing(f"no {names} topic in the log (the input)")
    if _PX4_OUTPUT[0] not in data:
        raise missing(f"no {_PX4_OUTPUT[0]} topic in the log (the output)")

    fields: dict[str, _Field] = {}
    clocks: dict[str, str] = {}
    for topic, mapping, prefer in (
        (*_PX4_INPUTS[chosen], ("timestamp",)),
        (*_PX4_OUTPUT, ("timestamp_sample", "timestamp")),
    ):
        cols = data[topic]
        clock = next((c for c in prefer if c in cols), None)
        absent = [f for f in mapping.values() if f not in cols] + ([] if clock else [prefer[-1]])
        if absent:
            raise FlightDataError(
                f"{where}: topic {topic} has no field {', '.join(absent)}; its fields are: "
                f"{', '.join(cols)}"
            )
        t = np.asarray(cols[clock], dtype=np.float64) * 1e-6
        for column, name in mapping.items():
            fields[column] = _Field(topic, name, t, np.asarray(cols[name], dtype=np.float64))
        clocks[topic] = clock
    t_in, t_out = fields["delta_lat"].time, fields["p"].time
    if t_in.size < 2 or t_out.size < 2:
        short = _PX4_INPUTS[chosen][0] if t_in.size < 2 else _PX4_OUTPUT[0]
        raise FlightDataError(f"{where}: topic {short} has fewer than 2 samples")
    if span is None:
        start_s, stop_s = float(min(t_in[0], t_out[0])), float(max(t_in[-1], t_out[-1]))
        segment = "whole log (both topics' overlap)"
    else:
        start_s, stop_s = span
        segment = f"window {start_s:.6g}-{stop_s:.6g} s since boot"
    grid, values, how = _resample(
        fields,
        start_s=start_s,
        stop_s=stop_s,
        sample_rate=sample_rate,
        max_gap=max_gap,
        where=where,
    )
    in_topic, in_map = _PX4_INPUTS[chosen]
    metadata = {
        "source": f"PX4 ULog {p.name}",
        "source_format": "px4",
        "input": ", ".join(f"{in_topic}.{f} -> {c}" for c, f in in_map.items()) + " (normalised)",
        "output": ", ".join(f"{_PX4_OUTPUT[0]}.{f} -> {c}" for c, f in _PX4_OUTPUT[1].items())
        + " (rad/s)",
        "segment": segment,
        "resampling": how,
        "time": "seconds since boot (ULog "
        + ", ".join(f"{topic}.{clock}" for topic, clock in clocks.items())
        + " / 1e6)",
    }
    if getattr(ulog, "file_corruption", False):
        metadata["log_warning"] = "pyulog found corruption in the file and skipped over it"
    ordered = {c: values[c] for c in (*INPUT_NAMES, *OUTPUT_NAMES)}
    req = tuple(required) if required is not None else INPUT_NAMES + OUTPUT_NAMES
    attitude, metadata["attitude"] = _px4_attitude(data.get(_PX4_ATTITUDE), grid, max_gap, where)
    ordered |= attitude
    return _record(grid, ordered, metadata, req, where, "")


def _px4_attitude(cols: Mapping[str, np.ndarray] | None, grid: np.ndarray, max_gap: float,
                  where: str) -> tuple[dict, str]:
    """``vehicle_attitude.q`` on ``grid`` as ``phi, theta`` (rad), or none and why."""
    names = [f"q[{i}]" for i in range(4)]
    if cols is None or not all(n in cols for n in names):
        return {}, f"none (no {_PX4_ATTITUDE} topic with q[0..3] in the log)"
    clock = "timestamp_sample" if "timestamp_sample" in cols else "timestamp"
    q0, q1, q2, q3 = (np.asarray(cols[n], dtype=np.float64) for n in names)
    roll = np.unwrap(np.arctan2(2.0 * (q0 * q1 + q2 * q3), 1.0 - 2.0 * (q1 * q1 + q2 * q2)))
    pitch = np.arcsin(np.clip(2.0 * (q0 * q2 - q3 * q1), -1.0, 1.0))
    t = np.asarray(cols[clock], dtype=np.float64) * 1e-6
    return _attitude_on_grid(_PX4_ATTITUDE, t, roll, pitch, grid, max_gap, where,
                             f"{_PX4_ATTITUDE}.q -> phi, theta (roll and pitch of the quaternion, rad; timed by {clock}",
                             "the logger's high-rate profile, SDLOG_PROFILE")  # fmt: skip


# -- the dispatcher -----------------------------------------------------------------------


def _accepted() -> str:
    by_ext = ", ".join(f"{fmt} ({ext})" for ext, fmt in EXTENSIONS.items())
    return f"accepted formats: {by_ext}; .BIN is read as ardupilot too"


def detect_format(path: str | os.PathLike) -> str:
    """The format ``load_any(format="auto")`` picks: by extension (:data:`EXTENSIONS`), or
    for an unknown extension by the first bytes (DataFlash ``A3 95``, ULog ``ULog 01 12
    35``, NPZ's zip ``PK 03 04``, or UTF-8 text with a ``time`` header cell for CSV).

    Raises:
        FlightDataError: neither the extension nor the content says (lists the formats).
    """
    p = Path(path)
    suffix = p.suffix.lower()
    if suffix in EXTENSIONS:
        return EXTENSIONS[suffix]
    _file_size(p)
    head = _head(p, 4096)
    if head.startswith(_DATAFLASH_MAGIC):
        return "ardupilot"
    if head.startswith(_ULOG_MAGIC):
        return "px4"
    if head.startswith(_ZIP_MAGIC):
        return "npz"
    try:
        text = head.decode("utf-8")
    except UnicodeDecodeError:
        text = ""
    for line in text.splitlines():
        line = line.strip()
        if line and not line.startswith("#"):
            if "time" in (cell.strip() for cell in line.split(",")):
                return "csv"
            break
    raise FlightDataError(
        f"{p}: cannot tell the format from the extension {suffix or '(none)'!r} or the "
        f"content; {_accepted()}; or pass format="
    )


def _load_table(p: Path, fmt: str, required: Sequence[str] | None, columns) -> FlightRecord:
    kwargs = {} if required is None else {"required": tuple(required)}
    try:
        if (p.suffix.lower() == ".npz") == (fmt == "npz"):
            return _data.load_record(p, columns, **kwargs)
        # load_record goes by the suffix; the content (or format=) says otherwise, so it
        # reads a copy under the right suffix, and errors name the user's file
        _file_size(p)
        with tempfile.TemporaryDirectory(prefix="jaxgwo-") as tmp:
            copy = Path(tmp) / f"record.{fmt}"
            shutil.copyfile(p, copy)
            try:
                return _data.load_record(copy, columns, **kwargs)
            except FlightDataError as err:
                raise FlightDataError(str(err).replace(str(copy), str(p))) from None
    except (OSError, zipfile.BadZipFile, EOFError, UnicodeDecodeError) as err:
        if isinstance(err, FileNotFoundError):
            raise
        raise FlightDataError(
            f"{p}: not a readable {fmt} file ({type(err).__name__}: {err})"
        ) from None


_LOADERS = {"ardupilot": load_ardupilot, "px4": load_px4}


def load_any(
    path: str | os.PathLike,
    *,
    format: str = "auto",
    required: Sequence[str] | None = None,
    **options: object,
) -> FlightRecord:
    """Load flight data from any supported file: jaxgwo CSV/NPZ, ArduPilot ``.bin``, PX4 ``.ulg``.

    Args:
        path: the file.
        format: ``"auto"`` (by extension: ``.csv``, ``.npz``, ``.bin``/``.BIN`` ->
            ardupilot, ``.ulg`` -> px4; an unknown extension by the file's first bytes, see
            :func:`detect_format`), ``"csv"``, ``"npz"``, ``"ardupilot"`` or ``"px4"``.
        required: canonical columns that must be present; ``None`` takes the format's
            default (all four for CSV/NPZ, mixer and PX4; the excited channel's pair for
            ArduPilot ``input="targ"``).
        **options: passed to the reader.  csv/npz: ``columns`` (see
            :func:`jaxgwo.load_record`).  ardupilot: ``input``, ``output``, ``run``,
            ``channel``, ``window``, ``sample_rate``, ``max_gap`` (see
            :func:`load_ardupilot`).  px4: ``input``, ``window``, ``sample_rate``,
            ``max_gap`` (see :func:`load_px4`).

    Raises:
        ValueError: an unknown ``format`` or an option the format does not take (both
            list what is accepted).
        FlightDataError: (a ``ValueError``) an unknown extension with unrecognised content
            (listing the formats), or anything wrong in the file.
        FileNotFoundError: no such file.
        ImportError: ardupilot/px4 without ``pymavlink``/``pyulog``
            (``pip install "jaxgwo[logs]"``).
    """
    if format not in FORMATS:
        raise ValueError(f"unknown format {format!r}; expected one of {', '.join(FORMATS)}")
    p = Path(path)
    if not p.exists():
        raise FileNotFoundError(f"no such flight-data file: {p}")
    fmt = detect_format(p) if format == "auto" else format
    if fmt in ("csv", "npz"):
        accepted = ("columns",)
    else:
        accepted = tuple(
            k for k in inspect.signature(_LOADERS[fmt]).parameters if k not in ("path", "required")
        )
    unknown = sorted(set(options) - set(accepted))
    if unknown:
        raise ValueError(
            f"option(s) {', '.join(unknown)} do not apply to format {fmt!r}; it takes: "
            f"{', '.join(accepted)}"
        )
    if fmt in ("csv", "npz"):
        return _load_table(p, fmt, required, options.get("columns"))
    return _LOADERS[fmt](p, required=required, **options)
