"""Entry point: dispatches ``jaxgwo SUBCOMMAND``."""

from __future__ import annotations

import argparse
import importlib
import sys

# (module, name) pairs; each module defines add_parser(subparsers) and run(args).
_SUBCOMMANDS = (
    "jaxgwo.cli._identify",
    "jaxgwo.cli._diagnose",
    "jaxgwo.cli._simulate",
    "jaxgwo.cli._compare",
    "jaxgwo.cli._montecarlo",
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


def enable_compilation_cache() -> str | None:
    """Use JAX's persistent compilation cache so a second run on the same shapes starts
    without recompiling.  The directory is ``$JAXGWO_CACHE_DIR``, else
    ``$XDG_CACHE_HOME/jaxgwo/xla`` (``~/.cache/jaxgwo/xla``); ``JAXGWO_CACHE_DIR=off``
    disables it.  Returns the directory in use, or None."""
    import os

    import jax

    path = os.environ.get("JAXGWO_CACHE_DIR")
    if path is not None and path.lower() in ("", "0", "off", "none"):
        return None
    if path is None:
        base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
        path = os.path.join(base, "jaxgwo", "xla")
    try:
        os.makedirs(path, exist_ok=True)
    except OSError:
        return None  # a read-only home: run without the cache rather than fail
    jax.config.update("jax_compilation_cache_dir", path)
    jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.0)
    jax.config.update("jax_persistent_cache_min_entry_size_bytes", 0)
    return path


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "command", None):
        parser.print_help()
        return 2
    enable_compilation_cache()
    try:
        return int(args.func(args) or 0)
    except (UserError, ValueError, FileNotFoundError) as err:
        print(f"jaxgwo {args.command}: error: {err}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
