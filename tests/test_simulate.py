"""The simulator against independent references: scipy ZOH discretisations, scipy.signal.csd,
Python loops for vmap, and the statistics of its gusts and noise."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
import scipy.signal

from jaxgwo._data import FlightRecord
from jaxgwo._effects import EffectSet
from jaxgwo._plants import PaperPlant, R50Plant
from jaxgwo._signals import frequency_sweep, multistep_3211, pilot_corrections
from jaxgwo._simulate import Disturbance, HoldLoop, simulate
from jaxgwo._transfer import paper_model_coefficients

FS = 100.0
PLANT = PaperPlant.default()


def _zoh_reference(num, den, u, delay_samples=0):
    """scipy's exact ZOH discretisation of num/den driven by the held input u."""
    b, a, _ = scipy.signal.cont2discrete((num, den), 1.0 / FS, method="zoh")
    y = scipy.signal.lfilter(np.ravel(b), a, u)
    return np.r_[np.zeros(delay_samples), y[: len(y) - delay_samples]]


def _paper_tf(params, tau_f=0.0):
    k, tau, m, ws, zs = (float(v) for v in params)
    rotor_den = np.polyadd(np.polymul([1.0, 1.0 / tau, 0.0], [tau_f, 1.0]), [m]) if tau_f else np.array([1.0, 1.0 / tau, m])
    return np.array([k * ws * ws]), np.polymul(rotor_den, [1.0, 2 * zs * ws, ws * ws])


N = 500
U = np.where(np.arange(N) >= 50, 0.1, 0.0) + 0.05 * np.sin(2 * np.pi * 1.3 * np.arange(N) / FS)


@pytest.mark.parametrize(
    "case",
    ["none", "time_delay", "sensor_lag", "structural_mode", "rotor_flapping", "all_linear"],
)
@pytest.mark.filterwarnings("ignore::scipy.signal.BadCoefficients")
def test_linear_chain_matches_exact_zoh_discretisation(case):
    """Plant, servo and linear effects reproduce scipy's exact ZOH model sample by sample."""
    eff = EffectSet()
    num, den = _paper_tf(PLANT.lateral)
    delay = 0
    if case in ("time_delay", "all_linear"):
        eff = eff.with_effect("time_delay", delay_s=0.07)
        delay = 7
    if case in ("sensor_lag", "all_linear"):
        eff = eff.with_effect("sensor_lag", cutoff_hz=6.0)
        den = np.polymul(den, [1.0 / (2 * np.pi * 6.0), 1.0])
    if case in ("structural_mode", "all_linear"):
        eff = eff.with_effect("structural_mode", freq_hz=14.0, zeta_p=0.05, zeta_z=0.3)
        wn = 2 * np.pi * 14.0
        num = np.polymul(num, [1.0, 2 * 0.3 * wn, wn * wn])
        den = np.polymul(den, [1.0, 2 * 0.05 * wn, wn * wn])
    if case in ("rotor_flapping", "all_linear"):
        eff = eff.with_effect("rotor_flapping", tau_f=0.015)
        num2, den2 = _paper_tf(PLANT.lateral, tau_f=0.015)
        base_num, base_den = _paper_tf(PLANT.lateral)
        # swap the paper plant for the flapping plant, keep the series effects
        num = np.polydiv(np.polymul(num, num2), base_num)[0]
        den = np.polydiv(np.polymul(den, den2), base_den)[0]
    exc = jnp.asarray(np.stack([U, np.zeros(N)], axis=1))
    res = simulate(PLANT, exc, jax.random.key(0), sample_rate_hz=FS, effects=eff)
    ref = _zoh_reference(num, den, U, delay)
    scale = np.max(np.abs(ref))
    # RK4 at a 1 ms step: global error ~1e-9 of the signal; 1e-6 leaves room for polynomial conditioning
    np.testing.assert_allclose(np.asarray(res.rate[:, 0]), ref, atol=1e-6 * scale)


def _spectra(u, y, nperseg):
    kw = dict(fs=FS, nperseg=nperseg, window="boxcar", noverlap=0, detrend=False)
    f, pxy = scipy.signal.csd(u, y, **kw)
    _, pxx = scipy.signal.welch(u, **kw)
    _, pyy = scipy.signal.welch(y, **kw)
    return f, pxy / pxx, np.abs(pxy) ** 2 / (pxx * pyy)


@pytest.fixture(scope="module")
def periodic_sweep():
    """A 10 s sweep (0.3-12 Hz) repeated 13 times; the first period is the transient."""
    period = 10.0
    one = frequency_sweep(jnp.arange(int(period * FS), dtype=jnp.float64) / FS,
                          f_start_hz=0.3, f_stop_hz=12.0, duration_s=period, amplitude=0.1, n_low_cycles=1.0)
    e = jnp.tile(one, 13)
    return period, jnp.stack([e, jnp.zeros_like(e)], axis=1)


@pytest.mark.parametrize("gust, snr", [(0.0, np.inf), (0.3, 40.0)])
def test_sweep_frequency_response_matches_analytic(periodic_sweep, gust, snr):
    """The paper plant's sweep through scipy.signal.csd matches eqs. (15)-(16) where coherence > 0.9.

    Reference: the analytic response times the logger's ZOH half-sample delay e^{-jw dt/2}
    (documented in jaxgwo._simulate).  Whole periods with a boxcar window make the estimate
    leakage-free.  With turbulence and noise each estimate also carries a random error,
    Bendat & Piersol's eps = sqrt(1-g^2)/(|g| sqrt(2 n_d)) (n_d = 12 averages): every
    point must lie within max(1 dB, 3 eps) and max(5 deg, 3 eps), and most (85 %) within
    the strict 1 dB / 5 deg: near coherence 0.9 one standard deviation of phase is about
    4 deg, so a minority of such points exceed 5 deg by chance, not by bias.  Noise-free,
    every point must meet 1 dB / 5 deg.
    """
    period, exc = periodic_sweep
    dist = Disturbance(gust_rms=gust, gust_time_constant_s=1.0, snr_db=snr)
    res = simulate(PLANT, exc, jax.random.key(5), sample_rate_hz=FS, disturbance=dist)
    skip = int(period * FS)
    f, h, coh = _spectra(np.asarray(res.command[skip:, 0]), np.asarray(res.rate[skip:, 0]), skip)
    w = 2 * np.pi * f
    g = np.asarray(PLANT.frequency_response(jnp.asarray(w)))[0] * np.exp(-0.5j * w / FS)
    sel = (coh > 0.9) & (f >= 0.3) & (f <= 12.0)
    assert sel.sum() >= 40
    err_db = np.abs(20 * np.log10(np.abs(h[sel] / g[sel])))
    err_deg = np.abs(np.angle(h[sel] / g[sel], deg=True))
    if np.isinf(snr) and gust == 0.0:
        assert sel.sum() == ((f >= 0.3) & (f <= 12.0)).sum()
        assert np.max(err_db) < 1.0 and np.max(err_deg) < 5.0
        return
    eps = np.sqrt(1 - coh[sel]) / (np.sqrt(coh[sel]) * np.sqrt(2 * 12))
    assert np.all(err_db <= np.maximum(1.0, 3 * 20 * np.log10(1 + eps)))
    assert np.all(err_deg <= np.maximum(5.0, 3 * np.degrees(eps)))
    assert np.mean((err_db <= 1.0) & (err_deg <= 5.0)) >= 0.85


def test_gust_and_noise_statistics(periodic_sweep):
    _, exc = periodic_sweep
    dist = Disturbance(gust_rms=(0.5, 1.0), gust_time_constant_s=0.5, snr_db=(30.0, 20.0))
    res = simulate(PLANT, exc, jax.random.key(2), sample_rate_hz=FS, disturbance=dist)
    gust = np.asarray(res.gust)
    # 130 s holds ~130 correlation times of the Dryden filter: ~10 % scatter of the rms
    np.testing.assert_allclose(np.std(gust, axis=0), [0.5, 1.0], rtol=0.2)
    noise = np.asarray(res.rate - res.rate_clean)
    clean = np.asarray(res.rate_clean)
    snr = 20 * np.log10(np.std(clean, axis=0) / np.std(noise, axis=0))
    np.testing.assert_allclose(snr, [30.0, 20.0], atol=0.2)
    # white: lag-1 autocorrelation near zero
    r1 = np.corrcoef(noise[1:, 0], noise[:-1, 0])[0, 1]
    assert abs(r1) < 0.05


def test_determinism_and_vmap_over_seeds_equals_loop():
    exc = jnp.asarray(np.stack([U, 0.5 * U[::-1]], axis=1))
    dist = Disturbance(gust_rms=1.0, snr_db=25.0)

    def run(key):
        return simulate(PLANT, exc, key, sample_rate_hz=FS, disturbance=dist)

    keys = jax.random.split(jax.random.key(9), 3)
    a, b = run(keys[0]), run(keys[0])
    np.testing.assert_array_equal(np.asarray(a.rate), np.asarray(b.rate))
    assert not np.array_equal(np.asarray(a.rate), np.asarray(run(keys[1]).rate))
    batched = jax.vmap(run)(keys)
    for i in range(3):
        one = run(keys[i])
        np.testing.assert_allclose(np.asarray(batched.rate[i]), np.asarray(one.rate), rtol=1e-12, atol=1e-14)
        np.testing.assert_allclose(np.asarray(batched.gust[i]), np.asarray(one.gust), rtol=1e-12, atol=1e-14)


def test_vmap_over_plant_and_effect_parameters_equals_loop():
    exc = jnp.asarray(np.stack([U, np.zeros(N)], axis=1))
    scales = jnp.array([0.7, 1.0, 1.4])
    delays = jnp.array([0.0, 0.02, 0.05])

    def run(s, d):
        plant = PaperPlant(PLANT.lateral * jnp.array([s, 1.0, s, 1.0, 1.0]), PLANT.longitudinal)
        eff = EffectSet().with_effect("time_delay", delay_s=d)
        return simulate(plant, exc, jax.random.key(0), sample_rate_hz=FS, effects=eff).rate

    batched = jax.vmap(run)(scales, delays)
    for i in range(3):
        np.testing.assert_allclose(np.asarray(batched[i]), np.asarray(run(scales[i], delays[i])), rtol=1e-12, atol=1e-14)


def test_no_retrace_for_new_data_of_same_shape():
    import equinox as eqx

    @jax.jit
    @eqx.debug.assert_max_traces(max_traces=1)
    def run(exc, key):
        return simulate(PLANT, exc, key, sample_rate_hz=FS).rate

    exc = jnp.asarray(np.stack([U, np.zeros(N)], axis=1))
    run(exc, jax.random.key(0))
    run(exc * 2.0, jax.random.key(1))


def test_r50_hold_loop_keeps_hover_and_logs_totals():
    n = 4000
    t = np.arange(n) / FS
    sweep = np.asarray(frequency_sweep(jnp.asarray(t), f_start_hz=0.25, f_stop_hz=5.0, duration_s=40.0, amplitude=0.1))
    off = np.asarray(pilot_corrections(jax.random.key(1), n, FS, rms=0.01))
    exc = jnp.asarray(np.stack([sweep, off], axis=1))
    dist = Disturbance(gust_rms=1.0, gust_time_constant_s=1.5, noise_std=0.005)
    plant = R50Plant.default()
    held = simulate(plant, exc, jax.random.key(0), sample_rate_hz=FS, disturbance=dist, hold=HoldLoop.r50())
    free = simulate(plant, exc, jax.random.key(0), sample_rate_hz=FS, disturbance=dist, hold=None)
    # the logged command is the total: excitation plus the hold loop's correction
    np.testing.assert_allclose(np.asarray(held.command), np.asarray(held.excitation + held.hold_correction), atol=1e-15)
    assert np.std(np.asarray(held.hold_correction)) > 1e-3
    np.testing.assert_array_equal(np.asarray(free.hold_correction), 0.0)
    # unstable at 0.32 rad/s open loop: it drifts far away; held, the rates stay sweep-sized
    assert np.max(np.abs(np.asarray(held.body_rate))) < 1.5
    assert np.max(np.abs(np.asarray(free.body_rate[-500:]))) > 10 * np.max(np.abs(np.asarray(held.body_rate[-500:])))


def test_to_record_and_validation_inputs():
    exc = multistep_3211(jnp.arange(N, dtype=jnp.float64) / FS, amplitude=0.1, unit_s=0.3, start_s=0.5)
    res = simulate(PLANT, jnp.stack([exc, jnp.zeros_like(exc)], axis=1), jax.random.key(0), sample_rate_hz=FS)
    rec = res.to_record({"note": "unit"}, truth=True)
    assert isinstance(rec, FlightRecord)
    assert rec.sample_rate == pytest.approx(FS)
    assert rec.metadata["zoh_delay_s"] == "0.005" and rec.metadata["note"] == "unit"
    assert {"p_true", "servo_lat", "exc_lat"} <= set(rec.extras)
    np.testing.assert_array_equal(np.asarray(rec["p"]), np.asarray(res.rate[:, 0]))


def test_too_long_delay_is_an_error():
    exc = jnp.zeros((N, 2))
    with pytest.raises(Exception, match="time_delay"):
        simulate(PLANT, exc, jax.random.key(0), sample_rate_hz=FS,
                 effects=EffectSet().with_effect("time_delay", delay_s=0.4), max_delay_s=0.25)
