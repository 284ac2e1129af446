"""Excitation signals against independent NumPy/SciPy references."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
import scipy.signal

from jaxgwo._signals import (
    doublet,
    frequency_sweep,
    multistep_3211,
    odd_multisine,
    pilot_corrections,
    sid_chirp,
    sid_chirp_frequency_hz,
    sid_chirp_from_params,
    sweep_frequency_hz,
    time_vector,
)

FS = 100.0


def test_sweep_frequency_law_and_phase():
    """Dwell at f_start, then Tischler's exponential law; phase is the integral of frequency."""
    t = time_vector(60.0, 1000.0)
    kw = dict(f_start_hz=0.3, f_stop_hz=12.0, duration_s=60.0)
    f = np.asarray(sweep_frequency_hz(t, **kw))
    t_np = np.asarray(t)
    dwell = 2.0 / 0.3
    assert np.all(f[t_np < dwell] == pytest.approx(0.3))
    tau = t_np[t_np >= dwell] - dwell
    ref = 0.3 + (12.0 - 0.3) * 0.0187 * (np.exp(4.0 * tau / (60.0 - dwell)) - 1.0)  # Tischler eq. 5.6
    np.testing.assert_allclose(f[t_np >= dwell], ref, rtol=1e-12)
    assert np.all(np.diff(f) >= 0.0)
    assert f[-1] == pytest.approx(12.0, rel=0.01)  # K(T) = 0.0187 (e^4 - 1) = 1.002
    # the signal's phase advance matches the cumulative integral of 2 pi f (trapezoid)
    x = np.asarray(frequency_sweep(t, amplitude=1.0, fade_in_s=0.0, fade_out_s=0.0, **kw))
    phase = np.cumsum(np.r_[0.0, 0.5 * (f[1:] + f[:-1]) * np.diff(t_np)]) * 2 * np.pi
    mid = (t_np > 1.0) & (t_np < 59.0)
    np.testing.assert_allclose(x[mid], np.sin(phase[mid]), atol=2e-3)


def test_sweep_fades_and_amplitude():
    t = time_vector(40.0, FS)
    x = np.asarray(frequency_sweep(t, f_start_hz=0.5, f_stop_hz=10.0, duration_s=30.0, amplitude=0.2, start_s=5.0))
    t_np = np.asarray(t)
    assert np.all(x[t_np < 5.0] == 0.0) and np.all(x[t_np > 35.0] == 0.0)
    assert np.max(np.abs(x)) <= 0.2 + 1e-12
    assert np.max(np.abs(x)) > 0.19
    # fade-in: small in the first tenth of a start period
    assert np.max(np.abs(x[(t_np >= 5.0) & (t_np < 5.2)])) < 0.02


def _ardupilot_chirp_reference(t, f0, f1, fade_in, rec, fade_out, mag):
    """Line-by-line transcription of ArduPilot's Chirp::update (AP_Math/chirp.cpp)."""
    w_min, w_max = 2 * np.pi * f0, 2 * np.pi * f1
    const_freq = 2.0 / f0
    b = np.log(w_max / w_min)
    out = np.zeros_like(t)
    for i, ti in enumerate(t):
        if ti <= 0.0:
            window = 0.0
        elif ti <= fade_in:
            window = 0.5 - 0.5 * np.cos(np.pi * ti / fade_in)
        elif ti <= rec - fade_out:
            window = 1.0
        elif ti <= rec:
            window = 0.5 - 0.5 * np.cos(np.pi * (ti - (rec - fade_out)) / fade_out + np.pi)
        else:
            window = 0.0
        if ti <= 0.0:
            out[i] = 0.0
        elif ti <= const_freq:
            out[i] = window * mag * np.sin(w_min * ti - w_min * const_freq)
        elif ti <= rec:
            out[i] = window * mag * np.sin((w_min * (rec - const_freq) / b) * (np.exp(b * (ti - const_freq) / (rec - const_freq)) - 1))
        else:
            out[i] = 0.0
    return out


def test_sid_chirp_matches_ardupilot():
    t = time_vector(50.0, FS)
    sid = {"SID_F_START_HZ": 0.5, "SID_F_STOP_HZ": 15.0, "SID_T_FADE_IN": 5.0, "SID_T_REC": 45.0,
           "SID_T_FADE_OUT": 2.0, "SID_MAGNITUDE": 0.15}
    x = np.asarray(sid_chirp_from_params(t, sid))
    ref = _ardupilot_chirp_reference(np.asarray(t), 0.5, 15.0, 5.0, 45.0, 2.0, 0.15)
    np.testing.assert_allclose(x, ref, atol=1e-12)
    f = np.asarray(sid_chirp_frequency_hz(t, f_start_hz=0.5, f_stop_hz=15.0, t_rec_s=45.0))
    assert f[1] == pytest.approx(0.5) and f[int(44.99 * FS)] == pytest.approx(15.0, rel=1e-3)
    with pytest.raises(ValueError, match="SID_T_REC"):
        sid_chirp_from_params(t, {"SID_F_START_HZ": 1.0, "SID_F_STOP_HZ": 2.0, "SID_MAGNITUDE": 1.0})
    jitted = jax.jit(lambda tt, m: sid_chirp(tt, f_start_hz=0.5, f_stop_hz=15.0, t_rec_s=45.0, magnitude=m,
                                             t_fade_in_s=5.0, t_fade_out_s=2.0))
    np.testing.assert_allclose(np.asarray(jitted(t, 0.15)), ref, atol=1e-12)


def test_doublet_and_3211():
    t = time_vector(10.0, FS)
    t_np = np.asarray(t)
    d = np.asarray(doublet(t, amplitude=0.1, pulse_s=0.5, start_s=1.0))
    ref = np.where((t_np >= 1.0) & (t_np < 1.5), 0.1, 0.0) + np.where((t_np >= 1.5) & (t_np < 2.0), -0.1, 0.0)
    np.testing.assert_array_equal(d, ref)
    s = np.asarray(multistep_3211(t, amplitude=0.2, unit_s=0.4, start_s=2.0))
    levels = np.array([0.2] * 120 + [-0.2] * 80 + [0.2] * 40 + [-0.2] * 40)
    np.testing.assert_allclose(s[200:480], levels)
    assert np.all(s[:200] == 0.0) and np.all(s[480:] == 0.0)
    assert np.sum(s) == pytest.approx(0.2 * 40 * (3 - 2 + 1 - 1))


def test_odd_multisine_lines():
    """Power only at excited odd lines; even and detection lines are empty (FFT reference)."""
    period, fs = 20.0, 50.0
    ms = odd_multisine(jax.random.key(3), period_s=period, sample_rate_hz=fs, f_min_hz=0.2, f_max_hz=5.0, amplitude=0.1)
    t = jnp.arange(int(period * fs), dtype=jnp.float64) / fs
    x = np.asarray(ms(t))
    assert np.max(np.abs(x)) == pytest.approx(0.1, rel=1e-9)
    spec = np.abs(np.fft.rfft(x)) / x.size
    lines = np.asarray(ms.lines)
    excited = lines[np.asarray(ms.excited)]
    detection = lines[~np.asarray(ms.excited)]
    assert np.all(lines % 2 == 1)
    assert detection.size == lines.size // 3  # one per group of three odd lines
    assert np.min(spec[excited]) > 1e3 * np.max(spec[detection])
    other = np.setdiff1d(np.arange(spec.size), excited)
    assert np.max(spec[other]) < 1e-12
    # equal amplitudes on the excited lines
    np.testing.assert_allclose(spec[excited], spec[excited][0], rtol=1e-9)
    # same key, same signal; another key, another plan
    again = odd_multisine(jax.random.key(3), period_s=period, sample_rate_hz=fs, f_min_hz=0.2, f_max_hz=5.0, amplitude=0.1)
    np.testing.assert_array_equal(np.asarray(again(t)), x)
    other_ms = odd_multisine(jax.random.key(4), period_s=period, sample_rate_hz=fs, f_min_hz=0.2, f_max_hz=5.0, amplitude=0.1)
    assert not np.array_equal(np.asarray(other_ms.excited), np.asarray(ms.excited))
    with pytest.raises(ValueError, match="whole number of samples"):
        odd_multisine(jax.random.key(0), period_s=10.005, sample_rate_hz=fs, f_min_hz=0.2, f_max_hz=5.0, amplitude=0.1)


def test_pilot_corrections_rms_and_spectrum():
    """Analytic variance scaling, and the spectrum of two cascaded lags (scipy.signal.lfilter)."""
    n, fs, fc = 40000, 100.0, 0.4
    key = jax.random.key(11)
    y = np.asarray(pilot_corrections(key, n, fs, rms=0.02, bandwidth_hz=fc))
    assert np.std(y[2000:]) == pytest.approx(0.02, rel=0.1)  # ~1/sqrt(effective samples) scatter
    # exact filter reference on the same white numbers
    a = np.exp(-2 * np.pi * fc / fs)
    gain2 = (1 - a) ** 4 * (1 + a * a) / (1 - a * a) ** 3
    w = np.asarray(jax.random.normal(key, (n,), dtype=jnp.float64)) * 0.02 / np.sqrt(gain2)
    ref = scipy.signal.lfilter([(1 - a) ** 2], np.convolve([1, -a], [1, -a]), w)
    np.testing.assert_allclose(y, ref, rtol=1e-9, atol=1e-12)
    # deterministic by key
    np.testing.assert_array_equal(np.asarray(pilot_corrections(key, n, fs, rms=0.02, bandwidth_hz=fc)), y)
