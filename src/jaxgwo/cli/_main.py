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


class HelpFormatter(argparse.RawDescriptionHelpFormatter):
    """Descriptions and epilogs kept as written (examples stay aligned); an option's
    default is appended to its help when it has a meaningful one (not None/False) and the
    help does not already give it."""

    def _get_help_string(self, action):
        text = action.help or ""
        default = action.default
        if (default is None or default is False or default == argparse.SUPPRESS
                or "default" in text or "%(default)" in text or not action.option_strings
                or isinstance(default, list) and not default):
            return text
        return text + " (default: %(default)s)"


def build_parser() -> argparse.ArgumentParser:
    from jaxgwo import __version__

    parser = argparse.ArgumentParser(
        prog="jaxgwo",
        description=(
            "Frequency-domain system identification of small unmanned helicopters\n"
            "with a batched grey wolf optimiser (GWO / IGWO) in JAX, float64 throughout."
        ),
        epilog=(
            "Run `jaxgwo COMMAND --help` for a command's options. Input errors end in one\n"
            "line on stderr with exit status 2; outputs are written atomically (a failed run\n"
            "leaves no partial file). JAX's compilation cache lives in $JAXGWO_CACHE_DIR\n"
            "(default ~/.cache/jaxgwo/xla; JAXGWO_CACHE_DIR=off disables it); its exported/\n"
            "folder keeps the traced programs, so a warm run skips tracing too.\n"
            "\n"
            "examples:\n"
            "  jaxgwo identify --report report.html     # the embedded R-50 dataset\n"
            "  jaxgwo simulate --channel lateral --excitation sweep --out sweep.csv\n"
            "  jaxgwo compare                           # GWO vs IGWO, reduced"
        ),
        formatter_class=HelpFormatter,
    )
    parser.add_argument("--version", action="version", version=f"jaxgwo {__version__}")
    parser.add_argument("--quiet", "-q", dest="global_quiet", action="store_true",
                        help="no progress lines on stderr, for every command")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", title="commands")
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
    without recompiling, and keep the lowered programs beside it (``exported/``,
    :mod:`jaxgwo._aot`) so that it starts without re-tracing either.  The directory is ``$JAXGWO_CACHE_DIR``, else
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
    # and the lowered programs, so that a warm run skips tracing too (jaxgwo._aot); a
    # subdirectory without JAX's "-cache" suffix, which JAX's own cache ignores
    from .._aot import enable

    try:
        enable(os.path.join(path, "exported"))
    except OSError:
        enable(None)
    return path


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    args.argv = list(sys.argv[1:] if argv is None else argv)  # for provenance (command_line)
    if not getattr(args, "command", None):
        parser.print_help()
        return 2
    # `jaxgwo --quiet CMD` and `jaxgwo CMD --quiet` mean the same (separate dests: a
    # subcommand's own default would otherwise overwrite the global flag)
    args.quiet = bool(getattr(args, "quiet", False) or args.global_quiet)
    enable_compilation_cache()
    try:
        return int(args.func(args) or 0)
    except (UserError, ValueError, OSError) as err:
        # OSError: a missing file, a directory where a file was expected, no permission,
        # a full disk -- the user's environment, told in one line (outputs are atomic)
        print(f"jaxgwo {args.command}: error: {err}", file=sys.stderr)
        return 2
    finally:
        if argv is None:  # the console script: the process ends next
            _spare_the_final_collection()


def _spare_the_final_collection() -> None:
    """Move every live object out of the garbage collector's reach.

    The interpreter's last collection at exit walks all objects JAX, NumPy and SciPy
    created, about 0.3 s after the command's work is done, to free memory the operating
    system is about to take back anyway.  Frozen objects are skipped by it.  Everything
    the command writes is written and closed before this, and ``atexit`` handlers (JAX's
    own) still run; only a command run as a script does this (``main(argv)`` called from
    Python, as in the tests, does not: frozen objects are never collected)."""
    import gc

    gc.freeze()


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
