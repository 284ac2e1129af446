"""``jaxgwo diagnose``: where the paper model departs from flight data, which unmodelled
effect causes it, and how far the held-out gap shrinks once it is added."""

from __future__ import annotations

import dataclasses
import json

from ._identify import add_input_options, check_output_paths, command_line, load_by_channel


def add_parser(sub) -> None:
    from .._export import EXPORT_FORMATS
    from ._main import HelpFormatter

    p = sub.add_parser(
        "diagnose",
        help="diagnose the sim-to-real gap: where the model departs, which effect, how far it shrinks",
        description=(
            "Identify the paper model on TRAIN, localise its departure from the data (frequency\n"
            "bands, residual tests on VAL, amplitude dependence, coherence loss), then add every\n"
            "candidate effect (time_delay, sensor_lag, rotor_flapping, cross_coupling,\n"
            "structural_mode, rate_limit, backlash, saturation), refit it and rank the candidates\n"
            "by what they explain on the held-out VAL records. Answers 'none' when no candidate\n"
            "beats noise. With no TRAIN it diagnoses the embedded default dataset (simulated\n"
            "R-50) on its held-out record of the channel."
        ),
        epilog=(
            "examples:\n"
            "  jaxgwo diagnose --channel lateral --report d.html     # the embedded dataset\n"
            "  jaxgwo diagnose sweep.csv --validate check.csv --channel lateral \\\n"
            "      --json d.json --plot d.png --report d.html --export nominal.json\n"
            "\n"
            "--export writes the nominal paper model as a jaxgwo model file (or .npz); the\n"
            "verdict, the best candidate's effect parameters and the paper model refitted by\n"
            "output error (time_domain_refit) go into its metadata (an effect such as a delay\n"
            "is not part of the rational transfer function)."
        ),
        formatter_class=HelpFormatter,
    )
    p.add_argument("files", nargs="*", metavar="TRAIN",
                   help="identification records (csv, npz or a flight log); none: the embedded "
                        "default dataset")
    p.add_argument("--validate", nargs="+", metavar="VAL", default=None,
                   help="held-out validation records (required with TRAIN; nothing is fitted "
                        "to them)")
    p.add_argument("--channel", choices=("lateral", "longitudinal"), required=True,
                   help="lateral: p/delta_lat, longitudinal: q/delta_lon")
    p.add_argument("--seed", type=int, default=0, metavar="N", help="PRNG seed of the optimisers")
    p.add_argument("--wolves", type=int, default=None, metavar="N",
                   help="IGWO pack size for the nominal fit and the refits (default 12: the "
                        "configuration the blind study validates)")
    p.add_argument("--iterations", type=int, default=None, metavar="N",
                   help="IGWO iterations for the nominal fit and the refits (default 30, as "
                        "the blind study)")
    p.add_argument("--w-max", type=float, default=120.0, metavar="RAD_S",
                   help="highest frequency analysed (rad/s)")
    p.add_argument("--json", metavar="OUT.json", help="write the stable JSON report here")
    p.add_argument("--plot", metavar="OUT.png", help="Bode mismatch, residual correlations, overlays, gains")
    p.add_argument("--report", metavar="OUT.html",
                   help="self-contained HTML report: verdict, ranking table and the figure")
    p.add_argument("--export", metavar="FILE",
                   help="write the nominal model (.json model file or .npz), candidates in its metadata")
    p.add_argument("--export-format", choices=EXPORT_FORMATS, default=None,
                   help="format of --export (default: from its extension)")
    p.add_argument("--quiet", action="store_true",
                   help="no progress line on stderr (shown only on a terminal anyway)")
    add_input_options(p)
    p.set_defaults(func=run)


def export_diagnosis(d, path: str, fmt: str | None, source: str, command: str | None = None) -> str:
    """The nominal model of ``d``; the verdict, the augmented models' effect parameters
    (top candidate and the top-two combination) and the time-domain null refit as metadata."""
    import jax.numpy as jnp

    from .._export import export_model
    from .._models import PaperModel

    doc = d.to_json()
    names = PaperModel.names
    model = PaperModel.from_array(jnp.asarray([float(d.nominal_params[n]) for n in names]))
    top = doc["ranking"][0] if doc["ranking"] else None
    meta = {
        "role": "nominal model of jaxgwo diagnose",
        "cost_J": doc["nominal"]["cost_J"], "validation_r2": doc["nominal"]["val_r2"],
        "validation_tic": doc["nominal"]["val_tic"], "verdict": doc["verdict"],
        "top_candidate": None if top is None else {
            k: top[k] for k in ("effect", "params", "params_sigma", "val_r2", "gap_closed",
                                "beats_noise")},
        "combined_top2": doc.get("combined_top2"),
        # the paper model refitted by output error, no effect: the better model where VAL says so
        "time_domain_refit": doc.get("time_domain_refit"),
    }
    return export_model({d.channel: model}, path, fmt,
                        provenance={"source": source, "command": command or command_line()}, **meta)


def diagnose_settings(args):
    """The diagnosis's settings from the command line: :class:`DiagnoseSettings`'s defaults
    (the configuration the blind study validates), with ``--seed`` and ``--w-max``, and
    ``--wolves`` / ``--iterations`` where given (for the nominal fit and the refits alike)."""
    if (args.wolves is not None and args.wolves < 4) or (args.iterations is not None and args.iterations < 1):
        raise ValueError("--wolves must be >= 4 and --iterations >= 1.")
    from .._diagnose import DiagnoseSettings

    base = DiagnoseSettings()
    size = {k: v for k, v in (("wolves", args.wolves), ("iterations", args.iterations)) if v is not None}
    ids = dataclasses.replace(base.identify, seed=args.seed, w_max=args.w_max, **size)
    return dataclasses.replace(base, identify=ids, seed=args.seed, **size)


def run(args) -> int:
    from .._atomic import atomic_write_text
    from .._data import default_dataset
    from .._diagnose import DIAGNOSE_STAGES, diagnose, plot_diagnosis
    from .._progress import Progress

    if args.files and not args.validate:
        raise ValueError("diagnose needs held-out records: pass --validate VAL [VAL ...] (the ranking is scored on them).")
    settings = diagnose_settings(args)
    check_output_paths(args)
    ch = args.channel
    if args.files:
        train = load_by_channel(args.files, (ch,), args)[ch]
        source = ", ".join(args.files)
    else:
        if args.run is not None or args.window is not None:
            raise ValueError("--run and --window select part of a flight log; give the log file.")
        data = default_dataset()
        train = [data.identification[ch]]
        source = "embedded default dataset (simulated Yamaha R-50 hover)"
    if args.validate:
        val = load_by_channel(args.validate, (ch,), args, role="validation")[ch]
        source += " (validated on " + ", ".join(args.validate) + ")"
    else:
        val = [data.validation[ch]]
        source += " (validated on its held-out record)"
    # a diagnosis takes minutes: a stage line on a terminal, between the compiled calls
    with Progress(len(DIAGNOSE_STAGES), "diagnose", "stages", quiet=args.quiet, eta=False) as bar:
        d = diagnose(train, val, args.channel, settings, progress=bar.update)
    print(d.summary())
    if args.json:
        atomic_write_text(args.json, json.dumps(d.to_json(), indent=2) + "\n")
    if args.plot:
        plot_diagnosis(d, args.plot)
    if getattr(args, "export", None):
        export_diagnosis(d, args.export, args.export_format, source, command_line(args))
    if getattr(args, "report", None):
        from .._report import write_diagnosis_report

        write_diagnosis_report(d, args.report, source=source, command=command_line(args))
    return 0
