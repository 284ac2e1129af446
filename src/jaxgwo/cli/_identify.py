"""``jaxgwo identify``: the main job."""

from __future__ import annotations

import argparse
import json
import sys
import time

JSON_SCHEMA_VERSION = 1


def add_parser(sub) -> None:
    from .._identify import METHODS

    p = sub.add_parser(
        "identify",
        help="identify roll- and pitch-rate models from sweep flight data (default: the "
             "embedded R-50 dataset)",
        description=(
            "Identify the paper's rate model K/(s^2 + s/tau + M) x servo for the lateral "
            "(p/delta_lat) and longitudinal (q/delta_lon) channels: composite frequency "
            "response, WLS start, then the chosen optimiser on the CIFER cost J. With no "
            "FILE it identifies the embedded default dataset (both channels) and validates "
            "on its held-out multi-step record."
        ),
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
    )
    p.add_argument("files", nargs="*", metavar="FILE",
                   help="identification records (.csv or .npz in the jaxgwo flight-data format)")
    p.add_argument("--validate", nargs="+", metavar="FILE", default=None,
                   help="held-out validation records (nothing is fitted to them)")
    p.add_argument("--channel", choices=("lateral", "longitudinal", "both"), default="both")
    p.add_argument("--method", choices=METHODS, default="wls-igwo+polish")
    p.add_argument("--seed", type=int, default=0, help="PRNG seed of the optimiser")
    p.add_argument("--wolves", type=int, default=50)
    p.add_argument("--iterations", type=int, default=500)
    p.add_argument("--w-min", type=float, default=1.0, help="lowest frequency (rad/s)")
    p.add_argument("--w-max", type=float, default=60.0, help="highest frequency (rad/s)")
    p.add_argument("--coherence", type=float, default=0.6, help="coherence mask threshold")
    p.add_argument("--json", metavar="OUT.json", help="write the stable JSON result here")
    p.add_argument("--plot", metavar="OUT.png", help="Bode, convergence and validation figure")
    p.set_defaults(func=run)


def _load(paths, channels):
    """Load records, requiring only the columns of the channels asked for."""
    from .._data import CHANNELS, load_record

    required = tuple(c for ch in channels for c in CHANNELS[ch])
    return [load_record(p, required=required) for p in paths]


def run(args) -> int:
    from .._atomic import atomic_write_text
    from .._data import CHANNELS, default_dataset
    from .._identify import IdentifySettings, identify_channels

    t0 = time.perf_counter()
    channels = ("lateral", "longitudinal") if args.channel == "both" else (args.channel,)
    settings = IdentifySettings(
        method=args.method, wolves=args.wolves, iterations=args.iterations, seed=args.seed,
        w_min=args.w_min, w_max=args.w_max, coherence_threshold=args.coherence,
    )
    settings.optimiser()  # configuration errors before any data work
    if args.files:
        train = _load(args.files, channels)
        validation = _load(args.validate, channels) if args.validate else None
        by_channel = {}
        for ch in channels:
            cols = CHANNELS[ch]
            recs = [r for r in train if all(c in r.columns for c in cols)]
            if not recs:
                raise ValueError(
                    f"no identification file has the {ch} columns {cols[0]!r} and {cols[1]!r} "
                    f"(columns seen: {', '.join(train[0].columns)}); pick --channel or rename "
                    "the columns."
                )
            by_channel[ch] = recs
        source = ", ".join(args.files)
    else:
        data = default_dataset()
        by_channel = {ch: [data.identification[ch]] for ch in channels}
        # Each channel is scored on its own held-out record (its cyclic excited).
        validation = (_load(args.validate, channels) if args.validate
                      else {ch: [data.validation[ch]] for ch in channels})
        source = "embedded default dataset (simulated Yamaha R-50 hover)"
    if validation:
        for ch in channels:
            cols = CHANNELS[ch]
            for rec in (validation[ch] if isinstance(validation, dict) else validation):
                missing = [c for c in cols if c not in rec.columns]
                if missing:
                    raise ValueError(
                        f"validation record lacks {ch} column(s) {missing}; it has "
                        f"{', '.join(rec.columns)}."
                    )
    results = identify_channels(by_channel, settings, validation)
    wall = time.perf_counter() - t0
    print(summary_table(results, source, wall))
    if args.json:
        doc = to_json(results, source)
        atomic_write_text(args.json, json.dumps(doc, indent=2) + "\n")
    if args.plot:
        from .._plots import plot_identification

        plot_identification(list(results.values()), args.plot)
    return 0


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
