"""``jaxgwo identify``: the main job."""

from __future__ import annotations

import json
import sys
import time

JSON_SCHEMA_VERSION = 1


def add_parser(sub) -> None:
    from .._export import EXPORT_FORMATS
    from .._identify import METHODS
    from ._main import HelpFormatter

    p = sub.add_parser(
        "identify",
        help="identify roll- and pitch-rate models from sweep flight data (default: the "
             "embedded R-50 dataset)",
        description=(
            "Identify the paper's rate model K/(s^2 + s/tau + M) x servo for the lateral\n"
            "(p/delta_lat) and longitudinal (q/delta_lon) channels: composite frequency\n"
            "response, WLS start, then the chosen optimiser on the CIFER cost J. Prints the\n"
            "parameters with Cramer-Rao bounds, J and the held-out R^2 and TIC. With no FILE\n"
            "it identifies the embedded default dataset (both channels) and validates on its\n"
            "held-out multi-step record."
        ),
        epilog=(
            "examples:\n"
            "  jaxgwo identify                                   # the embedded dataset\n"
            "  jaxgwo identify sweep.csv --validate check.csv --channel lateral\n"
            "  jaxgwo identify --export models.json --report report.html --plot fig.png\n"
            "\n"
            "--export writes one file holding the model of every channel identified: a jaxgwo\n"
            "model file (.json; jaxgwo.load_model(path, channel='lateral') reads it back bit\n"
            "for bit) or a scipy-style .npz archive (num/den for one channel, lateral_num,\n"
            "lateral_den, ... for several). Outputs are written atomically: a failed run leaves\n"
            "no partial file."
        ),
        formatter_class=HelpFormatter,
    )
    p.add_argument("files", nargs="*", metavar="FILE",
                   help="identification records (.csv or .npz in the jaxgwo flight-data "
                        "format); none: the embedded default dataset")
    p.add_argument("--validate", nargs="+", metavar="FILE", default=None,
                   help="held-out validation records (nothing is fitted to them)")
    p.add_argument("--channel", choices=("lateral", "longitudinal", "both"), default="both",
                   help="lateral: p/delta_lat, longitudinal: q/delta_lon")
    p.add_argument("--method", choices=METHODS, default="wls-igwo+polish",
                   help="refinement after the WLS start (see README: What identify does)")
    p.add_argument("--seed", type=int, default=0, metavar="N", help="PRNG seed of the optimiser")
    p.add_argument("--wolves", type=int, default=50, metavar="N", help="pack size of GWO/IGWO")
    p.add_argument("--iterations", type=int, default=500, metavar="N", help="GWO/IGWO iterations")
    p.add_argument("--w-min", type=float, default=1.0, metavar="RAD_S",
                   help="lowest frequency (rad/s)")
    p.add_argument("--w-max", type=float, default=60.0, metavar="RAD_S",
                   help="highest frequency (rad/s)")
    p.add_argument("--coherence", type=float, default=0.6, metavar="C",
                   help="coherence threshold: frequencies below it are left out of J")
    p.add_argument("--json", metavar="OUT.json", help="write the stable JSON result here")
    p.add_argument("--plot", metavar="OUT.png", help="Bode, convergence and validation figure")
    p.add_argument("--export", metavar="FILE",
                   help="write the identified model(s) to FILE (.json model file or .npz)")
    p.add_argument("--export-format", choices=EXPORT_FORMATS, default=None,
                   help="format of --export (default: from its extension)")
    p.add_argument("--report", metavar="OUT.html",
                   help="self-contained HTML report: tables and figures in one file")
    p.add_argument("--quiet", action="store_true",
                   help="no progress line on stderr (shown only on a terminal anyway)")
    add_input_options(p)
    p.set_defaults(func=run)


FIGURE_OPTIONS = ("plot", "convergence_plot")


def figure_format_error(flag: str, path: str) -> str | None:
    """Why matplotlib cannot write a figure to ``path`` (from its extension), or None."""
    import os

    from matplotlib.backend_bases import FigureCanvasBase

    ext = os.path.splitext(path)[1].lower().lstrip(".") or "png"
    supported = FigureCanvasBase.get_supported_filetypes()
    if ext in supported:
        return None
    return (f"{flag} format {ext!r} is not supported; use a name ending in one of "
            f"{', '.join('.' + e for e in sorted(supported))}.")


def check_output_paths(args, names=("json", "plot", "export", "report", "convergence_plot",
                                    "markdown")) -> None:
    """Fail before any work, not after a long run, when an output cannot be written: its
    directory is missing, it names a directory, or its format is unknown."""
    from pathlib import Path

    for name in names:
        path = getattr(args, name, None)
        if not path:
            continue
        flag = "--" + name.replace("_", "-")
        if Path(path).is_dir():
            raise ValueError(f"{flag} {path} is a directory; give a file name.")
        if not Path(path).resolve().parent.is_dir():
            raise ValueError(f"{flag} directory does not exist: {Path(path).parent}")
        if name in FIGURE_OPTIONS:
            why = figure_format_error(flag, path)
            if why:
                raise ValueError(why)
    export = getattr(args, "export", None)
    if export:
        from .._export import _format_for

        _format_for(export, getattr(args, "export_format", None))
    elif getattr(args, "export_format", None):
        raise ValueError("--export-format needs --export FILE.")


def command_line(args=None) -> str:
    """The command as typed, for provenance: ``args.argv`` (set by :func:`main`), else
    the process' own arguments."""
    import shlex

    argv = getattr(args, "argv", None)
    return "jaxgwo " + " ".join(shlex.quote(a) for a in (sys.argv[1:] if argv is None else argv))


def add_input_options(p) -> None:
    """``--format`` and the flight-log options shared by identify and diagnose."""
    from .._logs import FORMATS

    g = p.add_argument_group("input files")
    g.add_argument("--format", choices=FORMATS, default="auto",
                   help="file format: jaxgwo csv/npz, an ArduPilot DataFlash .bin or a PX4 "
                        ".ulg log; auto: by extension, else by the file's first bytes")
    g.add_argument("--log-input", choices=("mixer", "targ"), default="mixer",
                   help="ArduPilot input: the rate controllers' mixer outputs RATE.ROut/POut "
                        "(bare airframe) or the injected chirp SIDD.Targ")
    g.add_argument("--run", type=int, default=None, metavar="N",
                   help="ArduPilot: which System ID (SIDS) run to take, 0 = first; default: "
                        "the log's run on the channel identified")
    g.add_argument("--window", type=float, nargs=2, default=None, metavar=("START_S", "STOP_S"),
                   help="ArduPilot/PX4: take this time span (s since boot) instead of a run")


def load_by_channel(paths, channels, args, role: str = "identification") -> dict:
    """``{channel: [records]}`` from ``paths`` in any supported format (``--format``).

    A jaxgwo CSV/NPZ file or a PX4 log serves every channel whose columns it has.  An
    ArduPilot log is read once per channel: each channel takes its own System ID run (or
    ``--run``/``--window``).
    """
    from .._data import CHANNELS
    from .._logs import detect_format, load_any

    fmt_opt = getattr(args, "format", "auto")
    run_opt, window = getattr(args, "run", None), getattr(args, "window", None)
    # an ArduPilot log gives each channel its own run unless --run/--window pick one span
    one_span = run_opt is not None or window is not None
    out = {ch: [] for ch in channels}
    seen: dict[str, None] = {}  # every column of every file read, in order
    for path in paths:
        fmt = detect_format(path) if fmt_opt == "auto" else fmt_opt
        try:
            if fmt == "ardupilot":
                for ch in channels:
                    out[ch].append(load_any(
                        path, format=fmt, required=CHANNELS[ch], input=args.log_input,
                        run=run_opt, window=window, channel=None if one_span else ch))
                continue
            if fmt == "px4":
                rec = load_any(path, format=fmt, window=window)
            else:
                if run_opt is not None or window is not None:
                    raise ValueError(f"{path}: --run and --window apply to flight logs "
                                     f"(ardupilot, px4), not to {fmt} files.")
                rec = load_any(path, format=fmt, required=())
        except ImportError as err:  # an optional extra missing: a user's fix, one line
            raise ValueError(str(err)) from None
        seen.update(dict.fromkeys(rec.columns))
        for ch in channels:
            if all(c in rec.columns for c in CHANNELS[ch]):
                out[ch].append(rec)
    for ch in channels:
        if not out[ch]:
            u, y = CHANNELS[ch]
            raise ValueError(
                f"no {role} file has the {ch} columns {u!r} and {y!r} (columns seen: "
                f"{', '.join(seen)}); pick --channel, or map or rename the columns "
                "(jaxgwo.load_record(path, columns={...}))."
            )
    return out


def run(args) -> int:
    from .._atomic import atomic_write_text
    from .._data import default_dataset
    from .._identify import IdentifySettings

    t0 = time.perf_counter()
    check_output_paths(args)
    channels = ("lateral", "longitudinal") if args.channel == "both" else (args.channel,)
    settings = IdentifySettings(
        method=args.method, wolves=args.wolves, iterations=args.iterations, seed=args.seed,
        w_min=args.w_min, w_max=args.w_max, coherence_threshold=args.coherence,
    )
    settings.optimiser()  # configuration errors before any data work
    if args.files:
        by_channel = load_by_channel(args.files, channels, args)
        source = ", ".join(args.files)
    else:
        if any(getattr(args, k, None) is not None for k in ("run", "window")):
            raise ValueError("--run and --window select part of a flight log; give the log file.")
        data = default_dataset()
        by_channel = {ch: [data.identification[ch]] for ch in channels}
        source = "embedded default dataset (simulated Yamaha R-50 hover)"
    if args.validate:
        validation = load_by_channel(args.validate, channels, args, role="validation")
    elif not args.files:  # the embedded held-out record of each channel
        validation = {ch: [data.validation[ch]] for ch in channels}
    else:
        validation = None
    results = _identify_with_progress(by_channel, settings, validation, args.quiet)
    wall = time.perf_counter() - t0
    print(summary_table(results, source, wall))
    if args.json:
        doc = to_json(results, source)
        atomic_write_text(args.json, json.dumps(doc, indent=2) + "\n")
    if args.plot:
        from .._plots import plot_identification

        plot_identification(list(results.values()), args.plot)
    if args.export:
        export_results(results, args.export, args.export_format, source, command_line(args))
    if args.report:
        from .._report import write_identification_report

        write_identification_report(results, args.report, source=source, wall_s=wall,
                                    command=command_line(args))
    return 0


def _identify_with_progress(by_channel, settings, validation, quiet):
    """:func:`jaxgwo.identify_channels` in its stages, with a progress line between the
    compiled calls: a frequency response and WLS start per channel, then one batched
    optimiser call for all channels (and the validation simulations)."""
    from .. import _identify as I
    from .._progress import Progress

    channels = list(by_channel)
    # held-out records are checked before anything compiles
    validation_pairs = I._check_validation(validation, channels, settings)
    with Progress(len(channels) + 1, "identify", "stages", quiet=quiet, eta=False) as bar:
        preps = []
        for i, ch in enumerate(channels):
            bar.update(i, f"{ch}: frequency response, WLS start")
            preps.append(I._prepare(list(by_channel[ch]), ch, settings))
        bar.update(len(channels), f"{settings.method}: {len(channels)} channel(s) in one "
                   "call" + (", validation" if validation else ""))
        results = I._identify_prepared(preps, settings, validation, validation_pairs)
        bar.update(len(channels) + 1)
    return results


def export_results(results, path: str, fmt: str | None, source: str,
                   command: str | None = None) -> str:
    """Export every channel's model to one file (see ``jaxgwo identify --help``)."""
    from .._export import export_model

    per_channel = {}
    for ch, r in results.items():
        unc = r.uncertainty.as_dict()
        v = r.validation
        per_channel[ch] = {
            "method": r.method, "seed": r.seed, "cost_J": r.cost_J, "wls_cost_J": r.wls_cost_J,
            "frequencies_used": int(r.response.n_passing),
            "cramer_rao_percent": {k: d["cr_percent"] for k, d in unc.items()},
            "validation_r2": None if v is None else v.r2,
            "validation_tic": None if v is None else v.tic,
        }
    return export_model({ch: r.model for ch, r in results.items()}, path, fmt,
                        provenance={"source": source, "command": command or command_line()},
                        per_channel=per_channel)


def summary_table(results, source: str, wall_s: float) -> str:
    lines = [f"jaxgwo identify: {source}"]
    for ch, r in results.items():
        unc = r.uncertainty.as_dict()
        lines.append("")
        lines.append(f"{ch} channel ({r.method}, seed {r.seed}, {r.evaluations} evaluations, "
                     f"{r.runtime_s:.2f} s optimiser time)")
        lines.append(f"  {'param':8s} {'value':>12s} {'CR bound %':>11s} {'insens. %':>10s}")
        for name, d in unc.items():
            lines.append(f"  {name:8s} {d['value']:12.5g} {d['cr_percent']:11.2f} "
                         f"{d['insensitivity_percent']:10.2f}")
        lines.append(f"  J = {r.cost_J:.2f}   (WLS start J = {r.wls_cost_J:.2f})")
        if r.validation is not None:
            v = r.validation
            lines.append(f"  validation: R^2 = {v.r2:.4f}   TIC = {v.tic:.4f}   RMS = {v.rms:.4g} rad/s")
    lines.append("")
    lines.append(f"total wall time {wall_s:.2f} s (including compilation)")
    return "\n".join(lines)


def to_json(results, source: str) -> dict:
    """The stable document: one entry per channel (see README)."""
    out = {"schema": JSON_SCHEMA_VERSION, "source": source, "channels": {}}
    for ch, r in results.items():
        unc = r.uncertainty.as_dict()
        entry = {
            "method": r.method,
            "seed": r.seed,
            "model": {
                "structure": "K/(s^2 + s/tau + M) * omega_s^2/(s^2 + 2 zeta_s omega_s s + omega_s^2)",
                "params": {k: float(v) for k, v in r.model.params.items()},
                "numerator": [float(c) for c in r.model.numerator],
                "denominator": [float(c) for c in r.model.denominator],
            },
            "wls_start": {"params": {k: float(v) for k, v in r.wls_model.params.items()},
                          "cost_J": r.wls_cost_J},
            "fit": {"cost_J": r.cost_J, "mse": r.mse,
                    "frequencies_used": int(r.response.n_passing)},
            "validation": None if r.validation is None else {
                "r2": r.validation.r2, "tic": r.validation.tic, "rms": r.validation.rms,
                "per_record_r2": list(r.validation.per_record_r2),
            },
            "uncertainty": {k: d["cr_percent"] for k, d in unc.items()},
            "insensitivity": {k: d["insensitivity_percent"] for k, d in unc.items()},
            "convergence": [float(v) for v in r.convergence],
            "evaluations": r.evaluations,
            "runtime_s": r.runtime_s,
        }
        out["channels"][ch] = entry
    return out


if __name__ == "__main__":  # pragma: no cover
    from ._main import main

    sys.exit(main(["identify", *sys.argv[1:]]))
