"""Test-suite configuration: float64 and strict dtype promotion, as the library expects."""

import jax

jax.config.update("jax_enable_x64", True)
jax.config.update("jax_numpy_dtype_promotion", "strict")

import jaxgwo  # noqa: E402,F401  (import after the flags so the package sees them)

import os  # noqa: E402

# CLI tests must not write into the user's persistent XLA cache, nor into a cache the
# caller set up (CI exports a cold one for its install run): off, whatever was set.
os.environ["JAXGWO_CACHE_DIR"] = "off"
