"""jaxgwo: frequency-domain identification of small unmanned helicopters with a
batched (improved) grey wolf optimiser in JAX.

Importing the package switches JAX to float64 (see :mod:`jaxgwo._config`).

The public names below are imported on first use (PEP 562 ``__getattr__``), not when the
package is: ``import jaxgwo`` then costs only JAX itself, and the command line loads just
the modules its subcommand needs (``jaxgwo identify`` never imports the simulator, the
diagnosis or the log readers' dependencies).  ``from jaxgwo import X``, ``jaxgwo.X`` and
``from jaxgwo import *`` work as for eagerly imported names.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

from ._config import enable_float64 as enable_float64
from ._config import float64_enabled as float64_enabled

enable_float64()

__version__ = "0.1.0"

# module -> the public names it provides, in the order of the documentation
_EXPORTS: dict[str, tuple[str, ...]] = {
    "_gwo": (
        "GreyWolfConfig", "GreyWolfResult", "GreyWolfState", "convergence_factor",
        "gwo", "igwo", "init", "run", "run_batch", "run_seeds", "splitmix_uniform",
        "stack_objectives", "step",
    ),
    "_transfer": ("paper_model_coefficients", "paper_model_response"),
    "_data": (
        "FlightRecord", "FlightDataError", "load_record", "save_record", "make_record",
        "default_dataset", "DefaultDataset",
    ),
    "_signals": (
        "time_vector", "frequency_sweep", "sid_chirp", "sid_chirp_from_params",
        "doublet", "multistep_3211", "multistep", "odd_multisine", "Multisine",
        "pilot_corrections",
    ),
    "_plants": (
        "PaperPlant", "R50Plant", "PlantDraw", "draw_paper_plant", "draw_r50_plant",
        "paper_params_from_r50", "r50_frequency_response",
    ),
    "_effects": (
        "EFFECTS", "EffectSet", "effects_from_strings", "parse_effect",
        "effect_response", "paper_model_with_effect",
    ),
    "_simulate": (
        "simulate", "SimulationResult", "Disturbance", "HoldLoop",
        "closed_loop_stability", "default_dataset_records", "multistep_validation",
    ),
    "_preprocess": (
        "preprocess", "PreprocessReport", "SignalReport", "reject_wild_values",
        "detrend", "smooth", "lowpass_zero_phase",
    ),
    "_spectral": (
        "FrequencyResponse", "SpectralEstimate", "cross_spectral_estimate",
        "composite_frequency_response", "random_error", "log_frequencies",
        "zoh_correction",
    ),
    "_wls": (
        "LevyFit", "levy_fit", "levy_fit_response", "levy_design", "LevyMoments",
        "MOMENT_NAMES", "levy_moments", "levy_moment_matrix", "solve_levy_moments",
        "QuarticFactorisation", "quartic_to_paper_params",
    ),
    "_models": (
        "PaperModel", "QuarticModel", "ParameterMap", "PhysicalDerivatives",
        "canonicalize_paper_params", "paper_model_from_physical",
        "simulate_transfer_function", "simulate_transfer_function_delayed",
    ),
    "_cost": (
        "CiferObjective", "ComplexErrorObjective", "TimeDomainObjective", "cifer_cost",
        "coherence_weight", "wrap_degrees", "PHASE_WEIGHT",
    ),
    "_metrics": (
        "r_squared", "theil_inequality", "rms_error", "parameter_uncertainty",
        "fisher_information", "ParameterUncertainty",
    ),
    "_identify": (
        "METHODS", "IdentifySettings", "IdentificationError", "ChannelIdentification",
        "Validation", "identify_channels", "validate", "wls_start", "polish",
        "identify_responses", "independent_points",
    ),
    "_paper_mode": ("MomentObjective", "PaperModeResult", "identify_paper_mode"),
    "_export": ("ModelFile", "export_model", "load_model", "load_model_file", "save_model"),
    "_report": ("write_diagnosis_report", "write_identification_report"),
    "_logs": ("load_any", "load_ardupilot", "load_px4", "ardupilot_runs", "SystemIdRun"),
    "_diagnose": ("diagnose", "DiagnoseSettings", "Diagnosis", "plot_diagnosis"),
}

_MODULE_OF = {name: module for module, names in _EXPORTS.items() for name in names}

__all__ = ["enable_float64", "float64_enabled", *_MODULE_OF]


def __getattr__(name: str):
    module = _MODULE_OF.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(f".{module}", __name__), name)
    globals()[name] = value  # later look-ups skip this function
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))


if TYPE_CHECKING:  # the same names, for type checkers and IDEs
    from ._gwo import GreyWolfConfig as GreyWolfConfig
    from ._gwo import GreyWolfResult as GreyWolfResult
    from ._gwo import GreyWolfState as GreyWolfState
    from ._gwo import convergence_factor as convergence_factor
    from ._gwo import gwo as gwo
    from ._gwo import igwo as igwo
    from ._gwo import init as init
    from ._gwo import run as run
    from ._gwo import run_batch as run_batch
    from ._gwo import run_seeds as run_seeds
    from ._gwo import splitmix_uniform as splitmix_uniform
    from ._gwo import stack_objectives as stack_objectives
    from ._gwo import step as step
    from ._transfer import paper_model_coefficients as paper_model_coefficients
    from ._transfer import paper_model_response as paper_model_response
    from ._data import FlightRecord as FlightRecord
    from ._data import FlightDataError as FlightDataError
    from ._data import load_record as load_record
    from ._data import save_record as save_record
    from ._data import make_record as make_record
    from ._data import default_dataset as default_dataset
    from ._data import DefaultDataset as DefaultDataset
    from ._signals import time_vector as time_vector
    from ._signals import frequency_sweep as frequency_sweep
    from ._signals import sid_chirp as sid_chirp
    from ._signals import sid_chirp_from_params as sid_chirp_from_params
    from ._signals import doublet as doublet
    from ._signals import multistep_3211 as multistep_3211
    from ._signals import multistep as multistep
    from ._signals import odd_multisine as odd_multisine
    from ._signals import Multisine as Multisine
    from ._signals import pilot_corrections as pilot_corrections
    from ._plants import PaperPlant as PaperPlant
    from ._plants import R50Plant as R50Plant
    from ._plants import PlantDraw as PlantDraw
    from ._plants import draw_paper_plant as draw_paper_plant
    from ._plants import draw_r50_plant as draw_r50_plant
    from ._plants import paper_params_from_r50 as paper_params_from_r50
    from ._plants import r50_frequency_response as r50_frequency_response
    from ._effects import EFFECTS as EFFECTS
    from ._effects import EffectSet as EffectSet
    from ._effects import effects_from_strings as effects_from_strings
    from ._effects import parse_effect as parse_effect
    from ._effects import effect_response as effect_response
    from ._effects import paper_model_with_effect as paper_model_with_effect
    from ._simulate import simulate as simulate
    from ._simulate import SimulationResult as SimulationResult
    from ._simulate import Disturbance as Disturbance
    from ._simulate import HoldLoop as HoldLoop
    from ._simulate import closed_loop_stability as closed_loop_stability
    from ._simulate import default_dataset_records as default_dataset_records
    from ._simulate import multistep_validation as multistep_validation
    from ._preprocess import preprocess as preprocess
    from ._preprocess import PreprocessReport as PreprocessReport
    from ._preprocess import SignalReport as SignalReport
    from ._preprocess import reject_wild_values as reject_wild_values
    from ._preprocess import detrend as detrend
    from ._preprocess import smooth as smooth
    from ._preprocess import lowpass_zero_phase as lowpass_zero_phase
    from ._spectral import FrequencyResponse as FrequencyResponse
    from ._spectral import SpectralEstimate as SpectralEstimate
    from ._spectral import cross_spectral_estimate as cross_spectral_estimate
    from ._spectral import composite_frequency_response as composite_frequency_response
    from ._spectral import random_error as random_error
    from ._spectral import log_frequencies as log_frequencies
    from ._wls import LevyFit as LevyFit
    from ._wls import levy_fit as levy_fit
    from ._wls import levy_fit_response as levy_fit_response
    from ._wls import levy_design as levy_design
    from ._wls import LevyMoments as LevyMoments
    from ._wls import MOMENT_NAMES as MOMENT_NAMES
    from ._wls import levy_moments as levy_moments
    from ._wls import levy_moment_matrix as levy_moment_matrix
    from ._wls import solve_levy_moments as solve_levy_moments
    from ._wls import QuarticFactorisation as QuarticFactorisation
    from ._wls import quartic_to_paper_params as quartic_to_paper_params
    from ._models import PaperModel as PaperModel
    from ._models import QuarticModel as QuarticModel
    from ._models import ParameterMap as ParameterMap
    from ._models import PhysicalDerivatives as PhysicalDerivatives
    from ._models import canonicalize_paper_params as canonicalize_paper_params
    from ._models import paper_model_from_physical as paper_model_from_physical
    from ._models import simulate_transfer_function as simulate_transfer_function
    from ._models import simulate_transfer_function_delayed as simulate_transfer_function_delayed
    from ._cost import CiferObjective as CiferObjective
    from ._cost import ComplexErrorObjective as ComplexErrorObjective
    from ._cost import TimeDomainObjective as TimeDomainObjective
    from ._cost import cifer_cost as cifer_cost
    from ._cost import coherence_weight as coherence_weight
    from ._cost import wrap_degrees as wrap_degrees
    from ._cost import PHASE_WEIGHT as PHASE_WEIGHT
    from ._metrics import r_squared as r_squared
    from ._metrics import theil_inequality as theil_inequality
    from ._metrics import rms_error as rms_error
    from ._metrics import parameter_uncertainty as parameter_uncertainty
    from ._metrics import fisher_information as fisher_information
    from ._metrics import ParameterUncertainty as ParameterUncertainty
    from ._identify import METHODS as METHODS
    from ._identify import IdentifySettings as IdentifySettings
    from ._identify import IdentificationError as IdentificationError
    from ._identify import ChannelIdentification as ChannelIdentification
    from ._identify import Validation as Validation
    from ._identify import identify_channels as identify_channels
    from ._identify import validate as validate
    from ._identify import wls_start as wls_start
    from ._identify import polish as polish
    from ._identify import identify_responses as identify_responses
    from ._identify import independent_points as independent_points
    from ._paper_mode import MomentObjective as MomentObjective
    from ._paper_mode import PaperModeResult as PaperModeResult
    from ._paper_mode import identify_paper_mode as identify_paper_mode
    from ._spectral import zoh_correction as zoh_correction
    from ._export import ModelFile as ModelFile
    from ._export import export_model as export_model
    from ._export import load_model as load_model
    from ._export import load_model_file as load_model_file
    from ._export import save_model as save_model
    from ._report import write_diagnosis_report as write_diagnosis_report
    from ._report import write_identification_report as write_identification_report
    from ._logs import load_any as load_any
    from ._logs import load_ardupilot as load_ardupilot
    from ._logs import load_px4 as load_px4
    from ._logs import ardupilot_runs as ardupilot_runs
    from ._logs import SystemIdRun as SystemIdRun
    from ._diagnose import diagnose as diagnose
    from ._diagnose import DiagnoseSettings as DiagnoseSettings
    from ._diagnose import Diagnosis as Diagnosis
    from ._diagnose import plot_diagnosis as plot_diagnosis
