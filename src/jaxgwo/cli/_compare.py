"""``jaxgwo compare``: GWO versus IGWO on benchmark functions and the helicopter fit."""

from __future__ import annotations


REDUCED_PROBLEMS = ("F1 sphere", "F9 rastrigin")
REDUCED_VARIANTS = ("gwo", "igwo", "igwo eq39 as printed")


def add_parser(sub) -> None:
    from ._main import HelpFormatter

    p = sub.add_parser(
        "compare",
        help="compare GWO and IGWO on benchmark functions (a reduced run by default)",
        description=(
            "Run GWO, IGWO and (with --full) IGWO with each improvement switched off, on\n"
            "Mirjalili's F1-F13 and the 5-parameter helicopter fit, over the same seeds (one\n"
            "compiled, vmapped call per problem and variant). Prints a markdown table of the\n"
            "final error f(x) - f* (median, IQR, best, evaluations, Wilcoxon rank-sum p\n"
            "against GWO). The default is a reduced run (F1, F9, the helicopter fit; GWO, IGWO\n"
            "and eq. 39 as printed) of under a minute; benchmarks/gwo_vs_igwo.py runs the\n"
            "full study."
        ),
        epilog=(
            "examples:\n"
            "  jaxgwo compare --plot conv.png\n"
            "  jaxgwo compare --problems F5,helicopter --variants gwo,igwo --seeds 30\n"
            "  jaxgwo compare --full --markdown table.md"
        ),
        formatter_class=HelpFormatter,
    )
    p.add_argument("--full", action="store_true",
                   help="all 13 functions, the helicopter fit and all 8 variants")
    p.add_argument("--problems", metavar="F1,F9,...",
                   help="comma-separated problem ids to run (F1..F13, helicopter)")
    p.add_argument("--variants", metavar="gwo,igwo,...",
                   help="comma-separated variant names: gwo, igwo, 'igwo eq39 as printed', "
                        "'igwo eq39 e^(t/T)', 'igwo linear a', 'igwo no grouping', "
                        "'igwo reinit grouping', 'igwo no dynamic weights'")
    p.add_argument("--seeds", type=int, default=10, metavar="N", help="independent runs per variant")
    p.add_argument("--wolves", type=int, default=50, metavar="N", help="pack size")
    p.add_argument("--iterations", type=int, default=300, metavar="N", help="iterations per run")
    p.add_argument("--dim", type=int, default=30, metavar="N", help="dimension of F1-F13")
    p.add_argument("--seed", type=int, default=0, metavar="N", help="master PRNG seed")
    p.add_argument("--markdown", metavar="OUT.md", help="also write the table here")
    p.add_argument("--plot", metavar="OUT.png",
                   help="convergence plot: median and IQR band over seeds per problem")
    p.add_argument("--quiet", action="store_true",
                   help="no progress line (shown only on a terminal)")
    p.set_defaults(func=run)


def run(args) -> int:
    import jax

    from .._atomic import atomic_write_text
    from .._compare import plot_convergence, run_comparison, variants
    from .._progress import Progress
    from .._testfunctions import helicopter_problem, mirjalili_functions

    from ._identify import check_output_paths

    check_output_paths(args, ("markdown", "plot"))
    if args.seeds < 2:
        raise ValueError(f"--seeds {args.seeds}: a comparison needs at least 2 seeds.")
    if args.dim < 2:
        raise ValueError(f"--dim {args.dim}: F1-F13 need dimension >= 2.")
    key_f7, key_runs = jax.random.split(jax.random.key(args.seed))
    problems = list(mirjalili_functions(key_f7)) + [helicopter_problem()]
    configs = variants(args.wolves, args.iterations)
    if not args.full:
        problems = [p for p in problems if p.name in REDUCED_PROBLEMS or p.fixed_dim]
        configs = {k: v for k, v in configs.items() if k in REDUCED_VARIANTS}
    if args.problems:
        wanted = [w.strip().lower() for w in args.problems.split(",") if w.strip()]
        ids = {p.name.split()[0].lower(): p for p in list(mirjalili_functions(key_f7))
               + [helicopter_problem()]}
        unknown = [w for w in wanted if w not in ids]
        if unknown:
            raise ValueError(f"unknown problem(s) {unknown}; choose from {sorted(ids)}.")
        problems = [ids[w] for w in wanted]
    if args.variants:
        every = variants(args.wolves, args.iterations)
        wanted = [w.strip() for w in args.variants.split(",") if w.strip()]
        unknown = [w for w in wanted if w not in every]
        if unknown:
            raise ValueError(f"unknown variant(s) {unknown}; choose from {list(every)}.")
        configs = {w: every[w] for w in wanted}
    with Progress(len(problems) * len(configs), "compare", "runs", quiet=args.quiet) as bar:
        # one vmapped call over the seeds per (problem, variant): progress between calls
        report = run_comparison(problems, configs, dim=args.dim, seeds=args.seeds,
                                key=key_runs, progress=lambda msg: bar.advance(1, " ".join(msg.split())))
    table = report.to_markdown()
    print(table)
    for name, (better, same, worse) in report.wins().items():
        print(f"{name}: better than GWO on {better}, no significant difference on {same}, "
              f"worse on {worse} of {better + same + worse} problems (p < 0.05)")
    print(f"({report.seconds:.1f} s including compilation)")
    if args.markdown:
        atomic_write_text(args.markdown, table)
    if args.plot:
        plot_convergence(report, args.plot)
    return 0
