"""The flight-data format: a frozen record, a validating loader and an atomic writer.

The contract every jaxgwo command reads and writes:

* **CSV** with one header row.  Lines starting with ``#`` are comments; ``# key: value``
  comments before the header are the record's metadata (sample rate, units, how the
  file was made).
* A ``time`` column in seconds, strictly increasing and uniformly sampled (each step
  within 1 % of the median step).
* Helicopter channels ``delta_lat`` and ``delta_lon`` (normalised cyclic inputs,
  dimensionless) and ``p`` and ``q`` (body roll and pitch rate, rad/s).  Extra numeric
  columns are kept (``FlightRecord.extras``) and otherwise ignored.  Other column names
  are mapped with ``load_record(path, columns={"p": "gyro_x", ...})``.
* **NPZ** with the same names as arrays, and the metadata as a JSON string under the key
  ``__metadata__`` (read without ``allow_pickle``).

Every rejection raises :class:`FlightDataError`, a ``ValueError``, with a message that
names the file, the column and the row.
"""

from __future__ import annotations

import csv
import io
import json
import os
import re
from collections.abc import Mapping, Sequence
from pathlib import Path

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from ._atomic import atomic_output

INPUT_NAMES: tuple[str, ...] = ("delta_lat", "delta_lon")
"""Canonical input columns: normalised lateral and longitudinal cyclic (dimensionless)."""

OUTPUT_NAMES: tuple[str, ...] = ("p", "q")
"""Canonical output columns: body roll and pitch rate (rad/s)."""

CHANNELS: dict[str, tuple[str, str]] = {
    "lateral": ("delta_lat", "p"),
    "longitudinal": ("delta_lon", "q"),
}
"""Channel name -> (input column, output column), as in the paper's eqs. (15)-(16)."""

ATTITUDE_COLUMNS: dict[str, str] = {"lateral": "phi", "longitudinal": "theta"}
"""Channel name -> the optional column of its logged attitude (rad or deg; an estimator's,
from the raw gyro).  Where the records have it, ``jaxgwo diagnose`` reads the gyro's own
filter against it (:func:`jaxgwo._diagnose_where.gyro_path`)."""

UNITS: dict[str, str] = {
    "time": "s",
    "delta_lat": "normalised (dimensionless)",
    "delta_lon": "normalised (dimensionless)",
    "p": "rad/s",
    "q": "rad/s",
}

TIME_TOLERANCE = 0.01
"""Allowed deviation of each time step from the median step, as a fraction of the step."""

_NPZ_METADATA_KEY = "__metadata__"
_UNDECODABLE = re.compile("[\udc80-\udcff]")  # bytes that were not UTF-8 (surrogateescape)


class FlightDataError(ValueError):
    """Flight data that breaks the format contract (missing column, NaN, bad time, ...)."""


class FlightRecord(eqx.Module):
    """One uniformly sampled flight record (immutable PyTree).

    Attributes:
        time: sample times in seconds, strictly increasing and uniform.
        inputs: input name -> samples (``delta_lat``, ``delta_lon``, dimensionless).
        outputs: output name -> samples (``p``, ``q``, rad/s).
        extras: any further numeric columns, kept and not interpreted.
        sample_rate: samples per second (Hz), ``1 / median(diff(time))``.
        metadata_items: metadata as sorted ``(key, value)`` string pairs; static, so the
            record stays hashable for ``jax.jit``.  Read it as the dict :attr:`metadata`.
    """

    time: Float[Array, " n"]
    inputs: dict[str, Float[Array, " n"]]
    outputs: dict[str, Float[Array, " n"]]
    extras: dict[str, Float[Array, " n"]]
    sample_rate: float = eqx.field(static=True)
    metadata_items: tuple[tuple[str, str], ...] = eqx.field(static=True, default=())

    @property
    def metadata(self) -> dict[str, str]:
        """The metadata as a fresh ``dict`` (the record itself stays frozen)."""
        return dict(self.metadata_items)

    @property
    def n_samples(self) -> int:
        return int(self.time.shape[0])

    @property
    def dt(self) -> float:
        """Sample period in seconds."""
        return 1.0 / self.sample_rate

    @property
    def duration(self) -> float:
        """``time[-1] - time[0]`` in seconds."""
        return float(self.time[-1] - self.time[0])

    @property
    def columns(self) -> tuple[str, ...]:
        """All column names, ``time`` first, in the order they are written."""
        return ("time", *self.inputs, *self.outputs, *self.extras)

    def __getitem__(self, name: str) -> Float[Array, " n"]:
        if name == "time":
            return self.time
        for group in (self.inputs, self.outputs, self.extras):
            if name in group:
                return group[name]
        raise KeyError(f"no column {name!r}; columns are {', '.join(self.columns)}")

    def channel(self, name: str) -> tuple[Float[Array, " n"], Float[Array, " n"]]:
        """``(input, output)`` samples of ``"lateral"`` or ``"longitudinal"``."""
        if name not in CHANNELS:
            raise KeyError(f"unknown channel {name!r}; expected one of {', '.join(CHANNELS)}")
        u, y = CHANNELS[name]
        return self[u], self[y]

    def segment(self, start_s: float, stop_s: float) -> FlightRecord:
        """The samples with ``start_s <= time < stop_s`` as a new record."""
        t = np.asarray(self.time)
        keep = np.flatnonzero((t >= start_s) & (t < stop_s))
        if keep.size < 2:
            raise FlightDataError(f"segment [{start_s}, {stop_s}) s holds fewer than 2 samples")
        sl = slice(int(keep[0]), int(keep[-1]) + 1)

        def cut(d: dict[str, Array]) -> dict[str, Array]:
            return {k: v[sl] for k, v in d.items()}

        return FlightRecord(
            time=self.time[sl],
            inputs=cut(self.inputs),
            outputs=cut(self.outputs),
            extras=cut(self.extras),
            sample_rate=self.sample_rate,
            metadata_items=self.metadata_items,
        )


def _metadata_items(
    metadata: Mapping[str, object] | None, where: str = "record"
) -> tuple[tuple[str, str], ...]:
    if not metadata:
        return ()
    items = []
    for k, v in metadata.items():
        key = str(k).strip()
        if not key or ":" in key or "\n" in key:
            raise FlightDataError(
                f"{where}: metadata key {k!r} must be non-empty, without ':' or newline"
            )
        text = str(v)
        if "\n" in text:
            raise FlightDataError(f"{where}: metadata value for {key!r} must be a single line")
        items.append((key, text))
    return tuple(sorted(items))


def _check_time(time: np.ndarray, where: str, line_of: Sequence[int] | None) -> float:
    """Validate a time vector and return its sample rate (Hz)."""

    def row(i: int) -> str:
        return f"row {i}" + (f" (line {line_of[i]})" if line_of is not None else "")

    if time.shape[0] < 2:
        raise FlightDataError(f"{where}: fewer than two samples ({time.shape[0]}); need at least 2")
    steps = np.diff(time)
    bad = np.flatnonzero(steps <= 0.0)
    if bad.size:
        i = int(bad[0]) + 1
        raise FlightDataError(
            f"{where}: time is not strictly increasing at {row(i)}: "
            f"{float(time[i - 1])!r} s then {float(time[i])!r} s"
        )
    dt = float(np.median(steps))
    off = np.flatnonzero(np.abs(steps - dt) > TIME_TOLERANCE * dt)
    if off.size:
        i = int(off[0]) + 1
        raise FlightDataError(
            f"{where}: time is not uniformly sampled at {row(i)}: step {float(steps[i - 1]):.6g} s "
            f"differs from the median step {dt:.6g} s by more than {TIME_TOLERANCE:.0%}"
        )
    return 1.0 / dt


def _build(
    columns: dict[str, np.ndarray],
    metadata: dict[str, str],
    *,
    where: str,
    required: Sequence[str],
    mapping: Mapping[str, str] | None,
    line_of: Sequence[int] | None,
    text_columns: Sequence[str] = (),
) -> FlightRecord:
    """Common validation of CSV and NPZ contents, then the frozen record.

    ``text_columns``: CSV columns dropped as non-numeric; they are listed (marked as text)
    when a required column is missing, so the message shows every column the file has."""
    mapping = dict(mapping or {})
    unknown = set(mapping) - {"time", *INPUT_NAMES, *OUTPUT_NAMES}
    if unknown:
        raise FlightDataError(
            f"column mapping names unknown canonical column(s) {sorted(unknown)}; "
            f"map from time, {', '.join(INPUT_NAMES + OUTPUT_NAMES)}"
        )
    file_name = {name: mapping.get(name, name) for name in ("time", *INPUT_NAMES, *OUTPUT_NAMES)}
    names = [*columns, *(f"{c!r} (text, dropped)" for c in text_columns)]
    existing = ", ".join(names) if names else "(none)"
    for name in ("time", *required):
        src = file_name.get(name, name)
        if src not in columns:
            shown = name if src == name else f"{src!r} (for {name})"
            hint = ""
            if len(columns) + len(text_columns) == 1 and any(
                sep in c for c in [*columns, *text_columns] for sep in ";\t|"
            ):
                hint = "; the header looks like one column: separate the columns by commas"
            elif src in text_columns:
                hint = f"; column {src!r} holds text, it must be numeric"
            raise FlightDataError(
                f"{where}: missing column {shown}; the columns are: {existing}{hint}"
            )

    def row(i: int) -> str:
        return f"row {i}" + (f" (line {line_of[i]})" if line_of is not None else "")

    picked: dict[str, np.ndarray] = {}
    for name in ("time", *INPUT_NAMES, *OUTPUT_NAMES):
        src = file_name[name]
        if src in columns:
            values = columns[src]
            bad = np.flatnonzero(~np.isfinite(values))
            if bad.size:
                i = int(bad[0])
                raise FlightDataError(
                    f"{where}: column {src!r} has a non-finite value ({float(values[i])!r}) at {row(i)}"
                )
            picked[name] = values
    used = {file_name[n] for n in picked}
    extras = {k: v for k, v in columns.items() if k not in used}

    time = picked.pop("time")
    rate = _check_time(time, where, line_of)
    claimed = metadata.get("sample_rate_hz")
    if claimed is not None:
        try:
            claimed_rate = float(claimed)
        except ValueError:
            raise FlightDataError(f"{where}: metadata sample_rate_hz {claimed!r} is not a number")
        if not abs(claimed_rate - rate) <= TIME_TOLERANCE * rate:
            raise FlightDataError(
                f"{where}: metadata says sample_rate_hz {claimed_rate:g} but the time column "
                f"is sampled at {rate:g} Hz"
            )

    def arr(x: np.ndarray) -> Array:
        return jnp.asarray(np.asarray(x, dtype=np.float64))

    return FlightRecord(
        time=arr(time),
        inputs={k: arr(picked[k]) for k in INPUT_NAMES if k in picked},
        outputs={k: arr(picked[k]) for k in OUTPUT_NAMES if k in picked},
        extras={k: arr(v) for k, v in extras.items()},
        sample_rate=rate,
        metadata_items=_metadata_items(metadata, where),
    )


def _read_csv(path: Path) -> tuple[dict[str, np.ndarray], dict[str, str], list[int], list[str]]:
    metadata: dict[str, str] = {}
    header: list[str] | None = None
    rows: list[list[str]] = []
    lines: list[int] = []
    # utf-8-sig: a byte-order mark (Excel writes one) is not part of the first column name
    with open(path, newline="", encoding="utf-8-sig", errors="surrogateescape") as fh:
        for lineno, raw in enumerate(fh, start=1):
            if not raw.isascii() and _UNDECODABLE.search(raw):
                raise FlightDataError(
                    f"{path}: line {lineno} is not UTF-8 text; save the file as UTF-8 CSV "
                    "(a binary file or another encoding?)"
                )
            if "\x00" in raw:
                raise FlightDataError(
                    f"{path}: line {lineno} holds a NUL byte; this is not a text CSV file"
                )
            text = raw.strip()
            if not text:
                continue
            if text.startswith("#"):
                body = text[1:].strip()
                if header is None and ":" in body:
                    key, _, value = body.partition(":")
                    metadata[key.strip()] = value.strip()
                continue
            cells = [c.strip() for c in next(csv.reader([text]))]
            if header is None:
                header = cells
                # a logger that ends every line with a comma makes one trailing, empty,
                # nameless column: tolerated (and dropped below when it is empty)
                if "" in header[:-1] or (header[-1:] == [""] and len(header) == 1):
                    raise FlightDataError(
                        f"{path}: the header (line {lineno}) has an empty column name at "
                        f"position {header.index('') + 1}; name every column"
                    )
                if len(set(header)) != len(header):
                    dup = sorted({h for h in header if header.count(h) > 1})
                    raise FlightDataError(f"{path}: duplicate column name(s) {dup} in the header")
                continue
            if len(cells) != len(header):
                hint = ""
                if len(cells) > len(header) and any(c.isdigit() for c in cells[-1][:1]):
                    hint = " (decimal commas? write numbers with a '.' decimal point)"
                raise FlightDataError(
                    f"{path}: line {lineno} has {len(cells)} fields, the header has "
                    f"{len(header)}{hint}"
                )
            rows.append(cells)
            lines.append(lineno)
    if header is None:
        raise FlightDataError(f"{path}: no header row (the file is empty or only comments)")
    columns: dict[str, np.ndarray] = {}
    dropped: list[str] = []
    for j, name in enumerate(header):
        if name == "":  # the trailing nameless column
            filled = [i for i, r in enumerate(rows) if r[j] != ""]
            if filled:
                i = filled[0]
                raise FlightDataError(
                    f"{path}: the last column has no name in the header but holds "
                    f"{rows[i][j]!r} at row {i} (line {lines[i]}); name every column"
                )
            continue
        values = np.empty(len(rows), dtype=np.float64)
        numeric = True
        for i, r in enumerate(rows):
            try:
                values[i] = float(r[j])
            except ValueError:
                numeric = False
                bad = (i, r[j])
                break
        if numeric:
            columns[name] = values
        elif name in ("time", *INPUT_NAMES, *OUTPUT_NAMES):
            raise FlightDataError(
                f"{path}: column {name!r} has a non-numeric value {bad[1]!r} at row {bad[0]} "
                f"(line {lines[bad[0]]})"
            )
        else:  # a text column (flight mode, ...): not data, noted and dropped
            dropped.append(name)
    if dropped:
        metadata["dropped_text_columns"] = ", ".join(dropped)
    return columns, metadata, lines, dropped


def _read_npz(path: Path) -> tuple[dict[str, np.ndarray], dict[str, str]]:
    with open(path, "rb") as fh:
        magic = fh.read(4)
    if magic not in (b"PK\x03\x04", b"PK\x05\x06"):  # an .npz is a zip archive (the
        # second signature: an empty one); anything else np.load would
        # try to unpickle (refused) or read as a bare .npy array
        what = "an empty file" if not magic else "not a NumPy .npz archive (a zip file)"
        raise FlightDataError(
            f"{path}: {what}; write it with numpy.savez(path, time=..., p=...) "
            "or save it as .csv"
        )
    try:
        with np.load(path, allow_pickle=False) as npz:
            raw = {k: npz[k] for k in npz.files}
    except ValueError as err:  # object arrays need pickle, which we refuse
        raise FlightDataError(
            f"{path}: cannot read without pickle: an array holds Python objects, which jaxgwo "
            f"never unpickles; save numeric arrays ({err})"
        ) from None
    except (OSError, EOFError, KeyError) as err:  # a damaged zip
        raise FlightDataError(f"{path}: cannot read the .npz archive ({err})") from None
    metadata: dict[str, str] = {}
    if _NPZ_METADATA_KEY in raw:
        try:
            metadata = {str(k): str(v) for k, v in json.loads(str(raw.pop(_NPZ_METADATA_KEY))).items()}
        except (json.JSONDecodeError, AttributeError) as err:
            raise FlightDataError(f"{path}: {_NPZ_METADATA_KEY} is not a JSON object ({err})")
    columns: dict[str, np.ndarray] = {}
    for k, v in raw.items():
        if v.ndim != 1:
            raise FlightDataError(f"{path}: array {k!r} has shape {v.shape}; columns must be 1-D")
        if not (np.issubdtype(v.dtype, np.integer) or np.issubdtype(v.dtype, np.floating)):
            raise FlightDataError(
                f"{path}: array {k!r} has dtype {v.dtype}; columns must be real numbers "
                "(integer or float)"
            )
        columns[k] = np.asarray(v, dtype=np.float64)
    lengths = {k: v.shape[0] for k, v in columns.items()}
    if len(set(lengths.values())) > 1:
        raise FlightDataError(f"{path}: columns have different lengths {lengths}")
    return columns, metadata


def load_record(
    path: str | os.PathLike,
    columns: Mapping[str, str] | None = None,
    *,
    required: Sequence[str] = INPUT_NAMES + OUTPUT_NAMES,
) -> FlightRecord:
    """Load and validate a flight record from ``.csv`` or ``.npz``.

    Args:
        path: the file; ``.npz`` is read as NumPy arrays, anything else as CSV.
        columns: optional mapping from canonical name (``time``, ``delta_lat``,
            ``delta_lon``, ``p``, ``q``) to the file's column name, e.g.
            ``{"p": "gyro_x", "delta_lat": "ail"}``.
        required: canonical columns that must exist besides ``time`` (all four by
            default; ``("delta_lat", "p")`` for a lateral-only file).

    Raises:
        FlightDataError: a missing column (listing those that exist), a NaN or inf
            (column and first row), non-increasing or irregular time (row), fewer than
            two samples, or an unreadable file.
        FileNotFoundError: no such file.
    """
    p = Path(path)
    if not p.exists():
        raise FileNotFoundError(f"no such flight-data file: {p}")
    if p.is_dir():
        raise FlightDataError(f"{p} is a directory; pass a .csv or .npz flight-data file")
    if columns is not None and not (
        isinstance(columns, Mapping) and all(isinstance(v, str) for v in columns.values())
    ):
        raise FlightDataError(
            f"columns must map canonical names to the file's column names, e.g. "
            f'{{"p": "gyro_x"}}; got {columns!r:.80}'
        )
    try:
        if p.suffix.lower() == ".npz":
            cols, meta = _read_npz(p)
            lines, text = None, []
        else:
            cols, meta, lines, text = _read_csv(p)
    except OSError as err:  # unreadable (permissions, a device, ...): not a traceback
        raise FlightDataError(f"{p}: cannot read the file ({err.strerror or err})") from None
    return _build(cols, meta, where=str(p), required=required, mapping=columns, line_of=lines,
                  text_columns=text)


def make_record(
    time: Float[Array, " n"] | np.ndarray,
    columns: Mapping[str, Float[Array, " n"] | np.ndarray],
    metadata: Mapping[str, object] | None = None,
    *,
    required: Sequence[str] = (),
) -> FlightRecord:
    """Build a validated record from in-memory arrays (same checks as the loader)."""
    cols = {"time": _real_column("time", time)}
    if cols["time"].ndim != 1:
        raise FlightDataError(f"record: time has shape {cols['time'].shape}; it must be 1-D")
    for k, v in columns.items():
        if not isinstance(k, str) or not k:
            raise FlightDataError(f"record: column name {k!r} must be a non-empty string")
        a = _real_column(k, v)
        if a.shape != cols["time"].shape:
            raise FlightDataError(
                f"record: column {k!r} has shape {a.shape}, time has {cols['time'].shape}; "
                "every column needs one value per time sample"
            )
        cols[k] = a
    if metadata is not None and not isinstance(metadata, Mapping):
        raise FlightDataError(f"record: metadata must be a mapping, not {type(metadata).__name__}")
    meta = dict(_metadata_items(metadata))
    return _build(cols, meta, where="record", required=required, mapping=None, line_of=None)


def _real_column(name: str, values: object) -> np.ndarray:
    """``values`` as a float64 array, or a :class:`FlightDataError` naming the column."""
    try:
        a = np.asarray(values)
    except ValueError as err:  # ragged nested sequences
        raise FlightDataError(f"record: column {name!r} is not a rectangular array ({err})") from None
    if a.dtype == np.bool_ or not (
        np.issubdtype(a.dtype, np.integer) or np.issubdtype(a.dtype, np.floating)
    ):
        raise FlightDataError(
            f"record: column {name!r} has dtype {a.dtype}; columns must be real numbers "
            "(integer or float arrays)"
        )
    return a.astype(np.float64)


def _format_csv(record: FlightRecord, digits: int) -> str:
    buf = io.StringIO()
    meta = record.metadata
    meta.setdefault("format", "jaxgwo flight record v1")
    meta["sample_rate_hz"] = f"{record.sample_rate:.10g}"
    meta.setdefault("units", "; ".join(f"{k} [{v}]" for k, v in UNITS.items()))
    for k in sorted(meta):
        buf.write(f"# {k}: {meta[k]}\n")
    names = record.columns
    buf.write(",".join(names) + "\n")
    data = np.stack([np.asarray(record[n], dtype=np.float64) for n in names], axis=1)
    # time keeps more digits than the data so long records stay uniform to 1 %.
    fmt = ["%.12g"] + [f"%.{digits}g"] * (len(names) - 1)
    np.savetxt(buf, data, fmt=fmt, delimiter=",")
    return buf.getvalue()


def save_record(record: FlightRecord, path: str | os.PathLike, *, digits: int = 7) -> Path:
    """Write ``record`` to ``.csv`` (``digits`` significant figures) or ``.npz``, atomically.

    The data goes to a temporary file in the same directory, is flushed and fsynced,
    then renamed over ``path`` with :func:`os.replace`; a failure leaves no partial file.
    Returns the path written.
    """
    p = Path(path)
    with atomic_output(p, "wb") as fh:
        if p.suffix.lower() == ".npz":
            meta = record.metadata
            meta["sample_rate_hz"] = f"{record.sample_rate:.10g}"
            arrays = {n: np.asarray(record[n], dtype=np.float64) for n in record.columns}
            arrays[_NPZ_METADATA_KEY] = np.array(json.dumps(meta, sort_keys=True))
            np.savez(fh, **arrays)
        else:
            fh.write(_format_csv(record, digits).encode("utf-8"))
    return p


# -- the embedded default dataset --------------------------------------------------------

DEFAULT_DATASET_FILES: dict[str, str] = {
    "lateral": "default_id_lateral.csv",
    "longitudinal": "default_id_longitudinal.csv",
    "validation_lateral": "default_validation_lateral.csv",
    "validation_longitudinal": "default_validation_longitudinal.csv",
}
"""Files of the embedded default dataset under ``jaxgwo/data`` (see :func:`default_dataset`)."""


class DefaultDataset(eqx.Module):
    """The embedded default dataset: identification records per channel and a validation record.

    Attributes:
        identification: ``{"lateral": ..., "longitudinal": ...}``; each record holds two
            frequency sweeps on that channel's cyclic at different amplitudes (segments
            listed in its metadata), with pilot-like activity on the other cyclic.
        validation: ``{"lateral": ..., "longitudinal": ...}``; held-out records with
            multi-step inputs (3-2-1-1s and a doublet) on that channel's cyclic.
    """

    identification: dict[str, FlightRecord]
    validation: dict[str, FlightRecord]


def default_dataset() -> DefaultDataset:
    """Load the embedded default dataset (simulated Yamaha R-50 hover, 100 Hz).

    Made by the simulator from the R-50 13-state plant with servos, a weak pilot hold
    loop, Dryden-like gusts and gyro noise, so it carries the model-structure error real
    flight data has for the paper's 2nd-order-plus-servo model.  Regenerate it with
    ``jaxgwo simulate --default-dataset DIR``.
    """
    import importlib.resources

    root = importlib.resources.files("jaxgwo").joinpath("data")
    records = {}
    for name, file_name in DEFAULT_DATASET_FILES.items():
        with importlib.resources.as_file(root.joinpath(file_name)) as path:
            records[name] = load_record(path)
    return DefaultDataset(
        identification={"lateral": records["lateral"], "longitudinal": records["longitudinal"]},
        validation={"lateral": records["validation_lateral"],
                    "longitudinal": records["validation_longitudinal"]},
    )
