"""jaxgwo: frequency-domain identification of small unmanned helicopters with a
batched (improved) grey wolf optimiser in JAX.

Importing the package switches JAX to float64 (see :mod:`jaxgwo._config`).
"""

from ._config import enable_float64 as enable_float64
from ._config import float64_enabled as float64_enabled

enable_float64()

from ._gwo import GreyWolfConfig as GreyWolfConfig
from ._gwo import GreyWolfResult as GreyWolfResult
from ._gwo import GreyWolfState as GreyWolfState
from ._gwo import convergence_factor as convergence_factor
from ._gwo import gwo as gwo
from ._gwo import igwo as igwo
from ._gwo import init as init
from ._gwo import run as run
from ._gwo import run_seeds as run_seeds
from ._gwo import step as step
from ._transfer import paper_model_coefficients as paper_model_coefficients
from ._transfer import paper_model_response as paper_model_response

__version__ = "0.1.0"

__all__ = [
    "GreyWolfConfig",
    "GreyWolfResult",
    "GreyWolfState",
    "convergence_factor",
    "enable_float64",
    "float64_enabled",
    "gwo",
    "igwo",
    "init",
    "paper_model_coefficients",
    "paper_model_response",
    "run",
    "run_seeds",
    "step",
]
