"""Held-out multi-step validation flights from the R-50 simulator, shared by the benchmarks.

The recipe is :func:`jaxgwo.multistep_validation` (one record per channel, each exciting
its own cyclic, and its turbulence-free twin); this module only names the keys from which
the embedded default dataset made its two validation records, so that the benchmarks can
fly the same flight again (for example without turbulence) or fly further ones.
"""

from __future__ import annotations

import jax

from jaxgwo._simulate import DEFAULT_DATASET_SEED, multistep_validation

__all__ = ["default_validation_key", "multistep_validation"]


def default_validation_key(channel: str) -> jax.Array:
    """The key from which ``default_dataset_records`` makes the embedded validation record
    of ``channel`` (``"lateral"`` or ``"longitudinal"``)."""
    k_val = jax.random.split(jax.random.key(DEFAULT_DATASET_SEED), 3)[2]
    return jax.random.split(k_val)[("lateral", "longitudinal").index(channel)]
