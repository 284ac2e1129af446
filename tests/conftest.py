"""Test-suite configuration: float64 and strict dtype promotion, as the library expects,
and one XLA compilation cache for the whole test session."""

import atexit
import os
import shutil
import tempfile

import jax

jax.config.update("jax_enable_x64", True)
jax.config.update("jax_numpy_dtype_promotion", "strict")

import jaxgwo  # noqa: E402,F401  (import after the flags so the package sees them)

# CLI tests must not write into the user's persistent XLA cache, nor into a cache the
# caller set up (CI exports a cold one for its install run): off, whatever was set.
os.environ["JAXGWO_CACHE_DIR"] = "off"

# The session's own XLA cache, empty at the start: pytest-xdist's workers (started by the
# process that imports this first, and inheriting its environment) compile the same
# diagnosis programs on the same shapes, and each would otherwise compile them again --
# about half of a diagnosis test's time in a fresh process (a CI-sized diagnosis: 116 s
# cold, 53 s with the programs another process compiled).  Compiled programs only: every
# test still traces, and still runs, all of its code.
_SESSION_CACHE = "JAXGWO_TEST_SESSION_XLA_CACHE"
if not os.environ.get(_SESSION_CACHE):
    os.environ[_SESSION_CACHE] = tempfile.mkdtemp(prefix="jaxgwo-test-xla-")
    atexit.register(shutil.rmtree, os.environ[_SESSION_CACHE], True)
jax.config.update("jax_compilation_cache_dir", os.environ[_SESSION_CACHE])
jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.0)
jax.config.update("jax_persistent_cache_min_entry_size_bytes", 0)

# The diagnosis tests first, the rest after.  pytest-xdist's worksteal scheduler hands each
# worker a contiguous half of this order: one worker starts on the diagnosis tests and
# compiles their programs into the session cache above while the other runs the quick
# tests; when that one runs dry it steals from the diagnosis queue's tail and loads those
# programs from the cache instead of compiling them at the same time (on two cores, two
# workers compiling the same cold diagnosis together took 250 s each, one alone 175 s).
# Order only: every test still runs.  Measured once each on two cores: the whole suite
# 1142 s in file order, 1087 s in this one, within the machine's run-to-run spread.
_COMPILE_HEAVY = ("test_diagnose.py", "test_gyro_path.py", "test_matched_filter.py")


def pytest_collection_modifyitems(config, items):
    items.sort(key=lambda item: item.path.name not in _COMPILE_HEAVY)  # stable: file order kept within each part
