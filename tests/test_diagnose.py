"""Sim-to-real gap diagnosis: signature detectors against constructed references, the
ranking on fixed simulated blind cases, the JSON schema and the CLI end to end."""

import argparse
import dataclasses
import functools
import json
import math
import warnings
from pathlib import Path

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxgwo._data import make_record, save_record
from jaxgwo._diagnose import DIAGNOSE_STAGES, DiagnoseSettings, _nonlinear_budget, diagnose
from jaxgwo._diagnose_where import amplitude_dependence, bands_from_flags, frequency_mismatch, residual_tests
from jaxgwo._effects import EffectSet, time_delay_response
from jaxgwo._metrics import rms_error
from jaxgwo._models import PaperModel
from jaxgwo._plants import SERVO_RANGES, PaperPlant
from jaxgwo._signals import doublet, frequency_sweep, multistep_3211, pilot_corrections
from jaxgwo._simulate import Disturbance, simulate
from jaxgwo._spectral import FrequencyResponse

FS = 100.0
D = 25.0  # sweep length: each half-record (one amplitude) still resolves 1 rad/s... nearly
MODEL = PaperModel.from_array(jnp.asarray(PaperPlant.default().lateral))
SETTINGS = DiagnoseSettings.quick()  # the CI-sized searches, every threshold the default's
NL_SMALL = _nonlinear_budget(SETTINGS)  # SETTINGS' nonlinear fits, for the tests that call them directly


def _case(effect=None, seed=0, plant_effects=None, val_off_rms=0.02, **params):
    """TRAIN: two 0.3-10 Hz sweeps (amplitudes 0.05, 0.09) with off-axis pilot activity;
    VAL: a 3-2-1-1 and a doublet (off-axis activity ``val_off_rms``); light gusts, 35 dB
    SNR.  Same shapes for every case.  ``plant_effects`` (an :class:`EffectSet`) is part
    of the plant, ``effect`` added to it."""
    k = jax.random.split(jax.random.key(seed), 5)
    n = int((3 + D + 2 + D + 2) * FS)
    t = jnp.arange(n, dtype=jnp.float64) / FS
    sw = frequency_sweep(t, f_start_hz=0.3, f_stop_hz=10, duration_s=D, amplitude=0.05, start_s=3) + frequency_sweep(
        t, f_start_hz=0.3, f_stop_hz=10, duration_s=D, amplitude=0.09, start_s=5 + D)
    eff = EffectSet() if plant_effects is None else plant_effects
    eff = eff if effect is None else eff.with_effect(effect, **params)
    dist = Disturbance(gust_rms=0.05, snr_db=35.0)
    tr = simulate(PaperPlant.default(), jnp.stack([sw, pilot_corrections(k[0], n, FS, rms=0.02)], 1), k[1],
                  sample_rate_hz=FS, disturbance=dist, effects=eff)  # fmt: skip
    nv = 2000
    tv = jnp.arange(nv, dtype=jnp.float64) / FS
    lat = (multistep_3211(tv, amplitude=0.075, unit_s=0.3, start_s=1.0) + doublet(tv, amplitude=0.075, pulse_s=0.4, start_s=10.0)
           + pilot_corrections(k[2], nv, FS, rms=0.01))  # fmt: skip
    va = simulate(PaperPlant.default(), jnp.stack([lat, pilot_corrections(k[3], nv, FS, rms=val_off_rms)], 1), k[4],
                  sample_rate_hz=FS, disturbance=dist, effects=eff)  # fmt: skip
    return [tr.to_record()], [va.to_record()]


# -- signature detectors ------------------------------------------------------------------


def test_bands_from_flags_against_hand_count():
    f = np.arange(10.0)
    flags = np.array([0, 1, 1, 0, 1, 0, 0, 0, 1, 0], bool)
    assert bands_from_flags(f, flags) == [[1.0, 4.0]]  # one gap bridged, the lone point at 8 dropped
    assert bands_from_flags(f, flags, max_gap=0) == [[1.0, 2.0]]


def _response(h, eps=0.01, w_max=60.0):
    w = jnp.geomspace(1.0, w_max, 80)
    return FrequencyResponse(w=w, H=h(w), coherence=jnp.full_like(w, 0.95), random_error=jnp.full_like(w, eps),
                             n_averages=jnp.full_like(w, 50.0), mask=jnp.ones_like(w, dtype=bool),
                             window_s=jnp.full_like(w, 10.0))  # fmt: skip


def test_frequency_mismatch_delay_signature_and_none():
    delay = 0.03
    resp = _response(lambda w: MODEL.frequency_response(w) * time_delay_response(w, delay))
    fm = frequency_mismatch(resp, np.asarray(MODEL.frequency_response(resp.w)))
    # flat magnitude, phase error = w * delay exactly (in the wrapped range below 60 rad/s)
    assert fm.equivalent_delay_s == pytest.approx(delay, rel=1e-6)
    assert np.max(np.abs(fm.magnitude_error_db)) < 1e-9
    assert fm.bands_hz and fm.bands_hz[-1][1] == pytest.approx(60.0 / (2 * np.pi))
    clean = _response(MODEL.frequency_response)
    fm0 = frequency_mismatch(clean, np.asarray(MODEL.frequency_response(clean.w)))
    assert fm0.bands_hz == [] and abs(fm0.equivalent_delay_s) < 1e-12 and fm0.resonance_hz is None


def test_structural_mode_agrees_only_with_a_resonance_where_it_is_fitted():
    """A lightly damped gyro-side resonance (6 Hz, pole damping 0.04) shows as a narrow
    magnitude departure; a structural_mode fitted there, lightly damped, agrees with it
    (+1).  A broad pole pair (damping 0.6, as one standing in for a lag fits), one fitted
    a factor 1.5 away, or any mode where no resonance shows, does not (0)."""
    from jaxgwo._diagnose import _agreement
    from jaxgwo._diagnose_where import AmplitudeDependence
    from jaxgwo._effects import structural_mode_response

    freq = 6.0
    sign = float(np.sign(float(MODEL.K)))
    G = lambda w: sign * MODEL.frequency_response(w)  # noqa: E731
    resonant, clean = _response(lambda w: G(w) * structural_mode_response(w, freq, 0.04, 0.2)), _response(G)
    fm = frequency_mismatch(resonant, np.asarray(G(resonant.w)))
    flat = frequency_mismatch(clean, np.asarray(G(clean.w)))
    assert fm.resonance_hz == pytest.approx(freq, rel=0.1) and flat.resonance_hz is None
    amp = AmplitudeDependence(False, 1.1, 0.0, 0.0, 0.0, "", False)
    mode = lambda f, zp: {"freq_hz": f, "zeta_p": zp, "zeta_z": 0.2}  # noqa: E731
    assert _agreement("structural_mode", fm, amp, None, mode(freq * 1.05, 0.05)) == 1.0
    assert _agreement("structural_mode", fm, amp, None, mode(freq, 0.6)) == 0.0
    assert _agreement("structural_mode", fm, amp, None, mode(freq * 1.5, 0.05)) == 0.0
    assert _agreement("structural_mode", flat, amp, None, mode(freq, 0.05)) == 0.0


def test_residual_tests_whiteness_and_input_lag():
    key_u, key_e = jax.random.split(jax.random.key(3))
    u = np.asarray(jax.random.normal(key_u, (4000,)))
    e = np.asarray(jax.random.normal(key_e, (4000,)))
    white = residual_tests([u], [e], 0.01)
    assert white.white and abs(white.input_residual_peak) < white.xcorr_bound
    lagged = residual_tests([u], [np.r_[np.zeros(5), u[:-5]] + 0.5 * e], 0.01)
    assert not lagged.white or lagged.input_residual_peak > 0.5
    assert lagged.input_residual_peak_lag_s == pytest.approx(0.05)


def test_amplitude_dependence_linear_vs_saturated():
    t = np.arange(int(2 * 40 * FS)) / FS
    half = t.size // 2
    sweep = lambda tt: np.asarray(frequency_sweep(jnp.asarray(tt), f_start_hz=0.2, f_stop_hz=8, duration_s=40.0, amplitude=1.0))  # noqa: E731
    u = np.r_[0.05 * sweep(t[:half]), 0.15 * sweep(t[:half])]
    noise = 1e-4 * np.asarray(jax.random.normal(jax.random.key(0), (t.size,)))
    w = np.geomspace(1.0, 40.0, 60)
    lin = np.asarray(MODEL.simulate(jnp.asarray(t), jnp.asarray(u))) + noise
    sat = np.asarray(MODEL.simulate(jnp.asarray(t), jnp.asarray(np.clip(u, -0.06, 0.06)))) + noise
    a_lin = amplitude_dependence([(u, lin)], FS, w)
    a_sat = amplitude_dependence([(u, sat)], FS, w)
    assert a_lin.amplitude_ratio == pytest.approx(3.0, rel=0.05)
    assert not a_lin.dependent and a_sat.dependent
    assert a_sat.high_minus_low_db < -1.0  # clipping lowers the high-amplitude gain
    flat = amplitude_dependence([(0.05 * np.r_[sweep(t[:half]), sweep(t[:half])], lin)], FS, w)
    assert not flat.dependent and "differ by only" in flat.note


def _two_sweep_record(nonlinearity):
    """The blind study's TRAIN layout: two 25 s sweeps, amplitudes 0.05 and 0.15, in one 57 s
    record whose halves (28.5 s) are too short for the 1 rad/s windows of the full band."""
    t = np.arange(int((3 + D + 2 + D + 2) * FS)) / FS
    tj = jnp.asarray(t)
    u = np.asarray(frequency_sweep(tj, f_start_hz=0.3, f_stop_hz=10, duration_s=D, amplitude=0.05, start_s=3)
                   + frequency_sweep(tj, f_start_hz=0.3, f_stop_hz=10, duration_s=D, amplitude=0.15, start_s=5 + D))  # fmt: skip
    noise = 1e-4 * np.asarray(jax.random.normal(jax.random.key(0), (t.size,)))
    return u, np.asarray(MODEL.simulate(tj, jnp.asarray(nonlinearity(u)))) + noise


def _play(u, width):
    """Backlash of total ``width`` (the simulator's play operator), sample by sample."""
    out, s = np.zeros_like(u), 0.0
    for i, x in enumerate(u):
        s = min(max(s, x - 0.5 * width), x + 0.5 * width)
        out[i] = s
    return out


def test_amplitude_dependence_on_half_records_and_its_sign():
    w = np.geomspace(1.0, 120.0, 80)
    lin = amplitude_dependence([_two_sweep_record(lambda u: u)], FS, w)
    sat = amplitude_dependence([_two_sweep_record(lambda u: np.clip(u, -0.08, 0.08))], FS, w)
    play = amplitude_dependence([_two_sweep_record(lambda u: _play(u, 0.03))], FS, w)
    # the halves cannot resolve 1 rad/s; the test must still run on the band they do resolve
    assert lin.tested and sat.tested and play.tested
    assert not lin.dependent and sat.dependent and play.dependent
    # saturation costs the large inputs gain, backlash the small ones
    assert sat.high_minus_low_db < -1.0 and play.high_minus_low_db > 0.5


def test_amplitude_agreement_follows_the_effects_sign():
    from jaxgwo._diagnose import _amplitude_agreement
    from jaxgwo._diagnose_where import AmplitudeDependence

    falls = AmplitudeDependence(True, 3.0, 0.5, -1.0, -2.0, "")
    rises = AmplitudeDependence(True, 3.0, 0.5, 0.5, 2.0, "")
    flat = AmplitudeDependence(False, 3.0, 0.05, 0.0, 0.0, "")
    untested = AmplitudeDependence(False, 1.1, 0.0, 0.0, 0.0, "", False)
    assert [_amplitude_agreement(n, falls) for n in ("rate_limit", "saturation", "backlash")] == [1.0, 1.0, -0.5]
    assert [_amplitude_agreement(n, rises) for n in ("rate_limit", "saturation", "backlash")] == [-0.5, -0.5, 1.0]
    assert _amplitude_agreement("saturation", flat) == -1.0 and _amplitude_agreement("backlash", untested) == 0.0


def test_delay_aware_start_recovers_a_long_delay_and_the_gain_sign():
    from jaxgwo._cost import CiferObjective
    from jaxgwo._diagnose_which import delay_aware_start
    from jaxgwo._models import ParameterMap

    delay = 0.07  # 250 deg at 10 Hz: a delay-free WLS fit picks the wrong gain sign
    resp = _response(lambda w: MODEL.frequency_response(w) * time_delay_response(w, delay))
    sign = -1.0 if float(MODEL.K) > 0 else 1.0  # what a delay-free fit may wrongly conclude
    obj = CiferObjective.from_response(eqx.tree_at(lambda r: r.H, resp, resp.H * sign),
                                       ParameterMap.for_model(MODEL))  # fmt: skip
    ds = delay_aware_start(resp, obj, sign, np.arange(0.0, 0.15, 0.005))
    assert ds.sign == np.sign(float(MODEL.K))
    assert abs(ds.delay_s - delay) <= 0.0025 + 1e-12  # the trial grid's half step
    assert ds.cost_J < 1.0  # WLS on the exactly delay-compensated, noise-free response is all but exact


def _airframe_numpy(w, p, fz, fp, fm, zp, zz, delay, tau_f=0.0):
    """Eqs. (15)-(16) times a lead-lag, a pole pair and a delay, in plain NumPy; with
    ``tau_f`` the rotor term is the flapping-lag cubic ``K/((s^2+s/tau)(tau_f s+1)+M)``."""
    s = 1j * np.asarray(w)
    k, tau, m, ws, zs = p
    wm = 2 * np.pi * fm
    return (k / ((s * s + s / tau) * (tau_f * s + 1) + m) * ws**2 / (s * s + 2 * zs * ws * s + ws**2)
            * (s / (2 * np.pi * fz) + 1) / (s / (2 * np.pi * fp) + 1)
            * (s * s + 2 * zz * wm * s + wm**2) / (s * s + 2 * zp * wm * s + wm**2) * np.exp(-s * delay))  # fmt: skip


_AIRFRAME = (1.3, 4.0, 1.8, 0.2, 0.8)  # lead-lag zero and pole (Hz), pair (Hz, pole and zero damping)


@pytest.mark.parametrize("lag", ["time_delay", "rotor_flapping"])
def test_lead_lag_airframe_response_matches_numpy(lag):
    from jaxgwo._cost import CiferObjective
    from jaxgwo._diagnose_which import LeadLagAirframe
    from jaxgwo._models import ParameterMap

    p = np.abs(np.asarray(MODEL.to_array(), float))
    resp = _response(lambda w: MODEL.frequency_response(w), w_max=120.0)
    obj = LeadLagAirframe(CiferObjective.from_response(resp, ParameterMap.for_model(MODEL)), lag)
    x = np.r_[np.log(p), np.log(_AIRFRAME), 0.025]
    delay, tau_f = (0.025, 0.0) if lag == "time_delay" else (0.0, 0.025)
    np.testing.assert_allclose(np.asarray(obj.response(jnp.asarray(x))),
                               _airframe_numpy(resp.w, p, *_AIRFRAME, delay, tau_f), rtol=1e-10)  # fmt: skip


@pytest.mark.parametrize("lag, truth", [("time_delay", 0.040), ("rotor_flapping", 0.020)])
def test_airframe_lag_refit_recovers_a_lag_inside_its_family(lag, truth):
    """Noise-free data from the lead-lag x low-mode airframe with a 40 ms delay or a 20 ms
    flapping lag; the refit starts where a pair fit might leave it (paper parameters 30 %
    off, the lag 10 ms short, the pair elsewhere) and reads the lag back."""
    from jaxgwo._cost import CiferObjective
    from jaxgwo._diagnose_which import airframe_lag_refit
    from jaxgwo._models import ParameterMap

    p = np.abs(np.asarray(MODEL.to_array(), float))
    delay, tau_f = (truth, 0.0) if lag == "time_delay" else (0.0, truth)
    resp = _response(lambda w: jnp.asarray(_airframe_numpy(w, p, *_AIRFRAME, delay, tau_f)), w_max=120.0)
    obj = CiferObjective.from_response(resp, ParameterMap.for_model(MODEL))
    z = np.array([0.0, np.log(100.0), 0.0, *np.log([8.0, 0.3, 3.0])])
    z[0 if lag == "time_delay" else 2] = truth - 0.010
    x_fit = np.r_[np.log(p) + np.log([1.3, 0.8, 1.3, 0.8, 1.3]), z]
    v, j = airframe_lag_refit(obj, x_fit, lag)
    assert abs(v - truth) < 5e-4
    assert j < 1e-3


def test_bracketed_lag_is_the_centre_with_a_rectangular_spread_in_quadrature():
    from jaxgwo._diagnose_which import bracketed_lag

    d, s = bracketed_lag(0.020, 0.0009, 0.028)
    assert d == pytest.approx(0.024) and s == pytest.approx(math.hypot(0.0009, 0.004 / math.sqrt(3.0)))
    assert bracketed_lag(0.028, 0.0009, 0.020) == pytest.approx((d, s))  # either order
    assert bracketed_lag(0.020, 0.0009, 0.020) == pytest.approx((0.020, 0.0009))
    assert math.isnan(bracketed_lag(0.020, math.nan, 0.028)[1])


@pytest.mark.parametrize("lag, param, stem, truth", [("time_delay", "delay_s", "delay", 0.040),
                                                     ("rotor_flapping", "tau_f", "tau_f", 0.020)])
def test_airframe_bracket_reports_the_centre_only_for_a_lag_that_beats_noise(lag, param, stem, truth):
    """The pair fit read the lag 4 ms short (``read``); the lead-lag airframe, which made the
    data, reads it back, and the report gives their centre with the bracket's spread."""
    from jaxgwo._cost import CiferObjective
    from jaxgwo._diagnose import _airframe_bracket, _params_text
    from jaxgwo._diagnose_which import LinearFit, airframe_lag_refit
    from jaxgwo._models import ParameterMap

    p = np.abs(np.asarray(MODEL.to_array(), float))
    delay, tau_f = (truth, 0.0) if lag == "time_delay" else (0.0, truth)
    read = truth - 0.004
    resp = _response(lambda w: jnp.asarray(_airframe_numpy(w, p, *_AIRFRAME, delay, tau_f)), w_max=120.0)
    obj = CiferObjective.from_response(resp, ParameterMap.for_model(MODEL))
    pair = ("structural_mode", lag)
    z = np.array([0.0, np.log(100.0), 0.0, *np.log([8.0, 0.3, 3.0])])
    z[0 if lag == "time_delay" else 2] = read
    x_fit = np.r_[np.log(p), z]
    fits = {pair: LinearFit(pair, x_fit, 1.0, {}, {})}
    lin_from = {pair: (obj, x_fit[:5], x_fit[5:], np.ones(5))}

    def cand(effect, ok):
        if effect != lag:
            return _scored(effect, 1.0, ok)
        return dataclasses.replace(_scored(effect, 1.0, ok), params={effect: {param: read}},
                                   sigma={effect: {param: 0.001}})  # fmt: skip

    other = "sensor_lag" if lag == "time_delay" else "time_delay"
    for unchanged in (cand(lag, False), cand(other, True)):
        assert _airframe_bracket(unchanged, fits, lin_from) is unchanged
    assert _airframe_bracket(cand(lag, True), {}, lin_from).params[lag][param] == read
    out = _airframe_bracket(cand(lag, True), fits, lin_from)
    v_air, j_air = airframe_lag_refit(obj, x_fit, lag)
    assert abs(v_air - truth) < 1e-3  # the refit reads the lag inside its own family
    assert out.detail[f"{stem}_pair_s"] == read and out.detail[f"{stem}_airframe_s"] == pytest.approx(v_air)
    assert out.params[lag][param] == pytest.approx(0.5 * (read + v_air))
    spread = 0.5 * abs(v_air - read) / math.sqrt(3.0)  # the bracket's rectangular spread
    assert out.sigma[lag][param] == pytest.approx(math.hypot(0.001, spread))
    assert "two airframe models read" in _params_text(out)
    # where the pair fits J better than the lead-lag airframe, only the ratio is recorded
    assert 0.0 < j_air < 1.0 and out.detail["airframe_J_ratio"] == pytest.approx(j_air)
    better_pair = {pair: LinearFit(pair, x_fit, 0.5 * j_air, {}, {})}
    kept = _airframe_bracket(cand(lag, True), better_pair, lin_from)
    assert kept.params[lag][param] == read and kept.sigma[lag][param] == 0.001
    assert kept.detail["airframe_J_ratio"] > 1.0 and f"{stem}_airframe_s" not in kept.detail
    assert "airframe models" not in _params_text(kept)


@pytest.mark.parametrize("tau_f, read, pair_j, pair_sigma, named", [
    (0.020, 0.005, 1.0, 0.002, True),     # both read a lag: named, at the head
    (0.020, 0.0005, 1.0, 0.002, False),   # the pair fit reads none (below 1 ms)
    (0.006, 0.003, 1.0, 0.002, False),    # the lead-lag reads one shorter than the vocabulary's 10 ms
    (0.012, 0.005, 1.0, 0.002, False),    # ... or than 13 ms (read 12 ms, 4.2 sigma)
    (0.095, 0.005, 1.0, 0.002, False),    # ... or longer than its 60 ms (read 95 ms)
    (0.020, 0.005, 0.0, 0.002, False),    # the pair fits J no worse than the lead-lag airframe
    (0.020, 0.005, 1.0, 0.012, False),    # the reading within 2 of its bound's sigma of zero (20 +- 12.7 ms)
    (0.020, 0.005, 1.0, math.nan, False),  # ... or the bound unknown
    (0.020, 0.005, 1.0, 0.008, True),     # 20 +- 9.1 ms: 2.2 sigma, named
])
def test_flapping_lag_both_airframes_read_is_named_where_nothing_beats_noise(tau_f, read, pair_j, pair_sigma, named):
    """Noise-free data from the lead-lag airframe with a flapping lag; the pair fit read it
    ``read`` +- ``pair_sigma``.  Named only where the pair reads at least 1 ms, the lead-lag
    13-60 ms, the lead-lag fits J better, and its reading lies at least twice the bracket's
    1-sigma above zero; then at the head, beating noise, its lag the lead-lag's reading
    with that bound."""
    from jaxgwo._cost import CiferObjective
    from jaxgwo._diagnose import _flapping_between_airframes, _params_text
    from jaxgwo._diagnose_which import LinearFit, airframe_lag_refit
    from jaxgwo._models import ParameterMap

    p = np.abs(np.asarray(MODEL.to_array(), float))
    resp = _response(lambda w: jnp.asarray(_airframe_numpy(w, p, *_AIRFRAME, 0.0, tau_f)), w_max=120.0)
    obj = CiferObjective.from_response(resp, ParameterMap.for_model(MODEL))
    pair = ("structural_mode", "rotor_flapping")
    z = np.array([0.0, np.log(100.0), read, *np.log([8.0, 0.3, 3.0])])
    x_fit = np.r_[np.log(p), z]
    fits = {pair: LinearFit(pair, x_fit, pair_j, {}, {})}
    lin_from = {pair: (obj, x_fit[:5], x_fit[5:], np.ones(5))}
    flap = dataclasses.replace(_scored("rotor_flapping", -8.0, False), params={"rotor_flapping": {"tau_f": read}},
                               sigma={"rotor_flapping": {"tau_f": pair_sigma}})  # fmt: skip
    ranking = (_scored("cross_coupling", -7.0, False), flap, _scored("time_delay", -9.0, False))
    out = _flapping_between_airframes(ranking, fits, lin_from)
    if not named:
        assert out == ranking
        return
    v_air, _j = airframe_lag_refit(obj, x_fit, "rotor_flapping")
    assert abs(v_air - tau_f) < 1e-3
    head = out[0]
    assert head.effects == ("rotor_flapping",) and head.beats_noise and head.detail["named_between_airframes"] == 1.0
    assert head.detail["tau_f_pair_s"] == read and head.detail["tau_f_airframe_s"] == pytest.approx(v_air)
    # reported: the lead-lag's reading, with the bracket's 1-sigma (_lead_lag_reading)
    assert head.params["rotor_flapping"]["tau_f"] == pytest.approx(v_air)
    bound = math.hypot(pair_sigma, 0.5 * abs(v_air - read) / math.sqrt(3.0))
    assert head.sigma["rotor_flapping"]["tau_f"] == pytest.approx(bound) and v_air >= 2.0 * bound
    assert "the lead-lag airframe's reading" in _params_text(head)
    assert out[1:] == (ranking[0], ranking[2])
    # nothing changes where a candidate already beats noise, or without the pair's fit
    passing = (_scored("cross_coupling", 1.0, True), flap)
    assert _flapping_between_airframes(passing, fits, lin_from) == passing
    assert _flapping_between_airframes(ranking, {}, lin_from) == ranking


@pytest.mark.parametrize("freq, zp, zz", [(6.5, 0.03, 0.25), (5.8, 0.05, 0.2)])
def test_mode_candidate_recovers_a_mode_the_nominal_servo_absorbed_whole(freq, zp, zz):
    """A mode near the servo's frequency (the default plant's: 6.08 Hz, damping 0.51) is
    absorbed whole by the paper fit: its servo becomes the resonance (damping 0.11 and
    0.20).  Refitted from that nominal, the structural mode candidate recovers the mode and
    the servo exactly (noise-free ``J`` to zero), because the profile is also started with
    the servo restarted out of the mode (``_mode_scan``).  Without that restart the
    candidate kept the absorbed servo (damping 0.03-0.05) and made the mode a broad pair on
    its damping's box top (``J`` 4.1 and 2.2)."""
    from scipy.optimize import least_squares

    from jaxgwo._cost import CiferObjective
    from jaxgwo._diagnose_which import _Z_NEUTRAL, AugmentedCifer, _active_mask, fit_linear_candidates
    from jaxgwo._effects import structural_mode_response
    from jaxgwo._models import ParameterMap

    sign = float(np.sign(float(MODEL.K)))
    resp = _response(lambda w: sign * MODEL.frequency_response(w) * structural_mode_response(w, freq, zp, zz),
                     w_max=120.0)  # fmt: skip
    cifer = CiferObjective.from_response(resp, ParameterMap.for_model(MODEL))
    paper_only = AugmentedCifer.from_cifer(cifer, _active_mask([]))
    x_true = np.log(np.abs(np.asarray(MODEL.to_array(), float)))
    nominal = least_squares(lambda v: np.asarray(paper_only.residuals(jnp.asarray(np.r_[v, _Z_NEUTRAL]))), x_true,
                            method="lm")  # fmt: skip
    j_nominal = float(np.sum(nominal.fun**2))
    assert np.exp(nominal.x[4]) < 0.5 * float(MODEL.zeta_s)  # the servo took the mode
    (fit,) = fit_linear_candidates(cifer, nominal.x, [("structural_mode",)], jax.random.key(0), wolves=12,
                                   iterations=30)  # fmt: skip
    mode = fit.params["structural_mode"]
    assert fit.cost_J < 1e-4 * j_nominal
    assert mode["freq_hz"] == pytest.approx(freq, rel=1e-3)
    assert mode["zeta_p"] == pytest.approx(zp, rel=1e-2) and mode["zeta_z"] == pytest.approx(zz, rel=1e-2)
    assert np.exp(fit.x[4]) == pytest.approx(float(MODEL.zeta_s), rel=1e-2)


def _stored_mode_fit(name):
    """The structural mode candidate refitted on an objective stored from a blind case
    (``tests/data/NAME``, see its ``what``): ``(fit, stored dict)``."""
    from jaxgwo._cost import CiferObjective
    from jaxgwo._diagnose_which import fit_linear_candidates
    from jaxgwo._models import ParameterMap

    d = json.loads((Path(__file__).resolve().parent / "data" / name).read_text())
    obj = CiferObjective(w=jnp.asarray(d["w"]), magnitude_db=jnp.asarray(d["magnitude_db"]),
                         phase_deg=jnp.asarray(d["phase_deg"]), weight=jnp.asarray(d["weight"]),
                         n=jnp.asarray(d["n"]), phase_weight=jnp.asarray(d["phase_weight"]),
                         parameter_map=ParameterMap("paper", (True,) * 5, tuple(d["signs"])))  # fmt: skip
    kw = {k: np.asarray(d[k]) for k in ("z_hi", "effect_seed") if d.get(k) is not None}
    (fit,) = fit_linear_candidates(obj, np.asarray(d["x_nominal"]), [("structural_mode",)], jax.random.key(0),
                                   wolves=12, iterations=30, dependence_factor=d["dependence_factor"], **kw)  # fmt: skip
    return fit, {**d, "objective": obj}


def test_mode_candidate_keeps_the_servo_a_servo_where_j_cannot_choose():
    """Seed-433 case_018 of the blind study (an R-50 plant, mode at 11.58 Hz, pole
    damping 0.021): the objective the structure step fitted beside the pair, its nominal's
    servo at 11.5 Hz with damping 0.044, i.e. the servo had absorbed the mode.  Restarted
    out of the mode, the fit finds it (11.66 Hz, ``J`` 7.10, servo damping 0.29); from the
    pack, the servo keeps the mode and a broad notch sits beside it (10.54 Hz, ``J`` 6.88).
    The R-50's model-form error leaves ``J`` 3 % apart, below its own sampling spread, so
    the candidate keeps the fit whose servo stayed a servo (``_RESTART_J_TOLERANCE``);
    with the lower ``J`` alone it answered the notch."""
    fit, d = _stored_mode_fit("blind433_case018_mode_objective.json")
    obj, x_nom = d["objective"], np.asarray(d["x_nominal"])
    mode, truth = fit.params["structural_mode"], d["truth"]
    assert mode["freq_hz"] == pytest.approx(truth["freq_hz"], rel=0.02)
    assert abs(mode["freq_hz"] - truth["freq_hz"]) < 2.0 * fit.sigma["structural_mode"]["freq_hz"]
    assert mode["zeta_p"] < 0.1  # lightly damped, as the truth (0.021), not a broad notch
    assert np.exp(fit.x[4]) > 2.0 * np.exp(x_nom[4])  # the servo let the mode go
    j_nominal = float(obj(jnp.asarray(x_nom)))
    assert fit.cost_J < j_nominal


def test_mode_candidate_keeps_the_lower_j_where_the_servo_is_a_servo():
    """Seed-437 case_014 of the blind study (a paper plant, mode at 21.1 Hz, pole damping
    0.053, its nominal's servo damping 0.45): the usual fit finds the mode (20.7 Hz, ``J``
    2.66) with the servo at 0.43, a servo's damping, so the lower ``J`` decides.  The fit
    restarted out of the mode (``_mode_scan``) ends with the servo damping at 1.8 and a
    broad 4.3 Hz pair, ``J`` 2.70: preferred within ``_RESTART_J_TOLERANCE`` whatever the
    usual fit's servo (870f486), it replaced the mode."""
    fit, d = _stored_mode_fit("blind437_case014_mode_objective.json")
    mode, truth = fit.params["structural_mode"], d["truth"]
    assert mode["freq_hz"] == pytest.approx(truth["freq_hz"], rel=0.05)
    assert mode["zeta_p"] < 0.15  # lightly damped, as the truth (0.053)
    lo, hi = SERVO_RANGES["zeta_s"]
    assert 0.9 * lo < np.exp(fit.x[4]) < hi  # the servo stays a servo


def test_mode_profile_finds_a_mode_the_nominal_servo_absorbed():
    """The structural mode's profile (``_mode_scan``) refits the paper parameters and the
    damping at every grid frequency.  Started, as a nominal fit leaves it, from a servo
    damping bent by the mode (0.75 x), it finds the mode; and at a held frequency its
    Levenberg-Marquardt reaches the J of scipy's least_squares."""
    from scipy.optimize import least_squares

    from jaxgwo._cost import CiferObjective
    from jaxgwo._diagnose_which import _Z_HI, _Z_LO, _Z_NEUTRAL, AugmentedCifer, _active_mask, _mode_scan, _profile_lm
    from jaxgwo._effects import structural_mode_response
    from jaxgwo._models import ParameterMap

    freq, zp, zz = 6.0, 0.063, 0.103
    sign = float(np.sign(float(MODEL.K)))
    resp = _response(lambda w: sign * MODEL.frequency_response(w) * structural_mode_response(w, freq, zp, zz))
    act = _active_mask(["structural_mode"])
    obj = AugmentedCifer.from_cifer(CiferObjective.from_response(resp, ParameterMap.for_model(MODEL)), act)
    x_true = np.log(np.abs(np.asarray(MODEL.to_array(), float)))
    x_bent = x_true + np.array([0.0, 0.0, 0.0, 0.0, np.log(0.75)])
    lo = np.r_[x_bent - np.log(2.0), np.where(act, _Z_LO, _Z_NEUTRAL)]
    hi = np.r_[x_bent + np.log(2.0), np.where(act, _Z_HI, _Z_NEUTRAL + 1e-9)]
    j_bent = float(obj(jnp.asarray(np.r_[x_bent, _Z_NEUTRAL])))
    scan, _restarted = _mode_scan(obj, x_bent, _Z_NEUTRAL, lo, hi)
    best = scan[0]
    assert abs(np.exp(best[8]) / freq - 1.0) < 0.06  # within a step of the 48-point grid
    assert float(obj(jnp.asarray(best))) < 0.05 * j_bent
    assert np.all(best >= lo) and np.all(best <= hi)
    # one row at a held frequency 4 % off, against scipy's bounded least squares
    x0 = np.r_[x_bent, 0.0, np.log(100.0), 0.0, np.log(1.04 * freq), np.log(0.05), np.log(0.15)]
    free = np.r_[np.ones(5, bool), act]
    free[8] = False
    xs, js = _profile_lm(obj, jnp.asarray(x0[None]), jnp.asarray(free), jnp.asarray(lo), jnp.asarray(hi))
    idx = np.flatnonzero(free)

    def res(v):
        x = x0.copy()
        x[idx] = v
        return np.asarray(obj.residuals(jnp.asarray(x)))

    ref = least_squares(res, x0[idx], bounds=(lo[idx], hi[idx]), xtol=1e-12, ftol=1e-12)
    j_ref = float(np.sum(ref.fun**2))
    assert j_ref < 0.5 * j_bent  # the held frequency still leaves a J worth refining
    assert float(js[0]) <= 1.02 * j_ref
    assert np.asarray(xs)[0, 8] == x0[8]  # the frequency stays held


def _paper_times_mode(freq_hz: float, zeta_p: float, zeta_z: float):
    """``J`` of the noise-free response of the paper model (:data:`MODEL`) times a
    ``structural_mode``, and the paper model's log-parameters (the fits' start)."""
    from jaxgwo._cost import CiferObjective
    from jaxgwo._effects import structural_mode_response
    from jaxgwo._models import ParameterMap

    sign = float(np.sign(float(MODEL.K)))
    resp = _response(lambda w: sign * MODEL.frequency_response(w) * structural_mode_response(w, freq_hz, zeta_p,
                                                                                           zeta_z))  # fmt: skip
    obj = CiferObjective.from_response(resp, ParameterMap.for_model(MODEL))
    return obj, np.log(np.abs(np.asarray(MODEL.to_array(), float)))


def test_structure_box_reaches_a_pole_pair_beyond_the_resonance_box():
    """A pole pair the paper model lacks, damped beyond the vocabulary's resonances (poles
    0.7, zeros 4: real zeros): the vocabulary's box stops on its caps, the structure
    step's box (``z_hi=_Z_HI_STRUCTURE``) recovers the pair on noise-free data."""
    from jaxgwo._diagnose_which import _Z_HI, _Z_HI_STRUCTURE, fit_linear_candidates

    freq, zp, zz = 5.0, 0.7, 4.0
    obj, x_nom = _paper_times_mode(freq, zp, zz)
    key = jax.random.key(3)
    (narrow,) = fit_linear_candidates(obj, x_nom, [("structural_mode",)], key, wolves=10, iterations=25)
    (wide,) = fit_linear_candidates(obj, x_nom, [("structural_mode",)], key, wolves=10, iterations=25,
                                    z_hi=_Z_HI_STRUCTURE)  # fmt: skip
    n, w = narrow.params["structural_mode"], wide.params["structural_mode"]
    assert n["zeta_p"] <= np.exp(_Z_HI[4]) + 1e-9 and n["zeta_z"] <= np.exp(_Z_HI[5]) + 1e-9
    assert wide.cost_J < 0.1 * narrow.cost_J
    assert all(abs(w[k] / v - 1.0) < 0.01 for k, v in (("freq_hz", freq), ("zeta_p", zp), ("zeta_z", zz)))


def test_structure_box_reaches_down_to_a_flybars_coupled_flapping():
    """A pole pair below the vocabulary's resonances (1.7 Hz, poles 0.2, zeros 0.7: the
    coupled flapping a flybar airframe adds): the vocabulary's bottom (3 Hz) stops the
    fit on that floor, the structure step's (``z_lo=_Z_LO_STRUCTURE``, 1 Hz) recovers the
    pair on noise-free data, and it counts as the airframe's, not an effect's."""
    from jaxgwo._diagnose import _airframe_pair
    from jaxgwo._diagnose_which import _Z_HI_STRUCTURE, _Z_LO, _Z_LO_STRUCTURE, fit_linear_candidates

    freq, zp, zz = 1.7, 0.2, 0.7
    obj, x_nom = _paper_times_mode(freq, zp, zz)
    key = jax.random.key(3)
    kw = dict(wolves=10, iterations=25, z_hi=_Z_HI_STRUCTURE)
    (floor,) = fit_linear_candidates(obj, x_nom, [("structural_mode",)], key, **kw)
    (low,) = fit_linear_candidates(obj, x_nom, [("structural_mode",)], key, z_lo=_Z_LO_STRUCTURE, **kw)
    f, w = floor.params["structural_mode"], low.params["structural_mode"]
    assert f["freq_hz"] >= np.exp(_Z_LO[3]) - 1e-9
    assert low.cost_J < 0.1 * floor.cost_J
    assert all(abs(w[k] / v - 1.0) < 0.01 for k, v in (("freq_hz", freq), ("zeta_p", zp), ("zeta_z", zz)))
    assert _airframe_pair(w, 1.0)  # complex zeros, but below every resonance of the vocabulary
    assert not _airframe_pair({"freq_hz": 8.0, "zeta_p": 0.05, "zeta_z": 0.15}, 1.0)  # a resonance
    assert _airframe_pair({"freq_hz": 8.0, "zeta_p": 0.5, "zeta_z": 3.0}, 1.0)  # real zeros
    # structure_zeta_z = inf switches the structure step off: neither a low pair nor real zeros count
    assert not _airframe_pair(w, math.inf) and not _airframe_pair({"freq_hz": 8.0, "zeta_p": 0.5, "zeta_z": 3.0}, math.inf)


def test_a_lag_that_pressed_the_structure_pair_up_is_refitted_beside_the_flybar():
    """Noise-free: the paper model with a 20 ms flapping lag and the rotor term's ``tau`` of
    the R-50 (0.049 s), times a flybar pair (1.8 Hz, poles 0.12, zeros 0.93).  The structure
    step's pair alone is pressed above the vocabulary's floor with real zeros, and the
    rotor term's ``tau`` with it (to about 0.4): refitted with the lag around those paper
    parameters, ``tau`` stops on the polish box's edge (a factor 8) and ``J`` stays above
    zero; from the flybar's pair with the paper parameters free by a factor 10
    (:func:`fit_beside_flybar`) the truth is recovered."""
    from jaxgwo._cost import CiferObjective
    from jaxgwo._diagnose import _below_vocabulary, fit_beside_flybar
    from jaxgwo._diagnose_which import _Z_HI_STRUCTURE, _Z_LO_STRUCTURE, fit_linear_candidates
    from jaxgwo._effects import rotor_flapping_response, structural_mode_response
    from jaxgwo._models import ParameterMap

    p = np.array([306.0, 0.049, 270.0, 41.8, 0.43])
    tau_f, pair = 0.02, (1.8, 0.12, 0.93)
    resp = _response(lambda w: rotor_flapping_response(jnp.asarray(p), w, tau_f) * structural_mode_response(w, *pair))
    obj = CiferObjective.from_response(resp, ParameterMap.for_model(PaperModel.from_array(jnp.asarray(p))))
    kw = dict(wolves=10, iterations=25)
    (s,) = fit_linear_candidates(obj, np.log([230.0, 0.6, 150.0, 45.0, 0.3]), [("structural_mode",)],
                                 jax.random.key(1), z_hi=_Z_HI_STRUCTURE, z_lo=_Z_LO_STRUCTURE, **kw)  # fmt: skip
    mode = s.params["structural_mode"]
    assert not _below_vocabulary(mode) and mode["zeta_z"] > 1.0 and np.exp(s.x[1]) > 0.3
    names = [("structural_mode", "rotor_flapping")]
    (near,) = fit_linear_candidates(obj, s.x[:5], names, jax.random.key(2), effect_seed=s.x[5:],
                                    z_hi=_Z_HI_STRUCTURE, z_lo=_Z_LO_STRUCTURE, **kw)  # fmt: skip
    (low,) = fit_beside_flybar(obj, s.x[:5], names, s.x[5:], jax.random.key(2), **kw)
    assert np.exp(near.x[1]) >= np.exp(s.x[1]) / 8.0 * (1.0 - 1e-6)  # tau on the polish box's edge
    assert near.cost_J > 1e-4
    assert low.cost_J < 1e-8
    np.testing.assert_allclose(np.exp(low.x[:5]), p, rtol=1e-4)
    assert low.params["rotor_flapping"]["tau_f"] == pytest.approx(tau_f, rel=1e-4)
    got = low.params["structural_mode"]
    assert [got[k] for k in ("freq_hz", "zeta_p", "zeta_z")] == pytest.approx(list(pair), rel=1e-4)


def test_a_resonance_taken_for_the_structure_pair_is_refitted_beside_the_flybar():
    """Noise-free, to 21 Hz: the paper model times a flybar pair (1.7 Hz, poles 0.2, zeros
    0.8) times a 16 Hz resonance (poles 0.03, zeros 0.28).  One pair in the structure
    step's box takes the resonance, with real zeros; from it
    :func:`fit_flybar_and_resonance` refits the pair below the vocabulary's floor and the
    resonance beside it, recovering both and fitting ``J`` far better.  The trigger,
    :func:`_pair_pressed_up`: any pair above the floor, lightly damped or broad (this one
    fits poles 0.24, which the trigger before session 63 let stand), not a flybar's pair
    below the floor or on it.  A broad pair is replaced only by a refit under the floor
    (:func:`_under_the_floor`), a lightly damped one
    (:func:`_resonance_taken_for_structure`) by one on it as well."""
    from jaxgwo._cost import CiferObjective
    from jaxgwo._diagnose import (
        _pair_pressed_up,
        _resonance_taken_for_structure,
        _under_the_floor,
        fit_flybar_and_resonance,
    )
    from jaxgwo._diagnose_which import _Z_HI_STRUCTURE, _Z_LO_STRUCTURE, fit_linear_candidates
    from jaxgwo._effects import structural_mode_response
    from jaxgwo._models import ParameterMap

    pair, res = (1.7, 0.2, 0.8), (16.0, 0.03, 0.28)
    sign = float(np.sign(float(MODEL.K)))
    resp = _response(lambda w: sign * MODEL.frequency_response(w) * structural_mode_response(w, *pair)
                     * structural_mode_response(w, *res), w_max=130.0)  # fmt: skip
    obj = CiferObjective.from_response(resp, ParameterMap.for_model(MODEL))
    kw = dict(wolves=10, iterations=25)
    (one,) = fit_linear_candidates(obj, np.log(np.abs(np.asarray(MODEL.to_array(), float))), [("structural_mode",)],
                                   jax.random.key(1), z_hi=_Z_HI_STRUCTURE, z_lo=_Z_LO_STRUCTURE, **kw)  # fmt: skip
    m = one.params["structural_mode"]
    assert abs(m["freq_hz"] / res[0] - 1.0) < 0.1 and m["zeta_z"] > 1.0
    low, beside = fit_flybar_and_resonance(obj, one.x, jax.random.key(2), **kw)
    assert low.params["structural_mode"]["freq_hz"] < 3.0
    assert beside.cost_J < 1e-3 * one.cost_J
    got = beside.params["structural_mode"]
    assert [got[k] for k in ("freq_hz", "zeta_p", "zeta_z")] == pytest.approx(list(res), rel=0.01)
    np.testing.assert_allclose(np.exp(beside.x[:5]), np.abs(np.asarray(MODEL.to_array(), float)), rtol=0.01)
    assert m["zeta_p"] > 0.15 and _pair_pressed_up(m)  # broad, and refitted beside the flybar all the same
    assert _pair_pressed_up({"freq_hz": 17.6, "zeta_p": 0.07, "zeta_z": 8.8})  # seed-149 case_004
    assert _pair_pressed_up({"freq_hz": 4.51, "zeta_p": 0.66, "zeta_z": 2.29})  # 435/055, a 10.9 Hz R-50 mode's
    assert _pair_pressed_up({"freq_hz": 8.7, "zeta_p": 0.32, "zeta_z": 4.5})  # a lag's pressed pair
    assert not _pair_pressed_up({"freq_hz": 2.03, "zeta_p": 0.05, "zeta_z": 0.9})  # below the floor
    assert not _pair_pressed_up({"freq_hz": 3.0, "zeta_p": 0.6, "zeta_z": 1.8})  # on it: fit_beside_flybar's box
    assert _under_the_floor(low.params["structural_mode"])
    assert not _under_the_floor({"freq_hz": 3.0, "zeta_p": 0.61, "zeta_z": 1.73})  # 433/018's refit, on the edge
    assert _under_the_floor({"freq_hz": 2.95, "zeta_p": 0.55, "zeta_z": 1.22})  # 445/032's, just under it
    assert _resonance_taken_for_structure({"freq_hz": 17.6, "zeta_p": 0.07, "zeta_z": 8.8})  # seed-149 case_004
    assert _resonance_taken_for_structure({"freq_hz": 14.45, "zeta_p": 0.134, "zeta_z": 6.89})  # seed-199 case_071
    assert not _resonance_taken_for_structure({"freq_hz": 8.7, "zeta_p": 0.32, "zeta_z": 4.5})  # a lag's pressed pair
    assert not _resonance_taken_for_structure(m)  # noise-free, the one pair fits poles 0.24: broad


def _mode_np(w, freq_hz, zeta_p, zeta_z):
    """A ``structural_mode``'s response in plain NumPy."""
    wn = 2 * np.pi * freq_hz
    return (wn * wn - w * w + 2j * zeta_z * wn * w) / (wn * wn - w * w + 2j * zeta_p * wn * w)


def _plain_j(obj, x_paper, modes):
    """``J`` in plain NumPy of the paper model ``exp(x_paper)`` (sign-normalised) times the pole
    pairs ``modes`` against ``obj``'s measured response (dB and wrapped phase errors)."""
    sign = float(np.sign(float(MODEL.K)))
    w = np.asarray(obj.w)
    h = sign * np.asarray(PaperModel.from_array(jnp.asarray(np.exp(x_paper) * np.array([sign, 1, 1, 1, 1])))
                          .frequency_response(w))  # fmt: skip
    for m in modes:
        h = h * _mode_np(w, *m)
    e_db = 20 * np.log10(np.abs(h)) - np.asarray(obj.magnitude_db)
    e_ph = (np.rad2deg(np.angle(h)) - np.asarray(obj.phase_deg) + 180.0) % 360.0 - 180.0
    return 20.0 / float(obj.n) * np.sum(np.asarray(obj.weight) * (e_db**2 + float(obj.phase_weight) * e_ph**2))


def _pair_and_resonance_structure(pair, res, **kw):
    """Noise-free: the measured response of the paper model times ``pair`` times ``res``,
    its CIFER objective, and the structure step's one-slot fit there (its ``(freq_hz,
    zeta_p, zeta_z)`` too)."""
    from jaxgwo._cost import CiferObjective
    from jaxgwo._diagnose_which import _Z_HI_STRUCTURE, _Z_LO_STRUCTURE, fit_linear_candidates
    from jaxgwo._models import ParameterMap

    sign = float(np.sign(float(MODEL.K)))
    resp = _response(lambda w: sign * MODEL.frequency_response(w) * _mode_np(np.asarray(w), *pair)
                     * _mode_np(np.asarray(w), *res))  # fmt: skip
    obj = CiferObjective.from_response(resp, ParameterMap.for_model(MODEL))
    x_nom = np.log(np.abs(np.asarray(MODEL.to_array(), float)))
    (st,) = fit_linear_candidates(obj, x_nom, [("structural_mode",)], jax.random.key(3), z_hi=_Z_HI_STRUCTURE,
                                  z_lo=_Z_LO_STRUCTURE, **kw)  # fmt: skip
    bent = tuple(st.params["structural_mode"][k] for k in ("freq_hz", "zeta_p", "zeta_z"))
    return obj, st, bent


def test_a_resonance_is_fitted_beside_a_held_pole_pair():
    """Noise-free: the paper model times an airframe pair (1.7 Hz, zeros 0.7) times a 6 Hz
    resonance.  ``with_fixed_modes`` holds the pair: ``J`` of a model under it equals a
    plain NumPy ``J`` of that model times the pair against the measured response (so the
    objective is the original's, not an approximation), and the one ``structural_mode``
    slot fitted under it recovers the resonance, which the slot alone, without the pair
    held, cannot fit as well."""
    from jaxgwo._cost import CiferObjective
    from jaxgwo._diagnose_which import AugmentedCifer, _active_mask, fit_linear_candidates, with_fixed_modes
    from jaxgwo._models import ParameterMap

    pair, res = (1.7, 0.2, 0.7), (6.0, 0.04, 0.12)
    sign = float(np.sign(float(MODEL.K)))
    resp = _response(lambda w: sign * MODEL.frequency_response(w) * _mode_np(np.asarray(w), *pair)
                     * _mode_np(np.asarray(w), *res))  # fmt: skip
    obj = CiferObjective.from_response(resp, ParameterMap.for_model(MODEL))
    x_nom = np.log(np.abs(np.asarray(MODEL.to_array(), float)))
    held = with_fixed_modes(obj, [pair])
    # J at a point off the truth, against the plain formula (dB and wrapped phase errors)
    x = np.r_[x_nom + np.array([0.1, -0.05, 0.08, 0.1, -0.1]), 0.0, np.log(100.0), 0.0, np.log([8.0, 0.06, 0.2])]
    got = float(AugmentedCifer.from_cifer(held, _active_mask(["structural_mode"]))(jnp.asarray(x)))
    ref = _plain_j(obj, x[:5], [np.exp(x[8:]), pair])
    assert ref > 1.0 and got == pytest.approx(ref, rel=1e-9)
    key = jax.random.key(3)
    (beside,) = fit_linear_candidates(held, x_nom, [("structural_mode",)], key, wolves=10, iterations=25)
    (alone,) = fit_linear_candidates(obj, x_nom, [("structural_mode",)], key, wolves=10, iterations=25)
    b = beside.params["structural_mode"]
    assert all(abs(b[k] / v - 1.0) < 0.01 for k, v in zip(("freq_hz", "zeta_p", "zeta_z"), res))
    assert beside.cost_J < 1e-3 < alone.cost_J


def test_the_pair_is_refitted_beside_the_resonance():
    """Noise-free: the paper model times an airframe pair (1.7 Hz, zeros 0.7) times a 6 Hz
    resonance.  The structure step's one slot bends the pair toward the resonance (1.94 Hz);
    the resonance fitted beside that bent pair held misses its zeros' damping, and
    ``fit_resonance_beside_pair``, which refits the pair beside it and the resonance again,
    recovers both (2 % on the resonance, 5 % on the pair with this small pack) at a
    fraction of the held pair's ``J``."""
    from jaxgwo._diagnose import _Z_HI_SECOND_PAIR, fit_resonance_beside_pair
    from jaxgwo._diagnose_which import fit_linear_candidates, with_fixed_modes

    pair, res = (1.7, 0.2, 0.7), (6.0, 0.04, 0.12)
    kw = dict(wolves=10, iterations=25)
    obj, st, bent = _pair_and_resonance_structure(pair, res, **kw)
    keys = ("freq_hz", "zeta_p", "zeta_z")
    assert abs(bent[0] / pair[0] - 1.0) > 0.1  # the one slot took some of the resonance

    def errors(fitted, truth):
        return np.abs(np.asarray(fitted) / np.asarray(truth) - 1.0)

    (held,) = fit_linear_candidates(with_fixed_modes(obj, [bent]), st.x[:5], [("structural_mode",)],
                                    jax.random.key(4), z_hi=_Z_HI_SECOND_PAIR, **kw)  # fmt: skip
    f, (refit,) = fit_resonance_beside_pair(obj, st.x[:5], bent, st.x[5:], jax.random.key(4), **kw)
    got = [f.params["structural_mode"][k] for k in keys]
    held_got = [held.params["structural_mode"][k] for k in keys]
    assert errors(held_got, res).max() > 0.1 and held.cost_J > 1.0
    assert errors(got, res).max() < 0.02 and errors(refit, pair).max() < 0.05
    assert f.cost_J < 0.05 * held.cost_J


def test_the_pair_is_refitted_with_the_resonance(monkeypatch):
    """Noise-free: the paper model times an airframe pair (2.5 Hz, poles 0.5, zeros 1.0)
    times an 8.5 Hz resonance (poles 0.04, zeros 0.2).  The structure step's one slot takes
    the resonance into the pair (8.9 Hz); fitting the resonance beside that pair held, then
    the pair beside the resonance, stays in that basin (9.5 Hz, zeros 0.02: the alternation
    alone, the joint scan switched off here).  ``fit_resonance_beside_pair`` also refits the
    pair *with* the resonance from a grid of the resonance's frequency
    (``joint_pair_resonance_scan``) and finds the resonance within 1 % in frequency and 10 %
    in pole damping, at a tenth of the alternation's ``J``; the scan's own ``J`` is a plain
    NumPy ``J`` of its model against the measured response."""
    import jaxgwo._diagnose as D
    from jaxgwo._diagnose_which import joint_pair_resonance_scan

    pair, res = (2.5, 0.5, 1.0), (8.5, 0.04, 0.2)
    kw = dict(wolves=10, iterations=25)
    obj, st, bent = _pair_and_resonance_structure(pair, res, **kw)
    keys = ("freq_hz", "zeta_p", "zeta_z")
    assert abs(bent[0] / res[0] - 1.0) < 0.1  # the one slot took the resonance
    j_scan, x_scan = joint_pair_resonance_scan(obj, st.x[:5], bent, D._Z_HI_SECOND_PAIR[3:6])
    assert j_scan == pytest.approx(_plain_j(obj, x_scan[:5], [np.exp(x_scan[5:8]), np.exp(x_scan[8:11])]), rel=1e-9)
    f, _pair = D.fit_resonance_beside_pair(obj, st.x[:5], bent, st.x[5:], jax.random.key(4), **kw)
    monkeypatch.setattr(D, "joint_pair_resonance_scan", lambda *a, **k: (math.inf, None))
    alone, _ = D.fit_resonance_beside_pair(obj, st.x[:5], bent, st.x[5:], jax.random.key(4), **kw)
    got, got_alone = ([g.params["structural_mode"][k] for k in keys] for g in (f, alone))
    assert abs(got[0] / res[0] - 1.0) < 0.01 and abs(got[1] / res[1] - 1.0) < 0.1
    assert abs(got_alone[0] / res[0] - 1.0) > 0.05 or abs(got_alone[2] / res[2] - 1.0) > 0.5
    assert f.cost_J < 0.1 * alone.cost_J
    # fitted again beside its pair held, from the scan's point (both may reach round-off: 1e-20)
    assert f.cost_J <= j_scan * (1.0 + 1e-9) + 1e-20


def test_the_joint_scan_finds_the_pair_the_structure_step_bent(monkeypatch):
    """Noise-free: the paper model times an airframe pair (1.7 Hz, poles 0.2, zeros 0.7)
    times a 9.7 Hz resonance (poles 0.025, zeros 0.2).  The structure step's one slot bends
    its pair onto the resonance (about 10.5 Hz, zeros above 5), and a joint scan started
    from that pair alone ends with the pair near 10 Hz and a broad 5 Hz "resonance" (``J``
    about 11, the scan's extra pair starts switched off here).  From the broad pairs of
    ``_JOINT_SCAN_PAIR_STARTS`` as well, both are found: pair and resonance within 1 % in
    frequency and 5 % in damping, ``J`` below 1e-6 of that."""
    import jaxgwo._diagnose as D
    import jaxgwo._diagnose_which as W

    pair, res = (1.7, 0.2, 0.7), (9.7, 0.025, 0.2)
    kw = dict(wolves=10, iterations=25)
    obj, st, bent = _pair_and_resonance_structure(pair, res, **kw)
    assert bent[0] > 2.0 * pair[0]  # the one slot left the airframe's pair
    keys = ("freq_hz", "zeta_p", "zeta_z")
    f, (got_pair,) = D.fit_resonance_beside_pair(obj, st.x[:5], bent, st.x[5:], jax.random.key(4), **kw)
    monkeypatch.setattr(W, "_JOINT_SCAN_PAIR_STARTS", ())
    alone, (alone_pair,) = D.fit_resonance_beside_pair(obj, st.x[:5], bent, st.x[5:], jax.random.key(4), **kw)
    got = [f.params["structural_mode"][k] for k in keys]
    assert np.allclose(got[:2], res[:2], rtol=[0.01, 0.05]) and np.allclose(got_pair[:2], pair[:2], rtol=[0.01, 0.05])
    assert abs(alone_pair[0] / pair[0] - 1.0) > 0.5  # from the bent pair alone the pair stays bent
    assert f.cost_J < 1e-6 * alone.cost_J
    assert f.cost_J == pytest.approx(_plain_j(obj, f.x[:5], [got_pair, got]), rel=1e-6, abs=1e-12)


def test_a_joint_fit_that_moved_the_pair_into_the_resonance_slot_is_told():
    """The joint scan may hand back the structure pair as its resonance (real zeros, at the
    pair's frequency) beside another pair; a resonance beside the pair is neither one with
    a resonance's zeros nor one away from the pair's half-power half-width."""
    from jaxgwo._diagnose import _pair_in_resonance_slot

    pair = (9.05, 0.159, 1.45)
    mode = lambda f, zp, zz: {"freq_hz": f, "zeta_p": zp, "zeta_z": zz}  # noqa: E731
    assert _pair_in_resonance_slot(mode(9.15, 0.151, 1.23), pair, 1.0)
    assert not _pair_in_resonance_slot(mode(9.15, 0.151, 0.23), pair, 1.0)  # a resonance's zeros
    assert not _pair_in_resonance_slot(mode(11.8, 0.094, 1.26), pair, 1.0)  # 2.75 Hz away, width 1.44
    assert not _pair_in_resonance_slot(mode(9.15, 0.151, 1.23), pair, math.inf)  # the structure test off


def test_a_resonance_beside_a_held_pair_counts_only_inside_its_box():
    """The fits the R-50 blind cases gave beside a held pair: on the 3 Hz floor at the
    0.2 pole-damping cap (a flapping lag's), at the zero-damping cap (a long delay's) or
    at the pole-damping floor are edges of the box; near a true resonance they lay inside."""
    from jaxgwo._diagnose import _on_box_edge

    edges = [(3.0, 0.2, 0.14), (8.49, 0.087, 1.5), (16.35, 0.01, 0.5), (45.0, 0.05, 0.2), (9.0, 0.05, 0.02)]
    inside = [(13.54, 0.089, 0.26), (11.28, 0.041, 0.127), (3.2, 0.19, 0.14)]
    keys = ("freq_hz", "zeta_p", "zeta_z")
    assert all(_on_box_edge(dict(zip(keys, v))) for v in edges)
    assert not any(_on_box_edge(dict(zip(keys, v))) for v in inside)


def test_an_output_error_refit_stands_in_for_a_resonance_beside_a_pair_only_off_the_box_edges():
    """Fresh seed 511's case_052, an R-50 `none`: the ``J`` fit beside the held pair sat on
    the 0.2 pole-damping cap (4.75 Hz, zeros 0.248); its output-error refit stepped just
    inside (4.45 Hz, pole damping 0.185) and had named it ``structural_mode``.  A refit
    starting from a fit on an edge cannot stand in for it, nor one that stops on an edge;
    from a fit inside, a refit inside can."""
    from jaxgwo._diagnose import _on_box_edge, _refit_may_stand_in

    keys = ("freq_hz", "zeta_p", "zeta_z")
    j_fit, refit = dict(zip(keys, (4.753, 0.2, 0.2479))), dict(zip(keys, (4.451, 0.1852, 0.2371)))
    assert _on_box_edge(j_fit) and not _on_box_edge(refit)
    assert not _refit_may_stand_in(j_fit, refit)
    inside, near = dict(zip(keys, (11.28, 0.041, 0.127))), dict(zip(keys, (11.4, 0.045, 0.13)))
    assert _refit_may_stand_in(inside, near)
    assert not _refit_may_stand_in(inside, dict(zip(keys, (8.49, 0.087, 1.5))))


def _one_record_objective(t, u, k, names, fixed_modes=()):
    """``LinearOutputError`` on the single record ``u`` (its output stands in for the
    measured one: only ``outputs`` is read), gain ``k``, the linear effects ``names``."""
    from jaxgwo._diagnose_which import LinearOutputError

    return LinearOutputError(jnp.asarray(u[None]), jnp.asarray(u[None]), jnp.ones((1, u.size)), jnp.asarray(t),
                             jnp.asarray(k), tuple(names), fixed_modes)  # fmt: skip


def test_held_pole_pairs_simulate_as_the_product_transfer_function():
    """A model with a resonance and a held pole pair (``ModelSpec.fixed_modes``), simulated
    by ``simulate_model`` and by the time-domain check's ``LinearOutputError``, against
    scipy.signal.lsim of the product; the held pair changes the output."""
    import scipy.signal

    from jaxgwo._diagnose import _time_pairs
    from jaxgwo._diagnose_which import ModelSpec, simulate_model

    train, _val = _case(None, seed=2)
    (t, u, _o, _y), *_ = _time_pairs(train, "lateral", SETTINGS.identify)
    k, tau, m, ws, zs = (float(v) for v in MODEL.to_array())
    pair, res = (1.7, 0.2, 0.7), (9.0, 0.04, 0.12)
    spec = ModelSpec(np.asarray(MODEL.to_array(), float), {"structural_mode": dict(zip(("freq_hz", "zeta_p", "zeta_z"), res))},
                     fixed_modes=(pair,))  # fmt: skip
    num, den = [k * ws * ws], np.polymul([1.0, 1.0 / tau, m], [1.0, 2 * zs * ws, ws * ws])
    for f, zp, zz in (pair, res):
        wn = 2 * np.pi * f
        num, den = np.polymul(num, [1.0, 2 * zz * wn, wn * wn]), np.polymul(den, [1.0, 2 * zp * wn, wn * wn])
    _t, ref, _x = scipy.signal.lsim((num, den), u, t, interp=False)
    scale = np.max(np.abs(ref))
    assert scale > 0.1
    assert np.max(np.abs(simulate_model(spec, t, u) - ref)) < 1e-8 * scale
    def objective(pairs):
        return _one_record_objective(t, u, k, ("structural_mode",), pairs)

    traces = []

    @eqx.filter_jit
    def outputs(obj, x):
        traces.append(1)  # runs only while JAX traces
        return obj.outputs(x)

    z = np.r_[0.0, np.log(100.0), 0.0, np.log(res)]
    x = jnp.asarray(np.r_[z, np.log([ws, zs, tau, m])])
    got = np.asarray(outputs(objective((pair,)), x))[0]
    assert np.max(np.abs(got - ref)) < 1e-8 * scale
    without = simulate_model(dataclasses.replace(spec, fixed_modes=()), t, u)
    assert np.max(np.abs(without - ref)) > 0.05 * scale
    # the held pair is data to the compiled refit, not part of its key: a pair at other
    # values (the next case's structure finding) runs the same program, and acts
    moved = (2.3, 0.3, 0.5)
    again = np.asarray(outputs(objective((moved,)), x))[0]
    assert len(traces) == 1
    assert np.max(np.abs(again - simulate_model(dataclasses.replace(spec, fixed_modes=(moved,)), t, u))) < 1e-8 * scale
    assert np.max(np.abs(again - got)) > 0.05 * scale
    assert objective(()).fixed_modes.shape == (0, 3)


def test_a_candidates_fit_does_not_depend_on_the_others_in_its_batch(monkeypatch):
    """Each candidate's pack draws from its own key (``candidate_key``: the effects, in any
    order, and the profile point).  Refitted alone or beside other candidates, in either
    order, a candidate's packs get the same keys, and its fit is the same; a nonlinear
    one's packs get the same keys beside a rate limit's extra profile points.  Before, every key was a split
    of one key by the batch's size, so adding a candidate redrew all the others."""
    from jaxgwo import _gwo
    from jaxgwo._cost import CiferObjective
    from jaxgwo._diagnose import _time_pairs
    from jaxgwo._diagnose_which import ModelSpec, candidate_key, fit_linear_candidates, fit_nonlinear_candidates
    from jaxgwo._models import ParameterMap

    key = jax.random.key(5)
    draw = lambda names, point=0: float(jax.random.uniform(candidate_key(key, names, point)))  # noqa: E731
    assert draw(("time_delay", "sensor_lag")) == draw(("sensor_lag", "time_delay"))
    assert len({draw(()), draw(("time_delay",)), draw(("sensor_lag",)), draw(("time_delay",), 1)}) == 4

    calls = []  # per run_batch call: {a row's rounded bounds: that row's key data}
    run_batch = _gwo.run_batch
    stop_after_batch = False

    class Captured(Exception):
        pass

    def spy(cfg, objs, lo, hi, keys, **kw):
        data = np.asarray(jax.random.key_data(keys))
        rows = np.round(np.concatenate([np.asarray(lo), np.asarray(hi)], axis=1), 9)
        calls.append({tuple(r): tuple(d) for r, d in zip(rows, data)})
        if stop_after_batch:  # the keys are captured; the costly polishes are not needed
            raise Captured
        return run_batch(cfg, objs, lo, hi, keys, **kw)

    monkeypatch.setattr(_gwo, "run_batch", spy)

    def same_rows(alone, beside):
        assert alone and all(beside[r] == d for r, d in alone.items())

    sign = float(np.sign(float(MODEL.K)))
    resp = _response(lambda w: sign * MODEL.frequency_response(w) * time_delay_response(w, 0.03))
    obj = CiferObjective.from_response(resp, ParameterMap.for_model(MODEL))
    x_nom = np.log(np.abs(np.asarray(MODEL.to_array(), float)))
    (alone,) = fit_linear_candidates(obj, x_nom, [("time_delay",)], key, wolves=10, iterations=25)
    for batch in ([("sensor_lag",), ("time_delay",)], [("time_delay",), ("rotor_flapping",), ("sensor_lag",)]):
        fits = fit_linear_candidates(obj, x_nom, batch, key, wolves=10, iterations=25)
        same_rows(calls[0], calls[-1])
        beside = fits[batch.index(("time_delay",))]
        np.testing.assert_allclose(beside.x, alone.x, rtol=1e-12, atol=1e-12)

    train, _val = _case(None, seed=2)
    tt = _time_pairs(train, "lateral", SETTINGS.identify)
    base = ModelSpec(np.asarray(MODEL.to_array(), float))
    kw = dict(key=key, wolves=6, iterations=6, profile_points=4)
    stop_after_batch = True
    for names in (["saturation"], ["rate_limit", "saturation"]):
        with pytest.raises(Captured):
            fit_nonlinear_candidates(base, tt, names, **kw)
    same_rows(calls[-2], calls[-1])  # the saturation's profile rows and the null's row


def test_quick_settings_shrink_the_searches_and_keep_every_threshold():
    """``DiagnoseSettings.quick()`` (this suite's ``SETTINGS``, the blind study's
    ``--quick``) differs from the defaults in the search sizes only, each smaller (the
    nominal fit's too); ``changes`` replace fields and are validated like any."""
    sizes = {"wolves", "iterations", "nonlinear_wolves", "nonlinear_iterations", "nonlinear_profile_points",
             "nonlinear_refine_rows", "nonlinear_polish_steps"}  # fmt: skip
    quick, default = DiagnoseSettings.quick(), DiagnoseSettings()
    differ = {f.name for f in dataclasses.fields(DiagnoseSettings) if getattr(quick, f.name) != getattr(default, f.name)}
    assert differ == sizes | {"identify"}
    assert all(getattr(quick, name) < getattr(default, name) for name in sizes)
    a, b = quick.identify, default.identify
    assert (a.wolves, a.iterations, a.polish_steps) == (10, 20, 30) and (b.wolves, b.iterations, b.polish_steps) == (12, 30, 40)
    assert dataclasses.replace(a, wolves=b.wolves, iterations=b.iterations, polish_steps=b.polish_steps) == b
    assert DiagnoseSettings.quick(seed=4, candidates=("time_delay",)) == dataclasses.replace(
        quick, seed=4, candidates=("time_delay",))
    with pytest.raises(ValueError, match="nonlinear_wolves"):
        DiagnoseSettings.quick(nonlinear_wolves=3)


def test_the_settings_nonlinear_budget_reaches_its_fits(monkeypatch):
    """``DiagnoseSettings``' nonlinear budget is what ``fit_nonlinear_candidates`` runs: the
    profile has ``profile_points`` rows per candidate (a rate limit twice as many), the
    Levenberg-Marquardt batch ``refine_rows`` per candidate, and every L-BFGS-B finish
    ``polish_steps`` steps."""
    from jaxgwo import _diagnose_which as W
    from jaxgwo._diagnose import _time_pairs
    from jaxgwo._diagnose_which import ModelSpec, fit_nonlinear_candidates

    seen = {"steps": [], "rows": None, "lm": None}

    class Captured(Exception):
        pass

    polish, run_batch = W._polish_nonlinear, W.G.run_batch

    def spy_polish(obj, x0, lo, hi, null, method="Nelder-Mead", maxiter=60):
        if method == "L-BFGS-B":
            seen["steps"].append(maxiter)
        return polish(obj, x0, lo, hi, null, method, maxiter)

    def spy_batch(cfg, objs, lo, hi, keys, **kw):
        seen["rows"] = int(np.asarray(lo).shape[0])
        return run_batch(cfg, objs, lo, hi, keys, **kw)

    def spy_lm(objs, xs, lo, hi):
        seen["lm"] = int(xs.shape[0])
        raise Captured

    monkeypatch.setattr(W, "_polish_nonlinear", spy_polish)
    monkeypatch.setattr(W.G, "run_batch", spy_batch)
    monkeypatch.setattr(W, "_nl_lm", spy_lm)
    train, _val = _case(None, seed=2)
    tt = _time_pairs(train, "lateral", SETTINGS.identify)
    with pytest.raises(Captured):
        fit_nonlinear_candidates(ModelSpec(np.asarray(MODEL.to_array(), float)), tt, ["rate_limit", "saturation"],
                                 jax.random.key(0), include_null=True, **NL_SMALL)  # fmt: skip
    s = SETTINGS
    assert seen["rows"] == 3 * s.nonlinear_profile_points + 1  # rate limit x2, saturation, the null's row
    assert seen["lm"] == 2 * s.nonlinear_refine_rows
    assert seen["steps"] == [s.nonlinear_polish_steps]  # the null's finish, before the profile


@pytest.mark.slow
def test_nonlinear_candidates_never_fit_worse_than_the_null_refit():
    from jaxgwo._diagnose import _time_pairs
    from jaxgwo._diagnose_which import ModelSpec, fit_nonlinear_candidates

    train, _val = _case(None, seed=2)
    tt = _time_pairs(train, "lateral", SETTINGS.identify)
    base = ModelSpec(np.asarray(MODEL.to_array(), float))
    *fits, null = fit_nonlinear_candidates(base, tt, key=jax.random.key(0), include_null=True, **NL_SMALL)
    # each candidate's box reaches where its nonlinearity no longer acts: it nests the null
    for f in fits:
        assert f.train_mse <= null.train_mse * (1 + 1e-9), f.effects


@pytest.mark.slow
def test_nonlinear_refit_moves_the_rotor_term_the_nominal_fit_bent():
    """A frequency-domain nominal fit absorbs a rate limit's describing function into the
    rotor term as well as the servo.  Started from such a bent base (rotor tau and M 20 %
    off, servo 25 % slow), the rate-limit refit must free the rotor term to find the rate
    and cut the null refit's error (with the rotor held it found neither), whatever the key."""
    from jaxgwo._diagnose import _time_pairs
    from jaxgwo._diagnose_which import ModelSpec, fit_nonlinear_candidates

    train, _val = _case("rate_limit", seed=3, rate=1.0)
    tt = _time_pairs(train, "lateral", SETTINGS.identify)
    true = np.asarray(MODEL.to_array(), float)
    bent = true * np.array([1.0, 1.2, 0.8, 0.75, 1.0])
    fit, null = fit_nonlinear_candidates(ModelSpec(bent), tt, ["rate_limit"], key=jax.random.key(0), include_null=True,
                                         wolves=12, iterations=15)
    assert abs(fit.params["rate_limit"]["rate"] - 1.0) < 0.1
    assert null.train_mse > 2.0 * fit.train_mse
    refit = fit.spec(ModelSpec(bent)).params
    np.testing.assert_allclose(refit[1:3], true[1:3], rtol=0.08)  # tau, M back near the truth from 20 % off
    # another key reaches the same optimum: before the Levenberg-Marquardt refinement of the
    # profile's best rows, three keys in four stopped at x0.37 of the null's error (rate
    # 0.94) where key 0 reached x0.31 (rate 0.99)
    fit1, _null = fit_nonlinear_candidates(ModelSpec(bent), tt, ["rate_limit"], key=jax.random.key(1),
                                           include_null=True, wolves=12, iterations=15)  # fmt: skip
    assert fit1.train_mse == pytest.approx(fit.train_mse, rel=0.01)
    assert abs(fit1.params["rate_limit"]["rate"] - 1.0) < 0.03


def test_free_mode_objective_equals_the_held_pair_objective_at_the_same_pair():
    """With ``free_mode`` the structure finding's pair comes from ``x[5:8]`` instead of the
    fixed gyro-side filter: at the base's own pair both objectives simulate the same output
    (the same polynomial products), and moving the pair changes it."""
    from jaxgwo._diagnose import _time_pairs
    from jaxgwo._diagnose_which import ModelSpec, nonlinear_objectives

    train, _val = _case("rate_limit", seed=4, rate=1.8)
    tt = _time_pairs(train, "lateral", SETTINGS.identify)
    pair = {"freq_hz": 2.0, "zeta_p": 0.2, "zeta_z": 0.8}
    base = ModelSpec(np.asarray(MODEL.to_array(), float), {"structural_mode": pair, "sensor_lag": {"cutoff_hz": 20.0}})
    (held,) = nonlinear_objectives(base, tt, ["rate_limit"])
    (free,) = nonlinear_objectives(base, tt, ["rate_limit"], free_mode=True)
    _k, tau, m, ws, zs = np.asarray(MODEL.to_array(), float)
    x = np.log([1.8, ws, zs, tau, m])
    z = np.log([pair["freq_hz"], pair["zeta_p"], pair["zeta_z"]])
    y_held = np.asarray(held.outputs(jnp.asarray(x)))
    y_free = np.asarray(free.outputs(jnp.asarray(np.r_[x, z])))
    np.testing.assert_allclose(y_free, y_held, rtol=0, atol=1e-10 * np.abs(y_held).max())
    moved = np.asarray(free.outputs(jnp.asarray(np.r_[x, z + np.log([1.2, 1.0, 1.0])])))
    assert np.abs(moved - y_held).max() > 0.01 * np.abs(y_held).max()


@pytest.mark.slow
def test_rate_limit_refit_frees_a_structure_pair_the_nominal_fit_misplaced():
    """A structure finding's pair, fitted to ``J`` before any nonlinearity, absorbs part of
    a rate limit's describing function (seed-359 case_059, an R-50: held there, the refit
    predicted the clean held-out output at R^2 0.89; with the pair free, 0.996).  Here the
    plant carries a 2 Hz pair and a rate limit of 1.8, and the base's pair is misplaced
    (frequency x0.8, damping x1.6 and x0.7).  Held, the refit leaves ten times the error and
    the rate 7 % low; with ``free_mode`` it finds the rate and the pair, and it is tested
    against a null refit given the same freedom, which it nests."""
    from jaxgwo._diagnose import _time_pairs
    from jaxgwo._diagnose_which import ModelSpec, fit_nonlinear_candidates, simulate_model

    truth = {"freq_hz": 2.0, "zeta_p": 0.2, "zeta_z": 0.8}
    plant = EffectSet().with_effect("structural_mode", **truth)
    train, _val = _case("rate_limit", seed=4, plant_effects=plant, rate=1.8)
    tt = _time_pairs(train, "lateral", SETTINGS.identify)
    misplaced = {"freq_hz": 1.6, "zeta_p": 0.32, "zeta_z": 0.56}
    base = ModelSpec(np.asarray(MODEL.to_array(), float) * np.array([1.0, 1.0, 1.0, 1.0, 1.5]),
                     {"structural_mode": misplaced})  # fmt: skip
    held, null = fit_nonlinear_candidates(base, tt, ["rate_limit"], key=jax.random.key(0), include_null=True,
                                          **NL_SMALL)  # fmt: skip
    free, null_f = fit_nonlinear_candidates(base, tt, ["rate_limit"], key=jax.random.key(0), include_null=True,
                                            free_mode=True, **NL_SMALL)  # fmt: skip
    assert held.mode is None and held.against is None and held.held is None
    assert free.held.mode is None and free.held.train_mse == pytest.approx(held.train_mse, rel=1e-9)
    assert free.train_mse < 0.2 * held.train_mse
    assert abs(free.params["rate_limit"]["rate"] / 1.8 - 1.0) < 0.05
    for q, v in truth.items():
        assert free.mode[q] == pytest.approx(v, rel=0.1), q
    # the null returned is the common one (pair held); the candidate's own null frees the pair
    assert null_f.train_mse == pytest.approx(null.train_mse, rel=1e-9)
    assert free.train_mse <= free.against.train_mse * (1 + 1e-9) < null.train_mse
    # its model carries the refitted pair, and simulates the fitted error
    spec = free.spec(base)
    assert spec.effects["structural_mode"] == free.mode
    t, u, _o, y = tt[0]
    e = y - simulate_model(spec, t, u)
    assert np.mean((e - e.mean()) ** 2) == pytest.approx(free.train_mse, rel=1e-6)


@pytest.mark.parametrize("seed", [0, 1])
def test_rate_limit_refit_escapes_the_damping_the_nominal_absorbed_it_into(seed):
    """A frequency-domain nominal fit absorbs a rate limit into a more damped servo.  Started
    from such a base (servo damping doubled), the refit must still find the rate and cut the
    null refit's error by what the truth does (1.09 here, from a polish started at the true
    parameters); the search that held the nominal servo found neither (rate at the box top,
    ratio 1.000), whatever the key."""
    from jaxgwo._diagnose import _time_pairs
    from jaxgwo._diagnose_which import ModelSpec, fit_nonlinear_candidates

    train, _val = _case("rate_limit", seed=4, rate=1.8)
    tt = _time_pairs(train, "lateral", SETTINGS.identify)
    absorbed = np.asarray(MODEL.to_array(), float) * np.array([1.0, 1.0, 1.0, 1.0, 2.0])
    fit, null = fit_nonlinear_candidates(ModelSpec(absorbed), tt, ["rate_limit"], key=jax.random.key(seed),
                                         wolves=12, iterations=15, include_null=True)  # fmt: skip
    assert abs(fit.params["rate_limit"]["rate"] / 1.8 - 1.0) < 0.1
    assert null.train_mse > 1.05 * fit.train_mse


def test_residual_correlation_inflation_against_the_ar1_variance_factor():
    """(1 + rho)/(1 - rho) for an AR(1) residual (analytic), about 1 for white residuals,
    1 for anti-correlated ones (clipped), masked frequencies skipped, and the magnitude and
    phase rows pooled but never chained into one another."""
    from jaxgwo._diagnose_which import residual_correlation_inflation

    rng = np.random.default_rng(11)
    n, rho = 20000, 0.8
    e = rng.standard_normal((2, n))
    ar = np.zeros((2, n))
    for k in range(1, n):
        ar[:, k] = rho * ar[:, k - 1] + e[:, k]
    on = np.ones(n, bool)
    assert residual_correlation_inflation(ar.ravel(), on) == pytest.approx((1 + rho) / (1 - rho), rel=0.1)
    assert residual_correlation_inflation(e.ravel(), on) == pytest.approx(1.0, abs=0.05)
    alternating = np.tile([1.0, -1.0], n)  # rho = -1
    assert residual_correlation_inflation(alternating, on) == 1.0
    # a masked point between two runs of the same sign is skipped, not read as a zero
    steps = np.r_[np.ones(5), 0.0, np.ones(5), -np.ones(5), 0.0, -np.ones(5)]
    mask = np.ones(11, bool)
    mask[5] = False
    r = np.r_[steps[:11], steps[11:]]
    plain = r.reshape(2, -1)[:, mask]
    rho_ref = np.sum(plain[:, :-1] * plain[:, 1:]) / np.sum(plain**2)  # 18/20: no chaining across rows
    assert residual_correlation_inflation(r, mask) == pytest.approx((1 + rho_ref) / (1 - rho_ref), rel=1e-12)


def test_nonstiff_servo_keeps_the_slow_pole_and_moves_the_fast_one_to_the_rk4_step():
    """The analytic poles of the servo before and after: an overdamped servo's slow pole is
    kept and its fast pole put at 1/h; servos RK4 integrates already come back unchanged."""
    from jaxgwo._diagnose_which import _nonstiff_servo

    h = 0.0025
    w, z = _nonstiff_servo(2000.0, 64.0, h)  # seed-223 case_059's nominal servo
    before = np.sort(np.abs(np.roots([1.0, 2 * 64.0 * 2000.0, 2000.0**2])))
    after = np.sort(np.abs(np.roots([1.0, 2 * z * w, w * w])))
    assert after[0] == pytest.approx(before[0], rel=1e-9)  # the pole the records see
    assert after[1] == pytest.approx(1.0 / h, rel=1e-9)
    assert _nonstiff_servo(50.0, 0.5, h) == (50.0, 0.5)
    assert _nonstiff_servo(100.0, 1.5, h) == (100.0, 1.5)  # fast pole 262 1/s < 400
    assert _nonstiff_servo(900.0, 0.3, h) == (400.0, 0.3)
    assert _nonstiff_servo(1e6, 2.0, h) == (400.0, 1.0)  # both poles beyond 1/h


def test_rate_limit_refit_from_a_stiff_overdamped_nominal_servo():
    """A nominal fit can absorb a rate limit into a heavily overdamped servo (seed-223
    case_059: 2000 rad/s at damping 64, one pole at 15.7 1/s and one at 2.6e5).  The null
    refit started there simulated NaN (RK4 diverges on the fast pole), so every
    candidate's evidence against it was NaN and the blind case answered ``none``.  From
    that servo the null's error must be finite and the rate found."""
    from jaxgwo._diagnose import _time_pairs
    from jaxgwo._diagnose_which import ModelSpec, fit_nonlinear_candidates

    train, _val = _case("rate_limit", seed=4, rate=1.8)
    tt = _time_pairs(train, "lateral", SETTINGS.identify)
    stiff = np.array(MODEL.to_array(), float)
    stiff[3:] = 2000.0, 64.0
    fit, null = fit_nonlinear_candidates(ModelSpec(stiff), tt, ["rate_limit"], key=jax.random.key(0),
                                         wolves=12, iterations=15, include_null=True)  # fmt: skip
    assert math.isfinite(null.train_mse)
    assert abs(fit.params["rate_limit"]["rate"] / 1.8 - 1.0) < 0.1
    assert null.train_mse > 1.05 * fit.train_mse


@pytest.mark.parametrize("effect, value", [("null", 1.0), ("rate_limit", 0.5), ("saturation", 0.6)])
def test_nonlinear_error_gradient_matches_forward_mode(effect, value):
    """The polish's batched central-difference gradient against jax.jacfwd through the
    same simulation, with and without a nonlinearity acting: within 1e-6 of the largest
    component (1e-9 seen here; where a limit switches within the difference step on some
    samples the two can differ by more, 3e-5 seen on a blind case)."""
    from jaxgwo._diagnose import _time_pairs
    from jaxgwo._diagnose_which import ModelSpec, _nl_value_and_grad, nonlinear_objectives

    train, _val = _case(None, seed=2)
    tt = _time_pairs(train, "lateral", SETTINGS.identify)
    _k, tau, m, ws, zs = (float(v) for v in MODEL.to_array())
    if effect == "saturation":
        value *= max(float(np.max(np.abs(u))) for _t, u, _o, _y in tt)  # a limit below the input's peaks
    (obj,) = nonlinear_objectives(ModelSpec(MODEL.to_array()), tt, [effect])
    x = jnp.asarray(np.log([value, 0.9 * ws, 1.3 * zs, 1.1 * tau, 0.95 * m]))  # away from the optimum
    val, g = _nl_value_and_grad(obj, x)
    f = lambda v: obj.gain_and_mse(v)[1]  # noqa: E731
    ref = np.asarray(jax.jacfwd(f)(x))
    assert float(val) == pytest.approx(float(f(x)), rel=1e-12)
    assert np.max(np.abs(ref)) > 0
    assert np.max(np.abs(np.asarray(g) - ref)) < 1e-6 * np.max(np.abs(ref))
    if effect != "null":
        assert abs(ref[0]) > 1e-3 * np.max(np.abs(ref))  # the limit acts on these records


def test_output_error_fits_a_constant_per_record_beside_the_gain():
    """Both output-error objectives fit the output gain and one constant per record (the
    records' trim errors): against numpy.linalg.lstsq with those columns, on two records
    of different length (padding); a different shift of each record's output moves
    neither the gain nor the error (it did before: the shift's square was error); and the
    residual vector the Levenberg-Marquardt steps use squares to that error."""
    from jaxgwo._diagnose_which import (LinearOutputError, ModelSpec, _output_residual_vector, _padded,
                                        nonlinear_objectives, simulate_model)  # fmt: skip

    t = np.arange(int(20 * FS)) / FS
    u = np.asarray(frequency_sweep(jnp.asarray(t), f_start_hz=0.3, f_stop_hz=8, duration_s=18, amplitude=0.1, start_s=1))
    rng = np.random.default_rng(5)
    y = simulate_model(ModelSpec(MODEL.to_array()), t, u) + 0.01 * rng.standard_normal(t.size) + 0.003
    o = np.zeros_like(u)
    n1 = int(0.6 * y.size)
    tt = [(t, u, o, y), (t[:n1], u[:n1], o[:n1], 0.8 * y[:n1])]
    shifts = (0.05, -0.04)
    shifted = [(a, b, c, d + k) for (a, b, c, d), k in zip(tt, shifts, strict=True)]
    _k, tau, m, ws, zs = (float(v) for v in MODEL.to_array())
    x_nl = jnp.asarray(np.log([0.5, 0.9 * ws, 1.3 * zs, 1.1 * tau, 0.95 * m]))  # a rate limit that acts
    x_lin = jnp.asarray(np.r_[np.zeros(6), np.log([0.9 * ws, 1.3 * zs, 1.1 * tau, 0.95 * m])])

    def linear(pairs):
        uu, yy, mask, tp, _dt = _padded(pairs, 0.0)
        return LinearOutputError(*(jnp.asarray(v) for v in (uu, yy, mask, tp)), jnp.asarray(float(MODEL.to_array()[0])),
                                 ())  # fmt: skip

    for make, x in ((lambda p: nonlinear_objectives(ModelSpec(MODEL.to_array()), p, ["rate_limit"])[0], x_nl),
                    (linear, x_lin)):  # fmt: skip
        obj = make(tt)
        s = np.asarray(obj.outputs(x))
        mask = np.asarray(obj.mask)
        assert mask[1].sum() == n1 and mask[0].sum() == y.size  # padded
        cols, rhs = [], []
        for r in range(2):
            keep = mask[r] > 0
            one_hot = np.zeros((int(keep.sum()), 2))
            one_hot[:, r] = 1.0
            cols.append(np.column_stack([s[r, keep], one_hot]))
            rhs.append(np.asarray(obj.y)[r, keep])
        a, b = np.concatenate(cols), np.concatenate(rhs)
        sol, res, *_ = np.linalg.lstsq(a, b, rcond=None)
        c, mse = (float(v) for v in obj.gain_and_mse(x))
        assert c == pytest.approx(sol[0], rel=1e-9)
        assert mse == pytest.approx(res[0] / b.size, rel=1e-9)
        c2, mse2 = (float(v) for v in make(shifted).gain_and_mse(x))
        assert (c2, mse2) == pytest.approx((c, mse), rel=1e-9)
        b_sh = b + np.where(a[:, 1] > 0, shifts[0], shifts[1])
        no_constants = np.linalg.lstsq(a[:, :1], b_sh, rcond=None)[1][0] / b.size
        assert no_constants > 1.2 * mse  # the shifts would have been error without the constants
        r = np.asarray(_output_residual_vector(obj, x))
        assert float(np.sum(r**2) / mask.sum()) == pytest.approx(mse, rel=1e-9)


def _hard_stop_servo(u, omega, zeta, rate, limit, substeps=200):
    """Plain NumPy reference of the simulator's servo (:mod:`jaxgwo._simulate`): the velocity
    state stops at ``rate`` and the position at ``limit`` by switching, integrated by
    explicit Euler at ``substeps`` steps per sample; sampled mid-interval."""
    h = 1.0 / FS / substeps
    pos = vel = 0.0
    out = np.zeros(u.size)
    for k, cmd in enumerate(u):
        for j in range(substeps):
            acc = omega * omega * (cmd - pos) - 2.0 * zeta * omega * vel
            if (vel >= rate and acc > 0.0) or (vel <= -rate and acc < 0.0):
                acc = 0.0
            v_out = min(max(vel, -rate), rate)
            d_pos = 0.0 if (pos >= limit and v_out > 0.0) or (pos <= -limit and v_out < 0.0) else v_out
            pos, vel = pos + h * d_pos, vel + h * acc
            if j == substeps // 2 - 1:
                out[k] = min(max(pos, -limit), limit)
    return out


@pytest.mark.parametrize("rate, limit", [(1.0, math.inf), (math.inf, 0.12), (1.5, 0.15)])
def test_nonlinear_servo_against_a_fine_step_reference_of_the_simulators_stops(rate, limit):
    """The diagnosis's servo (four RK4 steps per sample, stops approached at the rate
    1/step) against the simulator's switching stops integrated 50 times finer, on a
    sweep that drives it into them: within 0.3 % rms (0.13-0.19 % here; the switching rule
    at four RK4 steps, which an RK4 step cannot follow across a switch, 0.37-0.49 %)."""
    from jaxgwo._diagnose_which import _nonlinear_servo, _ServoParams

    t = np.arange(int(12 * FS)) / FS
    u = np.asarray(frequency_sweep(jnp.asarray(t), f_start_hz=0.5, f_stop_hz=12, duration_s=10, amplitude=0.2,
                                   start_s=1))  # fmt: skip
    sp = _ServoParams(*(jnp.asarray(v) for v in (40.0, 0.6, rate, limit, 0.0)))
    got = np.asarray(_nonlinear_servo(sp, jnp.asarray(u), 1.0 / FS))
    ref = _hard_stop_servo(u, 40.0, 0.6, rate, limit)
    free = _hard_stop_servo(u, 40.0, 0.6, math.inf, math.inf, substeps=4)
    size = float(rms_error(ref, 0.0 * ref))
    assert float(rms_error(ref, free)) > 0.05 * size  # the stops act
    assert float(rms_error(got, ref)) < 3e-3 * size


def _rk4_servo(u, omega, zeta, rate, limit, width, substeps):
    """Plain-Python reference of the diagnosis's servo rules (:func:`_nonlinear_servo`'s
    docstring): RK4 at ``substeps`` steps per sample, each stop approached at the rate
    ``1/h``, the position clipped to the end stop and followed through a dead band of
    ``width``; the dead band's output after the sub-step that ends mid-sample."""
    h = 1.0 / FS / substeps
    stop = 1.0 / h

    def deriv(pos, vel, cmd):
        acc = omega * omega * (cmd - pos) - 2.0 * zeta * omega * vel
        acc = min(max(acc, stop * (-rate - vel)), stop * (rate - vel))
        v_out = min(max(vel, -rate), rate)
        return min(max(v_out, stop * (-limit - pos)), stop * (limit - pos)), acc

    pos = vel = swash = 0.0
    out = np.zeros(u.size)
    for k, cmd in enumerate(u):
        for j in range(substeps):
            k1 = deriv(pos, vel, cmd)
            k2 = deriv(pos + 0.5 * h * k1[0], vel + 0.5 * h * k1[1], cmd)
            k3 = deriv(pos + 0.5 * h * k2[0], vel + 0.5 * h * k2[1], cmd)
            k4 = deriv(pos + h * k3[0], vel + h * k3[1], cmd)
            pos += (h / 6.0) * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0])
            vel += (h / 6.0) * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1])
            end = min(max(pos, -limit), limit)
            swash = min(max(swash, end - 0.5 * width), end + 0.5 * width)
            if j == substeps // 2 - 1:
                out[k] = swash
    return out


def test_batched_servo_equals_the_single_one_with_every_stop_and_the_dead_band():
    """The servo vmapped over rows (its RK4 sub-steps a loop, the mid-sample position picked
    inside it) against the single simulation (sub-steps unrolled) row by row, and both
    against a plain-Python RK4 of the same rules (:func:`_rk4_servo`): the rate limit, the
    end stop and the backlash's dead band acting, at two sub-step counts (so two
    different sub-steps end mid-sample)."""
    from jaxgwo._diagnose_which import _nonlinear_servo, _ServoParams

    t = np.arange(int(6 * FS)) / FS
    u = np.asarray(frequency_sweep(jnp.asarray(t), f_start_hz=0.5, f_stop_hz=8, duration_s=5, amplitude=0.2, start_s=0.5))
    rows = np.array([[40.0, 0.6, 1.5, 0.15, 0.02], [30.0, 0.4, math.inf, 0.1, 0.0], [45.0, 0.7, 0.8, math.inf, 0.01]])
    for substeps in (4, 6):
        sp = _ServoParams(*(jnp.asarray(rows[:, i]) for i in range(5)))
        batch = np.asarray(jax.vmap(lambda s: _nonlinear_servo(s, jnp.asarray(u), 1.0 / FS, substeps))(sp))  # noqa: B023
        for row, got in zip(rows, batch):
            one = np.asarray(_nonlinear_servo(_ServoParams(*(jnp.asarray(v) for v in row)), jnp.asarray(u), 1.0 / FS,
                                              substeps, one=True))  # fmt: skip
            size = float(np.max(np.abs(one)))
            assert size > 0.05 and np.max(np.abs(got - one)) < 1e-13 * size, (substeps, row)
            ref = _rk4_servo(u, *row, substeps=substeps)
            assert np.max(np.abs(got - ref)) < 1e-12 * size, (substeps, row)
            free = _rk4_servo(u, *row[:2], math.inf, math.inf, 0.0, substeps=substeps)
            assert np.max(np.abs(free - ref)) > 0.05 * size, (substeps, row)  # the stops and band act


@pytest.mark.parametrize("effect, value", [("rate_limit", 1.0), ("rate_limit", 2.0), ("saturation", 0.09)])
def test_model_with_a_servo_nonlinearity_follows_the_simulator(effect, value):
    """The diagnosis's model of a paper plant with a rate limit or saturation
    (:func:`simulate_model`) against the simulator's noise-free, gust-free output of the
    same plant on a 0.3-15 Hz sweep (its stops switch, at 1 ms RK4 steps): within 0.4 %
    rms (0.20-0.27 % for these rate limits, 0.13 % for the saturation; the switching
    stops at the model's four steps per sample, 0.53-0.68 % for the rate limits)."""
    from jaxgwo._diagnose import _time_pairs
    from jaxgwo._diagnose_which import ModelSpec, simulate_model

    n = int(30 * FS)
    t = jnp.arange(n, dtype=jnp.float64) / FS
    u = frequency_sweep(t, f_start_hz=0.3, f_stop_hz=15, duration_s=25, amplitude=0.15, start_s=2)
    plant = PaperPlant.default()
    name = {"rate_limit": "rate", "saturation": "limit"}[effect]
    calm = Disturbance(gust_rms=0.0, snr_db=math.inf)

    def run(eff):
        rec = simulate(plant, jnp.stack([u, 0.0 * u], 1), jax.random.key(0), sample_rate_hz=FS, disturbance=calm,
                       effects=eff).to_record()  # fmt: skip
        return _time_pairs([rec], "lateral", SETTINGS.identify)[0]

    tt, uu, _o, y = run(EffectSet().with_effect(effect, **{name: value}))
    *_r, y_free = run(EffectSet())
    model = simulate_model(ModelSpec(np.asarray(plant.lateral), {effect: {name: value}}), tt, uu)
    size = float(rms_error(y, 0.0 * y))
    assert float(rms_error(y, y_free)) > 0.05 * size  # the nonlinearity acts
    assert float(rms_error(model, y)) < 4e-3 * size


@pytest.mark.parametrize("effect", ["rate_limit", "saturation"])
def test_nonlinear_error_has_no_steps_where_samples_reach_a_stop(effect):
    """The output error of a rate limit or saturation is continuous in its parameters:
    along 40 steps of 1e-6 in the log of the limit, where it acts, no step of the error
    is more than twice the median one.  A stop that switches the servo's derivative
    instead puts a jump wherever a sample's RK4 stage crosses it (the switching rule this
    model used before: x70 the median step for this rate limit; this saturation window
    held no jump under either rule), and central differences across a jump misread the
    gradient (the polish's and Levenberg-Marquardt's)."""
    from jaxgwo._diagnose import _time_pairs
    from jaxgwo._diagnose_which import ModelSpec, nonlinear_objectives

    train, _val = _case("rate_limit", seed=4, rate=1.8)
    tt = _time_pairs(train, "lateral", SETTINGS.identify)
    value = 1.8 if effect == "rate_limit" else 0.7 * max(float(np.max(np.abs(u))) for _t, u, _o, _y in tt)
    (obj,) = nonlinear_objectives(ModelSpec(MODEL.to_array()), tt, [effect])
    _k, tau, m, ws, zs = (float(v) for v in MODEL.to_array())
    x = np.log([value, ws, zs, tau, m])
    xs = np.repeat(x[None], 41, 0)
    xs[:, 0] += 1e-6 * np.arange(41)
    f = np.asarray(jax.jit(jax.vmap(lambda v: obj.gain_and_mse(v)[1]))(jnp.asarray(xs)))
    steps = np.abs(np.diff(f))
    assert f[0] - f[-1] != 0.0  # the limit acts
    assert np.max(steps) < 2.0 * np.median(steps)


def test_nonlinear_levenberg_marquardt_against_scipys_least_squares():
    """The batched Levenberg-Marquardt refinement of the nonlinear refit (:func:`_nl_lm`,
    central-difference Jacobian, two rows in one ``vmap``) against scipy's trust-region
    least squares with jax.jacfwd's Jacobian, both started at the same points with the
    servo and rotor term 10-20 % off.  Without a nonlinearity the error surface is smooth
    and both must reach the same optimum.  With a rate limit (started 15 % high) each
    sample where the limit starts or stops acting puts a kink in the surface, and local
    methods stop at slightly different kinks (here 0.3 % apart in error, the rate 0.4 %);
    the refinement must still land on the rate and within 1 % of scipy's error."""
    from scipy.optimize import least_squares

    from jaxgwo import _gwo as G
    from jaxgwo._diagnose import _time_pairs
    from jaxgwo._diagnose_which import ModelSpec, _nl_lm, _nl_mse, _output_residual_vector, nonlinear_objectives

    train, _val = _case("rate_limit", seed=4, rate=1.8)
    tt = _time_pairs(train, "lateral", SETTINGS.identify)
    _k, tau, m, ws, zs = (float(v) for v in MODEL.to_array())
    objs = nonlinear_objectives(ModelSpec(MODEL.to_array()), tt, ["null", "rate_limit"])
    x0 = np.log([[1.0, 1.1 * ws, 0.8 * zs, 0.9 * tau, 1.1 * m],
                 [1.8 * 1.15, 0.9 * ws, 1.2 * zs, 1.1 * tau, 0.9 * m]])  # fmt: skip
    lo, hi = x0 - 1.0, x0 + 1.0
    lo[0, 0], hi[0, 0] = x0[0, 0], x0[0, 0]  # the null's value does nothing: held
    xs, fs = (np.asarray(v) for v in _nl_lm(G.stack_objectives(objs), jnp.asarray(x0), jnp.asarray(lo),
                                            jnp.asarray(hi)))  # fmt: skip
    refs = []
    for obj, a, lo_i, hi_i in zip(objs, x0, lo, hi):
        free = hi_i > lo_i

        def res(v, obj=obj, a=a, free=free):
            return _output_residual_vector(obj, jnp.asarray(a).at[np.flatnonzero(free)].set(v))

        jac = lambda v, res=res: np.asarray(jax.jacfwd(res)(jnp.asarray(v)))  # noqa: E731
        ref = least_squares(lambda v, res=res: np.asarray(res(jnp.asarray(v))), a[free], jac=jac,
                            bounds=(lo_i[free], hi_i[free]), method="trf", x_scale="jac", xtol=1e-12, ftol=1e-14)  # fmt: skip
        refs.append((np.r_[a[~free], ref.x], _nl_mse(obj, np.r_[a[~free], ref.x])))
    for obj, a, x, f in zip(objs, x0, xs, fs):
        assert f == pytest.approx(_nl_mse(obj, x), rel=1e-12)
        assert f < 0.9 * _nl_mse(obj, a)
    (x_null, f_null), (_x_rate, f_rate) = refs
    assert fs[0] == pytest.approx(f_null, rel=1e-6)
    np.testing.assert_allclose(xs[0], x_null, atol=1e-4)
    assert fs[1] < 1.01 * f_rate
    assert abs(math.exp(xs[1, 0]) / 1.8 - 1.0) < 0.02


def test_rate_profile_points_against_a_sines_rate_distribution():
    """The rate limit's profile points are the rates the null refit's servo exceeds on given
    fractions of the samples.  For a sine through a linear servo the rate is a sinusoid of
    amplitude ``R = w A |G(jw)|``, exceeded in magnitude on the fraction
    ``(2/pi) arccos(r/R)`` of the time: the points are ``R cos(pi f / 2)``."""
    from jaxgwo._diagnose_which import _RATE_FRACTIONS, ModelSpec, _rate_profile, nonlinear_objectives

    _k, tau, m, ws, zs = (float(v) for v in MODEL.to_array())
    t = np.arange(int(120 * FS)) / FS
    w, a = 2 * np.pi * 2.0 * math.sqrt(1.01), 0.1  # incommensurate with the sampling: every phase sampled
    u = a * np.sin(w * t)
    (obj,) = nonlinear_objectives(ModelSpec(MODEL.to_array()), [(t, u, None, u)], ["null"])
    x_null = np.log([1.0, ws, zs, tau, m])
    pts = np.exp(_rate_profile(obj, x_null, (math.log(1e-3), math.log(1e3)), 9))
    g = ws**2 / abs(ws**2 - w**2 + 2j * zs * ws * w)
    f = np.geomspace(*_RATE_FRACTIONS, 9)
    ref = np.sort(w * a * g * np.cos(np.pi * f / 2))
    np.testing.assert_allclose(pts, ref, rtol=0.01)  # the start-up transient and sampling: 0.3 % seen
    assert np.all(np.diff(pts) > 0)
    # and the box clips them
    clipped = np.exp(_rate_profile(obj, x_null, (math.log(pts[2]), math.log(pts[6])), 9))
    np.testing.assert_allclose(clipped, np.clip(pts, pts[2], pts[6]), rtol=1e-12)


def test_nonlinear_objective_keeps_the_base_models_gyro_filters():
    """With a structural mode and a gyro filter in the base model, the nonlinear output
    error simulates them after the rotor term: without a nonlinearity acting its output is
    the linear chain servo x rotor x filters, checked against scipy.signal.lsim."""
    import scipy.signal

    from jaxgwo._diagnose import _time_pairs
    from jaxgwo._diagnose_which import ModelSpec, nonlinear_objectives

    train, _val = _case(None, seed=2)
    (t, u, _o, _y), *_ = _time_pairs(train, "lateral", SETTINGS.identify)
    k, tau, m, ws, zs = (float(v) for v in MODEL.to_array())
    eff = {"structural_mode": {"freq_hz": 9.0, "zeta_p": 0.15, "zeta_z": 1.5}, "sensor_lag": {"cutoff_hz": 12.0}}
    (obj,) = nonlinear_objectives(ModelSpec(np.array([k, tau, m, ws, zs]), eff), [(t, u, None, u)], ["null"])
    assert obj.filtered
    x = np.log([1.0, ws, zs, tau, m])  # the null refit's value coordinate is unused
    got = np.asarray(obj.outputs(jnp.asarray(x)))[0, : u.size]
    wn, wc = 2 * np.pi * 9.0, 2 * np.pi * 12.0
    num = np.polymul([k * ws * ws * wc], [1.0, 2 * 1.5 * wn, wn * wn])
    den = np.polymul(np.polymul(np.polymul([1.0, 1.0 / tau, m], [1.0, 2 * zs * ws, ws * ws]), [1.0, wc]),
                     [1.0, 2 * 0.15 * wn, wn * wn])  # fmt: skip
    _t, ref, _x = scipy.signal.lsim((num, den), u, t, interp=False)  # the input is held, as the servo holds it
    scale = np.max(np.abs(ref))
    assert scale > 0.1
    # the servo's RK4 sampled mid-interval and held into the rest against lsim's exact chain: 0.5 %
    assert np.max(np.abs(got - ref)) < 5e-3 * scale
    # and the unfiltered objective misses the filters by far more
    (plain,) = nonlinear_objectives(ModelSpec(np.array([k, tau, m, ws, zs])), [(t, u, None, u)], ["null"])
    assert np.max(np.abs(np.asarray(plain.outputs(jnp.asarray(x)))[0, : u.size] - ref)) > 0.05 * scale


def test_linear_output_error_matches_scipy_lsim():
    """The time-domain check's model with every linear effect at once: the held input
    delayed (zero before the record), then servo x rotor with a flapping lag x gyro filter
    x structural mode, against scipy.signal.lsim of the same product driven by the held
    input on a grid ten times finer, where the 23 ms delay is a whole number of steps."""
    from _references import lsim_of_delayed_held_input

    from jaxgwo._diagnose import _time_pairs
    from jaxgwo._diagnose_which import FREQUENCY_DOMAIN

    train, _val = _case(None, seed=2)
    (t, u, _o, _y), *_ = _time_pairs(train, "lateral", SETTINGS.identify)
    k, tau, m, ws, zs = (float(v) for v in MODEL.to_array())
    d, fc, tf, fn, zp, zz = 0.023, 12.0, 0.02, 9.0, 0.15, 0.4
    obj = _one_record_objective(t, u, k, FREQUENCY_DOMAIN)
    x = np.r_[d, np.log(fc), tf, np.log([fn, zp, zz]), np.log([ws, zs, tau, m])]
    got = np.asarray(obj.outputs(jnp.asarray(x)))[0]
    wn, wc = 2 * np.pi * fn, 2 * np.pi * fc
    num = np.polymul([k * ws * ws * wc], [1.0, 2 * zz * wn, wn * wn])
    rotor = np.polyadd(np.polymul([1.0, 1.0 / tau, 0.0], [tf, 1.0]), [m])
    den = np.polymul(np.polymul(np.polymul(rotor, [1.0, 2 * zs * ws, ws * ws]), [1.0, wc]), [1.0, 2 * zp * wn, wn * wn])
    ref = lsim_of_delayed_held_input(num, den, t, u, d, fine=10)  # 23 ms: 23 fine steps
    scale = np.max(np.abs(ref))
    assert scale > 0.1
    assert np.max(np.abs(got - ref)) < 1e-8 * scale
    # and the delay alone moves it by far more
    x0 = x.copy()
    x0[0] = 0.0
    assert np.max(np.abs(np.asarray(obj.outputs(jnp.asarray(x0)))[0] - ref)) > 0.05 * scale


def test_model_with_a_delay_holds_the_delayed_input_as_the_output_error_refit_does():
    """``simulate_model`` of a linear model with a 23 ms delay (the held-out records'
    prediction of a ``time_delay`` candidate) against scipy.signal.lsim of the held input
    delayed on a grid ten times finer, and against the time-domain check's
    ``LinearOutputError`` at the same parameters: the fitted and the scored model agree.
    Linear interpolation of the delayed samples, the form it used before, is off by far
    more."""
    from _references import lsim_of_delayed_held_input

    from jaxgwo._diagnose import _time_pairs
    from jaxgwo._diagnose_which import _Z_NEUTRAL, ModelSpec, simulate_model
    from jaxgwo._models import simulate_transfer_function

    train, _val = _case(None, seed=2)
    (t, u, _o, _y), *_ = _time_pairs(train, "lateral", SETTINGS.identify)
    k, tau, m, ws, zs = (float(v) for v in MODEL.to_array())
    d, fc = 0.023, 12.0
    spec = ModelSpec(np.asarray(MODEL.to_array(), float), {"time_delay": {"delay_s": d}, "sensor_lag": {"cutoff_hz": fc}})
    wc = 2 * np.pi * fc
    num = [k * ws * ws * wc]
    den = np.polymul(np.polymul([1.0, 1.0 / tau, m], [1.0, 2 * zs * ws, ws * ws]), [1.0, wc])
    ref = lsim_of_delayed_held_input(num, den, t, u, d, fine=10)
    scale = np.max(np.abs(ref))
    assert scale > 0.1
    got = simulate_model(spec, t, u)
    assert np.max(np.abs(got - ref)) < 1e-8 * scale
    obj = _one_record_objective(t, u, k, ("time_delay", "sensor_lag"))
    z = _Z_NEUTRAL.copy()
    z[0], z[1] = d, np.log(fc)
    fitted = np.asarray(obj.outputs(jnp.asarray(np.r_[z, np.log([ws, zs, tau, m])])))[0]
    assert np.max(np.abs(got - fitted)) < 1e-8 * scale
    interpolated = np.asarray(simulate_transfer_function(num, den, t, np.interp(t - d, t, u, left=0.0)))
    assert np.max(np.abs(interpolated - ref)) > 1e-4 * scale


def test_nonlinear_model_with_gyro_filters_simulates_as_it_is_fitted():
    """``simulate_model`` of a model with a servo nonlinearity and gyro-side filters (a
    structure finding's 2 Hz pair, a 12 Hz sensor lag; the held-out prediction of a
    nonlinear candidate on an R-50): with the nonlinearity inactive it must match the
    linear branch's exact ZOH simulation of the same model, and it must be what
    ``NonlinearOutputError`` fits.  Filtering the rotor output in a second ZOH simulation,
    the form it had before, lagged half a sample more and was 6.5 % of the peak off."""
    from jaxgwo._diagnose import _time_pairs
    from jaxgwo._diagnose_which import ModelSpec, nonlinear_objectives, simulate_model

    train, _val = _case(None, seed=2)
    tt = _time_pairs(train, "lateral", SETTINGS.identify)
    t, u, _o, _y = tt[0]
    p = np.asarray(MODEL.to_array(), float)
    filters = {"structural_mode": {"freq_hz": 2.0, "zeta_p": 0.2, "zeta_z": 0.8}, "sensor_lag": {"cutoff_hz": 12.0}}
    linear = simulate_model(ModelSpec(p, filters), t, u)
    scale = np.max(np.abs(linear))
    inactive = simulate_model(ModelSpec(p, filters | {"saturation": {"limit": 100.0}}), t, u)
    assert np.max(np.abs(inactive - linear)) < 2e-3 * scale  # the RK4 servo against the exact one
    rate = simulate_model(ModelSpec(p, filters | {"rate_limit": {"rate": 1.0}}), t, u)
    (obj,) = nonlinear_objectives(ModelSpec(p, filters), tt, ["rate_limit"])
    _k, tau, m, ws, zs = p
    fitted = np.asarray(obj.outputs(jnp.asarray(np.log([1.0, ws, zs, tau, m]))))[0]
    assert np.max(np.abs(rate - fitted)) < 1e-10 * scale
    assert np.max(np.abs(rate - linear)) > 0.05 * scale  # the limit acts


def test_time_domain_mode_check_finds_a_mode_its_j_start_misses():
    """The output-error refit of a ``structural_mode`` from the ``J`` fit's start alone (a
    broad pair at 4.5 Hz, where seed-89 case_033's ``J`` fit landed) stops at 6.4 Hz for a
    9 Hz mode at damping 0.04; with the diagnosis's extra starts
    (:func:`_time_domain_mode_starts`, servo and rotor from the null refit, here the true
    ones), of which only the one closest to the records is refined, it lands within 2 %
    and fits the records better."""
    from jaxgwo._diagnose import _time_domain_mode_starts, _time_pairs
    from jaxgwo._diagnose_which import _Z_NEUTRAL, ModelSpec, refit_linear_time_domain

    train, _val = _case("structural_mode", seed=0, freq_hz=9.0, zeta_p=0.04, zeta_z=0.13)
    tt = _time_pairs(train, "lateral", SETTINGS.identify)
    _k, tau, m, ws, zs = (float(v) for v in MODEL.to_array())
    z = _Z_NEUTRAL.copy()
    z[3:6] = np.log([4.5, 0.16, 0.18])
    j_start = np.r_[z, np.log([ws, zs, tau, m])]
    base = ModelSpec(MODEL.to_array())
    alone = refit_linear_time_domain(base, tt, ("structural_mode",), [j_start])
    both = refit_linear_time_domain(base, tt, ("structural_mode",), [j_start],
                                    screened=_time_domain_mode_starts(j_start))
    assert abs(alone.params["structural_mode"]["freq_hz"] / 9.0 - 1.0) > 0.1
    assert abs(both.params["structural_mode"]["freq_hz"] / 9.0 - 1.0) < 0.02
    assert both.train_mse < alone.train_mse


@pytest.mark.parametrize("effect, truth", [("sensor_lag", 6.0), (None, None)])
def test_linear_time_domain_check_finds_a_gyro_filter_and_passes_nothing_without_one(effect, truth):
    """The time-domain check of a linear candidate: from a start far off (cutoff 20 Hz on
    the true paper parameters) the output-error refit finds a 6 Hz gyro filter within 10 %
    and cuts the null refit's error significantly; on the same flight without a filter the
    refit cannot cut it significantly (the F-test is what lets it decide)."""
    from jaxgwo._diagnose import _time_pairs
    from jaxgwo._diagnose_which import ModelSpec, f_test_p, fit_nonlinear_candidates, refit_linear_time_domain

    train, _val = _case(effect, seed=5, **({} if effect is None else {"cutoff_hz": truth}))
    tt = _time_pairs(train, "lateral", SETTINGS.identify)
    p = np.asarray(MODEL.to_array(), float)
    base = ModelSpec(p)
    (null,) = fit_nonlinear_candidates(base, tt, [], key=jax.random.key(0), include_null=True, **NL_SMALL)
    x0 = np.r_[0.0, np.log(20.0), 0.0, np.log(10.0), 0.0, 0.0, np.log([p[3], p[4], p[1], p[2]])]
    fit = refit_linear_time_domain(base, tt, ("sensor_lag",), [x0])
    n = sum(y.size for *_r, y in tt) * 0.01 / 0.1
    pval = f_test_p(null.train_mse, fit.train_mse, 1, n - 5)
    if effect is None:
        assert pval > 1e-2
    else:
        assert abs(fit.params["sensor_lag"]["cutoff_hz"] / truth - 1.0) < 0.1
        assert pval < 1e-6
        assert null.train_mse > fit.train_mse


# -- ranking on fixed blind cases, the report, the CLI -----------------------------------------


@functools.cache
def _delay_records():
    """A 30 ms delay's TRAIN and VAL records (the delay test diagnoses them, the CLI test
    runs its own diagnosis on them)."""
    return _case("time_delay", seed=1, delay_s=0.03)


def _check_stages(stages, structure: bool):
    """The progress calls of one diagnosis: in order, ending done, the re-ranking stage only with a structure finding."""
    done = [i for i, _note in stages]
    assert done[0] == 0 and done == sorted(done)
    assert stages[-1] == (len(DIAGNOSE_STAGES), "done")
    assert set(done) == set(range(len(DIAGNOSE_STAGES) + 1)) - (set() if structure else {3})
    assert any("time domain" in note for _i, note in stages)  # the nonlinear refits announce themselves


def test_time_delay_case_is_found_estimated_and_reported():
    """The delay found and estimated, and the stable JSON report of the same diagnosis
    (one test: pytest-xdist's ``loadgroup``, which kept two tests sharing this diagnosis
    in one worker, no longer groups under pytest 9.2, pytest-xdist issue 1386)."""
    train, val = _delay_records()
    stages: list[tuple[int, str]] = []
    d = diagnose(train, val, "lateral", SETTINGS, progress=lambda done, note: stages.append((done, note)))
    assert d.verdict == "time_delay"
    top = d.ranking[0]
    assert abs(top.params["time_delay"]["delay_s"] - 0.03) < 0.003  # the issue's 3 ms target
    assert top.beats_noise and top.gap_closed > 0.2 and top.val_r2 > d.nominal_r2
    # J falls to the noise level of the same data without an effect (about 3 here)
    assert top.cost_J < 0.1 * d.nominal_cost_J
    assert d.mismatch.equivalent_delay_s > 0.0  # the nominal model leaves residual phase lag
    assert d.combined is not None and d.combined.effects[0] == "time_delay"
    _check_stages(stages, structure=False)
    # the summary quotes the delay and its (often sub-millisecond) bound to 0.1 ms
    ms, sig_ms = 1e3 * top.params["time_delay"]["delay_s"], 1e3 * top.sigma["time_delay"]["delay_s"]
    assert f"time_delay = {ms:.1f} ms (+-{sig_ms:.1f})" in d.summary()
    assert "model-form bias" not in d.summary()  # no structure finding: the model form is the plant's
    assert "the airframe's own included" not in d.summary()  # the coupling caveat: coupling verdicts only
    # the delay is the inverse-variance mean of the J fit's and the output-error refit's readings
    det = top.detail
    w = np.array([det["j_sigma_delay_s"], det["td_sigma_delay_s"]]) ** -2.0
    mean = float(np.average([det["j_delay_s"], det["td_delay_s"]], weights=w))
    assert top.params["time_delay"]["delay_s"] == pytest.approx(mean, rel=1e-9)
    assert top.sigma["time_delay"]["delay_s"] == pytest.approx(det["delay_scale_factor"] / math.sqrt(w.sum()))
    assert "The delay is the inverse-variance mean of the frequency-domain fit's reading" in d.summary()
    _check_json_report_schema(d)
    # the summary sets the null refit (no effect) beside the verdict's model: below it, level
    # with it to the 3 quoted decimals, above it
    assert top.val_r2 - d.nominal_r2 > 0.004
    for v, phrase in (((d.nominal_r2 + top.val_r2) / 2, None), (top.val_r2 + 4e-4, "do not tell that refit"),
                      (top.val_r2 + 3e-3, "better than the model with the effect")):  # fmt: skip
        text = dataclasses.replace(d, refit=dataclasses.replace(d.refit, val_r2=v)).summary()
        assert f"no effect added (the null the time-domain candidates are tested against), gives R^2 {v:.3f}" in text
        for p in ("do not tell that refit", "better than the model with the effect"):
            assert (p in text) == (p == phrase)
    # a candidate that passed against the null refit alone, below the nominal (made up here):
    # the summary says why the nominal predicts better and quotes the refit
    rf = dataclasses.replace(d.refit, val_r2=d.nominal_r2 - 0.02)
    for flag in (0.0, 1.0):
        low = dataclasses.replace(top, val_r2=d.nominal_r2 - 0.01, gap_closed=-0.2,
                                  detail=top.detail | {"confirmed_against_null_refit_only": flag})  # fmt: skip
        text = dataclasses.replace(d, ranking=(low, *d.ranking[1:]), refit=rf).summary()
        assert f"Adding it lowers the held-out R^2 ({d.nominal_r2:.3f} -> {low.val_r2:.3f}" in text
        assert f"gives R^2 {rf.val_r2:.3f}." in text
        assert ("model-form error, not the effect's" in text) == bool(flag)
        assert ("the held-out records do not confirm it" in text) == (not flag)
    # a band up to the analysed top where the coherence is lost (made up here) is named
    top_hz = float(np.max(d.response_w)) / (2.0 * np.pi)
    for bands, named in (([[0.2, 0.3], [0.6 * top_hz, top_hz]], True), ([[0.2, 0.3]], False), ([], False)):
        text = dataclasses.replace(d, noise_limited_bands_hz=bands).summary()
        assert (f"Above {0.6 * top_hz:.3g} Hz (to the analysed {top_hz:.3g} Hz) the coherence is too low" in text) == named
    # a verdict the held-out records carried (score_candidate's held_out_alpha; made up here)
    for flag in (0.0, 1.0):
        held = dataclasses.replace(top, detail=top.detail | {"passed_on_held_out_records": flag})
        text = dataclasses.replace(d, ranking=(held, *d.ranking[1:])).summary()
        assert (f"The held-out records carry its evidence (z {top.z_score:.1f})" in text) == bool(flag)
    # a nonlinearity ranked over an airframe pair (_nonlinearity_over_pair; made up here)
    for over in ({}, {"J_over_pair_J": 0.34, "over_pair_freq_hz": 4.92}):
        text = dataclasses.replace(d, ranking=(dataclasses.replace(top, detail=top.detail | over), *d.ranking[1:])).summary()
        assert ("a broad pole pair near 4.92 Hz (real zeros) also beats noise" in text) == bool(over)
        assert ("whose J is 0.34 times the pair's" in text) == bool(over)


def _paper_lsim(params: dict, t, u):
    """scipy.signal.lsim (zero-order hold) of the paper model, eqs. 15-16."""
    import scipy.signal

    k, tau, m, ws, zs = (params[n] for n in ("K", "tau", "M", "omega_s", "zeta_s"))
    den = np.polymul([1.0, 1.0 / tau, m], [1.0, 2 * zs * ws, ws * ws])
    return scipy.signal.lsim(([k * ws * ws], den), u, t, interp=False)[1]


def _r2_about_record_means(ys, ps):
    """Held-out R^2 (eq. 46) by plain NumPy over records ``ys`` and predictions ``ps``, a
    constant fitted to each record's residual and the null model taken about each record's
    mean, as the diagnosis scores every held-out prediction (``held_out_centred``)."""
    r = np.concatenate([y - p - np.mean(y - p) for y, p in zip(ys, ps, strict=True)])
    return 1.0 - np.sum(r**2) / sum(np.sum((y - y.mean()) ** 2) for y in ys)


def test_no_effect_case_answers_none():
    """No effect: the verdict is none.  The report also gives the null refit (the paper
    model refitted by output error on TRAIN, no effect added), checked here against
    scipy.signal.lsim of its reported parameters: its held-out R^2 (eq. 46, by hand) and its
    identification error, which is at most the nominal's, both taken about each record's
    mean (the held-out R^2's null model too).  The summary quotes it where it predicts VAL better than the frequency-domain fit."""
    from jaxgwo._diagnose import _time_pairs

    train, val = _case(None, seed=1)
    d = diagnose(train, val, "lateral", SETTINGS)
    assert d.verdict == "none" and not any(c.beats_noise for c in d.ranking)
    assert "No candidate effect beats noise" in d.summary()
    doc = _report_json(d)["time_domain_refit"]
    assert set(doc) == {"params", "effects", "train_mse", "val_r2", "val_tic", "gap_closed"} and doc["effects"] == {}
    pairs = _time_pairs(val, "lateral", SETTINGS.identify)
    r2 = _r2_about_record_means([yv for *_r, yv in pairs],
                                [_paper_lsim(doc["params"], tv, uv) for tv, uv, _o, _y in pairs])
    assert doc["val_r2"] == pytest.approx(r2, abs=1e-6)
    assert doc["gap_closed"] == pytest.approx((r2 - d.nominal_r2) / (1.0 - d.nominal_r2), abs=1e-5)

    def centred_mse(params):
        e = [yt - _paper_lsim(params, tt, ut) for tt, ut, _o, yt in _time_pairs(train, "lateral", SETTINGS.identify)]
        return float(np.mean(np.concatenate([v - v.mean() for v in e]) ** 2))

    assert doc["train_mse"] == pytest.approx(centred_mse(doc["params"]), rel=1e-3)
    assert doc["train_mse"] <= centred_mse(d.nominal_params)
    quoted = f"R^2 {doc['val_r2']:.3f} where its frequency-domain fit gives {d.nominal_r2:.3f}"
    assert (quoted in d.summary()) == (doc["val_r2"] >= d.nominal_r2 + 1e-3)
    from jaxgwo._report import diagnosis_report_html

    assert "Null refit" in diagnosis_report_html(d, figures=False)
    for v in (d.nominal_r2 + 0.01, d.nominal_r2 + 5e-4):  # the summary's two none sentences
        text = dataclasses.replace(d, refit=dataclasses.replace(d.refit, val_r2=v)).summary()
        assert ("That refit is the better model" in text) == (v >= d.nominal_r2 + 1e-3)
        assert ("is what the paper model can do" in text) == (v < d.nominal_r2 + 1e-3)
    # a candidate the identification records support and the held-out records refuse is named
    assert d.unconfirmed == () and _report_json(d)["unconfirmed"] == [] and "Unconfirmed" not in d.summary()
    (mode,) = [c for c in d.ranking if c.effects == ("structural_mode",)]
    for r2, held in ((d.nominal_r2 - 0.01, "predict the held-out records worse"), (d.nominal_r2 + 1e-4, "do not confirm it beyond noise")):
        refused = dataclasses.replace(mode, train_p=2e-5, val_r2=r2, z_score=-1.5, beats_noise=False)
        u = dataclasses.replace(d, ranking=(refused, *[c for c in d.ranking if c is not mode]), unconfirmed=("structural_mode",))
        text = u.summary()
        f = mode.params["structural_mode"]["freq_hz"]
        assert f"Unconfirmed: the identification records support structural_mode freq_hz = {f:.3g}" in text
        assert f"(p 2e-05), but they {held}" in text and f"-> {r2:.3f}, z -1.5)" in text
        assert f"energy near {f:.3g} Hz" in text and _report_json(u)["unconfirmed"] == ["structural_mode"]
    # a time-domain candidate is quoted against the null refit it was tested against
    (rl,) = [c for c in d.ranking if c.effects == ("rate_limit",)]
    worse = d.refit.val_r2 - 0.01
    refused = dataclasses.replace(rl, train_p=2e-5, val_r2=worse, z_score=-2.5, beats_noise=False)
    text = dataclasses.replace(d, ranking=(refused, *[c for c in d.ranking if c is not rl]),
                               unconfirmed=("rate_limit",)).summary()  # fmt: skip
    assert (f"(p 2e-05), but they predict the held-out records worse with it (R^2 {d.refit.val_r2:.3f} -> "
            f"{worse:.3f} against the paper model refitted by output error, z -2.5)") in text


@pytest.mark.slow
def test_an_extra_pole_pair_is_structure_not_an_effect(monkeypatch):
    """A plant with a pole pair the paper model lacks (a 9 Hz mode at damping 0.15 whose
    zeros are real, like an R-50's coupled rotor mode) and no effect: the paper-model
    ranking finds a structural_mode with zero damping far above a resonance's; that is
    reported as structure, kept, and no effect beats noise on top of it, nor a resonance
    fitted beside it, though the lag's and delay's ``J`` F-tests are read at
    ``alpha_lag_on_structure`` there (and at ``alpha`` on the paper model alone)."""
    import jaxgwo._diagnose as D

    levels: dict[tuple[str, ...], set[float]] = {}
    scored = D.score_candidate

    def spy(effects, *a, **kw):
        levels.setdefault(tuple(effects), set()).add(kw["alpha"])
        return scored(effects, *a, **kw)

    monkeypatch.setattr(D, "score_candidate", spy)
    train, val = _case("structural_mode", seed=4, freq_hz=9.0, zeta_p=0.15, zeta_z=1.5)
    stages: list[tuple[int, str]] = []
    d = diagnose(train, val, "lateral", SETTINGS, progress=lambda done, note: stages.append((done, note)))
    assert d.structure is not None
    for lag in (("rotor_flapping",), ("time_delay",)):
        assert levels[lag] == {SETTINGS.alpha, SETTINGS.alpha_lag_on_structure}
    assert levels[("sensor_lag",)] == levels[("structural_mode",)] == {SETTINGS.alpha}
    # a lag named at that level, over a delay shorter than the vocabulary's, says both
    (lag,) = [c for c in d.ranking if c.effects == ("rotor_flapping",)]
    for detail, said in (({"passed_at_structure_level": 1.0, "ranked_over_short_delay_s": 0.0084}, True), ({}, False)):
        won = dataclasses.replace(lag, beats_noise=True, detail=detail)
        text = dataclasses.replace(d, ranking=(won,), verdict="rotor_flapping").summary()
        assert ("passes at the level read beside the airframe's pole pair" in text) == said
        assert ("A time delay of 8.4 ms fits as well or better" in text) == said
    _check_stages(stages, structure=True)
    sm = d.structure.params["structural_mode"]
    assert abs(sm["freq_hz"] - 9.0) < 0.15 * 9.0 and sm["zeta_z"] > SETTINGS.structure_zeta_z
    # broad and above 3 Hz, it was refitted beside the flybar, and that refit did not earn
    # its parameters (alpha_pressed_pair): without the test a 1.9 Hz pair replaced it
    assert "pressed_pair_hz" not in d.structure.detail
    assert d.structure.val_r2 > d.nominal_r2 and d.paper_ranking[0].effects == ("structural_mode",)
    assert d.verdict == "none" and not any(c.beats_noise for c in d.ranking)
    # a resonance is still a candidate, fitted beside the held pair, lightly damped; none here
    (second,) = [c for c in d.ranking if c.effects == ("structural_mode",)]
    assert second.detail["second_pole_pair"] == 1.0 and second.params["structural_mode"]["zeta_p"] <= 0.2 + 1e-9
    # the report gives the airframe pair that candidate's model holds: still the 9 Hz pair
    assert abs(second.detail["pair_freq_hz"] - 9.0) < 0.15 * 9.0 and second.detail["pair_zeta_z"] > 1.0
    doc = _report_json(d)
    assert doc["structure"]["effect"] == "structural_mode" and doc["ranking_paper_model"][0]["effect"] == "structural_mode"
    assert "lacks a pole pair near" in d.summary() and "its zeros are real" in d.summary()
    assert "refits to" not in d.summary()  # no verdict: no resonance beside the pair to name
    # a resonance verdict beside the pair names the pair its model holds where it moved
    sm = d.structure.params["structural_mode"]
    for moved, said in ((1.05, True), (1.005, False)):
        detail = second.detail | {"pair_freq_hz": moved * sm["freq_hz"], "pair_zeta_p": sm["zeta_p"]}
        won = dataclasses.replace(second, beats_noise=True, detail=detail)
        text = dataclasses.replace(d, ranking=(won,), verdict="structural_mode").summary()
        assert (f"Beside it the airframe's pole pair refits to {moved * sm['freq_hz']:.3g} Hz" in text) == said
    from jaxgwo._report import diagnosis_report_html

    assert "Ranked on top of the structure finding" in diagnosis_report_html(d, figures=False)
    # switched off (no structure step: the verdict is the paper-model ranking's top), the
    # same data are blamed on a structural mode
    from jaxgwo._diagnose import _structure_route

    assert d.paper_ranking[0].beats_noise
    assert _structure_route(d.paper_ranking, {("structural_mode",): None}, float("inf"), 1e-3) is None


def test_a_pair_pressed_against_the_vocabulary_floor_is_structure():
    """A plant with a broad pole pair the paper model lacks at 2.5 Hz (damping 0.3, complex
    zeros at 0.6: below the vocabulary's resonances, as an R-50's coupled flapping is) and
    no effect.  The vocabulary's box stops the mode on its 3 Hz floor with complex zeros
    (3.0 Hz, zeros 0.95 here), which is no airframe pair by its zeros; before
    ``_on_vocabulary_floor`` that was the verdict, a ``structural_mode``.  The structure
    step refits it in its wider box: 2.34 Hz, damping 0.33, zeros 0.66, and the verdict
    is none (seed-149 case_044, an R-50 gyro filter, went the same way)."""
    train, val = _case("structural_mode", seed=4, freq_hz=2.5, zeta_p=0.3, zeta_z=0.6)
    d = diagnose(train, val, "lateral", SETTINGS)
    first = d.paper_ranking[0].params["structural_mode"]
    assert d.structure is not None and d.structure.detail.get("found_behind_time_delay") is None
    sm = d.structure.params["structural_mode"]
    assert abs(sm["freq_hz"] - 2.5) < 0.15 * 2.5 and sm["freq_hz"] < 3.0 and abs(sm["zeta_p"] - 0.3) < 0.1
    assert first == sm  # the wider refit replaced the floor fit in the paper-model ranking
    assert d.verdict == "none" and d.structure.val_r2 > d.nominal_r2


@pytest.mark.slow
def test_structure_hidden_behind_a_long_delay_is_found():
    """The extra-pole-pair plant of the test above (9 Hz, damping 0.15, real zeros) with a
    60 ms delay: the delay takes the top place from the mode in the paper-model ranking
    (as on the blind study's R-50 delays), so the mode is fitted on top of the delay, kept
    as structure and the delay estimated again on top of it, within the issue's 3 ms
    (2.4 ms here, 0.6 ms for the delay alone), and most of the held-out gap the delay
    alone leaves is closed.  Not every draw goes so well with this CI-sized optimiser:
    with an 80 ms delay and key 4 the mode lands at 6.7 Hz and the delay at 86 ms
    (held-out R^2 0.991 all the same)."""
    plant = EffectSet().with_effect("structural_mode", freq_hz=9.0, zeta_p=0.15, zeta_z=1.5)
    train, val = _case("time_delay", seed=3, plant_effects=plant, delay_s=0.06)
    stages: list[tuple[int, str]] = []
    d = diagnose(train, val, "lateral", SETTINGS, progress=lambda done, note: stages.append((done, note)))
    assert d.structure is not None and d.structure.detail.get("found_behind_time_delay") == 1.0
    _check_stages(stages, structure=True)
    sm = d.structure.params["structural_mode"]
    assert abs(sm["freq_hz"] - 9.0) < 0.15 * 9.0 and sm["zeta_z"] > SETTINGS.structure_zeta_z
    assert d.paper_ranking[0].effects == ("time_delay",)  # the delay hid the mode from the paper-model ranking
    assert d.verdict == "time_delay"
    top = d.ranking[0]
    assert abs(top.params["time_delay"]["delay_s"] - 0.06) < 0.003
    # the pair is the plant's own: the lead-lag airframe fits J worse, and the delay stays the pair fit's
    assert top.detail["airframe_J_ratio"] > 1.0 and "delay_airframe_s" not in top.detail
    # the mode closes most of the held-out gap the delay alone leaves (0.940 -> 0.992 here)
    alone = d.paper_ranking[0].val_r2
    assert (top.val_r2 - alone) / (1.0 - alone) > 0.5 and top.val_r2 > 0.98
    doc = _report_json(d)
    assert doc["structure"]["detail"]["found_behind_time_delay"] == 1.0
    assert "shows only on top of a time delay" in d.summary()
    assert f"With the extra pole pair + time_delay: R^2 {d.combined.val_r2:.3f}" in d.summary()  # not "structural_mode + "
    assert "model-form bias" in d.summary()  # the bound may understate the extra mode's model-form error


@pytest.mark.slow
def test_a_nominal_that_does_not_simulate_still_gets_finite_time_domain_tests():
    """A 50 ms delay drives the delay-free nominal to a servo of some 5e5 rad/s with
    damping 1e-3, which no simulation survives.  The time-domain fits then start from the
    linear refit that simulates (the delay's), so the null refit, its error and the
    nonlinear candidates' F-tests are finite instead of NaN, and scipy's warning on NaN
    input is not raised; the verdict is the delay's either way."""
    import warnings

    from jaxgwo._diagnose import _simulates, _time_pairs
    from jaxgwo._diagnose_which import NONLINEAR, ModelSpec

    train, val = _case("time_delay", seed=1, delay_s=0.05)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        d = diagnose(train, val, "lateral", SETTINGS)
    p = np.array([d.nominal_params[k] for k in ("K", "tau", "M", "omega_s", "zeta_s")])
    assert not _simulates(ModelSpec(p), _time_pairs(train, "lateral", SETTINGS.identify))  # the case this is about
    assert d.verdict == "time_delay" and abs(d.ranking[0].params["time_delay"]["delay_s"] - 0.05) < 0.003
    nulls = [c.detail["null_train_mse"] for c in d.ranking if "null_train_mse" in c.detail]
    assert len(nulls) >= len(NONLINEAR) and all(np.isfinite(nulls))
    for c in d.ranking:
        if c.effects[0] in NONLINEAR:
            assert np.isfinite(c.detail["train_mse"]) and 0.0 <= c.train_p <= 1.0
    assert not [w for w in caught if "NAN" in str(w.message).upper()], [str(w.message) for w in caught]
    # the report says why the nominal's held-out R^2 reads about 0
    assert not d.nominal_simulates and abs(d.nominal_r2) < 0.01
    assert _report_json(d)["nominal"]["simulates"] is False
    assert "does not simulate" in d.summary()


def test_without_linear_candidates_a_nominal_that_does_not_simulate_still_gets_finite_fits():
    """The same 50 ms delay with only time-domain candidates (``candidates``): no linear
    refit offers a start that simulates, so the paper part of the delay-aware WLS start
    does, for the ranking's fits and for the combined top two (two time-domain effects,
    refitted from that start).  Before, every fit started from the nominal: the
    candidates' held-out predictions and the combined one were not finite (taken as zero,
    R^2 about 0) and scipy warned of NaN input."""
    import warnings

    from jaxgwo._diagnose import _simulates, _time_pairs
    from jaxgwo._diagnose_which import ModelSpec

    train, val = _case("time_delay", seed=1, delay_s=0.05)
    settings = dataclasses.replace(SETTINGS, candidates=("cross_coupling", "rate_limit", "saturation"))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        d = diagnose(train, val, "lateral", settings)
    p = np.array([d.nominal_params[k] for k in ("K", "tau", "M", "omega_s", "zeta_s")])
    assert not _simulates(ModelSpec(p), _time_pairs(train, "lateral", SETTINGS.identify))  # the case this is about
    assert [c.effects[0] for c in d.ranking if c.effects[0] in ("rate_limit", "saturation")]
    for c in d.ranking:
        assert np.all(np.isfinite(np.concatenate(c.predicted))), c.effects
        # a model that simulates predicts most of this record; zero (no prediction) gives R^2 ~ 0
        assert c.val_r2 > 0.5, (c.effects, c.val_r2)
    assert d.combined is not None and len(d.combined.effects) == 2
    assert np.all(np.isfinite(np.concatenate(d.combined.predicted))) and d.combined.val_r2 > 0.5
    assert np.isfinite(d.combined.cost_J)
    assert not [w for w in caught if "NAN" in str(w.message).upper()], [str(w.message) for w in caught]


def test_saturation_case_is_found():
    train, val = _case("saturation", seed=1, limit=0.07)
    d = diagnose(train, val, "lateral", SETTINGS)
    assert d.verdict == "saturation"
    limit = d.ranking[0].params["saturation"]["limit"]
    assert abs(limit - 0.07) < 0.15 * 0.07  # a 6 x 6 IGWO on a 3-D box: 15 %
    assert d.ranking[0].train_p < SETTINGS.alpha


@pytest.mark.slow
def test_an_amplitude_backed_nonlinearity_needs_the_held_out_records_only_not_to_contradict_it(monkeypatch):
    """A saturation the amplitude test corroborates and whose output-error F-test passes at
    ``alpha`` stands on two tests of the identification records (``_amplitude_backed``):
    with every other route that spares it the held-out confirmation shut (no large error
    cut, no ``J`` against the null refit) and that confirmation made impossible
    (``z_min_time`` infinite), it still beats noise, and the summary says the held-out
    records did not confirm it; without the rule it is refused."""
    import jaxgwo._diagnose as D
    from jaxgwo._diagnose import _amplitude_backed

    assert _amplitude_backed(True, 1e-4, 1e-3) and not _amplitude_backed(True, 2e-3, 1e-3)
    assert not _amplitude_backed(False, 1e-30, 1e-3)
    train, val = _case("saturation", seed=1, limit=0.07)
    settings = dataclasses.replace(SETTINGS, candidates=("saturation",), strong_error_ratio=math.inf,
                                   z_min_time=math.inf)  # fmt: skip
    monkeypatch.setattr(D, "_against_null_j", lambda p_mse, p_j_null, *a: (False, p_mse))
    verdicts = {}
    for rule in (True, False):
        if not rule:
            monkeypatch.setattr(D, "_amplitude_backed", lambda *a: False)
        d = diagnose(train, val, "lateral", settings)
        (sat,) = [c for c in d.ranking if c.effects == ("saturation",)]
        assert sat.detail["amplitude_corroborates"] == 1.0 and sat.detail["p_output_error"] < settings.alpha
        assert sat.z_score > settings.z_min and sat.gap_closed > 0.0  # the held-out records do not contradict it
        verdicts[rule] = (sat.beats_noise, d.verdict)
        # the summary tells the user the held-out records did not confirm it, where they did not
        assert sat.detail.get("passed_on_amplitude_backing", 0.0) == float(rule)
        assert ("the held-out records do not confirm it" in d.summary()) == rule
    assert verdicts == {True: (True, "saturation"), False: (False, "none")}


def test_an_amplitude_size_refusal_is_flagged_in_the_detail(monkeypatch):
    """Where ``_amplitude_sizes`` alone refuses a nonlinear candidate its effect size (it
    passed on the amplitude test's backing, so that agreement cannot size it too), the
    candidate's JSON detail says so (``amplitude_refused_as_size``), so that the rule's
    refusals count exactly; where the rule is lifted the same candidate is sized, beats
    noise and carries no flag.  The saturation case of the test above, with every other
    size shut: no error cut counts (``min_error_ratio`` infinite) and the held-out BIC
    route is closed (the fitted limit said not to act on the held-out records)."""
    import jaxgwo._diagnose as D

    train, val = _case("saturation", seed=1, limit=0.07)
    settings = dataclasses.replace(SETTINGS, candidates=("saturation",), strong_error_ratio=math.inf,
                                   z_min_time=math.inf, min_error_ratio=math.inf)  # fmt: skip
    monkeypatch.setattr(D, "_against_null_j", lambda p_mse, p_j_null, *a: (False, p_mse))
    monkeypatch.setattr(D, "nonlinearity_acts", lambda *a: False)
    seen = {}
    for rule in (True, False):
        if not rule:
            monkeypatch.setattr(D, "_amplitude_sizes", lambda corroborated, *a: corroborated)
        d = diagnose(train, val, "lateral", settings)
        (sat,) = [c for c in d.ranking if c.effects == ("saturation",)]
        assert sat.detail["amplitude_corroborates"] == 1.0
        seen[rule] = (sat.detail.get("amplitude_refused_as_size", 0.0), sat.detail["effect_size_passes"],
                      sat.beats_noise)  # fmt: skip
    assert seen == {True: (1.0, 0.0, False), False: (0.0, 1.0, True)}


def test_cross_coupling_sigma_counts_the_regressors_and_residuals_joint_correlation():
    """Monte Carlo reference for the gain's 1-sigma: a slow off-axis stick (0.4 Hz pilot
    corrections) and an independent slow residual (the same process, another key) over
    150 draws.  The spread of the estimates matches Bartlett's bound; the white-residual
    bound sqrt(mean e^2 / sum x^2) is several times too small."""
    from jaxgwo._diagnose_which import ModelSpec, fit_cross_coupling, simulate_model

    n, g_true = 3000, 0.1
    t = np.arange(n) / FS
    base = ModelSpec(np.asarray(MODEL.to_array(), float))
    gains, sig, white = [], [], []
    for i in range(150):
        k1, k2 = jax.random.split(jax.random.key(100 + i))
        u_off = np.asarray(pilot_corrections(k1, n, FS, rms=0.02))
        e = np.asarray(pilot_corrections(k2, n, FS, rms=0.002))
        x = simulate_model(base, t, u_off)
        cc = fit_cross_coupling(base, [(t, np.zeros(n), u_off, g_true * x + e)])
        gains.append(cc.params["cross_coupling"]["gain"])
        sig.append(cc.sigma["cross_coupling"]["gain"])
        white.append(np.sqrt(cc.train_mse / float(x @ x)))
    spread = np.std(gains)
    assert abs(np.mean(gains) - g_true) < 3 * spread / np.sqrt(len(gains))
    assert 0.75 < np.median(sig) / spread < 1.33
    assert np.median(white) / spread < 0.4


def test_coloured_residual_covariance_matches_the_exact_sandwich_of_an_ar1_residual():
    """Two slow, correlated regressors and an AR(1) residual (rho 0.95, two records): the
    least-squares estimate's exact covariance is (X'X)^-1 X' S X (X'X)^-1 with S the AR(1)
    Toeplitz matrix per record (numpy.linalg, from the known process).  The estimate made
    from one draw's fitted residuals lands within 25 % of it in sigma on every draw; the
    white bound is under half of it."""
    from scipy.linalg import toeplitz

    from jaxgwo._diagnose_which import coloured_residual_covariance

    rng = np.random.default_rng(7)
    n, rho, dt = 3000, 0.95, 0.01
    s = toeplitz(rho ** np.arange(n) / (1.0 - rho**2))  # unit innovations
    xs = []
    for _ in range(2):
        a = np.asarray(pilot_corrections(jax.random.key(int(rng.integers(1 << 30))), n, 1.0 / dt, rms=1.0))
        b = np.asarray(pilot_corrections(jax.random.key(int(rng.integers(1 << 30))), n, 1.0 / dt, rms=1.0))
        xs.append(np.stack([a, 0.6 * a + b], axis=1))
    m_inv = np.linalg.inv(sum(x.T @ x for x in xs))
    exact = m_inv @ sum(x.T @ s @ x for x in xs) @ m_inv
    chol = np.linalg.cholesky(s)
    for _draw in range(4):
        es = [chol @ rng.standard_normal(n) for _ in xs]
        theta = m_inv @ sum(x.T @ e for x, e in zip(xs, es))
        res = [e - x @ theta for x, e in zip(xs, es)]
        cov = coloured_residual_covariance(xs, res, dt)
        ratio = np.sqrt(np.diag(cov) / np.diag(exact))
        assert np.all((ratio > 0.75) & (ratio < 1.25)), ratio
        white = np.mean(np.concatenate(res) ** 2) * m_inv
        assert np.all(np.sqrt(np.diag(white) / np.diag(exact)) < 0.5)


def test_cross_coupling_gain_is_not_made_by_trim_errors():
    """No cross-coupling, 40 draws: the off-axis stick is taken relative to its trim (the
    mean of its first 0.5 s, so its mean over the record is not zero) and the residual
    carries a constant the size of a gyro bias or a trim error (+-0.003 rad/s, above the
    slow residual's 0.002 rms).  The gain's z-score keeps unit spread, and the constant
    changes nothing.  Without a constant per record beside the gain the two constants'
    product counted as correlation: the spread was 1.58 (a blind `none` case reached 4.4
    sigma)."""
    from jaxgwo._diagnose_which import ModelSpec, fit_cross_coupling, simulate_model

    n, n0 = 3000, 50
    t = np.arange(n) / FS
    base = ModelSpec(np.asarray(MODEL.to_array(), float))
    z = []
    for i in range(40):
        k1, k2, k3 = jax.random.split(jax.random.key(300 + i), 3)
        u_off = np.asarray(pilot_corrections(k1, n, FS, rms=0.02))
        u_off = u_off - u_off[:n0].mean()
        e = np.asarray(pilot_corrections(k2, n, FS, rms=0.002))
        c = 0.003 * float(jax.random.rademacher(k3, ()))
        cc = fit_cross_coupling(base, [(t, np.zeros(n), u_off, e + c)])
        g, sg = cc.params["cross_coupling"]["gain"], cc.sigma["cross_coupling"]["gain"]
        if i < 3:
            plain = fit_cross_coupling(base, [(t, np.zeros(n), u_off, e)])
            assert g == pytest.approx(plain.params["cross_coupling"]["gain"], rel=1e-9, abs=1e-12)
            assert sg == pytest.approx(plain.sigma["cross_coupling"]["gain"], rel=1e-9)
            # the training error is taken about the record's mean, as the null refit's is: the
            # constant leaves it unchanged
            x = simulate_model(base, t, u_off)
            assert cc.train_mse == pytest.approx(np.mean((e - e.mean() - g * (x - x.mean())) ** 2), rel=1e-9)
            assert cc.train_mse == pytest.approx(plain.train_mse, rel=1e-9)
        z.append(g / sg)
    assert 0.75 < np.std(z) < 1.33
    assert np.max(np.abs(z)) < 4.0


def test_cross_coupling_case_is_found_against_the_time_domain_null_refit():
    """The off-axis stick drives the on-axis plant (gain 0.15).  The gain is fitted on top
    of the null refit (the paper model refitted by output error), whose error it must cut:
    it is the verdict, estimated within 3 sigma, and raises the held-out R^2.  The summary
    says that the gain counts the airframe's own coupling too."""
    train, val = _case("cross_coupling", seed=3, gain=0.15)
    d = diagnose(train, val, "lateral", SETTINGS)
    assert d.verdict == "cross_coupling"
    top = d.ranking[0]
    g, sg = top.params["cross_coupling"]["gain"], top.sigma["cross_coupling"]["gain"]
    assert abs(g - 0.15) < 3 * sg and sg < 0.05
    assert top.train_p < SETTINGS.alpha and top.val_r2 > d.nominal_r2
    # the summary says the gain includes the airframe's own coupling (an R-50's B_lon)
    assert "the airframe's own included" in d.summary()


def test_f_test_against_scipy():
    import scipy.stats

    from jaxgwo._diagnose_which import f_test_p

    assert f_test_p(10.0, 4.0, 2, 30) == pytest.approx(scipy.stats.f.sf((6.0 / 2) / (4.0 / 30), 2, 30), rel=1e-12)
    assert f_test_p(4.0, 5.0, 1, 30) == 1.0  # no reduction: no evidence


def _report_json(d):
    """The JSON report as another tool reads it."""
    return json.loads(json.dumps(d.to_json()))


def test_unconfirmed_candidates_are_named_beside_a_none_verdict_only():
    """``_unconfirmed``: with a ``none`` verdict, the candidates below noise whose
    identification p is below ``alpha``, in ranking order; nothing beside a verdict, and
    a NaN or larger p is no support."""
    from jaxgwo._diagnose import _unconfirmed

    def cand(effect, p):
        return dataclasses.replace(_scored(effect, -1.0, False), train_p=p)

    ranking = (cand("cross_coupling", 0.01), cand("rate_limit", 1e-5), cand("backlash", float("nan")),
               cand("structural_mode", 9e-4), cand("saturation", 1e-3))  # fmt: skip
    assert _unconfirmed(ranking, "none", 1e-3) == ("rate_limit", "structural_mode")
    assert _unconfirmed(ranking, "none", 0.05) == ("cross_coupling", "rate_limit", "structural_mode", "saturation")
    assert _unconfirmed(ranking, "rate_limit", 1e-3) == ()
    # a broad pair refused as no resonance (_broad_pairs_refused) is no lead either
    broad = dataclasses.replace(ranking[3], detail={"broad_pair_no_resonance": 1.0})
    assert _unconfirmed((*ranking[:3], broad, ranking[4]), "none", 1e-3) == ("rate_limit",)
    # nor is an effect switched off (_switched_off_refused): its J gain is its base's
    off = dataclasses.replace(ranking[1], detail={"effect_switched_off": 1.0})
    assert _unconfirmed((ranking[0], off, *ranking[2:]), "none", 1e-3) == ("structural_mode",)


def _check_json_report_schema(d):
    """The stable JSON report (issue 5's schema) of a diagnosis of all eight candidates."""
    doc = _report_json(d)
    assert {"channel", "nominal", "where", "ranking", "verdict", "combined_top2", "unconfirmed"} <= set(doc)
    assert set(doc["nominal"]) == {"params", "cost_J", "val_r2", "val_tic", "simulates"}
    assert doc["time_domain_refit"]["val_r2"] == pytest.approx(d.refit.val_r2)  # the time-domain candidates' null
    assert doc["nominal"]["simulates"] is True and "does not simulate" not in d.summary()  # a 30 ms delay's nominal does
    assert {"bands_hz", "worst_hz", "residual_white", "input_residual_peak_lag_s", "amplitude_dependent",
            "noise_limited_bands_hz"} <= set(doc["where"])  # fmt: skip
    assert len(doc["ranking"]) == 8
    for c in doc["ranking"]:
        assert {"effect", "params", "val_r2", "val_tic", "cost_J", "gap_closed", "score"} <= set(c)
    scores = [c["score"] for c in doc["ranking"]]
    assert scores == sorted(scores, reverse=True)
    assert doc["verdict"] in (doc["ranking"][0]["effect"], "none")
    assert len(doc["combined_top2"]["effects"]) == 2
    # gap_closed is (R2_after - R2_before) / (1 - R2_before)
    c = doc["ranking"][0]
    r0 = doc["nominal"]["val_r2"]
    assert c["gap_closed"] == pytest.approx((c["val_r2"] - r0) / (1 - r0), rel=1e-9)


def _diagnose_parser():
    from jaxgwo.cli import _diagnose as cli

    parser = argparse.ArgumentParser()
    cli.add_parser(parser.add_subparsers())
    return parser


def test_cli_settings_are_the_calibrated_defaults_sized_by_the_options():
    """``jaxgwo diagnose`` runs :class:`DiagnoseSettings`'s defaults (the blind study's
    configuration); ``--wolves`` / ``--iterations`` size the nominal fit and the linear
    refits alike, ``--seed`` and ``--w-max`` reach the nominal fit, the time-domain refits
    keep their own sizes."""
    from jaxgwo.cli._diagnose import diagnose_settings

    parse = lambda *a: _diagnose_parser().parse_args(["diagnose", "--channel", "lateral", *a])  # noqa: E731
    base = DiagnoseSettings()
    assert diagnose_settings(parse()) == base
    s = diagnose_settings(parse("--wolves", "10", "--iterations", "20", "--seed", "3", "--w-max", "100"))
    assert (s.wolves, s.iterations, s.identify.wolves, s.identify.iterations) == (10, 20, 10, 20)
    assert s.seed == s.identify.seed == 3 and s.identify.w_max == 100.0
    assert (s.nonlinear_wolves, s.nonlinear_iterations) == (base.nonlinear_wolves, base.nonlinear_iterations)
    assert dataclasses.replace(s, wolves=base.wolves, iterations=base.iterations, seed=base.seed,
                               identify=base.identify) == base  # fmt: skip
    with pytest.raises(ValueError, match="--wolves must be >= 4"):
        diagnose_settings(parse("--wolves", "3"))


def test_cli_end_to_end_and_bad_input(tmp_path, capsys, monkeypatch):
    """Records on disk through ``jaxgwo diagnose`` to its JSON, PNG and summary.  The
    configuration is this file's :data:`SETTINGS` (the CLI's defaults stand in for it, the
    mapping of the options is tested above): the blind study's sizes would only make this
    test slower, the shapes match the other diagnoses here and so do their compiled programs."""
    import jaxgwo._diagnose

    monkeypatch.setattr(jaxgwo._diagnose, "DiagnoseSettings", lambda: SETTINGS)
    parser = _diagnose_parser()
    train, val = _delay_records()  # records only: the CLI runs its own diagnosis
    tr_path, va_path = tmp_path / "train.csv", tmp_path / "val.csv"
    save_record(train[0], tr_path)
    # the validation record without its off-axis cyclic: cross_coupling must be skipped with a reason
    v = val[0]
    save_record(make_record(v.time, {"delta_lat": v["delta_lat"], "p": v["p"]}), va_path)
    out = tmp_path / "d.json"
    png = tmp_path / "d.png"
    args = parser.parse_args(["diagnose", str(tr_path), "--validate", str(va_path), "--channel", "lateral",
                              "--json", str(out), "--plot", str(png)])  # fmt: skip
    assert args.func(args) == 0
    doc = json.loads(out.read_text())
    assert doc["verdict"] in [c["effect"] for c in doc["ranking"][:1]] + ["none"]
    assert "cross_coupling" in doc["skipped"] and "off-axis" in doc["skipped"]["cross_coupling"]
    assert all(c["effect"] != "cross_coupling" for c in doc["ranking"])
    assert png.stat().st_size > 0
    assert "R^2" in capsys.readouterr().out
    bad = parser.parse_args(["diagnose", str(tr_path), "--channel", "lateral"])
    with pytest.raises(ValueError, match="--validate"):
        bad.func(bad)


def test_sensor_lag_and_rotor_flapping_are_the_same_input_output_family():
    """Why the blind study confuses them: the paper model with an in-loop flapping lag,
    K / ((s^2 + s/tau)(tau_f s + 1) + M), equals a paper model with other (tau', M', K')
    times a gyro filter 1/(tau_c s + 1) exactly, whenever the loop is stable (its cubic
    then has one real pole, the filter's, and a stable pair, the rotor/fuselage mode's).  Matching the cubics up to a scale
    lambda: tau_c = lambda tau_f and M' = lambda M, with 1/tau' from the s^2 and s terms
    (a quadratic in lambda).  Checked against both responses as the library computes them."""
    from scipy.optimize import brentq

    from jaxgwo._effects import paper_model_with_effect

    params = np.array([160.0, 0.2, 100.0, 38.0, 0.5])
    tau_f = 0.02  # a stable loop (a stiffer rotor or a longer lag destabilises it)
    k, tau, m = params[:3]
    # s^2 term: lambda (1 + tau_f/tau) = 1 + tau_c/tau'; s term: lambda/tau = 1/tau' + tau_c M'
    def residual(lam):
        inv_tau_p = lam / tau - lam * tau_f * lam * m
        return lam * (1 + tau_f / tau) - 1 - lam * tau_f * inv_tau_p

    lam = brentq(residual, 0.5, 1.0)
    tau_c, m_p = lam * tau_f, lam * m
    tau_p = 1.0 / (lam / tau - tau_c * m_p)
    assert tau_p > 0 and m_p > 0 and tau_c > 0
    w = jnp.asarray(np.logspace(-1, 2.5, 200))
    flap = np.asarray(paper_model_with_effect(jnp.asarray(params), w, "rotor_flapping", tau_f=tau_f))
    lagged = np.asarray(paper_model_with_effect(jnp.asarray([lam * k, tau_p, m_p, params[3], params[4]]), w, "sensor_lag",
                                                cutoff_hz=1.0 / (2 * np.pi * tau_c)))  # fmt: skip
    np.testing.assert_allclose(lagged, flap, rtol=1e-10, atol=0)


@pytest.mark.parametrize("cut, corroborated, passes", [
    (1.0549, False, False),  # seed-313 case_028, an R-50 without an effect: plain x1.05 cut
    (1.0639, False, False),  # 331/069, the same
    (1.0137, False, False),  # fresh seed 367's case_039, no effect: J at 0.38 of the null's
    (1.1134, False, True),   # 317/021, an R-50 rate limit: the cut
    (1.0806, True, True),    # 317/064: the amplitude test
])  # fmt: skip
def test_pair_free_effect_size_on_the_stored_r50_cases(cut, corroborated, passes):
    """The effect size a pair-free nonlinearity needs, on the stored R-50 cases it was set
    on (``J`` no worse than the null's here); the plain gate (``min_error_ratio`` 1.05, the
    held-out BIC or ``J``) passed every ``none`` case here."""
    from jaxgwo._diagnose import _effect_size_passes, _pair_free_effect_size

    assert _pair_free_effect_size(cut, SETTINGS.pair_free_error_ratio, corroborated, 1.0, 1.0) is passes
    if not passes:
        assert _effect_size_passes(cut, SETTINGS.min_error_ratio, corroborated, -3.0, True, SETTINGS.held_out_bic)


@pytest.mark.parametrize("cut, corroborated, j, j_null, passes", [
    (1.7419, True, 27.62, 145.98, True),    # fresh seed 373's case_050, an R-50 rate limit
    (3.3702, True, 27.85, 146.41, True),    # fresh seed 379's case_052, the same
    (2.5740, True, 70.17, 126.61, True),    # 313/011, the same
    (1.1134, False, 27.08, 68.29, True),    # 317/021, the same, on the cut
    (1.0806, True, 11.09, 19.23, True),     # 317/064, the same
    (1.1007, True, 30.81, 20.01, False),    # 313/047, a rate limit called saturation
    (1.0820, False, 45.48, 35.75, False),   # fresh seed 379's case_071, a resonance called saturation
])  # fmt: skip
def test_pair_free_nonlinearity_must_not_fit_j_worse_than_its_null(cut, corroborated, j, j_null, passes):
    """A pair-free nonlinearity whose ``J`` is above its pair-free null's is refused, whatever
    its cut or the amplitude test: the numbers of the R-50 cases rediagnosed on 3ca56e4
    (session 58).  The two refused ones passed the cut or amplitude test alone."""
    from jaxgwo._diagnose import _pair_free_effect_size

    assert _pair_free_effect_size(cut, SETTINGS.pair_free_error_ratio, corroborated, j, j_null) is passes
    if not passes:
        assert _pair_free_effect_size(cut, SETTINGS.pair_free_error_ratio, corroborated, j_null, j_null)


@pytest.mark.parametrize("held, free, n_eff, refit", [
    (2.135e-4, 1.6075e-4, 710.98, True),  # R-50 rate limit 557/053: held-out R^2 0.9605 -> 0.9819
    (1.421e-4, 1.1489e-4, 540.98, True),  # R-50 backlash 545/018: 0.9757 -> 0.9791
    (2.045e-4, 2.013e-4, 700.0, False),   # R-50 saturation 557/054: a 1.6 % cut
    (1.0e-4, 1.0e-4, 700.0, False),       # no cut
    (1.0e-4, 1.1e-4, 700.0, False),       # the refit fits worse
])  # fmt: skip
def test_a_refitted_pair_stands_where_it_cuts_the_identification_error(held, free, n_eff, refit):
    """A nonlinearity beating noise on a structure finding both with the pair held and
    refitted beside it is scored as the refitted fit where the pair's three parameters cut
    the held fit's output error at ``alpha`` (the numbers of the R-50 cases it was set on,
    re-simulated from their seeds); where only one fit beats noise, that one stands.  The
    p is the F-test's on the effective samples less the fit's eight parameters (scipy's F
    distribution as the reference)."""
    import scipy.stats

    from jaxgwo._diagnose import _pair_refit_stands, _refitted_pair_p

    p = _refitted_pair_p(held, free, n_eff)
    f = (held - free) / 3 / (free / (n_eff - 8))
    assert p == pytest.approx(scipy.stats.f.sf(f, 3, n_eff - 8) if held > free else 1.0, rel=1e-12)
    alpha = SETTINGS.alpha
    assert _pair_refit_stands(True, True, p, alpha) is refit
    assert _pair_refit_stands(False, True, p, alpha)  # the pair-held fit fails: the refit may stand
    assert not _pair_refit_stands(True, False, p, alpha) and not _pair_refit_stands(False, False, p, alpha)


@pytest.mark.parametrize("kw, what", [({"min_error_ratio": 0.9}, "min_error_ratio must be a number >= 1"),
                                      ({"strong_error_ratio": 0.5}, "strong_error_ratio must be a number >= 1"),
                                      ({"pair_free_error_ratio": 0.9}, "pair_free_error_ratio must be a number >= 1"),
                                      ({"structure_zeta_z": 0.0}, "structure_zeta_z must be a positive number"),
                                      ({"lag_over_delay": -0.1}, "lag_over_delay must be a score margin >= 0"),
                                      ({"nonlinearity_by_j": -0.1}, "nonlinearity_by_j must be a score margin >= 0"),
                                      ({"alpha_held_out_first": 1.0}, r"alpha_held_out_first must be a level in \[0, 1\)"),
                                      ({"alpha_coupling_gain": -1e-5}, r"alpha_coupling_gain must be a level in \[0, 1\)"),
                                      ({"alpha_resonance": 1.5}, r"alpha_resonance must be a level in \[0, 1\)"),
                                      ({"alpha_lag_on_structure": 1.0},
                                       r"alpha_lag_on_structure must be a level in \[0, 1\)"),
                                      ({"alpha_pressed_pair": -0.05}, r"alpha_pressed_pair must be a level in \[0, 1\)"),
                                      ({"j_null_ratio": 0.0}, "j_null_ratio must be a positive J ratio"),
                                      ({"wolves": 3}, "wolves")])  # fmt: skip
def test_diagnose_settings_reject_meaningless_thresholds(kw, what):
    with pytest.raises(ValueError, match=what):
        DiagnoseSettings(**kw)


def _scored(effect, score, ok=True):
    from jaxgwo._diagnose_which import CandidateScore

    nan = float("nan")
    return CandidateScore((effect,), {effect: {}}, {effect: {}}, nan, nan, nan, nan, nan, nan, nan, nan, nan, ok, 0.0,
                          score, 1)  # fmt: skip


def _j_found_nothing():
    """A lag's ``J`` fit that found nothing (F-test p 1, BIC worse): its refit may stand in."""
    return dataclasses.replace(_scored("rotor_flapping", -9.0, False), train_p=1.0, delta_bic=3.0)


@pytest.mark.parametrize("scores, order", [
    # both lags within 0.15 go ahead of the delay, in their order; the rest keep theirs
    ({"time_delay": 2.0, "backlash": 1.95, "rotor_flapping": 1.9, "sensor_lag": 1.88, "saturation": 1.0},
     ["rotor_flapping", "sensor_lag", "time_delay", "backlash", "saturation"]),
    ({"time_delay": 2.0, "rotor_flapping": 1.9, "sensor_lag": 1.8}, ["rotor_flapping", "time_delay", "sensor_lag"]),
    ({"time_delay": 2.0, "sensor_lag": 1.8}, ["time_delay", "sensor_lag"]),  # 0.2 behind: the delay stays
    ({"backlash": 2.0, "time_delay": 1.99, "sensor_lag": 1.98}, ["backlash", "time_delay", "sensor_lag"]),  # only a head delay
])  # fmt: skip
def test_lags_within_the_margin_are_ranked_ahead_of_a_delay(scores, order):
    from jaxgwo._diagnose import _lag_over_delay

    ranking = [_scored(e, v) for e, v in scores.items()]
    out = _lag_over_delay(ranking, 0.15)
    assert [c.effects[0] for c in out] == order
    for c in out:
        moved = c.effects[0] in ("rotor_flapping", "sensor_lag") and order.index(c.effects[0]) < order.index("time_delay")
        assert ("ranked_over_delay_by" in c.detail) == moved
        if moved:
            assert c.detail["ranked_over_delay_by"] == pytest.approx(scores["time_delay"] - scores[c.effects[0]])
    assert _lag_over_delay(ranking, 0.0) == tuple(ranking)  # off
    # a lag that does not beat noise never moves
    failing = [_scored(e, v, ok=e not in ("rotor_flapping", "sensor_lag")) for e, v in scores.items()]
    assert _lag_over_delay(failing, 0.15) == tuple(failing)


def _delay(delay_s, score, ok=True):
    return dataclasses.replace(_scored("time_delay", score, ok), params={"time_delay": {"delay_s": delay_s}})


@pytest.mark.parametrize("head, scores, order", [
    # seed-383 case_050 (R-50, a 19.3 ms flapping lag): the delay fitted 8.4 ms led by 0.02
    (_delay(0.0084, 0.59), {"rotor_flapping": 0.57, "backlash": -9.0}, ["rotor_flapping", "time_delay", "backlash"]),
    # both lags move, in their order, with no score margin
    (_delay(0.0050, 3.0), {"backlash": 1.0, "sensor_lag": 0.5, "rotor_flapping": 0.2},
     ["sensor_lag", "rotor_flapping", "time_delay", "backlash"]),
    # seed-435 case_061 (R-50, a true 18.9 ms delay fitted 16.4): the delay stays
    (_delay(0.0164, 0.56), {"rotor_flapping": 0.50}, ["time_delay", "rotor_flapping"]),
    # just inside the vocabulary (10 ms, less its 5 % margin): the delay stays
    (_delay(0.0096, 0.56), {"rotor_flapping": 0.50}, ["time_delay", "rotor_flapping"]),
    # only a delay at the head, and only one that beats noise
    (_scored("backlash", 2.0), {"time_delay": 1.0, "rotor_flapping": 0.5}, ["backlash", "time_delay", "rotor_flapping"]),
    (_delay(0.005, -9.0, ok=False), {"rotor_flapping": -9.5}, ["time_delay", "rotor_flapping"]),
])  # fmt: skip
def test_lags_go_ahead_of_a_delay_shorter_than_the_vocabularys(head, scores, order):
    """On top of a structure finding a delay fitted below the vocabulary's 10 ms is a lag's
    imitation (beside an R-50's flybar pair a flapping lag fits as a 4-10 ms delay): the
    passing lags go ahead of it whatever their score, and each records the delay."""
    from jaxgwo._diagnose import _DELAY_FLOOR_S, _lag_over_short_delay

    assert _DELAY_FLOOR_S == pytest.approx(0.0095)
    ranking = [head] + [_scored(e, v, ok=v > -9.0) for e, v in scores.items()]
    out = _lag_over_short_delay(ranking)
    assert [c.effects[0] for c in out] == order
    for c in out:
        moved = c.effects[0] in ("rotor_flapping", "sensor_lag") and order.index(c.effects[0]) < order.index(
            head.effects[0])
        assert ("ranked_over_short_delay_s" in c.detail) == moved
        if moved:
            assert c.detail["ranked_over_short_delay_s"] == head.params["time_delay"]["delay_s"]
    # a lag that does not beat noise never moves
    failing = [head] + [_scored(e, v, ok=False) for e, v in scores.items()]
    assert _lag_over_short_delay(failing) == tuple(failing)


@pytest.mark.parametrize("cands, order", [
    # seed-401 case_058 (R-50 rate limit): the pair-free saturation led by 0.016 at J 28.4, the rate limit at 11.7
    ({"saturation": (0.186, 28.4), "rate_limit": (0.170, 11.7), "backlash": (-10.0, 26.2)},
     ["rate_limit", "saturation", "backlash"]),
    # seed-359 case_017: both pair-free, the saturation by 0.002 at J 20.4 against 11.9
    ({"saturation": (0.443, 20.4), "rate_limit": (0.441, 11.9)}, ["rate_limit", "saturation"]),
    # seed-397 case_041: the rate limit leads by 0.31 at the lower J already
    ({"rate_limit": (0.663, 15.8), "saturation": (0.349, 58.0)}, ["rate_limit", "saturation"]),
    # seed-373 case_023 (R-50 saturation): the saturation leads by 1.9 at the higher J; it stays
    ({"saturation": (2.183, 65.5), "rate_limit": (0.283, 50.0)}, ["saturation", "rate_limit"]),
    # of three within the margin the lowest J goes ahead, the rest keep their order
    ({"backlash": (1.0, 9.0), "saturation": (0.95, 3.0), "rate_limit": (0.9, 2.0)},
     ["rate_limit", "backlash", "saturation"]),
    # a head that is no nonlinearity: unchanged
    ({"time_delay": (1.0, 9.0), "rate_limit": (0.99, 2.0)}, ["time_delay", "rate_limit"]),
])  # fmt: skip
def test_a_nonlinearity_of_lower_j_within_the_margin_is_ranked_ahead_of_another(cands, order):
    """``nonlinearity_by_j``: output-error scores within the margin do not separate two servo
    nonlinearities; the one that fits the coherent response (``J``) better goes first."""
    from jaxgwo._diagnose import _nonlinearity_by_j

    ranking = [dataclasses.replace(_scored(e, v), cost_J=j) for e, (v, j) in cands.items()]
    margin = DiagnoseSettings().nonlinearity_by_j
    out = _nonlinearity_by_j(ranking, margin)
    assert [c.effects[0] for c in out] == order
    moved = [c for c in out if "ranked_over_nonlinearity_by" in c.detail]
    if order[0] != next(iter(cands)):
        (m,) = moved
        assert m is out[0] and m.detail["ranked_over_nonlinearity_by"] == pytest.approx(ranking[0].score - m.score)
        assert m.detail["J_of_the_one_passed"] == ranking[0].cost_J
        assert 0.0 < m.detail["ranked_over_nonlinearity_by"] < margin
    else:
        assert not moved
    assert _nonlinearity_by_j(ranking, 0.0) == tuple(ranking)  # off
    # a nonlinearity that does not beat noise never moves
    failing = [dataclasses.replace(c, beats_noise=c is ranking[0]) for c in ranking]
    assert _nonlinearity_by_j(failing, margin) == tuple(failing)


def _with_p(effect, score, p, ok=False, **detail):
    return dataclasses.replace(_scored(effect, score, ok), train_p=p, detail=detail)


@pytest.mark.parametrize("cands, held, order", [
    # a passing head stays; the failing tail goes by p, not by score
    ([("time_delay", 1.2, 1e-9, True), ("structural_mode", -9.9, 0.3), ("rate_limit", -10.0, 1e-4),
      ("backlash", -9.95, 1.0)], None,
     ["time_delay", "rate_limit", "structural_mode", "backlash"]),
    # two passing ones keep their order, even against a failing one of smaller p
    ([("saturation", 0.5, 1e-3, True), ("backlash", 0.4, 1e-2, True), ("rate_limit", -9.5, 1e-12)], None,
     ["saturation", "backlash", "rate_limit"]),
    # a none verdict: the whole ranking by p, ties (p 1) in score order
    ([("cross_coupling", -9.95, 2.4e-4), ("backlash", -9.96, 1.0), ("saturation", -9.97, 1.0),
      ("time_delay", -10.0, 0.20), ("structural_mode", -10.18, 0.34), ("rate_limit", -10.2, 1e-6)], None,
     ["rate_limit", "cross_coupling", "time_delay", "structural_mode", "backlash", "saturation"]),
    # the two lags share their p and keep their order without the gyro path; a delay ahead
    # of them by less than a factor 10 in p has them go ahead of it
    ([("rotor_flapping", -9.85, 4.1482689015136e-4), ("sensor_lag", -9.86, 4.1482689015107e-4),
      ("time_delay", -9.87, 2.96e-4), ("backlash", -9.5, 1.0)], None,
     ["rotor_flapping", "sensor_lag", "time_delay", "backlash"]),
    # ... by more, not (an R-50 delay of the stored draws: the lags at 15 times its p)
    ([("sensor_lag", -9.85, 2.1e-2), ("rotor_flapping", -9.86, 2.1e-2), ("time_delay", -9.87, 1.4e-3),
      ("cross_coupling", -9.0, 1e-2)], None,
     ["time_delay", "cross_coupling", "sensor_lag", "rotor_flapping"]),
    # the gyro path tested: its order of the lags, a filter held or not
    ([("sensor_lag", -9.85, 0.2), ("rotor_flapping", -9.86, 0.2), ("backlash", -9.0, 0.1)], False,
     ["backlash", "rotor_flapping", "sensor_lag"]),
    ([("rotor_flapping", -9.85, 0.2), ("sensor_lag", -9.86, 0.2), ("backlash", -9.0, 0.1)], True,
     ["backlash", "sensor_lag", "rotor_flapping"]),
    # tied with others at p 1 the lags still stand together, at the first one's place
    ([("backlash", -9.0, 1.0), ("sensor_lag", -9.1, 1.0), ("saturation", -9.2, 1.0), ("rotor_flapping", -9.3, 1.0)],
     False, ["backlash", "rotor_flapping", "sensor_lag", "saturation"]),
    # a lag the gyro path refuted, and a p that is no number, go last
    ([("sensor_lag", -8.0, 1e-8, False, 1.0), ("rotor_flapping", -9.0, 1e-8), ("backlash", -9.1, float("nan")),
      ("saturation", -9.2, 0.5)], True,
     ["rotor_flapping", "saturation", "sensor_lag", "backlash"]),
])  # fmt: skip
def test_the_candidates_that_do_not_beat_noise_are_ordered_by_their_identification_evidence(cands, held, order):
    """``_failing_by_evidence``: the verdict and every candidate that beats noise keep their
    places; the rest follow their ``train_p``, the lags as one (in the gyro path's order,
    ahead of a delay of like evidence; a refuted lag last)."""
    from jaxgwo._diagnose import _failing_by_evidence

    ranking = [_with_p(e, s, p, *rest[:1], **({"refuted_by_gyro_path": 1.0} if rest[1:] else {}))
               for e, s, p, *rest in cands]  # fmt: skip
    out = _failing_by_evidence(ranking, held)
    assert [c.effects[0] for c in out] == order
    assert sorted(map(id, out)) == sorted(map(id, ranking))  # the same candidates, untouched
    passing = [c for c in ranking if c.beats_noise]
    assert list(out[: len(passing)]) == passing
    assert _failing_by_evidence(out, held) == out  # idempotent


def _on_paper_model(effect, score, cost_J, ok=True, **mode):
    sc = dataclasses.replace(_scored(effect, score, ok), cost_J=cost_J)
    if effect == "structural_mode":
        sc = dataclasses.replace(sc, params={effect: {"freq_hz": 4.9, "zeta_p": 0.77, "zeta_z": 1.36} | mode})
    return sc


def test_a_nonlinearity_that_fits_j_below_an_airframe_pair_is_ranked_over_it():
    """Seed-137 case_052's paper-model ranking (a paper rate limit taken for structure,
    rediagnosed on 38ab7bd): the vocabulary's mode at the head (29.96 Hz, real zeros, J
    3.46), the pair the structure step takes from it at 4.9 Hz and J 3.26, the rate limit at
    1.11; and seed-137 case_008's (an R-50 ``none`` case): the airframe pair at 1.9 Hz, J
    4.81, a saturation beating noise at 133."""
    from jaxgwo._diagnose import _nonlinearity_over_pair

    ranking = [_on_paper_model("structural_mode", 0.399, 3.46, freq_hz=29.96, zeta_p=0.01, zeta_z=1.5),
               _on_paper_model("rate_limit", 0.375, 1.11), _on_paper_model("saturation", -9.6, 6.56, ok=False),
               _on_paper_model("backlash", -9.6, 0.5, ok=False), _on_paper_model("time_delay", -10.1, 1.0, ok=False)]  # fmt: skip
    pair = _on_paper_model("structural_mode", 0.416, 3.26)
    out = _nonlinearity_over_pair(ranking, pair)
    assert [c.effects[0] for c in out] == ["rate_limit", "structural_mode", "saturation", "backlash", "time_delay"]
    assert out[0].detail["J_over_pair_J"] == pytest.approx(1.11 / 3.26) and out[0].detail["over_pair_freq_hz"] == 4.9
    assert all("J_over_pair_J" not in c.detail for c in out[1:])
    # two that beat noise below the pair: lowest J first
    two = [*ranking[:2], _on_paper_model("saturation", 0.2, 2.0)]
    assert [c.effects[0] for c in _nonlinearity_over_pair(two, pair)] == ["rate_limit", "saturation", "structural_mode"]
    # unchanged: a nonlinearity at or above the pair's J (the R-50 none case), one that does
    # not beat noise (however low its J), a linear effect below it, a pair whose J is not a number
    r50_pair = _on_paper_model("structural_mode", 3.43, 4.81, freq_hz=1.9, zeta_p=0.2, zeta_z=0.84)
    r50 = [r50_pair, _on_paper_model("saturation", 0.176, 133.0)]
    assert _nonlinearity_over_pair(r50, r50_pair) == tuple(r50)
    for kept in ([ranking[0], _on_paper_model("rate_limit", 0.3, 3.26)], [ranking[0], ranking[3]],
                 [ranking[0], _on_paper_model("time_delay", 0.3, 1.0)]):  # fmt: skip
        assert _nonlinearity_over_pair(kept, pair) == tuple(kept)
    assert _nonlinearity_over_pair(ranking, dataclasses.replace(pair, cost_J=float("nan"))) == tuple(ranking)


@pytest.mark.parametrize("p_mse, p_j_null, j, j_null, expected", [
    (0.14, 6.5e-5, 2.18, 3.39, (False, 0.14)),  # seed-199 case_005: a resonance read as a rate limit
    (0.15, 2.2e-4, 4.23, 6.12, (False, 0.15)),  # seed-199 case_040
    (2.6e-3, 3e-9, 1.19, 33.3, (True, 3e-9)),  # a true rate limit the output error barely shows
    (2.3e-56, 9.8e-5, 0.635, 1.0, (False, 2.3e-56)),  # a backlash passing on its output error
    (0.5, 2e-3, 1.0, 5.0, (False, 2e-3)),  # sized, but the J test not at alpha: its p still counts
    (1e-5, 1e-9, 2.0, 5.0, (True, 1e-9)),  # at the ratio: sized
])  # fmt: skip
def test_the_null_refits_j_counts_as_evidence_only_with_an_effect_size(p_mse, p_j_null, j, j_null, expected):
    from jaxgwo._diagnose import _against_null_j

    strong, p = _against_null_j(p_mse, p_j_null, j, j_null, 1e-3, 0.4)
    assert strong == expected[0] and p == pytest.approx(expected[1], rel=1e-12)
    # inf: the F-test alone, as before 0.4 was set
    assert _against_null_j(p_mse, p_j_null, j, j_null, 1e-3, math.inf) == (p_j_null < 1e-3, min(p_mse, p_j_null))
    assert DiagnoseSettings().j_null_ratio == 0.4


def test_structure_step_starts_only_from_a_frequency_domain_winner():
    from jaxgwo._diagnose import _structure_route

    def top(effect, ok=True, td_path=0.0, zeta_z=2.0, freq_hz=9.0, zeta_p=0.05):
        c = _scored(effect, 3.0, ok)
        params = {effect: {"freq_hz": freq_hz, "zeta_p": zeta_p, "zeta_z": zeta_z}} if effect == "structural_mode" \
            else c.params
        return dataclasses.replace(c, params=params, detail={"time_domain_path": td_path})

    fits = {("structural_mode",): object(), ("time_delay",): object(), ("sensor_lag",): object()}
    rest = [_scored("sensor_lag", 1.0)]
    assert _structure_route([top("structural_mode"), *rest], fits, 1.0, 1e-3) == "mode"
    # a resonance, not structure
    assert _structure_route([top("structural_mode", zeta_z=0.8), *rest], fits, 1.0, 1e-3) is None
    # pressed against the vocabulary's 3 Hz floor: the structure step refits it in its wider box
    assert _structure_route([top("structural_mode", zeta_z=0.8, freq_hz=3.0), *rest], fits, 1.0, 1e-3) == "mode"
    assert _structure_route([top("structural_mode", zeta_z=0.8, freq_hz=3.1), *rest], fits, 1.0, 1e-3) is None
    assert _structure_route([top("structural_mode", zeta_z=0.8, freq_hz=3.0), *rest], fits, math.inf, 1e-3) is None
    # a broad pair is no resonance of the vocabulary: refitted there too (seed-2005 case_011, an
    # R-50 backlash under a 3.1 Hz pair at pole damping 0.37, zeros 0.99)
    assert _structure_route([top("structural_mode", zeta_z=0.99, freq_hz=3.1, zeta_p=0.37), *rest], fits, 1.0,
                            1e-3) == "mode"  # fmt: skip
    assert _structure_route([top("structural_mode", zeta_z=0.8, zeta_p=0.2), *rest], fits, 1.0, 1e-3) is None
    assert _structure_route([top("structural_mode", zeta_z=0.8, zeta_p=0.37), *rest], fits, math.inf, 1e-3) is None
    assert _structure_route([top("time_delay"), *rest], fits, 1.0, 1e-3) == "behind_delay"
    # a winner by the time-domain path won with its output-error refit, not the J fit the step extends
    assert _structure_route([top("structural_mode", td_path=1.0), *rest], fits, 1.0, 1e-3) is None
    assert _structure_route([top("time_delay", td_path=1.0), *rest], fits, 1.0, 1e-3) is None
    # nothing beats noise, another effect on top, no J fit, no ranking at all
    assert _structure_route([top("time_delay", ok=False), *rest], fits, 1.0, 1e-3) is None
    assert _structure_route([_scored("backlash", 3.0), top("time_delay")], fits, 1.0, 1e-3) is None
    assert _structure_route([top("time_delay")], {}, 1.0, 1e-3) is None
    assert _structure_route([], fits, 1.0, 1e-3) is None


def test_an_airframe_pair_below_a_nonlinearity_starts_the_structure_step():
    """An R-50 saturation on the paper model alone (seed-543 case_045): the saturation on
    top at J 185, a 3.2 Hz pair with real zeros below it at J 18.4.  The pair is what J
    sees; the step takes it, and the saturation is ranked again on top of it."""
    from jaxgwo._diagnose import _pair_behind_nonlinearity, _structure_route

    def cand(effect, score, cost_j, ok=True, p=6e-8, delta_bic=-30.0, **mode):
        c = dataclasses.replace(_scored(effect, score, ok), cost_J=cost_j, detail={}, train_p=p, delta_bic=delta_bic)
        if effect == "structural_mode":
            c = dataclasses.replace(c, params={effect: {"freq_hz": 3.15, "zeta_p": 0.5, "zeta_z": 1.3} | mode})
        return c

    fits = {("structural_mode",): object()}
    sat, pair = cand("saturation", 1.44, 185.0), cand("structural_mode", 1.22, 18.4)
    lag = cand("rotor_flapping", 1.0, 30.0)
    assert _pair_behind_nonlinearity([sat, lag, pair], fits, 1.0, 1e-3) is pair
    assert _structure_route([sat, lag, pair], fits, 1.0, 1e-3) == "behind_nonlinearity"
    for effect in ("rate_limit", "backlash"):
        assert _structure_route([cand(effect, 1.44, 185.0), pair], fits, 1.0, 1e-3) == "behind_nonlinearity"
    # a resonance (complex zeros) is no airframe pair: a paper rate limit's pair (seed-543 case_029)
    assert _structure_route([sat, cand("structural_mode", 1.2, 5.0, zeta_z=0.03)], fits, 1.0, 1e-3) is None
    # below the vocabulary's 3 Hz floor it is the airframe's, whatever its zeros
    assert _structure_route([sat, cand("structural_mode", 1.2, 5.0, freq_hz=2.0, zeta_z=0.3)], fits, 1.0, 1e-3) \
        == "behind_nonlinearity"
    # a pair that fits J worse than the nonlinearity is what the pair imitated (_nonlinearity_over_pair)
    assert _structure_route([sat, cand("structural_mode", 1.2, 190.0)], fits, 1.0, 1e-3) is None
    # J must find the pair (F-test at alpha and BIC), which the step extends; the held-out
    # records, the nonlinearity's, need not (seed-157 case_065: J p 8e-7, held-out z -0.09)
    assert _structure_route([sat, cand("structural_mode", -9.0, 20.9, ok=False, p=8e-7)], fits, 1.0, 1e-3) \
        == "behind_nonlinearity"
    assert _structure_route([sat, cand("structural_mode", 1.2, 18.4, p=2e-3)], fits, 1.0, 1e-3) is None
    assert _structure_route([sat, cand("structural_mode", 1.2, 18.4, delta_bic=1.0)], fits, 1.0, 1e-3) is None
    on_td = dataclasses.replace(pair, detail={"time_domain_path": 1.0})
    assert _structure_route([sat, on_td], fits, 1.0, 1e-3) is None
    assert _structure_route([sat, pair], {}, 1.0, 1e-3) is None
    # the nonlinearity must be on top and beat noise; the step off (inf) takes nothing
    assert _structure_route([cand("saturation", -9.0, 185.0, ok=False), pair], fits, 1.0, 1e-3) is None
    assert _structure_route([cand("time_delay", 1.44, 185.0), pair], fits, 1.0, 1e-3) is None
    assert _structure_route([sat, pair], fits, math.inf, 1e-3) is None


def test_a_broad_pair_does_not_beat_noise_as_a_resonance():
    """Seed-551 case_061, a paper flapping lag of 33.5 ms: a 6.55 Hz pair at pole damping
    0.214 (zeros 0.51) ranked first ahead of the lag; the vocabulary's resonances fit pole
    damping 0.19 or less.  The broad pair goes among the failing candidates and the lag
    becomes the verdict; a lightly damped resonance, and the candidates that beat noise,
    keep their places."""
    from jaxgwo._diagnose import _MODE_AGREEMENT_ZETA_P, _broad_pairs_refused

    def mode(score, zeta_p, ok=True):
        c = _scored("structural_mode", score, ok)
        return dataclasses.replace(c, params={"structural_mode": {"freq_hz": 6.55, "zeta_p": zeta_p, "zeta_z": 0.51}},
                                   detail={})  # fmt: skip

    broad, lag, delay, cc = mode(2.6, 0.214), _scored("rotor_flapping", 2.4), _scored("time_delay", 2.3), \
        _scored("cross_coupling", -2.0, False)
    out = _broad_pairs_refused([broad, lag, delay, cc])
    assert [c.effects[0] for c in out] == ["rotor_flapping", "time_delay", "cross_coupling", "structural_mode"]
    assert [c.beats_noise for c in out] == [True, True, False, False]
    assert out[-1].detail == {"broad_pair_no_resonance": 1.0} and out[-1].score == pytest.approx(2.6 - 10.0)
    # at the threshold and below it the pair is a resonance and stays where it was
    for zeta_p in (_MODE_AGREEMENT_ZETA_P, 0.19, 0.03):
        ranking = (mode(2.6, zeta_p), lag, delay, cc)
        assert _broad_pairs_refused(ranking) == ranking
    # one that did not beat noise anyway is left alone, as is a ranking without a pair
    failing = (lag, delay, cc, mode(-3.0, 0.5, ok=False))
    assert _broad_pairs_refused(failing) == failing
    assert _broad_pairs_refused([]) == ()


def test_an_effect_switched_off_does_not_beat_noise():
    """Fresh seed 627's case_048, an R-50 resonance: on top of the structure finding a
    flapping lag and a delay of exactly zero (3.9e-25 s and 2.5e-25 s) both cut ``J`` 16.9 ->
    6.8 (the base refitted) and beat noise, and the lag was the verdict.  Switched off, an
    effect's model is its base's: both go among the failing candidates and nothing is
    named.  A delay or lag that is not zero, one scored by its time-domain refit, a gyro
    filter (whose neutral value is no cutoff at all) and a resonance keep their places."""
    from jaxgwo._diagnose import _switched_off, _switched_off_refused

    def cand(effect, params, score, ok=True, detail=None):
        return dataclasses.replace(_scored(effect, score, ok), params={effect: params}, detail=dict(detail or {}))

    flap = cand("rotor_flapping", {"tau_f": 3.9e-25}, 0.738)
    delay = cand("time_delay", {"delay_s": 2.5e-25}, 0.713)
    mode = cand("structural_mode", {"freq_hz": 15.35, "zeta_p": 0.034, "zeta_z": 1.04}, -9.006, ok=False)
    gyro = cand("sensor_lag", {"cutoff_hz": 100.0}, -9.352, ok=False)
    out = _switched_off_refused([flap, delay, mode, gyro])
    # by score among the failing: -9.006, 0.738 - 10, 0.713 - 10, -9.352
    assert [c.effects[0] for c in out] == ["structural_mode", "rotor_flapping", "time_delay", "sensor_lag"]
    assert not any(c.beats_noise for c in out)
    assert out[1].detail == {"effect_switched_off": 1.0} and out[1].score == pytest.approx(0.738 - 10.0)
    assert out[2].detail == {"effect_switched_off": 1.0} and out[2].score == pytest.approx(0.713 - 10.0)
    # a delay the vocabulary could hold (10 ms) or just above the threshold (0.1 us) is no
    # switched-off one; below it (0.05 us of a range up to 80 ms) it is
    for value, off in ((0.010, False), (1e-7, False), (5e-8, True), (0.0, True), (-0.0, True)):
        assert _switched_off(cand("time_delay", {"delay_s": value}, 1.0)) is off
    # a coupling gain of zero is off too; a gyro filter and a resonance are never judged here
    assert _switched_off(cand("cross_coupling", {"gain": 0.0}, 1.0))
    assert not _switched_off(cand("cross_coupling", {"gain": 0.05}, 1.0))
    assert not _switched_off(cand("sensor_lag", {"cutoff_hz": 1e30}, 1.0))
    assert not _switched_off(cand("structural_mode", {"freq_hz": 10.0, "zeta_p": 1.0, "zeta_z": 1.0}, 1.0))
    # nonlinearities are scored in the time domain: not judged either
    assert not _switched_off(cand("saturation", {"limit": 0.0}, 1.0))
    # passing ones that are not off keep their order, and so does a refit's
    live = cand("time_delay", {"delay_s": 0.03}, 1.2)
    by_refit = cand("rotor_flapping", {"tau_f": 0.0}, 1.0, detail={"time_domain_path": 1.0})
    ranking = (live, by_refit, mode)
    assert _switched_off_refused(ranking) == ranking
    assert _switched_off_refused([]) == ()
    out = _switched_off_refused([flap, live, mode])
    assert [c.effects[0] for c in out] == ["time_delay", "structural_mode", "rotor_flapping"]
    assert out[0] is live and [c.beats_noise for c in out] == [True, False, False]


def test_a_time_domain_refit_stands_in_only_where_it_passes_and_j_has_no_passing_fit_for_it():
    from jaxgwo._diagnose import _takes_time_domain_path

    def j(ok, p=1e-6, dbic=-50.0):
        return dataclasses.replace(_scored("structural_mode", 1.0, ok), train_p=p, delta_bic=dbic)

    def td_mode(zeta_z, ok=True, zeta_p=0.05, freq_hz=12.0):
        c = _scored("structural_mode", 0.8 if ok else -9.0, ok)
        return dataclasses.replace(c, params={"structural_mode": {"freq_hz": freq_hz, "zeta_p": zeta_p, "zeta_z": zeta_z}})

    td_pass, td_fail = td_mode(0.2), td_mode(0.2, ok=False)
    # J found no linear effect: a refit that passes decides (the rule before)
    assert _takes_time_domain_path(j(False, p=0.02), td_pass, j_found=False, alpha=1e-3, m_eff=40.0)
    # J finds this effect, its fit fails on VAL, the refit passes: two tests agree (seed-61 case_066)
    assert _takes_time_domain_path(j(False), td_pass, j_found=True, alpha=1e-3, m_eff=40.0)
    # ... not when J's own evidence is short of the level or of a BIC gain
    assert not _takes_time_domain_path(j(False, p=0.02), td_pass, j_found=True, alpha=1e-3, m_eff=40.0)
    assert not _takes_time_domain_path(j(False, dbic=3.0), td_pass, j_found=True, alpha=1e-3, m_eff=40.0)
    # a J fit that passes stands; a refit that fails, or none, never stands in
    assert not _takes_time_domain_path(j(True), td_pass, j_found=True, alpha=1e-3, m_eff=40.0)
    assert not _takes_time_domain_path(j(False), td_fail, j_found=True, alpha=1e-3, m_eff=40.0)
    assert not _takes_time_domain_path(j(False), td_fail, j_found=False, alpha=1e-3, m_eff=40.0)
    assert not _takes_time_domain_path(j(False), None, j_found=False, alpha=1e-3, m_eff=40.0)
    # a mode refit with real zeros (zero damping above structure_zeta_z) is no resonance:
    # it never stands in (seed-89 case_064); one with complex zeros does, as before
    for found in (False, True):
        assert not _takes_time_domain_path(j(False), td_mode(8.4), j_found=found, alpha=1e-3, structure_zeta_z=1.0, m_eff=40.0)
        assert _takes_time_domain_path(j(False), td_mode(0.2), j_found=found, alpha=1e-3, structure_zeta_z=1.0, m_eff=40.0)
    assert _takes_time_domain_path(j(False), td_mode(8.4), j_found=True, alpha=1e-3, m_eff=40.0)  # the rule off (inf)
    # a broad pole pair is no resonance either, whatever its zeros: the 45 Hz corner fit
    # (pole damping 0.99) and the 4.9 Hz one (0.44) of seed-89 case_064 never stand in;
    # the true modes' refits (0.026-0.073) do
    for found in (False, True):
        for zeta_p, zeta_z, f in ((0.99, 0.02, 45.0), (0.44, 0.2, 4.9), (0.21, 0.3, 12.0)):
            assert not _takes_time_domain_path(j(False), td_mode(zeta_z, zeta_p=zeta_p, freq_hz=f), j_found=found,
                                               alpha=1e-3, structure_zeta_z=1.0, m_eff=40.0)
        for zeta_p in (0.026, 0.073, 0.2):  # zeros at 0.3: not the pair its zeros cancel (_vanished)
            assert _takes_time_domain_path(j(False), td_mode(0.3, zeta_p=zeta_p), j_found=found, alpha=1e-3,
                                           structure_zeta_z=1.0, m_eff=40.0)
    lag = dataclasses.replace(_scored("sensor_lag", 0.8, True), params={"sensor_lag": {"cutoff_hz": 20.0}})
    assert _takes_time_domain_path(j(False), lag, j_found=True, alpha=1e-3, structure_zeta_z=1.0, m_eff=40.0)


def test_a_time_domain_refit_the_measured_response_contradicts_never_stands_in():
    """A lag refitted by output error whose simulated response fits ``J`` far worse than the
    base's (seed-179 R-50 `none` case_041: 17.08 against 3.47 on 43.4 independent
    frequencies) does not stand in; a refit that fits it about as well does (seed-157
    case_020's 9.6 Hz mode: 1.82 against 1.42, three parameters, 38 frequencies)."""
    import scipy.stats

    from jaxgwo._diagnose import _takes_time_domain_path
    from jaxgwo._diagnose_which import j_worse_p

    values = {"rotor_flapping": {"tau_f": 0.010}, "time_delay": {"delay_s": 0.005}}

    def td(effect, cost_j, nominal_j, k, ok=True):
        return dataclasses.replace(_scored(effect, 0.8, ok), cost_J=cost_j, nominal_J=nominal_j, n_params=k,
                                   params={effect: values.get(effect, {})})

    j_none = _j_found_nothing()
    lag, mode = td("rotor_flapping", 17.08, 3.47, 1), td("structural_mode", 1.82, 1.42, 3)
    mode = dataclasses.replace(mode, params={"structural_mode": {"freq_hz": 9.6, "zeta_p": 0.07, "zeta_z": 0.15}})
    # the reverse F-test against scipy's F distribution written out
    f = (17.08 - 3.47) / 1 / (3.47 / (43.4 - 6))
    assert j_worse_p(lag, 43.4) == pytest.approx(scipy.stats.f.sf(f, 1, 43.4 - 6), rel=1e-12)
    assert j_worse_p(lag, 43.4) < 1e-13
    assert 0.01 < j_worse_p(mode, 38.0) < 0.1
    assert j_worse_p(td("time_delay", 2.41, 2.82, 1), 40.0) == 1.0  # fits J better: nothing to contradict
    # too few frequencies: the degrees of freedom stop at the F-test's floor, as score_candidate's
    assert j_worse_p(lag, 2.0) == j_worse_p(lag, 8.0)
    assert not _takes_time_domain_path(j_none, lag, j_found=False, alpha=1e-3, m_eff=43.4)
    assert _takes_time_domain_path(j_none, mode, j_found=False, alpha=1e-3, m_eff=38.0)
    # the boundary: J worse by just less / more than the F-test allows at alpha
    crit = scipy.stats.f.isf(1e-3, 1, 43.4 - 6)
    at = 3.47 * (1.0 + crit / (43.4 - 6))
    assert _takes_time_domain_path(j_none, td("time_delay", at * 0.99, 3.47, 1), j_found=False, alpha=1e-3, m_eff=43.4)
    assert not _takes_time_domain_path(j_none, td("time_delay", at * 1.01, 3.47, 1), j_found=False, alpha=1e-3,
                                       m_eff=43.4)


def test_the_j_f_test_against_scipy_and_its_floor():
    """``j_f_test_p``: the F-test of a J reduction on ``m_eff`` independent frequencies, as
    scipy's F distribution gives it; seed-181 case_011's rate limit against its null refit
    (J 33.3 -> 1.19) passes far beyond alpha, a `none` case's best (0.88 of the null's)
    does not; fewer frequencies than the parameters need stop at the floor."""
    import scipy.stats

    from jaxgwo._diagnose_which import j_f_test_p

    for before, after, k, m in ((33.34, 1.19, 1, 40.0), (9.06, 2.48, 1, 25.0), (4.0, 3.5, 3, 60.0)):
        dof = m - 5 - k
        want = scipy.stats.f.sf((before - after) / k / (after / dof), k, dof)
        assert j_f_test_p(before, after, k, m) == pytest.approx(want, rel=1e-12)
    assert j_f_test_p(33.34, 1.19, 1, 40.0) < 1e-20
    assert j_f_test_p(1.0, 0.88, 1, 40.0) > 1e-3
    assert j_f_test_p(1.0, 1.2, 1, 40.0) == 1.0  # no reduction
    assert j_f_test_p(33.34, 1.19, 1, 3.0) == j_f_test_p(33.34, 1.19, 1, 8.0)


def test_a_time_domain_refit_whose_effect_vanished_never_stands_in():
    """Seed-173 case_026 (a rate limit) was called ``rotor_flapping`` by a refit whose lag
    sat on the box's 0.2 ms floor, seed-137 case_052 (a rate limit) ``time_delay`` by one
    with no delay, fresh seed 455's case_059 (``none``) by one at 0.12 ms and then by a
    pole pair whose zeros cancel it: what passed was the servo and rotor term moving, not
    the effect."""
    from jaxgwo._diagnose import _takes_time_domain_path
    from jaxgwo._diagnose_which import _FLAP_LO_TIME_DOMAIN_S

    j_none = _j_found_nothing()

    def td(effect, **params):
        c = _scored(effect, 0.8, True)
        return dataclasses.replace(c, cost_J=5.57, nominal_J=5.57, n_params=1, params={effect: params})

    for effect, gone, there in (("rotor_flapping", {"tau_f": _FLAP_LO_TIME_DOMAIN_S}, {"tau_f": 0.012}),
                                ("time_delay", {"delay_s": 1e-30}, {"delay_s": 0.004}),
                                ("time_delay", {"delay_s": 1.2e-4}, {"delay_s": 0.0119}),  # 455/059, none
                                ("structural_mode", {"freq_hz": 3.02, "zeta_p": 0.0199, "zeta_z": 0.0200},
                                 {"freq_hz": 12.04, "zeta_p": 0.0578, "zeta_z": 0.0985}),  # 455/059; 397/003
                                ("sensor_lag", {"cutoff_hz": 100.0}, {"cutoff_hz": 30.0})):
        assert not _takes_time_domain_path(j_none, td(effect, **gone), j_found=False, alpha=1e-3, m_eff=40.0)
        assert _takes_time_domain_path(j_none, td(effect, **there), j_found=False, alpha=1e-3, m_eff=40.0)


@pytest.mark.parametrize("cut, corroborated, dbic_val, acts, passes", [
    (1.06, False, 5.0, True, True),  # the identification error cut alone is effect size enough
    (1.06, False, 5.0, False, True),  # ... whether or not the held-out records reach the limit
    (1.039, False, -442.0, True, True),  # seed-61 case_071: sweeps seldom reach the limit, VAL often
    (1.03, False, 3.2, True, False),  # a cut under x1.05 that the held-out BIC does not back
    (1.03, False, 0.0, True, False),  # no held-out gain is no held-out effect
    (1.01, True, 20.0, False, True),  # the amplitude test corroborates (its own, weaker level)
    (1.028, False, -11.0, False, False),  # fresh seed 577's case_022, no effect: a limit above VAL's input
    (1.031, False, -510.7, True, True),  # fresh seed 565's case_068, a paper rate limit VAL reaches
    (1.022, False, -1.4, True, False),  # fresh seed 607's case_022, no effect: a held-out gain below 2
    (1.019, False, -3.1, True, True),  # 593/049's backlash: 3.1 is positive evidence
    (1.03, False, -2.0, True, False),  # the level itself is not past it
])  # fmt: skip
def test_a_small_nonlinear_error_cut_counts_only_with_an_effect_size_from_elsewhere(cut, corroborated, dbic_val, acts,
                                                                                    passes):  # fmt: skip
    from jaxgwo._diagnose import DiagnoseSettings, _effect_size_passes

    settings = DiagnoseSettings()
    assert settings.held_out_bic == 2.0
    assert _effect_size_passes(cut, settings.min_error_ratio, corroborated, dbic_val, acts,
                               settings.held_out_bic) is passes  # fmt: skip
    # 0 restores the earlier rule: any held-out gain where the nonlinearity acts
    assert _effect_size_passes(cut, settings.min_error_ratio, corroborated, dbic_val, acts, 0.0) is (
        corroborated or cut >= settings.min_error_ratio or (dbic_val < 0.0 and acts))


@pytest.mark.parametrize("bad", [-1.0, float("nan"), "2"])
def test_held_out_bic_must_be_a_non_negative_number(bad):
    from jaxgwo._diagnose import DiagnoseSettings

    with pytest.raises(ValueError, match="held_out_bic must be a BIC difference >= 0"):
        DiagnoseSettings(held_out_bic=bad)


@pytest.mark.parametrize("corroborated, by_amplitude, z_val, sizes", [
    (True, False, -0.5, True),  # confirmed otherwise (a cut, J): the amplitude test is its size
    (True, True, 2.3, True),  # backed, but the held-out records confirmed it: backing not needed
    (True, True, -0.07, False),  # fresh seed 589's case_045, no effect: backing and size in one test
    (True, True, 1.0, False),  # z at z_min_time is not a confirmation
    (True, True, float("nan"), False),  # nor is a z the held-out records could not give
    (False, False, 3.0, False),  # no agreement, no size from it
])  # fmt: skip
def test_the_amplitude_test_counts_once_backing_or_effect_size(corroborated, by_amplitude, z_val, sizes):
    from jaxgwo._diagnose import DiagnoseSettings, _amplitude_sizes, _effect_size_passes, _pair_free_effect_size

    settings = DiagnoseSettings()
    assert settings.z_min_time == 1.0
    got = _amplitude_sizes(corroborated, by_amplitude, z_val, settings.z_min_time)
    assert got is sizes
    # on a x1.013 cut (589/045's) the size then rests on this alone, on either path
    assert _effect_size_passes(1.013, settings.min_error_ratio, got, 5.7, True, settings.held_out_bic) is sizes
    assert _pair_free_effect_size(1.013, settings.pair_free_error_ratio, got, 0.9, 1.0) is sizes
    # a cut of the null refit's error by the ratio still sizes a backed candidate
    assert _pair_free_effect_size(1.144, settings.pair_free_error_ratio, got, 0.9, 1.0)


def test_a_servo_nonlinearity_acts_only_where_the_servo_reaches_it():
    """``nonlinearity_acts`` against the linear servo's own peak position and rate
    (scipy.signal.lsim of the servo alone, an independent reference): a saturation or
    rate limit a fifth beyond that peak does not act, one a fifth below it does, a
    backlash acts at any width, and a model without a servo nonlinearity never does."""
    import scipy.signal

    from jaxgwo._diagnose_which import ModelSpec, nonlinearity_acts, simulate_model

    k, tau, m, ws, zs = (float(v) for v in MODEL.to_array())
    t = np.arange(0.0, 6.0, 0.01)
    u = 0.2 * np.sin(2 * np.pi * 1.3 * t) * (t < 4.0)
    records = [(t, u, np.zeros_like(u), np.zeros_like(u))]
    _t, pos, _x = scipy.signal.lsim(([ws * ws], [1.0, 2 * zs * ws, ws * ws]), u, t)
    peak, rate = np.max(np.abs(pos)), np.max(np.abs(np.diff(pos))) / 0.01
    assert 0.15 < peak < 0.3 and rate > 1.0

    def acts(effects):
        spec = ModelSpec(np.asarray(MODEL.to_array(), float), effects)
        return nonlinearity_acts(spec, records, [simulate_model(spec, t, u)])

    assert not acts({"saturation": {"limit": 1.2 * peak}})
    assert acts({"saturation": {"limit": 0.8 * peak}})
    assert not acts({"rate_limit": {"rate": 1.2 * rate}})
    assert acts({"rate_limit": {"rate": 0.8 * rate}})
    assert acts({"backlash": {"width": 1e-3}})
    assert not acts({"time_delay": {"delay_s": 0.02}})
    # with a delay and a gyro filter beside it, the comparison is still like for like
    assert not acts({"saturation": {"limit": 1.2 * peak}, "time_delay": {"delay_s": 0.02},
                     "sensor_lag": {"cutoff_hz": 20.0}})  # fmt: skip


def test_a_gyro_filter_is_estimated_by_its_output_error_refit_and_decided_by_j():
    from jaxgwo._diagnose import _output_error_estimate

    def cand(effect, value, ok, r2, gap, pred, p=1e-9, z=3.0, score=1.2):
        name = {"sensor_lag": "cutoff_hz", "time_delay": "delay_s"}[effect]
        return dataclasses.replace(_scored(effect, score, ok), params={effect: {name: value}},
                                   sigma={effect: {name: 0.1 * value}}, val_r2=r2, val_tic=1.0 - r2, gap_closed=gap,
                                   train_p=p, z_score=z, predicted=(pred,))  # fmt: skip

    j = cand("sensor_lag", 25.0, True, 0.990, 0.5, "j")
    td = cand("sensor_lag", 36.0, False, 0.995, 0.8, "td", p=0.2, z=0.5, score=-9.0)
    out = _output_error_estimate(j, (td, None))
    # the refit's model: its parameters, bound, held-out scores and prediction ...
    assert out.params == td.params and out.sigma == td.sigma and out.predicted == ("td",)
    assert (out.val_r2, out.val_tic, out.gap_closed) == (0.995, td.val_tic, 0.8)
    # ... J's decision: its evidence and score stay, and its estimate is kept beside
    assert out.beats_noise and (out.score, out.train_p, out.z_score) == (1.2, 1e-9, 3.0)
    assert out.detail == {"j_cutoff_hz": 25.0, "estimate_output_error": 1.0}
    # the J fit stands: no refit, a refit stopped at the box's 100 Hz (no filter), one
    # that stood in on the time-domain path already, and the effects inside the band
    assert _output_error_estimate(j, None) is j
    assert _output_error_estimate(j, (cand("sensor_lag", 100.0, False, 0.995, 0.8, "td"), None)) is j
    on_path = dataclasses.replace(j, detail={"time_domain_path": 1.0})
    assert _output_error_estimate(on_path, (td, None)) is on_path
    # a delay's refit is reported only where it beats noise and predicts the held-out records
    # better by _LAG_REFIT_R2 or more (fresh seed 227's case_035: 23.9 ms on J, 18.2 ms
    # refitted, held-out R^2 0.9936 against 0.9970; the truth 18.2 ms)
    from jaxgwo._diagnose import _LAG_REFIT_R2

    delay = cand("time_delay", 0.0239, True, 0.9936, 0.58, "j")
    better = cand("time_delay", 0.0182, True, 0.9970, 0.81, "td")
    out = _output_error_estimate(delay, (better, None))
    assert out.params == better.params and out.val_r2 == 0.9970 and out.predicted == ("td",)
    assert out.beats_noise and (out.score, out.train_p) == (1.2, 1e-9)
    assert out.detail == {"j_delay_s": 0.0239, "estimate_output_error": 1.0}
    barely = cand("time_delay", 0.0182, True, 0.9936 + 0.5 * _LAG_REFIT_R2, 0.6, "td")
    assert _output_error_estimate(delay, (barely, None)) is delay
    assert _output_error_estimate(delay, (cand("time_delay", 0.0182, False, 0.9970, 0.81, "td"), None)) is delay
    assert _output_error_estimate(delay, (cand("time_delay", 0.0, True, 0.9970, 0.81, "td"), None)) is delay  # vanished
    # so is a flapping lag's (fresh seed 453's case_029, 36.9 ms: J 24.4 ms, held-out R^2
    # 0.9661; refitted 32.7 ms, 0.9995)

    def lag(tau_f, ok, r2, pred):
        c = cand("time_delay", 0.0, ok, r2, 0.5, pred)
        return dataclasses.replace(c, effects=("rotor_flapping",), params={"rotor_flapping": {"tau_f": tau_f}},
                                   sigma={"rotor_flapping": {"tau_f": 0.004}})  # fmt: skip

    flap, flap_td = lag(0.0244, True, 0.9661, "j"), lag(0.0327, False, 0.9995, "td")
    flap_td = dataclasses.replace(flap_td, beats_noise=True)
    out = _output_error_estimate(flap, (flap_td, None))
    assert out.params == flap_td.params and out.val_r2 == 0.9995 and out.predicted == ("td",)
    assert out.detail == {"j_tau_f": 0.0244, "estimate_output_error": 1.0}
    close = dataclasses.replace(flap_td, val_r2=0.9661 + 0.5 * _LAG_REFIT_R2)
    assert _output_error_estimate(flap, (close, None)) is flap  # the two predict alike: J's stands
    assert _output_error_estimate(flap, (dataclasses.replace(flap_td, beats_noise=False), None)) is flap


@pytest.mark.parametrize("refit, reported", [
    ((12.16, 0.022, 0.283), True),  # fresh seed 463's case_041 (truth 12.17 Hz): J 12.57 Hz, 0.030
    ((9.0, 0.06, 0.20), True),  # a resonance elsewhere: the time histories, which have no window, place it
    ((12.5, 0.49, 0.50), False),  # a broad pair (pole damping above 0.2): no resonance of the vocabulary
    ((12.5, 0.05, 0.051), False),  # zeros on the poles: the pair cancels (_vanished)
    ((45.0, 0.05, 0.2), False),  # on the box's 45 Hz edge
])  # fmt: skip
def test_a_resonance_named_on_j_is_estimated_by_its_output_error_refit(refit, reported):
    """``J`` reads a lightly damped resonance from a windowed response estimate, which
    widens its peak (the stored paper-plant modes of draws 373-473: pole damping 1.27 times
    the truth); a refit to the time histories that is itself a resonance of the
    vocabulary's shape estimates it, and ``J`` still decides."""
    from jaxgwo._diagnose import _output_error_estimate

    keys = ("freq_hz", "zeta_p", "zeta_z")

    def cand(mode, ok, r2, pred, p=1e-9, score=1.2):
        return dataclasses.replace(_scored("structural_mode", score, ok), params={"structural_mode": dict(zip(keys, mode))},
                                   sigma={"structural_mode": {k: 0.01 for k in keys}}, val_r2=r2, val_tic=1.0 - r2,
                                   gap_closed=r2 - 0.9, train_p=p, z_score=2.0, predicted=(pred,))  # fmt: skip

    j = cand((12.57, 0.030, 0.35), True, 0.9950, "j")
    td = cand(refit, False, 0.9955, "td", p=0.3, score=-5.0)
    out = _output_error_estimate(j, (td, None))
    if not reported:
        assert out is j
        return
    assert out.params == td.params and out.sigma == td.sigma and out.predicted == ("td",)
    assert (out.val_r2, out.gap_closed) == (td.val_r2, td.gap_closed)
    assert out.beats_noise and (out.score, out.train_p, out.z_score) == (1.2, 1e-9, 2.0)  # J decides
    assert out.detail == {"j_freq_hz": 12.57, "j_zeta_p": 0.030, "j_zeta_z": 0.35, "estimate_output_error": 1.0}


@pytest.mark.parametrize("effect, param, j_value, td_value, reported", [
    # a flapping lag J reads 20 ms (+-2) and the refit 26: J's reading stands, +- sqrt(2^2 + 3^2)
    ("rotor_flapping", "tau_f", 0.020, 0.026, "j"),
    # the refit reported: the same bound about it
    ("rotor_flapping", "tau_f", 0.020, 0.026, "td"),
    # a refit that stopped where the effect vanishes is no second reading
    ("rotor_flapping", "tau_f", 0.020, 0.0002, None),
    # a delay's two readings are combined instead (_delay_from_two_readings)
    ("time_delay", "delay_s", 0.041, 0.044, None),
    # a resonance's readings differ by J's windowed peak, a bias: no widening
    ("structural_mode", "freq_hz", 12.0, 12.3, None),
])  # fmt: skip
def test_a_lag_read_by_both_fits_counts_half_their_difference_in_its_bound(effect, param, j_value, td_value, reported):
    """``_two_readings_bound``: two readings of one quantity give half their difference as
    the standard uncertainty of their mean (GUM 4.2, two observations); it is added in
    quadrature to the quoted 1-sigma, and the estimate does not move."""
    from jaxgwo._diagnose import _two_readings_bound

    sigma = 0.001 if effect == "time_delay" else 0.002

    def cand(value, ok=True, **detail):
        c = dataclasses.replace(_scored(effect, 1.0, ok), params={effect: {param: value}},
                                sigma={effect: {param: sigma}})  # fmt: skip
        return dataclasses.replace(c, detail=detail)

    td = cand(td_value, ok=False)
    sc = cand(td_value, estimate_output_error=1.0, **{f"j_{param}": j_value}) if reported == "td" else cand(j_value)
    out = _two_readings_bound(sc, (td, None))
    if reported is None:
        assert out is sc
        return
    half = 0.5 * abs(j_value - td_value)
    assert out.params == sc.params  # the estimate stays
    assert out.sigma[effect][param] == pytest.approx(math.sqrt(sigma**2 + half**2), rel=1e-12)
    assert out.detail["two_readings_half_spread"] == pytest.approx(half, rel=1e-12)
    assert {k: v for k, v in out.detail.items() if k != "two_readings_half_spread"} == sc.detail
    # no refit, or the refit the only reading (the time-domain path): unchanged
    assert _two_readings_bound(sc, None) is sc
    on_path = dataclasses.replace(sc, detail=sc.detail | {"time_domain_path": 1.0})
    assert _two_readings_bound(on_path, (td, None)) is on_path


@pytest.mark.parametrize("d_j, s_j, d_t, s_t, reported", [
    # seed-491 case_029 (34.1 ms): J 52.7 +-75.6, the refit 29.5 +-4.1; J's model reported
    (0.0527, 0.0756, 0.0295, 0.0041, "j"),
    # two readings that disagree beyond their bounds: the mean's bound scaled (S = 5 / sqrt(2))
    (0.040, 0.001, 0.045, 0.001, "td"),
    # two that agree: no scaling
    (0.040, 0.002, 0.041, 0.001, "j"),
])  # fmt: skip
def test_a_delay_read_by_both_fits_is_their_inverse_variance_mean(d_j, s_j, d_t, s_t, reported):
    """``_delay_from_two_readings`` against the textbook weighted mean, with the Particle Data
    Group's scale factor for readings that disagree; the reported model stays."""
    from jaxgwo._diagnose import _delay_from_two_readings

    def cand(d, s, ok=True, **detail):
        c = dataclasses.replace(_scored("time_delay", 1.0, ok), params={"time_delay": {"delay_s": d}},
                                sigma={"time_delay": {"delay_s": s}}, val_r2=0.99, predicted=("model",))  # fmt: skip
        return dataclasses.replace(c, detail=detail)

    j_fit, td = cand(d_j, s_j), cand(d_t, s_t, ok=False)
    sc = cand(d_t, s_t, estimate_output_error=1.0, j_delay_s=d_j) if reported == "td" else j_fit
    out = _delay_from_two_readings(j_fit, sc, (td, None))
    w = np.array([s_j, s_t]) ** -2.0
    mean = float(np.average([d_j, d_t], weights=w))
    chi2 = float(np.sum(w * (np.array([d_j, d_t]) - mean) ** 2))  # PDG: S = sqrt(chi^2 / (N - 1)), N = 2
    scale = max(1.0, math.sqrt(chi2))
    assert out.params["time_delay"]["delay_s"] == pytest.approx(mean, rel=1e-12)
    assert out.sigma["time_delay"]["delay_s"] == pytest.approx(scale / math.sqrt(w.sum()), rel=1e-12)
    assert out.detail["delay_scale_factor"] == pytest.approx(scale, rel=1e-12)
    assert (out.detail["j_delay_s"], out.detail["td_delay_s"]) == (d_j, d_t)
    assert (out.detail["j_sigma_delay_s"], out.detail["td_sigma_delay_s"]) == (s_j, s_t)
    assert (out.val_r2, out.predicted, out.beats_noise) == (sc.val_r2, sc.predicted, sc.beats_noise)
    assert out.detail.get("estimate_output_error") == sc.detail.get("estimate_output_error")
    # no refit, the refit the only reading, a vanished refit, a bound that is no number: unchanged
    assert _delay_from_two_readings(j_fit, sc, None) is sc
    on_path = dataclasses.replace(j_fit, detail={"time_domain_path": 1.0})
    assert _delay_from_two_readings(on_path, on_path, (td, None)) is on_path
    assert _delay_from_two_readings(j_fit, sc, (cand(0.0005, s_t), None)) is sc
    assert _delay_from_two_readings(j_fit, sc, (cand(d_t, float("nan")), None)) is sc


@pytest.mark.parametrize("scores, names", [
    # a lag on top names its twin whatever the scores: the two fit the same responses
    ({"sensor_lag": 3.0, "time_delay": 1.0}, ("sensor_lag", "rotor_flapping")),
    ({"rotor_flapping": 3.0}, ("rotor_flapping", "sensor_lag")),
    # two candidates within the margin: that pair and its separating excitation
    ({"rate_limit": 2.0, "saturation": 1.95}, ("rate_limit", "saturation")),
    ({"sensor_lag": 2.0, "time_delay": 1.95}, ("sensor_lag", "time_delay")),
])  # fmt: skip
def test_separation_suggestion_names_the_pair_the_data_cannot_tell_apart(scores, names):
    from jaxgwo._diagnose import SEPARATING_EXCITATION, separation_suggestion

    text = separation_suggestion([_scored(e, v) for e, v in scores.items()])
    assert text.startswith(names[0]) and names[1] in text
    assert SEPARATING_EXCITATION[frozenset(names)] in text


def test_separation_suggestion_is_silent_without_a_rival():
    from jaxgwo._diagnose import separation_suggestion

    assert separation_suggestion([]) == ""
    assert separation_suggestion([_scored("sensor_lag", 3.0, ok=False)]) == ""  # verdict none
    assert separation_suggestion([_scored("time_delay", 3.0), _scored("sensor_lag", 1.0)]) == ""  # 2.0 apart
    # a rival that does not beat noise is no rival, however close its score
    assert separation_suggestion([_scored("backlash", 3.0), _scored("saturation", 2.99, ok=False)]) == ""


def test_output_error_evidence_is_minus_the_bic_change_per_effective_sample():
    from jaxgwo._diagnose_which import output_error_evidence

    n, k = 400.0, 3
    dbic = n * math.log(0.8 / 1.0) + k * math.log(n)  # BIC of the candidate minus that of the null
    assert output_error_evidence(1.0, 0.8, k, n) == pytest.approx(-dbic / n, rel=1e-12)
    assert output_error_evidence(1.0, 1.0, 1, n) < 0  # no cut: the added parameter costs


def test_a_nan_score_sorts_last():
    """A refit that simulated nothing finite scores NaN; with a plain ``-score`` key
    Python's sort leaves it where it stood, ahead of a candidate that beats noise."""
    from jaxgwo._diagnose import _best_first

    ranking = [_scored("backlash", float("nan"), ok=False), _scored("time_delay", 4.8), _scored("sensor_lag", -10.0, ok=False)]
    assert [c.effects[0] for c in sorted(ranking, key=lambda c: -c.score)][0] == "backlash"  # the trap
    assert [c.effects[0] for c in sorted(ranking, key=_best_first)] == ["time_delay", "sensor_lag", "backlash"]


def test_a_nonlinear_candidate_may_close_the_gap_its_own_null_refit_leaves():
    """A nonlinear candidate is the null time-domain refit plus the nonlinearity.  Where
    that refit predicts the held-out records worse than the frequency-domain nominal, a
    candidate that beats the refit (z above ``z_min``) but not the nominal passes only with
    ``gap_against_baseline``; its reported gap stays the nominal's (here negative).  One
    that falls below the refit fails either way, and the rule changes nothing for one
    that beats the nominal.  The R^2 values are checked against a plain NumPy formula.
    Evidence that is not a number, or a prediction that diverged, beats nothing."""
    from jaxgwo._diagnose_which import score_candidate

    rng = np.random.default_rng(3)
    t = np.arange(0.0, 20.0, 0.02)
    y = np.sin(2.0 * np.pi * 0.7 * t) + 0.4 * np.sin(2.0 * np.pi * 2.3 * t + 1.0)
    err = rng.standard_normal(t.size)

    def r2(p):
        return _r2_about_record_means([y], [p])

    nominal, refit = y + 0.10 * err, y + 0.20 * err

    def scored(cand, against):
        return score_candidate(("rate_limit",), {}, {}, [cand], [y], [nominal], r2(nominal), 1.0, 1.0, 500.0, 1, 0.02,
                               0.02, 0.0, baseline_predicted=[refit], extra_train_p=1e-12, j_required=False,
                               z_min=1.0, min_gap=0.0, gap_against_baseline=against)  # fmt: skip

    between = y + 0.15 * err
    assert r2(refit) < r2(between) < r2(nominal)
    for against in (False, True):
        sc = scored(between, against)
        assert sc.z_score > 1.0 and sc.val_r2 == pytest.approx(r2(between), abs=1e-9)
        assert sc.gap_closed == pytest.approx((r2(between) - r2(nominal)) / (1.0 - r2(nominal)), abs=1e-9)
        assert sc.gap_closed < 0.0 and sc.beats_noise == against
        assert not scored(y + 0.25 * err, against).beats_noise  # worse than the refit too
        assert scored(y + 0.05 * err, against).beats_noise  # better than both
    # evidence that is not a number (a diverged null refit) beats nothing, however good the fit
    nan_evidence = score_candidate(("rate_limit",), {}, {}, [y + 0.05 * err], [y], [nominal], r2(nominal), 1.0, 1.0,
                                   500.0, 1, 0.02, 0.02, 0.0, extra_train_p=1e-12, j_required=False, z_min=1.0,
                                   min_gap=0.0, evidence=math.nan)  # fmt: skip
    assert not nan_evidence.beats_noise and math.isnan(nan_evidence.score)
    # a simulation that diverged to huge but finite values (seed-211 case_057) beats nothing
    # and sorts last, without numpy's overflow warnings
    blown = y + 0.05 * err
    blown[-50:] = np.geomspace(1.0, 1e200, 50)
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        for against in (False, True):
            sc = scored(blown, against)
            assert not sc.beats_noise and sc.val_r2 == -math.inf and sc.score == -math.inf
            assert math.isnan(sc.z_score) and sc.delta_bic_val == math.inf


def test_held_out_scores_do_not_depend_on_the_records_trim():
    """Each held-out record is scored about its mean (``held_out_centred``): a trim error,
    a constant on the measured rate of each record, changes neither R^2, TIC, the gap
    closed nor the block z-score.  R^2 against a plain NumPy one over the two records with
    a constant fitted to each; a diverged simulation still predicts nothing."""
    from jaxgwo._diagnose_which import held_out_centred, held_out_fit, score_candidate

    rng = np.random.default_rng(11)
    dt = 0.02
    t = np.arange(0.0, 20.0, dt)
    ys = [np.sin(2.0 * np.pi * f * t) + 0.2 * rng.standard_normal(t.size) for f in (0.4, 0.9)]
    nominal = [np.sin(2.0 * np.pi * f * t + 0.3) for f in (0.4, 0.9)]
    cand = [np.sin(2.0 * np.pi * f * t + 0.1) for f in (0.4, 0.9)]

    def scored(ys):
        _y, _p, r2_nom, _tic, _g = held_out_fit(ys, nominal, 0.0)
        return score_candidate(("time_delay",), {}, {}, cand, ys, nominal, r2_nom, 1.0, 1.0, 50.0, 1, dt, dt, 0.0)

    trimmed = [y + c for y, c in zip(ys, (0.35, -0.2))]  # each record's rate off by its trim error
    a, b = scored(ys), scored(trimmed)
    assert a.val_r2 == pytest.approx(_r2_about_record_means(ys, cand), rel=1e-9)
    assert a.val_r2 > _r2_about_record_means(ys, nominal) + 0.05  # the candidate is the better model here
    for f in ("val_r2", "val_tic", "gap_closed", "z_score"):
        assert getattr(b, f) == pytest.approx(getattr(a, f), rel=1e-9, abs=1e-12)
    # scored from the records as they stand, the trim error would have cost R^2
    raw = 1.0 - np.sum(np.concatenate([y - p for y, p in zip(trimmed, cand)]) ** 2) / np.sum(
        (np.concatenate(trimmed) - np.concatenate(trimmed).mean()) ** 2)
    assert raw < b.val_r2 - 0.02
    blown, taken = held_out_centred([np.full(t.size, np.nan), cand[1]])
    assert np.all(blown == 0.0) and np.allclose(taken, cand[1] - np.mean(cand[1]))


def test_a_cross_coupling_may_pass_on_the_held_out_records_first():
    """``held_out_alpha``: strong held-out evidence (z at least the one-sided normal
    quantile of ``alpha``, 3.09 at 1e-3) with weak identification support (``extra_train_p``
    below ``held_out_alpha``) passes; weak held-out evidence, an identification p above
    that level, or a negative gap does not, and without ``held_out_alpha`` nothing changes.
    The z-score is checked against a plain NumPy block z of the squared-error reduction."""
    from statistics import NormalDist

    from jaxgwo._diagnose_which import score_candidate

    rng = np.random.default_rng(5)
    dt = 0.02
    t = np.arange(0.0, 24.0, dt)
    y = np.sin(2.0 * np.pi * 0.5 * t) + 0.3 * np.sin(2.0 * np.pi * 1.7 * t)
    err = rng.standard_normal(t.size)

    def r2(p):
        return _r2_about_record_means([y], [p])

    nominal = y + 0.10 * err

    def scored(cand, p_train, held_out_alpha=0.05):
        return score_candidate(("cross_coupling",), {}, {}, [cand], [y], [nominal], r2(nominal), 1.0, 1.0, 500.0, 1,
                               dt, dt, 0.0, extra_train_p=p_train, j_required=False, z_min=1.0, min_gap=0.0,
                               held_out_alpha=held_out_alpha)  # fmt: skip

    def block_z(cand):  # 0.5 s blocks: the correlation time here is one sample; each
        # prediction taken about the record's mean residual, as every held-out score is
        p0, p1 = (p + np.mean(y - p) for p in (nominal, cand))
        d = (y - p0) ** 2 - (y - p1) ** 2
        b = int(round(0.5 / dt))
        m = d[: d.size // b * b].reshape(-1, b).mean(axis=1)
        return m.mean() / (m.std(ddof=1) / np.sqrt(m.size))

    quantile = NormalDist().inv_cdf(1.0 - 1e-3)
    other = np.random.default_rng(6).standard_normal(t.size)  # errors of their own, partly shared
    strong, weak = (y + k * (0.8 * err + 0.6 * other) for k in (0.09, 0.095))
    assert scored(strong, 0.02).z_score == pytest.approx(block_z(strong), rel=1e-6)
    assert scored(strong, 0.02).z_score > quantile and 1.0 < scored(weak, 0.02).z_score < quantile
    assert scored(strong, 0.02).gap_closed > 0.0
    assert scored(strong, 0.02).beats_noise  # the held-out records carry it
    assert not scored(strong, 0.02, None).beats_noise  # the rule off: p 0.02 fails alpha
    assert not scored(strong, 0.2).beats_noise  # the identification records do not support it
    assert not scored(weak, 0.02).beats_noise  # the held-out evidence is not strong enough
    assert scored(weak, 1e-4).beats_noise  # the usual way round still passes
    worse = y + 0.11 * (0.8 * err + 0.6 * other)
    assert not scored(worse, 0.02).beats_noise and not scored(worse, 1e-4).beats_noise
    # consistent but immaterial: the nominal's own error 1.3 % smaller everywhere reaches any
    # z, but on 240 effective samples (0.1 s correlation time) its held-out BIC drops by
    # 240 ln(0.987^2) + ln 240 = 0.8 only, short of HELD_OUT_FIRST_BIC (seed-157 case_007)
    from jaxgwo._diagnose_which import HELD_OUT_FIRST_BIC

    slight = y + 0.987 * (nominal - y)
    sc = score_candidate(("cross_coupling",), {}, {}, [slight], [y], [nominal], r2(nominal), 1.0, 1.0, 500.0, 1, 0.1,
                         dt, 0.0, extra_train_p=0.004, j_required=False, z_min=1.0, min_gap=0.0,
                         held_out_alpha=0.05)  # fmt: skip
    assert sc.z_score > 10.0 and sc.gap_closed > 0.0
    assert sc.delta_bic_val == pytest.approx(240.0 * np.log(0.987**2) + np.log(240.0), rel=1e-6)
    assert -HELD_OUT_FIRST_BIC < sc.delta_bic_val < 0.0 and not sc.beats_noise


def _mode_fit(freq_hz, zeta_p, zeta_z, p=1e-10, dbic=-20.0):
    """A ``structural_mode`` J fit's score with its evidence (the fields _same_resonance reads)."""
    sc = _scored("structural_mode", 0.0, ok=False)
    return dataclasses.replace(sc, params={"structural_mode": {"freq_hz": freq_hz, "zeta_p": zeta_p, "zeta_z": zeta_z}},
                               train_p=p, delta_bic=dbic)  # fmt: skip


@pytest.mark.parametrize("j, td, same", [
    # seed-173 case_020's two fits: J 9.71 Hz (p 8e-17), the output-error refit 9.63 Hz
    ((9.71, 0.085, 0.171), 9.63, True),
    ((9.71, 0.085, 0.171), 9.71 * 1.084, True),  # just inside the half-power half-width (8.5 %)
    ((9.71, 0.085, 0.171), 9.71 * 1.086, False),  # just outside it
    ((9.71, 0.085, 0.171), 9.71 * 0.914, False),
    ((8.65, 0.335, 1.5), 7.84, False),  # a broad pair imitating a lag (seed-163 case_068): no resonance
    ((45.0, 0.01, 1.5), 45.0, False),  # on the box's edge (rate limits)
    ((11.10, 0.046, 1.082), 10.56, False),  # seed-163 case_025: 0.54 Hz apart, half-width 0.51
])  # fmt: skip
def test_a_resonance_found_by_j_and_the_matched_filter_is_one_finding(j, td, same):
    from jaxgwo._diagnose import _same_resonance

    assert _same_resonance(_mode_fit(*j), {"freq_hz": td, "zeta_p": 0.07, "zeta_z": 0.15}, 1e-3) is same


@pytest.mark.parametrize("effect, mode, p, dbic, found", [
    # seed-223 case_020 (R-50, a 10.11 Hz mode): J 7.20 -> 3.71 beside the structure pair
    ("structural_mode", (10.14, 0.054, 0.090), 1.2e-5, -20.0, True),
    # seed-269 case_007 (R-50, a 13.69 Hz mode)
    ("structural_mode", (14.45, 0.046, 0.651), 3.3e-12, -40.0, True),
    ("structural_mode", (10.14, 0.054, 0.090), 2e-3, -20.0, False),  # J's F-test fails alpha
    ("structural_mode", (10.14, 0.054, 0.090), 1.2e-5, 0.5, False),  # its BIC does not improve
    ("structural_mode", (10.14, 0.054, 0.060), 1.2e-5, -20.0, False),  # zeros below the poles: a notch
    ("structural_mode", (8.65, 0.335, 1.5), 1e-10, -40.0, False),  # a broad pair imitating a lag
    ("structural_mode", (8.65, 0.15, 1.2), 1e-10, -40.0, False),  # real zeros: a pair, not a resonance
    ("structural_mode", (3.0, 0.2, 0.14), 1e-10, -40.0, False),  # on the box's edge beside a pair
    ("structural_mode", (45.0, 0.01, 1.5), 1e-10, -40.0, False),  # on the box's edge (rate limits)
    # seed-353 case_027 (paper, no effect): a peak below the vocabulary's 8-30 Hz, where the
    # held-out multisteps can judge it (they did: gap -0.041)
    ("structural_mode", (6.35, 0.067, 0.101), 5.5e-4, -11.0, False),
    ("sensor_lag", (10.14, 0.054, 0.090), 1e-10, -40.0, False),  # not a resonance's candidate
])  # fmt: skip
def test_a_resonance_j_finds_needs_the_held_out_records_only_not_to_contradict_it(effect, mode, p, dbic, found):
    """:func:`_resonance_found_by_j`: where it holds, the candidate's held-out floor is a
    linear ``J`` fit's (``z_min``, ``min_gap``) instead of a positive gap."""
    from jaxgwo._diagnose import _resonance_found_by_j

    sc = _mode_fit(*mode, p=p, dbic=dbic)
    assert _resonance_found_by_j((effect,), sc.params, sc, 1e-3) is found


def _raise_the_mode_j_fits_floor(monkeypatch, dg):
    """Raise the positive gap a ``structural_mode``'s ``J`` fit must close on the held-out
    records to 0.5 (its output-error refits and the linear floor of ``as_linear`` keep
    theirs): held-out records that hardly see the mode.  Returns the floor it replaced."""
    own_floor = dg._held_out_floor

    def raised(s, effects, time_domain, *args, **kw):
        z_min, min_gap = own_floor(s, effects, time_domain, *args, **kw)
        j_fit = tuple(effects) == ("structural_mode",) and not time_domain and not kw.get("as_linear")
        return (z_min, 0.5) if j_fit else (z_min, min_gap)

    monkeypatch.setattr(dg, "_held_out_floor", raised)
    return own_floor


@pytest.mark.slow
def test_diagnose_takes_a_resonance_j_finds_where_its_own_floor_refuses_it(monkeypatch):
    """The wiring of :func:`_resonance_found_by_j` inside ``diagnose``.  An 8.5 Hz resonance
    (pole damping 0.07, zeros 0.15) that ``J`` finds is made to fail its own held-out floor:
    the positive gap a ``structural_mode``'s ``J`` fit needs is raised here to 0.5, above the gap
    its fit closes, standing in for held-out records that hardly see the mode (seed-277
    case_056: gap -0.036).  ``diagnose`` then scores it again on a linear ``J`` fit's floor;
    that fit is the verdict and says so (``passed_as_resonance_found_by_J``).  With the rule
    switched off the ``J`` fit is refused (here its output-error refit stands in, on its own
    route).  Only the resonance and a delay are candidates, which keeps each diagnosis to
    seconds."""
    import jaxgwo._diagnose as dg

    train, val = _case("structural_mode", seed=2, freq_hz=8.5, zeta_p=0.07, zeta_z=0.15)
    settings = dataclasses.replace(SETTINGS, candidates=("structural_mode", "time_delay"))
    own_floor = _raise_the_mode_j_fits_floor(monkeypatch, dg)
    # the J fit's own numbers: its output-error estimate (below) is held off until the last run
    estimate = dg._output_error_estimate
    monkeypatch.setattr(dg, "_output_error_estimate", lambda sc, refit: sc)
    d = diagnose(train, val, "lateral", settings)
    top = d.ranking[0]
    assert d.verdict == "structural_mode" and d.structure is None
    assert abs(top.params["structural_mode"]["freq_hz"] / 8.5 - 1.0) < 0.03
    assert top.beats_noise and 0.0 < top.gap_closed < 0.5 and top.z_score > SETTINGS.z_min
    assert top.detail.get("passed_as_resonance_found_by_J") == 1.0
    assert top.detail.get("time_domain_path") == 0.0  # the J fit itself
    monkeypatch.setattr(dg, "_resonance_found_by_j", lambda *args, **kw: False)
    off = diagnose(train, val, "lateral", settings)
    (mode,) = [c for c in off.ranking if c.effects == ("structural_mode",)]
    # the J fit refused; what stands now, if anything, is the mode's output-error refit
    assert mode.detail.get("time_domain_path") == 1.0 or not mode.beats_noise
    assert "passed_as_resonance_found_by_J" not in mode.detail
    # without the raised floor the fit passes on its own (positive) gap, unmarked
    monkeypatch.setattr(dg, "_held_out_floor", own_floor)
    monkeypatch.setattr(dg, "_output_error_estimate", estimate)
    plain = diagnose(train, val, "lateral", settings)
    assert plain.verdict == "structural_mode" and "passed_as_resonance_found_by_J" not in plain.ranking[0].detail
    # J decides; the resonance is estimated by its output-error refit (_output_error_estimate),
    # the J fit's parameters kept beside
    top = plain.ranking[0]
    assert top.detail["estimate_output_error"] == 1.0 and top.detail["time_domain_path"] == 0.0
    mode = top.params["structural_mode"]
    assert mode == {p: top.detail[f"td_{p}"] for p in ("freq_hz", "zeta_p", "zeta_z")}
    assert top.val_r2 == top.detail["td_val_r2"] and all(f"j_{p}" in top.detail for p in mode)
    assert (f"where the frequency-domain fit that found it read freq_hz {top.detail['j_freq_hz']:.3g}, "
            f"zeta_p {top.detail['j_zeta_p']:.3g}, zeta_z {top.detail['j_zeta_z']:.3g}: the response is measured "
            "over windows") in plain.summary()
    assert "Estimated by refitting" not in d.summary()  # the J fit's own estimate (held off above)


@pytest.mark.parametrize("p_j, p_td, refused", [
    (8.1e-4, 0.995, True),  # fresh seed 603's case_053, a paper plant without an effect
    (6.5e-4, 0.86, True),  # 541/054, the same
    (7.5e-12, 0.76, False),  # 545/041, a true 8.2 Hz mode J alone carries far beyond noise
    (1.3e-4, 3.2e-5, False),  # the output-error refit finds it at alpha: two tests agree
    (0.99e-4, 0.5, False),  # J below alpha / 10 passes
    (1.0e-4, 0.5, True),  # at it, not
    (8.1e-4, 1.0e-3, True),  # an output-error p at alpha is no finding
    (8.1e-4, None, False),  # no time-domain check: the rule has nothing to read
])  # fmt: skip
def test_a_resonance_j_alone_carries_near_its_threshold_is_refused(p_j, p_td, refused):
    from jaxgwo._diagnose import DiagnoseSettings, _resonance_on_j_alone

    s = DiagnoseSettings()
    assert (s.alpha, s.alpha_resonance_j_alone) == (1e-3, 1e-4)
    assert _resonance_on_j_alone(p_j, p_td, s.alpha, s.alpha_resonance_j_alone) is refused
    assert not _resonance_on_j_alone(p_j, p_td, s.alpha, s.alpha)  # switched off: J at alpha suffices
    with pytest.raises(ValueError, match="alpha_resonance_j_alone"):
        DiagnoseSettings(alpha_resonance_j_alone=1.0)


@pytest.mark.slow
def test_diagnose_refuses_a_resonance_j_alone_carries_and_says_so(monkeypatch):
    """The wiring of :func:`_resonance_on_j_alone` inside ``diagnose``: it is asked about
    the paper model's ``structural_mode`` only, with that ``J`` fit's F-test p and its
    time-domain check's p; a true 8.5 Hz mode passes (``J`` far beyond ``alpha`` / 10, the
    refit finding it too) and is the verdict, unmarked.  Made to refuse it (and its
    output-error refit kept from standing in), the mode no longer beats noise, is marked
    ``refused_as_resonance_on_J_alone`` and is not the verdict."""
    import jaxgwo._diagnose as dg

    train, val = _case("structural_mode", seed=2, freq_hz=8.5, zeta_p=0.07, zeta_z=0.15)
    settings = dataclasses.replace(SETTINGS, candidates=("structural_mode", "time_delay"))
    calls, rule = [], dg._resonance_on_j_alone

    def spy(p_j, p_td, alpha, alpha_j_alone):
        calls.append((p_j, p_td, alpha, alpha_j_alone))
        return rule(p_j, p_td, alpha, alpha_j_alone)

    monkeypatch.setattr(dg, "_resonance_on_j_alone", spy)
    d = diagnose(train, val, "lateral", settings)
    (mode,) = [c for c in d.ranking if c.effects == ("structural_mode",)]
    assert d.verdict == "structural_mode" and "refused_as_resonance_on_J_alone" not in mode.detail
    assert len(calls) == 1 and calls[0][2:] == (settings.alpha, settings.alpha_resonance_j_alone)
    p_j, p_td = calls[0][:2]
    assert p_j < settings.alpha_resonance_j_alone and p_td == mode.detail["td_p_output_error"]
    monkeypatch.setattr(dg, "_resonance_on_j_alone", lambda *a: True)
    monkeypatch.setattr(dg, "_takes_time_domain_path", lambda *a, **kw: False)
    off = diagnose(train, val, "lateral", settings)
    (mode,) = [c for c in off.ranking if c.effects == ("structural_mode",)]
    assert mode.detail.get("refused_as_resonance_on_J_alone") == 1.0 and not mode.beats_noise
    assert off.verdict != "structural_mode"
    # alone among the candidates, the refused mode leaves `none`, and the summary names it
    # as unconfirmed for this reason, not for the held-out records
    alone = diagnose(train, val, "lateral", dataclasses.replace(settings, candidates=("structural_mode",)))
    assert alone.verdict == "none" and alone.unconfirmed == ("structural_mode",)
    text = alone.summary()
    assert "support it in the frequency-domain fit alone (its output-error refit at p" in text
    assert "short of the 0.0001 a resonance picked from the band needs there" in text


@pytest.mark.slow
def test_diagnose_takes_a_resonance_the_matched_filter_alone_finds_far_beyond_noise(monkeypatch):
    """The wiring of :func:`_matched_filter_alone` (``alpha_resonance``) inside ``diagnose``.
    The 8.5 Hz resonance of the test above, with its ``J`` fit refused as there (positive-gap
    floor raised to 0.5, :func:`_resonance_found_by_j` off) and ``J`` made not to agree with
    the output-error refit (:func:`_same_resonance` off), as on seed-227 case_029.  The
    refit lands on the mode at matched-filter z 5.7, beyond the level's 4.0, while the
    held-out records do not confirm it (z -0.3, below ``z_min_time``): it stands in for the
    ``J`` fit on the unconfirmed floor, and the summary says why.  With ``alpha_resonance``
    0 (off) it needs that confirmation and is refused."""
    import jaxgwo._diagnose as dg
    from jaxgwo._diagnose_which import matched_filter_p

    train, val = _case("structural_mode", seed=2, freq_hz=8.5, zeta_p=0.07, zeta_z=0.15)
    _raise_the_mode_j_fits_floor(monkeypatch, dg)
    monkeypatch.setattr(dg, "_resonance_found_by_j", lambda *args, **kw: False)
    monkeypatch.setattr(dg, "_same_resonance", lambda *args, **kw: False)
    settings = dataclasses.replace(SETTINGS, candidates=("structural_mode", "time_delay"))
    d = diagnose(train, val, "lateral", settings)
    top = d.ranking[0]
    assert d.verdict == "structural_mode" and d.structure is None
    assert abs(top.params["structural_mode"]["freq_hz"] / 8.5 - 1.0) < 0.03
    assert top.detail.get("time_domain_path") == 1.0  # the output-error refit stands in
    assert top.detail.get("td_passed_on_matched_filter_alone") == 1.0
    assert matched_filter_p(top.detail["td_mf_z"], 3) < settings.alpha_resonance
    # what makes the rule decide: not contradicted, yet not confirmed
    assert top.beats_noise and top.gap_closed > 0.0 and settings.z_min < top.z_score <= settings.z_min_time
    assert f"matched-filter z {top.detail['td_mf_z']:.1f}" in d.summary()
    off = diagnose(train, val, "lateral", dataclasses.replace(settings, alpha_resonance=0.0))
    (mode,) = [c for c in off.ranking if c.effects == ("structural_mode",)]
    assert off.verdict != "structural_mode" and not mode.beats_noise
    assert mode.detail.get("time_domain_path") == 0.0 and "td_passed_on_matched_filter_alone" not in mode.detail
    assert mode.detail["td_mf_z"] == top.detail["td_mf_z"]  # the same refit, refused for want of confirmation


def test_a_resonance_j_does_not_find_on_its_own_needs_the_held_out_confirmation():
    from jaxgwo._diagnose import _same_resonance

    td = {"freq_hz": 9.63, "zeta_p": 0.074, "zeta_z": 0.145}
    assert _same_resonance(_mode_fit(9.71, 0.085, 0.171), td, 1e-3)
    assert not _same_resonance(_mode_fit(9.71, 0.085, 0.171, p=2e-3), td, 1e-3)  # J's F-test fails alpha
    assert not _same_resonance(_mode_fit(9.71, 0.085, 0.171, dbic=0.5), td, 1e-3)  # its BIC does not improve


def test_a_resonance_far_beyond_noise_by_the_matched_filter_alone_needs_the_held_out_records_only_not_to_contradict_it():
    """``alpha_resonance``: fresh seed 227's case_029 (a 10.42 Hz mode; the refit 10.51 Hz at
    matched-filter z 5.34, ``J`` finding no resonance) was refused at held-out z 0.77 and gap
    0.31 for want of confirmation; at this level it need only not be contradicted.  So,
    since the level is ``alpha`` (session 59), need the true paper resonances the stored
    seeds 347-379 answered ``none`` with their refit on the mode: 367/019 (z 4.20, held-out
    z 0.95, gap 0.019), 379/058 (4.58), 379/068 (4.94) and 347/046 (4.11, held-out z -0.62,
    gap 0.25).  A rate limit's refit in the box (383/005, z 3.41) and the ``none`` cases'
    (at most 1.35 on seeds 311-389) stay below it; a refit ``J`` agrees with (its own route,
    the linear floor) or one that is no resonance of the vocabulary needs the confirmation."""
    import scipy.stats

    from jaxgwo._diagnose import _held_out_floor, _matched_filter_alone
    from jaxgwo._diagnose_which import matched_filter_p

    s = DiagnoseSettings()
    # the level in matched-filter z: z^2 against chi^2 with the mode's three parameters
    z_level = math.sqrt(scipy.stats.chi2.isf(s.alpha_resonance, 3))
    assert 4.0 < z_level < 4.1 and abs(matched_filter_p(z_level, 3) - s.alpha_resonance) < 1e-9
    assert s.alpha_resonance == s.alpha
    for z in (5.34, 4.94, 4.58, 4.20, 4.11):
        assert _matched_filter_alone(True, False, matched_filter_p(z, 3), s.alpha_resonance), z
    for z in (3.41, 3.39, 1.35):
        assert not _matched_filter_alone(True, False, matched_filter_p(z, 3), s.alpha_resonance), z
    p029 = matched_filter_p(5.34, 3)
    assert not _matched_filter_alone(True, True, p029, s.alpha_resonance)  # J agrees: _same_resonance's route
    assert not _matched_filter_alone(False, False, p029, s.alpha_resonance)  # no resonance: the F-test's evidence
    assert not _matched_filter_alone(True, False, p029, 0.0)  # switched off
    # the held-out numbers of case_029, 367/019 and 347/046 pass the unconfirmed floor, not the confirming one
    z_un, gap_un = _held_out_floor(s, ("structural_mode",), True, False)
    z_co, gap_co = _held_out_floor(s, ("structural_mode",), True, True)
    assert (z_un, gap_un) == (s.z_min, 0.0) and (z_co, gap_co) == (s.z_min_time, 0.0)
    for z_held, gap in ((0.77, 0.31), (0.95, 0.019), (-0.62, 0.25)):
        assert z_un < z_held < z_co and gap > gap_un
    # seed-227 case_014 (z 5.25, gap -0.044): past the level, but a negative gap still refuses it
    assert _matched_filter_alone(True, False, matched_filter_p(5.25, 3), s.alpha_resonance) and not -0.044 > gap_un


@pytest.mark.slow
def test_a_coupling_far_beyond_noise_on_the_paper_model_needs_the_held_out_records_only_not_to_contradict_it():
    """``alpha_coupling_gain``: the held-out multisteps here carry almost no off-axis stick
    (0.002 rms against the sweeps' 0.02), so they cannot confirm a coupling of 0.1 (z below
    ``z_min_time``, which refused it before); its gain, far beyond noise on the
    identification records, carries the verdict, and the summary says so.  Without the
    rule (``alpha_coupling_gain`` 0) this case answers ``none``: checked when it was set."""
    train, val = _case("cross_coupling", seed=4, val_off_rms=0.002, gain=0.1)
    d = diagnose(train, val, "lateral", SETTINGS)
    assert d.verdict == "cross_coupling" and d.structure is None
    top = d.ranking[0]
    g, sg = top.params["cross_coupling"]["gain"], top.sigma["cross_coupling"]["gain"]
    assert abs(g - 0.1) < 3 * sg and top.train_p < SETTINGS.alpha_coupling_gain
    assert SETTINGS.z_min < top.z_score <= SETTINGS.z_min_time and top.gap_closed > 0.0
    assert top.detail.get("passed_on_gain_alone") == 1.0
    assert f"The identification records carry its evidence (gain p {top.train_p:.2g})" in d.summary()


def test_the_held_out_floor_of_each_route():
    """``_held_out_floor``: a linear ``J`` fit need only not be contradicted; a
    ``structural_mode`` and every time-domain candidate need a positive gap; a time-domain
    candidate to be confirmed needs ``z_min_time``; a resonance that ``J`` and the matched
    filter both find takes the linear ``J`` fit's floor.  Seed-181 case_063's refit (held-out
    z 1.17, gap -0.009, made up here on a score) passes on that floor and on no other."""
    from jaxgwo._diagnose import _held_out_floor
    from jaxgwo._diagnose_which import score_candidate

    s = DiagnoseSettings()
    assert s.z_min < s.z_min_time and s.min_gap < 0.0
    assert _held_out_floor(s, ("time_delay",), False, True) == (s.z_min, s.min_gap)
    assert _held_out_floor(s, ("structural_mode",), False, True) == (s.z_min, 0.0)
    assert _held_out_floor(s, ("rate_limit",), True, True) == (s.z_min_time, 0.0)
    assert _held_out_floor(s, ("cross_coupling",), True, False) == (s.z_min, 0.0)
    assert _held_out_floor(s, ("structural_mode",), True, True) == (s.z_min_time, 0.0)
    assert _held_out_floor(s, ("structural_mode",), True, False, as_linear=True) == (s.z_min, s.min_gap)
    # a refit predicting the held-out records a little worse than the nominal, a little
    # better than the null refit (its baseline)
    rng = np.random.default_rng(7)
    dt = 0.02
    t = np.arange(0.0, 24.0, dt)
    y = np.sin(2.0 * np.pi * 0.5 * t)
    err = rng.standard_normal(t.size)
    nominal, null = y + 0.050 * err, y + 0.054 * err
    cand = y + 0.0501 * err
    r2_nom = _r2_about_record_means([y], [nominal])

    def passes(z_min, min_gap):
        return score_candidate(("structural_mode",), {}, {}, [cand], [y], [nominal], r2_nom, 1.0, 1.0, 500.0, 3, dt,
                               dt, 0.0, baseline_predicted=[null], extra_train_p=1e-8, j_required=False,
                               z_min=z_min, min_gap=min_gap)  # fmt: skip

    sc = passes(*_held_out_floor(s, ("structural_mode",), True, False, as_linear=True))
    assert sc.beats_noise and sc.z_score > s.z_min_time and s.min_gap < sc.gap_closed < 0.0
    assert not passes(*_held_out_floor(s, ("structural_mode",), True, False)).beats_noise
    assert not passes(*_held_out_floor(s, ("structural_mode",), True, True)).beats_noise
