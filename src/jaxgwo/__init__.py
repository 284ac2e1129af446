"""jaxgwo: frequency-domain identification of small unmanned helicopters with a
batched (improved) grey wolf optimiser in JAX.

Importing the package switches JAX to float64 (see :mod:`jaxgwo._config`).
"""

from ._config import enable_float64 as enable_float64
from ._config import float64_enabled as float64_enabled

enable_float64()

from ._gwo import GreyWolfConfig as GreyWolfConfig  # noqa: E402
from ._gwo import GreyWolfResult as GreyWolfResult  # noqa: E402
from ._gwo import GreyWolfState as GreyWolfState  # noqa: E402
from ._gwo import convergence_factor as convergence_factor  # noqa: E402
from ._gwo import gwo as gwo  # noqa: E402
from ._gwo import igwo as igwo  # noqa: E402
from ._gwo import init as init  # noqa: E402
from ._gwo import run as run  # noqa: E402
from ._gwo import run_batch as run_batch  # noqa: E402
from ._gwo import run_seeds as run_seeds  # noqa: E402
from ._gwo import splitmix_uniform as splitmix_uniform  # noqa: E402
from ._gwo import stack_objectives as stack_objectives  # noqa: E402
from ._gwo import step as step  # noqa: E402
from ._transfer import paper_model_coefficients as paper_model_coefficients  # noqa: E402
from ._transfer import paper_model_response as paper_model_response  # noqa: E402
from ._data import FlightRecord as FlightRecord  # noqa: E402
from ._data import FlightDataError as FlightDataError  # noqa: E402
from ._data import load_record as load_record  # noqa: E402
from ._data import save_record as save_record  # noqa: E402
from ._data import make_record as make_record  # noqa: E402
from ._data import default_dataset as default_dataset  # noqa: E402
from ._data import DefaultDataset as DefaultDataset  # noqa: E402
from ._signals import time_vector as time_vector  # noqa: E402
from ._signals import frequency_sweep as frequency_sweep  # noqa: E402
from ._signals import sid_chirp as sid_chirp  # noqa: E402
from ._signals import sid_chirp_from_params as sid_chirp_from_params  # noqa: E402
from ._signals import doublet as doublet  # noqa: E402
from ._signals import multistep_3211 as multistep_3211  # noqa: E402
from ._signals import multistep as multistep  # noqa: E402
from ._signals import odd_multisine as odd_multisine  # noqa: E402
from ._signals import Multisine as Multisine  # noqa: E402
from ._signals import pilot_corrections as pilot_corrections  # noqa: E402
from ._plants import PaperPlant as PaperPlant  # noqa: E402
from ._plants import R50Plant as R50Plant  # noqa: E402
from ._plants import PlantDraw as PlantDraw  # noqa: E402
from ._plants import draw_paper_plant as draw_paper_plant  # noqa: E402
from ._plants import draw_r50_plant as draw_r50_plant  # noqa: E402
from ._plants import paper_params_from_r50 as paper_params_from_r50  # noqa: E402
from ._plants import r50_frequency_response as r50_frequency_response  # noqa: E402
from ._effects import EFFECTS as EFFECTS  # noqa: E402
from ._effects import EffectSet as EffectSet  # noqa: E402
from ._effects import effects_from_strings as effects_from_strings  # noqa: E402
from ._effects import parse_effect as parse_effect  # noqa: E402
from ._effects import effect_response as effect_response  # noqa: E402
from ._effects import paper_model_with_effect as paper_model_with_effect  # noqa: E402
from ._simulate import simulate as simulate  # noqa: E402
from ._simulate import SimulationResult as SimulationResult  # noqa: E402
from ._simulate import Disturbance as Disturbance  # noqa: E402
from ._simulate import HoldLoop as HoldLoop  # noqa: E402
from ._simulate import closed_loop_stability as closed_loop_stability  # noqa: E402
from ._simulate import default_dataset_records as default_dataset_records  # noqa: E402
from ._simulate import multistep_validation as multistep_validation  # noqa: E402
from ._preprocess import preprocess as preprocess  # noqa: E402
from ._preprocess import PreprocessReport as PreprocessReport  # noqa: E402
from ._preprocess import SignalReport as SignalReport  # noqa: E402
from ._preprocess import reject_wild_values as reject_wild_values  # noqa: E402
from ._preprocess import detrend as detrend  # noqa: E402
from ._preprocess import smooth as smooth  # noqa: E402
from ._preprocess import lowpass_zero_phase as lowpass_zero_phase  # noqa: E402
from ._spectral import FrequencyResponse as FrequencyResponse  # noqa: E402
from ._spectral import SpectralEstimate as SpectralEstimate  # noqa: E402
from ._spectral import cross_spectral_estimate as cross_spectral_estimate  # noqa: E402
from ._spectral import composite_frequency_response as composite_frequency_response  # noqa: E402
from ._spectral import random_error as random_error  # noqa: E402
from ._spectral import log_frequencies as log_frequencies  # noqa: E402
from ._wls import LevyFit as LevyFit  # noqa: E402
from ._wls import levy_fit as levy_fit  # noqa: E402
from ._wls import levy_fit_response as levy_fit_response  # noqa: E402
from ._wls import levy_design as levy_design  # noqa: E402
from ._wls import LevyMoments as LevyMoments  # noqa: E402
from ._wls import MOMENT_NAMES as MOMENT_NAMES  # noqa: E402
from ._wls import levy_moments as levy_moments  # noqa: E402
from ._wls import levy_moment_matrix as levy_moment_matrix  # noqa: E402
from ._wls import solve_levy_moments as solve_levy_moments  # noqa: E402
from ._wls import QuarticFactorisation as QuarticFactorisation  # noqa: E402
from ._wls import quartic_to_paper_params as quartic_to_paper_params  # noqa: E402
from ._models import PaperModel as PaperModel  # noqa: E402
from ._models import QuarticModel as QuarticModel  # noqa: E402
from ._models import ParameterMap as ParameterMap  # noqa: E402
from ._models import PhysicalDerivatives as PhysicalDerivatives  # noqa: E402
from ._models import canonicalize_paper_params as canonicalize_paper_params  # noqa: E402
from ._models import paper_model_from_physical as paper_model_from_physical  # noqa: E402
from ._models import simulate_transfer_function as simulate_transfer_function  # noqa: E402
from ._cost import CiferObjective as CiferObjective  # noqa: E402
from ._cost import ComplexErrorObjective as ComplexErrorObjective  # noqa: E402
from ._cost import TimeDomainObjective as TimeDomainObjective  # noqa: E402
from ._cost import cifer_cost as cifer_cost  # noqa: E402
from ._cost import coherence_weight as coherence_weight  # noqa: E402
from ._cost import wrap_degrees as wrap_degrees  # noqa: E402
from ._cost import PHASE_WEIGHT as PHASE_WEIGHT  # noqa: E402
from ._metrics import r_squared as r_squared  # noqa: E402
from ._metrics import theil_inequality as theil_inequality  # noqa: E402
from ._metrics import rms_error as rms_error  # noqa: E402
from ._metrics import parameter_uncertainty as parameter_uncertainty  # noqa: E402
from ._metrics import fisher_information as fisher_information  # noqa: E402
from ._metrics import ParameterUncertainty as ParameterUncertainty  # noqa: E402
from ._identify import METHODS as METHODS  # noqa: E402
from ._identify import IdentifySettings as IdentifySettings  # noqa: E402
from ._identify import IdentificationError as IdentificationError  # noqa: E402
from ._identify import ChannelIdentification as ChannelIdentification  # noqa: E402
from ._identify import Validation as Validation  # noqa: E402
from ._identify import identify_channels as identify_channels  # noqa: E402
from ._identify import validate as validate  # noqa: E402
from ._identify import wls_start as wls_start  # noqa: E402
from ._identify import polish as polish  # noqa: E402

from ._identify import identify_responses as identify_responses  # noqa: E402
from ._identify import independent_points as independent_points  # noqa: E402
from ._paper_mode import MomentObjective as MomentObjective  # noqa: E402
from ._paper_mode import PaperModeResult as PaperModeResult  # noqa: E402
from ._paper_mode import identify_paper_mode as identify_paper_mode  # noqa: E402
from ._spectral import zoh_correction as zoh_correction  # noqa: E402
from ._export import ModelFile as ModelFile  # noqa: E402
from ._export import export_model as export_model  # noqa: E402
from ._export import load_model as load_model  # noqa: E402
from ._export import load_model_file as load_model_file  # noqa: E402
from ._export import save_model as save_model  # noqa: E402
from ._report import write_diagnosis_report as write_diagnosis_report  # noqa: E402
from ._report import write_identification_report as write_identification_report  # noqa: E402
from ._logs import load_any as load_any  # noqa: E402
from ._logs import load_ardupilot as load_ardupilot  # noqa: E402
from ._logs import load_px4 as load_px4  # noqa: E402
from ._logs import ardupilot_runs as ardupilot_runs  # noqa: E402
from ._logs import SystemIdRun as SystemIdRun  # noqa: E402
from ._diagnose import diagnose as diagnose  # noqa: E402
from ._diagnose import DiagnoseSettings as DiagnoseSettings  # noqa: E402
from ._diagnose import Diagnosis as Diagnosis  # noqa: E402
from ._diagnose import plot_diagnosis as plot_diagnosis  # noqa: E402
__version__ = "0.1.0"

__all__ = [
    "diagnose",
    "DiagnoseSettings",
    "Diagnosis",
    "plot_diagnosis",
    "ChannelIdentification",
    "CiferObjective",
    "ComplexErrorObjective",
    "DefaultDataset",
    "Disturbance",
    "EFFECTS",
    "EffectSet",
    "FlightDataError",
    "FlightRecord",
    "FrequencyResponse",
    "GreyWolfConfig",
    "GreyWolfResult",
    "GreyWolfState",
    "HoldLoop",
    "IdentificationError",
    "IdentifySettings",
    "LevyFit",
    "LevyMoments",
    "METHODS",
    "MOMENT_NAMES",
    "MomentObjective",
    "Multisine",
    "PHASE_WEIGHT",
    "PaperModeResult",
    "PaperModel",
    "PaperPlant",
    "ParameterMap",
    "ParameterUncertainty",
    "PhysicalDerivatives",
    "PlantDraw",
    "PreprocessReport",
    "QuarticFactorisation",
    "QuarticModel",
    "R50Plant",
    "SignalReport",
    "SimulationResult",
    "SpectralEstimate",
    "SystemIdRun",
    "TimeDomainObjective",
    "Validation",
    "ardupilot_runs",
    "canonicalize_paper_params",
    "cifer_cost",
    "closed_loop_stability",
    "coherence_weight",
    "composite_frequency_response",
    "convergence_factor",
    "cross_spectral_estimate",
    "default_dataset",
    "default_dataset_records",
    "multistep_validation",
    "detrend",
    "doublet",
    "draw_paper_plant",
    "draw_r50_plant",
    "effect_response",
    "effects_from_strings",
    "enable_float64",
    "fisher_information",
    "float64_enabled",
    "frequency_sweep",
    "gwo",
    "identify_channels",
    "identify_paper_mode",
    "identify_responses",
    "igwo",
    "independent_points",
    "init",
    "levy_design",
    "levy_fit",
    "levy_fit_response",
    "levy_moment_matrix",
    "levy_moments",
    "load_any",
    "load_ardupilot",
    "load_px4",
    "load_record",
    "log_frequencies",
    "lowpass_zero_phase",
    "make_record",
    "multistep",
    "multistep_3211",
    "odd_multisine",
    "paper_model_coefficients",
    "paper_model_from_physical",
    "paper_model_response",
    "paper_model_with_effect",
    "paper_params_from_r50",
    "parameter_uncertainty",
    "parse_effect",
    "pilot_corrections",
    "polish",
    "preprocess",
    "quartic_to_paper_params",
    "r50_frequency_response",
    "r_squared",
    "random_error",
    "reject_wild_values",
    "rms_error",
    "run",
    "run_batch",
    "run_seeds",
    "save_record",
    "sid_chirp",
    "sid_chirp_from_params",
    "simulate",
    "simulate_transfer_function",
    "smooth",
    "solve_levy_moments",
    "splitmix_uniform",
    "stack_objectives",
    "step",
    "theil_inequality",
    "time_vector",
    "validate",
    "wls_start",
    "wrap_degrees",
    "zoh_correction",
    "ModelFile",
    "export_model",
    "load_model",
    "load_model_file",
    "save_model",
    "write_diagnosis_report",
    "write_identification_report",
]
