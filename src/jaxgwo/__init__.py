"""jaxgwo: frequency-domain identification of small unmanned helicopters with a
batched (improved) grey wolf optimiser in JAX.

Importing the package switches JAX to float64 (see :mod:`jaxgwo._config`).
"""

from ._config import enable_float64 as enable_float64
from ._config import float64_enabled as float64_enabled

enable_float64()

__version__ = "0.1.0"

__all__ = [
    "enable_float64",
    "float64_enabled",
]
