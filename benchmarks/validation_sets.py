"""Multi-step validation records from the R-50 simulator, shared by the benchmarks.

:func:`multistep_validation` is the recipe of the embedded default validation record
(``jaxgwo._simulate.default_dataset_records``): a lateral 3-2-1-1 at 2 s, a longitudinal
3-2-1-1 at 10 s, a lateral doublet at 18 s and a longitudinal doublet at 25 s, 34 s at
100 Hz, with small pilot corrections on both cyclics, the R-50 hover plant, the weak hold
loop, Dryden-like gusts and gyro noise at the default dataset's levels.  With the default
arguments and ``key = default_validation_key()`` it reproduces the embedded record; other
keys (and input timings) give further "flights".

Each call also returns the same flight with the turbulence and the gyro noise switched off
(same input design, same pilot corrections, same hold loop): the part of the output a
rate model driven by the logged input can predict at all.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from jaxgwo._data import FlightRecord
from jaxgwo._plants import R50Plant
from jaxgwo._signals import doublet, multistep_3211, pilot_corrections
from jaxgwo._simulate import (
    DEFAULT_DATASET_CONDITIONS,
    DEFAULT_DATASET_SEED,
    Disturbance,
    HoldLoop,
    simulate,
)

DURATION_S = 34.0


def default_validation_key() -> jax.Array:
    """The key from which ``default_dataset_records`` makes the embedded validation record."""
    return jax.random.split(jax.random.key(DEFAULT_DATASET_SEED), 3)[2]


def default_disturbance() -> Disturbance:
    c = DEFAULT_DATASET_CONDITIONS
    return Disturbance(gust_rms=c["gust_rms_rad_s2"], gust_time_constant_s=c["gust_time_constant_s"],
                       noise_std=c["gyro_noise_std_rad_s"])


def multistep_validation(
    key: jax.Array,
    *,
    unit_s: float = 0.4,
    pulse_s: float = 0.5,
    amplitude_3211: float = 0.08,
    amplitude_doublet: float = 0.1,
    disturbance: Disturbance | None = None,
) -> tuple[FlightRecord, FlightRecord]:
    """``(record, turbulence_free_record)`` of one multi-step validation flight (module doc)."""
    c = DEFAULT_DATASET_CONDITIONS
    fs = c["sample_rate_hz"]
    n = int(round(DURATION_S * fs))
    t = jnp.arange(n, dtype=jnp.float64) / fs
    lat = (multistep_3211(t, amplitude=amplitude_3211, unit_s=unit_s, start_s=2.0)
           + doublet(t, amplitude=amplitude_doublet, pulse_s=pulse_s, start_s=18.0))
    lon = (multistep_3211(t, amplitude=amplitude_3211, unit_s=unit_s, start_s=10.0)
           + doublet(t, amplitude=amplitude_doublet, pulse_s=pulse_s, start_s=25.0))
    k1, k2, k_sim = jax.random.split(key, 3)
    lat = lat + pilot_corrections(k1, n, fs, rms=0.5 * c["off_axis_rms"])
    lon = lon + pilot_corrections(k2, n, fs, rms=0.5 * c["off_axis_rms"])
    exc = jnp.stack([lat, lon], axis=1)
    plant, hold = R50Plant.default(), HoldLoop.r50()
    dist = default_disturbance() if disturbance is None else disturbance
    meta = {"record": f"validation, multi-step, unit {unit_s:g} s, doublet pulse {pulse_s:g} s"}
    res = simulate(plant, exc, k_sim, sample_rate_hz=fs, disturbance=dist, hold=hold)
    clean = simulate(plant, exc, k_sim, sample_rate_hz=fs, disturbance=Disturbance(), hold=hold)
    return res.to_record(meta), clean.to_record(meta | {"turbulence": "off", "noise": "off"})
