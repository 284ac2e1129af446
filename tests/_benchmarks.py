"""The scripts of ``benchmarks/`` as modules, for the tests that check them (the scripts are
not part of the package, so they are loaded from their files)."""

import importlib.util
import os

_DIR = os.path.join(os.path.dirname(os.path.abspath(__file__)), os.pardir, "benchmarks")


def load_benchmark(name: str):
    """``benchmarks/<name>.py`` as a freshly executed module."""
    spec = importlib.util.spec_from_file_location(name, os.path.join(_DIR, f"{name}.py"))
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod
