"""Numerical precision policy.

jaxgwo identifies models whose frequency-response moments span many decades (the
paper's Levy sums reach 1e16), so the identification path runs in float64.  Importing
:mod:`jaxgwo` switches on ``jax_enable_x64`` once, process-wide; this is the documented
way to get float64 in JAX.  Code that needs float32 (for example a fast first pass) asks
for it explicitly with a ``dtype`` argument.
"""

from __future__ import annotations

import jax


def enable_float64() -> None:
    """Turn on JAX's 64-bit mode (``jax_enable_x64``).  Idempotent."""
    jax.config.update("jax_enable_x64", True)


def float64_enabled() -> bool:
    """Whether JAX currently creates float64 arrays by default."""
    return bool(jax.config.jax_enable_x64)
