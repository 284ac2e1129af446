"""Entry point: dispatches ``jaxgwo SUBCOMMAND``."""

from __future__ import annotations

import argparse
import importlib
import sys

# (module, name) pairs; each module defines add_parser(subparsers) and run(args).
_SUBCOMMANDS = (
    "jaxgwo.cli._compare",
    "jaxgwo.cli._simulate",
)


class UserError(Exception):
    """An error in the user's input: printed as one line, exit status 2."""


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="jaxgwo",
        description=(
            "Frequency-domain system identification of small unmanned helicopters "
            "with a batched grey wolf optimiser (GWO / IGWO) in JAX."
        ),
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in _SUBCOMMANDS:
        try:
            module = importlib.import_module(name)
        except ModuleNotFoundError as err:  # a subcommand not written yet
            if err.name == name:
                continue
            raise
        module.add_parser(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "command", None):
        parser.print_help()
        return 2
    try:
        return int(args.func(args) or 0)
    except (UserError, ValueError, FileNotFoundError) as err:
        print(f"jaxgwo {args.command}: error: {err}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
