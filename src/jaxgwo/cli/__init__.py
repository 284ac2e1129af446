"""The ``jaxgwo`` console script.  Each subcommand lives in its own module with
``add_parser(subparsers)`` and ``run(args) -> int``."""

from ._main import main as main

__all__ = ["main"]
