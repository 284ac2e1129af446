"""Stage 1 preprocessing against hand-made references and scipy."""

import numpy as np
import pytest
import scipy.interpolate
import scipy.signal

from jaxgwo._preprocess import (
    detrend,
    lowpass_zero_phase,
    preprocess,
    reject_wild_values,
)


def _record(n=2000, fs=100.0, seed=0):
    rng = np.random.default_rng(seed)
    t = np.arange(n) / fs
    u = np.sin(2 * np.pi * 0.7 * t) + 0.05 * rng.standard_normal(n)
    return t, u


def test_wild_values_found_and_interpolated():
    t, u = _record()
    spikes = np.array([100, 555, 1234, 1999])
    bad = u.copy()
    bad[spikes] += np.array([8.0, -6.0, 5.0, 7.0])
    bad[777] = np.nan
    fixed, idx = reject_wild_values(bad)
    assert set(idx) == set(spikes.tolist()) | {777}
    # interior corrections: a cubic spline through the good samples (scipy reference);
    # the last sample: linear extrapolation of the two before it (by hand)
    good = np.setdiff1d(np.arange(u.size), list(idx))
    inner = [100, 555, 777, 1234]
    ref = scipy.interpolate.CubicSpline(good, bad[good])(inner)
    np.testing.assert_allclose(fixed[inner], ref, rtol=1e-12)
    assert fixed[1999] == pytest.approx(2 * bad[1998] - bad[1997], rel=1e-12)
    # and all back within a few noise sigmas (0.05) of the clean signal
    np.testing.assert_allclose(fixed[list(idx)], u[list(idx)], atol=0.2)
    untouched = np.setdiff1d(np.arange(u.size), list(idx))
    np.testing.assert_array_equal(fixed[untouched], bad[untouched])


def test_fast_sweep_is_not_mistaken_for_wild_values():
    # a sweep up to fs/8 (12.5 Hz at 100 Hz): a running median of 11 samples would flag
    # most of its last third; the leave-one-out cubic leaves it alone and finds the spikes
    rng = np.random.default_rng(5)
    t = np.arange(6000) / 100.0
    u = scipy.signal.chirp(t, 0.1, t[-1], 12.5, method="logarithmic") + 0.05 * rng.standard_normal(t.size)
    fixed, idx = reject_wild_values(u)
    assert idx == ()
    bad = u.copy()
    bad[[5900, 5950]] += 1.5
    fixed, idx = reject_wild_values(bad)
    assert idx == (5900, 5950)
    np.testing.assert_allclose(fixed[[5900, 5950]], u[[5900, 5950]], atol=0.25)


def test_clean_signal_is_not_touched():
    _, u = _record(seed=3)
    fixed, idx = reject_wild_values(u)
    assert idx == ()
    np.testing.assert_array_equal(fixed, u)


@pytest.mark.parametrize("kind", ["constant", "linear"])
def test_detrend_matches_scipy(kind):
    t, u = _record()
    x = u + 3.0 + 0.4 * t
    got, (offset, slope) = detrend(t, x, kind)
    np.testing.assert_allclose(got, scipy.signal.detrend(x, type=kind), atol=1e-10)
    if kind == "linear":
        assert slope == pytest.approx(0.4, abs=0.01)
        # the sine projects a little onto the linear basis over 14 periods
        assert offset == pytest.approx(3.0, abs=0.15)


def test_lowpass_is_zero_phase():
    fs = 100.0
    t = np.arange(4000) / fs
    x = np.sin(2 * np.pi * 1.0 * t)
    y = lowpass_zero_phase(x, fs, cutoff_hz=10.0)
    mid = slice(500, 3500)  # away from the edge transients
    # a 1 Hz tone well inside the pass band comes through with no delay
    np.testing.assert_allclose(y[mid], x[mid], atol=1e-3)
    with pytest.raises(ValueError, match="cutoff"):
        lowpass_zero_phase(x, fs, cutoff_hz=60.0)


def test_preprocess_reports_changes_and_keeps_inputs():
    t, u = _record()
    y = 2 * u + 1.5
    y_bad = y.copy()
    y_bad[[50, 60]] += 20.0
    sig = {"u": u.copy(), "y": y_bad.copy()}
    out, rep = preprocess(t, sig, smoothing_window=5, lowpass_hz=20.0)
    np.testing.assert_array_equal(sig["y"], y_bad)  # inputs unchanged
    assert rep["y"].wild_indices == (50, 60)
    assert rep["y"].n_corrected == 2 and rep["u"].n_corrected == 0
    assert rep.n_corrected == 2
    # the 2 x sine leaks ~0.13 into the fitted offset over 14 periods
    assert rep["y"].trend[0] == pytest.approx(1.5, abs=0.3)
    assert abs(np.mean(out["y"])) < 1e-3
    assert rep.sample_rate_hz == pytest.approx(100.0)
    assert "2 wild values" in rep.summary()
    # every step off: identity
    same, rep0 = preprocess(t, sig, wild_values=False, detrend_kind=None)
    np.testing.assert_array_equal(same["y"], y_bad)
    assert rep0.n_corrected == 0


def test_preprocess_rejects_bad_time():
    t, u = _record()
    t2 = t.copy()
    t2[10] += 0.003
    with pytest.raises(ValueError, match="uniformly"):
        preprocess(t2, {"u": u})
    with pytest.raises(ValueError, match="shape"):
        preprocess(t, {"u": u[:-1]})


def test_noise_free_fast_sweep_is_left_alone_and_spikes_still_found():
    # Regression: a global noise scale, set by the slow start of a noise-free sweep,
    # flagged ~4,000 samples of its fast end.
    fs, T = 100.0, 90.0
    t = np.arange(0.0, T, 1.0 / fs)
    f0, f1 = 0.15, 12.0
    x = 0.1 * np.sin(2 * np.pi * f0 * T / np.log(f1 / f0) * (np.exp(t / T * np.log(f1 / f0)) - 1))
    fixed, idx = reject_wild_values(x)
    assert idx == ()
    np.testing.assert_array_equal(fixed, x)
    spiky = x.copy()
    where = [500, 4000, 8500]
    spiky[where] += 0.5
    fixed, idx = reject_wild_values(spiky)
    assert list(idx) == where
    np.testing.assert_allclose(fixed[where], x[where], atol=5e-3)


def _step_input(noise=0.0, seed=0):
    """A 3-2-1-1 and a doublet on a slowly drifting trim (a hold loop's corrections)."""
    fs = 100.0
    t = np.arange(0.0, 30.0, 1.0 / fs)
    u = 0.02 * np.sin(2 * np.pi * 0.3 * t)
    for start, width, level in ((2.0, 1.2, 0.1), (3.2, 0.8, -0.1), (4.0, 0.4, 0.1), (4.4, 0.4, -0.1),
                                (12.0, 0.5, 0.12), (12.5, 0.5, -0.12)):
        u = u + np.where((t >= start) & (t < start + width), level, 0.0)
    return u + noise * np.random.default_rng(seed).standard_normal(t.size)


@pytest.mark.parametrize("noise", [0.0, 1e-3])
def test_step_inputs_are_not_wild_values(noise):
    # Regression: the edges of a 3-2-1-1 or a doublet looked wild to the leave-one-out
    # cubic (260 samples of each embedded validation input were "corrected", rounding
    # the steps off and costing 0.024 of the lateral validation R^2)
    u = _step_input(noise)
    fixed, idx = reject_wild_values(u)
    assert idx == ()
    np.testing.assert_array_equal(fixed, u)


@pytest.mark.parametrize("noise", [0.0, 1e-3])
def test_spikes_and_short_bursts_on_step_inputs_are_still_found(noise):
    u = _step_input(noise, seed=1)
    spiky = u.copy()
    single = [700, 1195]  # on a plateau, and five samples before the 12 s doublet edge
    burst2, burst3 = [1600, 1601], [2500, 2501, 2502]
    spiky[single] += 0.05
    spiky[burst2] -= 0.06
    spiky[burst3] += 0.04
    fixed, idx = reject_wild_values(spiky)
    assert set(idx) == set(single + burst2 + burst3)
    np.testing.assert_allclose(fixed[list(idx)], u[list(idx)], atol=5e-3 + 5 * noise)


def test_embedded_validation_inputs_are_left_alone():
    from jaxgwo._data import default_dataset

    ds = default_dataset()
    for channel, name in (("lateral", "delta_lat"), ("longitudinal", "delta_lon")):
        for rec in (ds.validation[channel], ds.identification[channel]):
            assert reject_wild_values(np.asarray(rec[name]))[1] == ()
