"""``jaxgwo diagnose``: where the paper model departs from flight data, which unmodelled
effect causes it, and how far the held-out gap shrinks once it is added."""

from __future__ import annotations

import argparse
import json


def add_parser(sub) -> None:
    p = sub.add_parser(
        "diagnose",
        help="diagnose the sim-to-real gap: where the model departs, which effect, how far it shrinks",
        description=(
            "Identify the paper model on TRAIN, localise its departure from the data (frequency bands, "
            "residual tests on VAL, amplitude dependence, coherence loss), then add every candidate "
            "effect (time_delay, sensor_lag, rotor_flapping, cross_coupling, structural_mode, rate_limit, "
            "backlash, saturation), refit it and rank the candidates by what they explain on the held-out "
            "VAL records. Answers 'none' when no candidate beats noise."
        ),
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
    )
    p.add_argument("files", nargs="+", metavar="TRAIN", help="identification records (.csv or .npz)")
    p.add_argument("--validate", nargs="+", metavar="VAL", default=None,
                   help="held-out validation records (required; nothing is fitted to them)")
    p.add_argument("--channel", choices=("lateral", "longitudinal"), required=True)
    p.add_argument("--seed", type=int, default=0, help="PRNG seed of the optimisers")
    p.add_argument("--wolves", type=int, default=20, help="IGWO pack size for the nominal fit and the refits")
    p.add_argument("--iterations", type=int, default=60, help="IGWO iterations for the nominal fit and the refits")
    p.add_argument("--w-max", type=float, default=120.0, help="highest frequency analysed (rad/s)")
    p.add_argument("--json", metavar="OUT.json", help="write the stable JSON report here")
    p.add_argument("--plot", metavar="OUT.png", help="Bode mismatch, residual correlations, overlays, gains")
    p.set_defaults(func=run)


def run(args) -> int:
    from .._atomic import atomic_write_text
    from .._data import CHANNELS, load_record
    from .._diagnose import DiagnoseSettings, diagnose, plot_diagnosis
    from .._identify import IdentifySettings

    if not args.validate:
        raise ValueError("diagnose needs held-out records: pass --validate VAL [VAL ...] (the ranking is scored on them).")
    if args.wolves < 4 or args.iterations < 1:
        raise ValueError("--wolves must be >= 4 and --iterations >= 1.")
    cols = CHANNELS[args.channel]
    train = [load_record(p, required=cols) for p in args.files]
    val = [load_record(p, required=cols) for p in args.validate]
    ids = IdentifySettings(method="wls-igwo+polish", wolves=args.wolves, iterations=args.iterations,
                           seed=args.seed, w_max=args.w_max)
    settings = DiagnoseSettings(identify=ids, wolves=args.wolves, iterations=args.iterations, seed=args.seed)
    d = diagnose(train, val, args.channel, settings)
    print(d.summary())
    if args.json:
        atomic_write_text(args.json, json.dumps(d.to_json(), indent=2) + "\n")
    if args.plot:
        plot_diagnosis(d, args.plot)
    return 0
