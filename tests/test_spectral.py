"""Stage 2 spectral estimates against scipy.signal and a synthetic system."""

import numpy as np
import pytest
import scipy.signal

from jaxgwo._spectral import (
    FrequencyResponse,
    composite_frequency_response,
    cross_spectral_estimate,
    random_error,
)

FS = 100.0


def _plant():
    # lightly damped second order at 8 rad/s times a first-order lag at 30 rad/s
    num = [30.0 * 64.0]
    den = np.polymul([1.0, 2 * 0.3 * 8.0, 64.0], [1.0, 30.0])
    # state space, so the discretised numerator has no near-zero leading coefficient
    return scipy.signal.cont2discrete(scipy.signal.tf2ss(num, den), 1 / FS, method="zoh")


def _record(seconds, seed, noise=0.05):
    rng = np.random.default_rng(seed)
    n = int(seconds * FS)
    # band-limited random input: white noise through a 15 Hz low-pass
    sos = scipy.signal.butter(4, 15.0 / (FS / 2), output="sos")
    u = scipy.signal.sosfilt(sos, rng.standard_normal(n))
    _, y, _ = scipy.signal.dlsim(_plant(), u)
    y = y.ravel()
    return u, y + noise * np.std(y) * rng.standard_normal(n)


def _truth(w):
    a, b, c, d, dt = _plant()
    z = np.exp(1j * w * dt)
    eye = np.eye(a.shape[0])
    return np.array([(c @ np.linalg.solve(zk * eye - a, b) + d)[0, 0] for zk in z])


def test_single_window_matches_scipy_csd_and_coherence():
    u, y = _record(30, 0)
    nper, nov = 512, 256
    est = cross_spectral_estimate((u, y), FS, nper, nov)
    f, pxy = scipy.signal.csd(u, y, FS, window="hann", nperseg=nper, noverlap=nov)
    _, pxx = scipy.signal.welch(u, FS, window="hann", nperseg=nper, noverlap=nov)
    _, coh = scipy.signal.coherence(u, y, FS, window="hann", nperseg=nper, noverlap=nov)
    np.testing.assert_allclose(np.asarray(est.frequency_hz), f)
    np.testing.assert_allclose(np.asarray(est.Gxy), pxy, rtol=1e-10, atol=1e-14)
    np.testing.assert_allclose(np.asarray(est.Gxx), pxx, rtol=1e-10, atol=1e-14)
    # coherence divides small near-Nyquist densities: round-off reaches ~1e-8 there
    np.testing.assert_allclose(np.asarray(est.coherence)[1:], coh[1:], rtol=1e-7)
    assert est.n_averages == (u.size - nov) // (nper - nov)


def test_records_are_averaged_not_spliced():
    r1, r2 = _record(20, 1), _record(13, 2)
    nper, nov = 256, 128
    est = cross_spectral_estimate([r1, r2], FS, nper, nov)
    kw = dict(fs=FS, window="hann", nperseg=nper, noverlap=nov)
    n1 = (r1[0].size - nov) // (nper - nov)
    n2 = (r2[0].size - nov) // (nper - nov)
    pooled = (n1 * scipy.signal.csd(*r1, **kw)[1] + n2 * scipy.signal.csd(*r2, **kw)[1]) / (n1 + n2)
    np.testing.assert_allclose(np.asarray(est.Gxy), pooled, rtol=1e-10, atol=1e-14)
    assert est.n_averages == n1 + n2
    spliced = scipy.signal.csd(np.r_[r1[0], r2[0]], np.r_[r1[1], r2[1]], **kw)[1]
    assert not np.allclose(np.asarray(est.Gxy), spliced)


def test_random_error_formula():
    # sqrt(1 - g2) / (sqrt(g2) sqrt(2 nd)) by hand at g2 = 0.64, nd = 8
    assert random_error(np.array(0.64), np.array(8.0)) == pytest.approx(0.6 / (0.8 * 4.0))
    assert np.isinf(random_error(np.array(0.0), np.array(8.0)))


@pytest.mark.parametrize("combine", ["min_error", "blend"])
def test_composite_recovers_synthetic_system(combine):
    recs = [_record(60, 10), _record(60, 11)]
    fr = composite_frequency_response(recs, FS, w_min=1.0, w_max=60.0, n_frequencies=60,
                                      combine=combine)
    assert isinstance(fr, FrequencyResponse)
    m = np.asarray(fr.mask)
    assert m.sum() >= 50
    h = _truth(np.asarray(fr.w))
    rel = np.abs(np.asarray(fr.H)[m] / h[m] - 1.0)
    # The random error is the 1-sigma scatter of |H| (the phase has the same in radians,
    # so the complex relative error is ~sqrt(2) of it), and n_d counts 50%-overlapped
    # segments and neighbouring Hann bins as independent, which under-states it by ~1.5x:
    # 8 eps is ~4 true sigmas.  The 3% covers leakage bias at the 8 rad/s resonance,
    # measured at 2-4% with no noise at all.
    assert np.all(rel < 8 * np.asarray(fr.random_error)[m] + 0.03), rel.max()
    assert np.median(rel) < 0.03


def test_composite_picks_smallest_error_window():
    recs = [_record(60, 20)]
    kw = dict(w_min=2.0, w_max=40.0, n_frequencies=40)
    fr = composite_frequency_response(recs, FS, window_lengths_s=[6.4, 3.2, 1.6], **kw)
    windows = np.unique(np.asarray(fr.window_s)[np.asarray(fr.mask)])
    assert windows.size >= 2  # the composite really mixes windows
    for tw in (6.4, 3.2, 1.6):
        single = composite_frequency_response(recs, FS, window_lengths_s=[tw],
                                              coherence_threshold=0.0, **kw)
        ok = np.isfinite(np.asarray(single.random_error))
        assert np.all(np.asarray(fr.random_error)[ok] <= np.asarray(single.random_error)[ok] + 1e-12)


def test_record_too_short_says_minimum_duration():
    u, y = _record(5, 3)
    with pytest.raises(ValueError, match=r"record too short.*at least 31.4 s"):
        composite_frequency_response((u, y), FS, w_min=1.0, w_max=20.0)


def test_no_usable_coherence():
    rng = np.random.default_rng(4)
    u, y = rng.standard_normal(6000), rng.standard_normal(6000)
    with pytest.raises(ValueError, match="no usable coherence"):
        composite_frequency_response((u, y), FS, w_min=2.0, w_max=40.0, n_frequencies=30)


def test_beyond_nyquist_rejected():
    u, y = _record(60, 5)
    with pytest.raises(ValueError, match="Nyquist"):
        composite_frequency_response((u, y), FS, w_min=1.0, w_max=400.0)


def test_hann_window_is_scipys_bit_for_bit():
    from jaxgwo._spectral import _window

    for n in (*range(1, 40), 255, 256, 1000, 1024, 3001):
        ours, ref = _window("hann", n), scipy.signal.get_window("hann", n)
        assert ours.dtype == ref.dtype and ours.tobytes() == ref.tobytes(), n
    # other windows come from scipy itself
    assert np.array_equal(_window("hamming", 64), scipy.signal.get_window("hamming", 64))
