r"""Identified models out of jaxgwo, and back in.

Two file formats, chosen by :func:`export_model` from the extension:

* ``.json`` -- the **jaxgwo model file**, which loads back (:func:`load_model`) into the same
  :class:`~jaxgwo.PaperModel` or :class:`~jaxgwo.QuarticModel`, bit for bit.  One file holds
  one model or several (one per channel)::

      {"format": "jaxgwo-model", "schema_version": 1,
       "provenance": {"jaxgwo_version": ..., "created_utc": ..., ...},
       "models": [{"channel": "lateral", "kind": "paper",
                   "structure": "K/(s^2 + s/tau + M) * ...",
                   "parameter_names": ["K", "tau", "M", "omega_s", "zeta_s"],
                   "parameters": {"K": -512.3, ...}, "units": {"K": ..., ...},
                   "numerator": [...], "denominator": [...],   # s-polynomials, highest power first
                   "metadata": {...}}]}

  Floats are written as JSON numbers by Python's ``repr`` (the shortest decimal string that
  reads back to the same float64), so ``load_model(save_model(m))`` has the same bits as
  ``m``.  The parameters are authoritative; ``numerator``/``denominator`` are written for other
  tools and checked against them on loading.

* ``.npz`` -- a scipy-style archive of float64 arrays (never pickled): for one model
  ``num``, ``den`` (``scipy.signal.TransferFunction(d["num"], d["den"])``), ``params``,
  ``parameter_names``, ``kind`` and ``channel``; for several models the same keys prefixed by
  the channel (``lateral_num``, ``lateral_den``, ...) plus ``channels``.  It also loads back
  losslessly.

In Python the loaded model's :meth:`to_scipy` and :meth:`to_control` give
``scipy.signal.TransferFunction`` and ``control.TransferFunction`` objects (python-control is
optional: ``pip install jaxgwo[control]``).
"""

from __future__ import annotations

import datetime
import json
import math
import os
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from ._atomic import atomic_output, atomic_write_text
from ._models import PaperModel, QuarticModel

__all__ = [
    "MODEL_FILE_FORMAT",
    "MODEL_SCHEMA_VERSION",
    "EXPORT_FORMATS",
    "ModelFile",
    "model_to_dict",
    "model_from_dict",
    "save_model",
    "load_model",
    "load_model_file",
    "export_model",
]

MODEL_FILE_FORMAT = "jaxgwo-model"
MODEL_SCHEMA_VERSION = 1
EXPORT_FORMATS = ("json", "npz")

_KINDS = {"paper": PaperModel, "quartic": QuarticModel}
_STRUCTURE = {
    "paper": "K/(s^2 + s/tau + M) * omega_s^2/(s^2 + 2 zeta_s omega_s s + omega_s^2)",
    "quartic": "b0/(a4 s^4 + a3 s^3 + a2 s^2 + a1 s + 1)",
}
_UNITS = {
    "paper": {"K": "output/input * rad^2/s^2", "tau": "s", "M": "rad^2/s^2",
              "omega_s": "rad/s", "zeta_s": "1"},
    "quartic": {"b0": "output/input", "a1": "s", "a2": "s^2", "a3": "s^3", "a4": "s^4"},
}
# numerator/denominator in a file are recomputed from the parameters on loading; they
# may differ in the last bits if another tool rewrote them, not by more
_POLY_RTOL = 1e-9


def _kind_of(model) -> str:
    if isinstance(model, PaperModel):
        return "paper"
    if isinstance(model, QuarticModel):
        return "quartic"
    raise TypeError(
        f"cannot export a {type(model).__name__}; pass a jaxgwo.PaperModel or jaxgwo.QuarticModel "
        "(for example ChannelIdentification.model)."
    )


def _finite_values(model, kind: str) -> dict[str, float]:
    arr = np.asarray(model.to_array(), dtype=np.float64)
    if arr.shape != (5,):
        raise ValueError(
            f"the {kind} model holds a batch of shape {arr.shape[:-1]}; export one model at a "
            "time (index the batch first)."
        )
    values = {name: float(v) for name, v in zip(model.names, arr)}
    bad = [n for n, v in values.items() if not math.isfinite(v)]
    if bad:
        raise ValueError(f"model parameter(s) {', '.join(bad)} are not finite ({values}); "
                         "a non-finite model cannot be exported.")
    return values


def _coefficients(model, values) -> tuple[np.ndarray, np.ndarray]:
    num = np.asarray(model.numerator, dtype=np.float64)
    den = np.asarray(model.denominator, dtype=np.float64)
    if not (np.all(np.isfinite(num)) and np.all(np.isfinite(den))):
        shown = ", ".join(f"{k} = {v!r}" for k, v in values.items())
        raise ValueError(f"{shown} give non-finite transfer-function coefficients (numerator "
                         f"{num.tolist()}, denominator {den.tolist()}): a division by zero "
                         "(tau = 0?) or an overflow of float64; such a model cannot be used.")
    return num, den


def _json_safe(value, where: str):
    """Metadata as plain JSON: NumPy/JAX scalars and arrays become numbers and lists,
    non-finite floats become ``null``."""
    if value is None or isinstance(value, (bool, str)):
        return value
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        v = float(value)
        return v if math.isfinite(v) else None
    if isinstance(value, Mapping):
        return {str(k): _json_safe(v, f"{where}.{k}") for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_json_safe(v, f"{where}[{i}]") for i, v in enumerate(value)]
    if hasattr(value, "shape") and hasattr(value, "dtype"):  # NumPy or JAX array
        arr = np.asarray(value)
        return _json_safe(arr.item() if arr.ndim == 0 else arr.tolist(), where)
    raise TypeError(f"metadata {where} is a {type(value).__name__}; only JSON values "
                    "(numbers, strings, booleans, None, lists, dicts) can be stored.")


def model_to_dict(model: PaperModel | QuarticModel, channel: str | None = None,
                  **metadata) -> dict:
    """One model as the ``models[i]`` entry of a jaxgwo model file (see the module docstring).

    ``metadata`` is any JSON-serialisable provenance (method, cost, data source, ...);
    NumPy/JAX scalars are converted and non-finite floats stored as ``null``.
    """
    kind = _kind_of(model)
    values = _finite_values(model, kind)
    num, den = _coefficients(model, values)
    return {
        "channel": channel,
        "kind": kind,
        "structure": _STRUCTURE[kind],
        "parameter_names": list(model.names),
        "parameters": values,
        "units": dict(_UNITS[kind]),
        "numerator": [float(c) for c in num],
        "denominator": [float(c) for c in den],
        "metadata": _json_safe(dict(metadata), "metadata"),
    }


def _number(value, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ValueError(f"{where} must be a number, got {value!r:.60}.")
    try:
        v = float(value)
    except OverflowError:  # a JSON integer beyond float64
        raise ValueError(f"{where} is an integer of {len(str(abs(value)))} digits, beyond "
                         "float64 (1.8e308); model values must be finite numbers.") from None
    if not math.isfinite(v):
        raise ValueError(f"{where} is {value!r}; model values must be finite numbers.")
    return v


def _require(doc: Mapping, key: str, kind: type, where: str):
    if key not in doc:
        raise ValueError(f"{where} has no {key!r} field; a jaxgwo model entry needs 'kind' and "
                         "'parameters' (re-export the model with jaxgwo.save_model).")
    value = doc[key]
    if not isinstance(value, kind):
        raise ValueError(f"{where}.{key} must be a {kind.__name__}, got "
                         f"{type(value).__name__} ({value!r:.60}).")
    return value


def model_from_dict(entry: Mapping, where: str = "model") -> PaperModel | QuarticModel:
    """The model of one ``models[i]`` entry; ``ValueError`` naming the faulty field."""
    if not isinstance(entry, Mapping):
        raise ValueError(f"{where} must be a JSON object, got {type(entry).__name__}.")
    kind = _require(entry, "kind", str, where)
    if kind not in _KINDS:
        raise ValueError(f"{where}.kind {kind!r} is unknown; expected one of "
                         f"{', '.join(map(repr, _KINDS))}.")
    cls = _KINDS[kind]
    names = tuple(cls.names)
    got_names = entry.get("parameter_names", list(names))
    if not isinstance(got_names, list) or tuple(got_names) != names:
        raise ValueError(f"{where}.parameter_names {got_names!r} do not match a "
                         f"{kind} model; expected {list(names)}.")
    params = _require(entry, "parameters", dict, where)
    missing = [n for n in names if n not in params]
    if missing:
        raise ValueError(f"{where}.parameters lacks {', '.join(missing)}; a {kind} model needs "
                         f"{', '.join(names)}.")
    extra = sorted(set(params) - set(names))
    if extra:
        raise ValueError(f"{where}.parameters has unknown name(s) {', '.join(extra)}; a {kind} "
                         f"model has {', '.join(names)}.")
    values = [_number(params[n], f"{where}.parameters.{n}") for n in names]
    import jax.numpy as jnp

    model = cls.from_array(jnp.asarray(values, dtype=jnp.float64))
    try:
        _coefficients(model, dict(zip(names, values)))
    except ValueError as err:
        raise ValueError(f"{where}.parameters: {err}") from None
    for key in ("numerator", "denominator"):
        if key not in entry:
            continue
        got = entry[key]
        if not isinstance(got, list):
            raise ValueError(f"{where}.{key} must be a list of numbers.")
        got = np.asarray([_number(c, f"{where}.{key}[{i}]") for i, c in enumerate(got)])
        want = np.asarray(getattr(model, key), dtype=np.float64)
        if got.shape != want.shape or not np.allclose(got, want, rtol=_POLY_RTOL, atol=0.0):
            raise ValueError(
                f"{where}.{key} {got.tolist()} disagrees with the parameters (which give "
                f"{want.tolist()}); the parameters are authoritative: fix them, or delete "
                f"{key!r} from the file."
            )
    return model


@dataclass(frozen=True)
class ModelFile:
    """A loaded model file: the models by channel (``None`` for a model saved without one),
    each model's metadata, and the file's provenance."""

    models: dict = field(default_factory=dict)
    metadata: dict = field(default_factory=dict)
    provenance: dict = field(default_factory=dict)
    schema_version: int = MODEL_SCHEMA_VERSION

    def model(self, channel: str | None = None) -> PaperModel | QuarticModel:
        """The one model, or the model of ``channel``."""
        if channel is None:
            if len(self.models) != 1:
                raise ValueError(f"the file holds {len(self.models)} models "
                                 f"({', '.join(map(str, self.models))}); pass channel=.")
            return next(iter(self.models.values()))
        if channel not in self.models:
            raise ValueError(f"no model for channel {channel!r}; the file has "
                             f"{', '.join(map(str, self.models)) or 'none'}.")
        return self.models[channel]


def _provenance(extra: Mapping | None) -> dict:
    from . import __version__

    out = {
        "jaxgwo_version": __version__,
        "created_utc": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
    }
    out.update(_json_safe(dict(extra or {}), "provenance"))
    return out


def _as_models(models) -> dict:
    """A single model or a ``{channel: model}`` mapping as ``{channel_or_None: model}``."""
    if isinstance(models, Mapping):
        if not models:
            raise ValueError("no models to export (an empty mapping).")
        for ch in models:
            if not isinstance(ch, str) or not ch:
                raise ValueError(f"channel names must be non-empty strings, got {ch!r}.")
        return dict(models)
    return {None: models}


def _document(models: Mapping, provenance: Mapping | None, metadata: Mapping) -> dict:
    per = metadata.get("per_channel") if isinstance(metadata.get("per_channel"), Mapping) else {}
    common = {k: v for k, v in metadata.items() if k != "per_channel"}
    entries = [model_to_dict(m, ch, **common, **dict(per.get(ch, {})))
               for ch, m in models.items()]
    return {"format": MODEL_FILE_FORMAT, "schema_version": MODEL_SCHEMA_VERSION,
            "provenance": _provenance(provenance), "models": entries}


def save_model(model, path: str | os.PathLike, *, channel: str | None = None,
               provenance: Mapping | None = None, **metadata) -> str:
    """Write ``model`` (or a ``{channel: model}`` mapping) to ``path`` as a jaxgwo model file
    (JSON, atomically).  ``metadata`` keyword arguments are stored with each model
    (``per_channel={channel: {...}}`` for values that differ by channel); ``provenance``
    updates the file-level provenance (``jaxgwo_version`` and ``created_utc`` are always
    written).  Returns the path written."""
    models = _as_models(model)
    if channel is not None:
        if set(models) != {None}:
            raise ValueError("pass channel= only with a single model.")
        models = {channel: models[None]}
    doc = _document(models, provenance, metadata)
    atomic_write_text(path, json.dumps(doc, indent=2, allow_nan=False) + "\n")
    return os.fspath(path)


def _read_json(path: str | os.PathLike) -> dict:
    p = os.fspath(path)
    if not os.path.exists(p):
        raise FileNotFoundError(f"no such model file: {p}")
    with open(p, "rb") as fh:
        raw = fh.read()
    if not raw.strip():
        raise ValueError(f"model file {p} is empty; write one with `jaxgwo identify --export "
                         "FILE.json` or jaxgwo.save_model(model, path).")
    try:
        doc = json.loads(raw.decode("utf-8"))
    except UnicodeDecodeError as err:
        raise ValueError(f"model file {p} is not UTF-8 text ({err.reason} at byte "
                         f"{err.start}); is it a .npz archive with the wrong extension?") from err
    except json.JSONDecodeError as err:
        raise ValueError(f"model file {p} is not valid JSON: {err.msg} at line {err.lineno}, "
                         f"column {err.colno}.") from err
    except RecursionError:
        raise ValueError(f"model file {p} nests JSON arrays/objects too deeply to be a jaxgwo "
                         "model file.") from None
    return doc


def _file_from_document(doc, p: str) -> ModelFile:
    if not isinstance(doc, dict) or doc.get("format") != MODEL_FILE_FORMAT:
        raise ValueError(f"{p} is not a jaxgwo model file (its 'format' field should be "
                         f"{MODEL_FILE_FORMAT!r}); `jaxgwo identify --json` writes a result "
                         "report, `--export FILE.json` writes a model file.")
    version = doc.get("schema_version")
    if isinstance(version, bool) or not isinstance(version, int):
        raise ValueError(f"{p}: 'schema_version' must be an integer, got {version!r}.")
    if version > MODEL_SCHEMA_VERSION or version < 1:
        raise ValueError(f"{p} has schema_version {version}; this jaxgwo reads "
                         f"1..{MODEL_SCHEMA_VERSION}. Upgrade jaxgwo to read it.")
    entries = doc.get("models")
    if not isinstance(entries, list) or not entries:
        raise ValueError(f"{p}: 'models' must be a non-empty list of model entries.")
    models, meta = {}, {}
    for i, entry in enumerate(entries):
        where = f"models[{i}]"
        model = model_from_dict(entry, where)
        ch = entry.get("channel")
        if ch is not None and not isinstance(ch, str):
            raise ValueError(f"{where}.channel must be a string or null, got {ch!r}.")
        if ch in models:
            raise ValueError(f"{where}: a second model for channel {ch!r}.")
        models[ch] = model
        m = entry.get("metadata", {})
        meta[ch] = m if isinstance(m, dict) else {}
    prov = doc.get("provenance", {})
    return ModelFile(models, meta, prov if isinstance(prov, dict) else {}, version)


def _npz_file(p: str) -> ModelFile:
    import zipfile

    try:
        data = np.load(p, allow_pickle=False)
    except (ValueError, OSError, zipfile.BadZipFile) as err:
        raise ValueError(f"{p} is not a readable .npz archive ({err}).") from err
    with data:
        keys = set(data.files)

        def get(key):
            if key not in keys:
                raise ValueError(f"{p} has no {key!r} array; it has {', '.join(sorted(keys))}. "
                                 "Write it with jaxgwo.export_model(model, 'FILE.npz').")
            return data[key]

        if "channels" in keys:
            channels = [str(c) for c in get("channels")]
            prefixes = {ch: f"{ch}_" for ch in channels}
        else:
            ch = str(get("channel")) if "channel" in keys else ""
            channels = [ch or None]
            prefixes = {channels[0]: ""}
        models = {}
        for ch, pre in prefixes.items():
            kind = str(get(pre + "kind"))
            names = [str(n) for n in get(pre + "parameter_names")]
            params = np.asarray(get(pre + "params"))
            if params.dtype != np.float64 or params.shape != (len(names),):
                raise ValueError(f"{p}: {pre}params must be float64 of shape ({len(names)},), "
                                 f"got {params.dtype} {params.shape}.")
            entry = {"kind": kind, "parameter_names": names,
                     "parameters": {n: float(v) for n, v in zip(names, params)},
                     "numerator": np.asarray(get(pre + "num"), float).tolist(),
                     "denominator": np.asarray(get(pre + "den"), float).tolist()}
            models[ch] = model_from_dict(entry, f"{p}[{pre or ''}...]")
    return ModelFile(models, {ch: {} for ch in models}, {}, MODEL_SCHEMA_VERSION)


def load_model_file(path: str | os.PathLike) -> ModelFile:
    """Read a jaxgwo model file (``.json``) or an archive written by :func:`export_model`
    (``.npz``).  ``ValueError`` says which field is wrong and what to do;
    ``FileNotFoundError`` for a missing file."""
    p = os.fspath(path)
    if p.lower().endswith(".npz"):
        if not os.path.exists(p):
            raise FileNotFoundError(f"no such model file: {p}")
        return _npz_file(p)
    return _file_from_document(_read_json(p), p)


def load_model(path: str | os.PathLike, channel: str | None = None) -> PaperModel | QuarticModel:
    """The model saved in ``path`` (the one model, or that of ``channel`` when the file
    holds several); see :func:`load_model_file`."""
    return load_model_file(path).model(channel)


def _format_for(path: str, format: str | None) -> str:
    if format is not None:
        fmt = format.lower().lstrip(".")
        if fmt not in EXPORT_FORMATS:
            raise ValueError(f"unknown export format {format!r}; choose {', '.join(EXPORT_FORMATS)}.")
        return fmt
    ext = os.path.splitext(path)[1].lower().lstrip(".")
    if ext not in EXPORT_FORMATS:
        raise ValueError(f"cannot tell the export format from {os.path.basename(path)!r}; use a "
                         f".json or .npz name, or pass the format explicitly.")
    return ext


def export_model(model, path: str | os.PathLike, format: str | None = None, *,
                 provenance: Mapping | None = None, **metadata) -> str:
    """Export ``model`` (or ``{channel: model}``) to ``path``; the format follows the
    extension (``.json``: jaxgwo model file; ``.npz``: scipy-style ``num``/``den`` arrays) or
    ``format``.  Metadata goes into JSON files only.  Written atomically; returns the path."""
    p = os.fspath(path)
    fmt = _format_for(p, format)
    if fmt == "json":
        return save_model(model, p, provenance=provenance, **metadata)
    models = _as_models(model)
    arrays: dict[str, np.ndarray] = {}
    several = len(models) > 1
    if several:
        arrays["channels"] = np.asarray(list(models), dtype=str)
    for ch, m in models.items():
        kind = _kind_of(m)
        values = _finite_values(m, kind)
        num, den = _coefficients(m, values)
        pre = f"{ch}_" if several else ""
        arrays[pre + "num"] = num
        arrays[pre + "den"] = den
        arrays[pre + "params"] = np.asarray(list(values.values()), dtype=np.float64)
        arrays[pre + "parameter_names"] = np.asarray(list(values), dtype=str)
        arrays[pre + "kind"] = np.asarray(kind)
        if not several:
            arrays["channel"] = np.asarray(ch or "")
    with atomic_output(p, "wb") as fh:
        np.savez(fh, **arrays)
    return p
