"""The effect vocabulary: registry, parsing, frequency responses, and simulated behaviour."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
import scipy.signal

from jaxgwo._effects import (
    EFFECTS,
    EffectSet,
    draw_effect_params,
    effect_response,
    effects_from_strings,
    paper_model_with_effect,
    parse_effect,
    rotor_flapping_response,
)
from jaxgwo._plants import PaperPlant
from jaxgwo._simulate import simulate
from jaxgwo._transfer import paper_model_response

FS = 100.0
N = 600  # every simulation here has this shape, so they share one compilation
T = np.arange(N) / FS
PLANT = PaperPlant.default()
W = jnp.logspace(-1, 2.5, 60)


def _sim(exc_lat, exc_lon=None, effects=None):
    exc_lon = np.zeros(N) if exc_lon is None else exc_lon
    exc = jnp.asarray(np.stack([exc_lat, exc_lon], axis=1))
    return simulate(PLANT, exc, jax.random.key(0), sample_rate_hz=FS, effects=effects)


def _sine_fit(y, f_hz, t=T, start_s=2.0):
    """Least-squares amplitude and phase (rad) of the f_hz component after start_s."""
    m = t >= start_s
    X = np.stack([np.sin(2 * np.pi * f_hz * t[m]), np.cos(2 * np.pi * f_hz * t[m]), np.ones(m.sum())], axis=1)
    (a, b, _), *_ = np.linalg.lstsq(X, y[m], rcond=None)
    return np.hypot(a, b), np.arctan2(b, a)


STEP = np.where(T >= 1.0, 0.1, 0.0)


# -- registry ---------------------------------------------------------------------------


def test_vocabulary_is_exact():
    assert {name: spec.params for name, spec in EFFECTS.items()} == {
        "time_delay": ("delay_s",),
        "sensor_lag": ("cutoff_hz",),
        "rotor_flapping": ("tau_f",),
        "cross_coupling": ("gain",),
        "structural_mode": ("freq_hz", "zeta_p", "zeta_z"),
        "rate_limit": ("rate",),
        "backlash": ("width",),
        "saturation": ("limit",),
    }
    linear = {name for name, spec in EFFECTS.items() if spec.linear}
    assert linear == {"time_delay", "sensor_lag", "rotor_flapping", "cross_coupling", "structural_mode"}
    for spec in EFFECTS.values():
        assert len(spec.default) == len(spec.neutral) == len(spec.ranges) == len(spec.params)
        for (lo, hi), d in zip(spec.ranges, spec.default):
            assert lo < hi and lo <= d <= hi
    assert EffectSet().active() == ()


def test_parse_and_build():
    assert parse_effect("structural_mode:freq_hz=15,zeta_p=0.03") == ("structural_mode", {"freq_hz": 15.0, "zeta_p": 0.03}, "both")
    assert parse_effect("time_delay") == ("time_delay", {}, "both")
    eff = effects_from_strings(["time_delay:delay_s=0.05,axis=lateral", "sensor_lag"])
    np.testing.assert_array_equal(np.asarray(eff.time_delay.delay_s), [0.05, 0.0])
    np.testing.assert_array_equal(np.asarray(eff.sensor_lag.cutoff_hz), [10.0, 10.0])  # registry default
    assert eff.active() == ("time_delay", "sensor_lag")
    assert "delay_s=(0.05, 0)" in eff.describe()


@pytest.mark.parametrize(
    "text, message",
    [
        ("wobble", "unknown effect 'wobble'; known effects: time_delay"),
        ("time_delay:delay=0.1", "has no parameter.*its parameters are: delay_s"),
        ("sensor_lag:cutoff_hz=-2", "cutoff_hz must be positive"),
        ("time_delay:delay_s=x", "not a number"),
        ("backlash:width", "expected param=value"),
        ("saturation:limit=0.1,axis=yaw", "axis must be lateral, longitudinal or both"),
        ("structural_mode:zeta_p=3", "zeta_p must be in"),
    ],
)
def test_parse_rejections(text, message):
    with pytest.raises(ValueError, match=message):
        parse_effect(text)


def test_draws_stay_in_range():
    for name, spec in EFFECTS.items():
        for k in jax.random.split(jax.random.key(1), 5):
            params = draw_effect_params(k, name)
            for p, (lo, hi) in zip(spec.params, spec.ranges):
                assert lo - 1e-12 <= float(params[p]) <= hi + 1e-12


# -- analytic frequency responses ---------------------------------------------------------


def test_sensor_lag_minus_3db_at_cutoff():
    h = effect_response("sensor_lag", jnp.array([2 * np.pi * 7.0]), cutoff_hz=7.0)
    assert 20 * np.log10(abs(complex(h[0]))) == pytest.approx(-10 * np.log10(2), abs=1e-12)
    assert np.angle(complex(h[0]), deg=True) == pytest.approx(-45.0)


def test_structural_mode_and_delay_against_scipy():
    wn = 2 * np.pi * 12.0
    h = effect_response("structural_mode", W, freq_hz=12.0, zeta_p=0.03, zeta_z=0.25)
    _, ref = scipy.signal.freqs([1, 2 * 0.25 * wn, wn**2], [1, 2 * 0.03 * wn, wn**2], np.asarray(W))
    np.testing.assert_allclose(np.asarray(h), ref, rtol=1e-12)
    peak = effect_response("structural_mode", jnp.array([wn]), freq_hz=12.0, zeta_p=0.03, zeta_z=0.25)
    assert abs(complex(peak[0])) == pytest.approx(0.25 / 0.03)
    d = effect_response("time_delay", W, delay_s=0.04)
    np.testing.assert_allclose(np.asarray(d), np.exp(-1j * np.asarray(W) * 0.04), rtol=1e-12)


def test_rotor_flapping_response():
    params = PLANT.lateral
    np.testing.assert_allclose(
        np.asarray(rotor_flapping_response(params, W, 0.0)), np.asarray(paper_model_response(params, W)), rtol=1e-12
    )
    k, tau, m, ws, zs = (float(v) for v in params)
    tf = 0.02
    den = np.polyadd(np.polymul([1, 1 / tau, 0], [tf, 1]), [m])
    _, rotor = scipy.signal.freqs([k], den, np.asarray(W))
    _, servo = scipy.signal.freqs([ws**2], [1, 2 * zs * ws, ws**2], np.asarray(W))
    np.testing.assert_allclose(np.asarray(paper_model_with_effect(params, W, "rotor_flapping", tau_f=tf)), rotor * servo, rtol=1e-10)


def test_series_and_in_loop_composition():
    params = PLANT.lateral
    base = np.asarray(paper_model_response(params, W))
    lag = np.asarray(paper_model_with_effect(params, W, "sensor_lag", cutoff_hz=5.0))
    np.testing.assert_allclose(lag, base / (1 + 1j * np.asarray(W) / (2 * np.pi * 5.0)), rtol=1e-12)
    cc = np.asarray(paper_model_with_effect(params, W, "cross_coupling", gain=0.2, cross_ratio=0.5 + 0.5j))
    np.testing.assert_allclose(cc, base * (1 + 0.2 * (0.5 + 0.5j)), rtol=1e-12)
    with pytest.raises(ValueError, match="nonlinear"):
        effect_response("backlash", W, width=0.01)
    with pytest.raises(ValueError, match="inside the plant"):
        effect_response("rotor_flapping", W, tau_f=0.01)


# -- simulated behaviour: each effect does what its definition says ----------------------


def test_time_delay_shifts_step_by_the_delay():
    ref = np.asarray(_sim(STEP).rate[:, 0])
    for delay in (0.05, 0.123):
        out = np.asarray(_sim(STEP, effects=EffectSet().with_effect("time_delay", delay_s=delay)).rate[:, 0])
        level = 0.1 * ref[-1]
        shift_s = (np.argmax(out > level) - np.argmax(ref > level)) / FS
        assert abs(shift_s - delay) <= 1.0 / FS  # within one sample
        # and the whole response is the shifted one (the 1 ms internal step rounds the delay)
        shifted = np.interp(T - delay, T, ref, left=0.0)
        assert np.max(np.abs(out - shifted)) < 0.01 * np.max(np.abs(ref))
    # a whole number of samples shifts the logged samples exactly
    out = np.asarray(_sim(STEP, effects=EffectSet().with_effect("time_delay", delay_s=0.05)).rate[:, 0])
    np.testing.assert_allclose(out[5:], ref[:-5], atol=1e-9 * np.max(np.abs(ref)))


def test_sensor_lag_is_minus_3db_at_cutoff_in_simulation():
    f = 4.0
    sine = 0.05 * np.sin(2 * np.pi * f * T)
    res = _sim(sine, effects=EffectSet().with_effect("sensor_lag", cutoff_hz=f))
    a_meas, ph_meas = _sine_fit(np.asarray(res.rate[:, 0]), f)
    a_body, ph_body = _sine_fit(np.asarray(res.body_rate[:, 0]), f)
    assert 20 * np.log10(a_meas / a_body) == pytest.approx(-3.0103, abs=0.02)
    assert np.degrees(ph_meas - ph_body) == pytest.approx(-45.0, abs=0.5)


def test_structural_mode_resonance_in_simulation():
    f = 9.0
    sine = 0.05 * np.sin(2 * np.pi * f * T)
    res = _sim(sine, effects=EffectSet().with_effect("structural_mode", freq_hz=f, zeta_p=0.1, zeta_z=0.3))
    a_meas, _ = _sine_fit(np.asarray(res.rate[:, 0]), f, start_s=3.0)
    a_body, _ = _sine_fit(np.asarray(res.body_rate[:, 0]), f, start_s=3.0)
    assert a_meas / a_body == pytest.approx(3.0, rel=0.01)


def test_rotor_flapping_tends_to_paper_plant():
    ref = np.asarray(_sim(STEP).rate[:, 0])
    scale = np.max(np.abs(ref))
    # below half an integration step the lag is exactly algebraic
    tiny = np.asarray(_sim(STEP, effects=EffectSet().with_effect("rotor_flapping", tau_f=1e-4)).rate[:, 0])
    np.testing.assert_array_equal(tiny, ref)
    errors = []
    for tf in (0.02, 0.005, 0.001):
        out = np.asarray(_sim(STEP, effects=EffectSet().with_effect("rotor_flapping", tau_f=tf)).rate[:, 0])
        errors.append(np.max(np.abs(out - ref)) / scale)
    assert errors[0] > errors[1] > errors[2]
    assert errors[2] < 0.02  # a 1 ms lag still shifts the lightly damped 12 rad/s mode slightly


def test_cross_coupling_drives_on_axis_through_same_dynamics():
    """y_lat(off-axis input x, gain g) == g * y_lat(on-axis input x): same servo and rotor."""
    g = 0.3
    coupled = _sim(np.zeros(N), STEP, effects=EffectSet().with_effect("cross_coupling", gain=g, axis="lateral"))
    direct = _sim(STEP)
    np.testing.assert_allclose(np.asarray(coupled.rate[:, 0]), g * np.asarray(direct.rate[:, 0]), atol=1e-12)
    # the longitudinal axis was not coupled
    np.testing.assert_allclose(np.asarray(coupled.rate[:, 1]), np.asarray(_sim(np.zeros(N), STEP).rate[:, 1]), atol=1e-12)


def test_rate_limit_caps_servo_rate_and_is_amplitude_dependent():
    rate = 0.5
    eff = EffectSet().with_effect("rate_limit", rate=rate)
    big = _sim(STEP, effects=eff)
    servo_rate = np.abs(np.diff(np.asarray(big.servo[:, 0]))) * FS
    assert np.max(servo_rate) <= rate * (1 + 1e-9)
    assert np.max(servo_rate) > 0.95 * rate  # it binds on a 0.1 step (free servo peaks near 2/s)
    assert np.max(np.abs(np.diff(np.asarray(_sim(STEP).servo[:, 0])))) * FS > 3 * rate
    small = _sim(STEP * 0.05, effects=eff)  # a 0.005 step never reaches the limit
    np.testing.assert_allclose(np.asarray(small.rate), 0.05 * np.asarray(_sim(STEP).rate), atol=1e-12)


def test_saturation_limits_servo_position():
    eff = EffectSet().with_effect("saturation", limit=0.05)
    res = _sim(STEP, effects=eff)
    assert np.max(np.asarray(res.servo[:, 0])) == pytest.approx(0.05, abs=1e-12)
    assert np.max(np.asarray(res.swashplate[:, 0])) <= 0.05 + 1e-12
    small = _sim(STEP * 0.2, effects=eff)  # servo peak 0.023 stays inside
    np.testing.assert_allclose(np.asarray(small.rate), 0.2 * np.asarray(_sim(STEP).rate), atol=1e-12)


def test_backlash_play_operator():
    width = 0.04
    res = _sim(STEP, effects=EffectSet().with_effect("backlash", width=width))
    servo, swash = np.asarray(res.servo[:, 0]), np.asarray(res.swashplate[:, 0])
    assert np.all(np.abs(servo - swash) <= width / 2 + 1e-12)
    # after the overshoot the servo settles back inside the play: the swashplate stays put
    # (the servo's continuous peak lies between samples, so allow a little above the logged peak)
    assert np.max(servo) - width / 2 <= swash[-1] <= np.max(servo) - width / 2 + 1e-3
    assert abs(servo[-1] - swash[-1]) < width / 2
    # a movement smaller than the play never reaches the swashplate
    tiny = _sim(STEP * 0.1, effects=EffectSet().with_effect("backlash", width=width))
    assert np.max(np.abs(np.asarray(tiny.swashplate[:, 0]))) == 0.0
    assert np.max(np.abs(np.asarray(tiny.rate[:, 0]))) < 1e-12
