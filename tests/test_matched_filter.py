"""The matched-filter evidence of a time-domain refit (``matched_filter_z``): its variance
against the analytic AR(1) autocovariance, calibrated under coloured noise (z^2 ~ chi^2_k),
as powerful as the analytic matched filter where the disturbance is low-frequency and the
effect is not, and the resonances it applies to (``_resonance_in_box``)."""

import numpy as np
import pytest
import scipy.signal

from jaxgwo._diagnose_which import disturbance_variance, matched_filter_p, matched_filter_z

FS = 100.0


def _ar1(rng, n, phi, sigma, white):
    """AR(1) noise (innovations ``sigma``) plus white noise ``white``, started stationary."""
    e = rng.normal(0.0, sigma, n)
    x, _ = scipy.signal.lfilter([1.0], [1.0, -phi], e[1:], zi=[phi * e[0] / np.sqrt(1.0 - phi**2)])
    return np.r_[e[0] / np.sqrt(1.0 - phi**2), x] + rng.normal(0.0, white, n)


def _ar1_autocovariance(n, phi, sigma, white):
    r = sigma**2 * phi ** np.arange(n) / (1.0 - phi**2)
    r[0] += white**2
    return r


def _exact_variance(r_noise, e):
    """sum_l R_n(l) R_e(l) over every lag, the noise's autocovariance known."""
    r_e = np.correlate(e, e, "full")[e.size - 1 :]
    return float(r_noise[0] * r_e[0] + 2.0 * np.dot(r_noise[1:], r_e[1:]))


@pytest.mark.parametrize("f_hz", [0.3, 2.0, 15.0])
def test_disturbance_variance_against_the_analytic_autocovariance(f_hz):
    """Low-frequency AR(1) noise (corner 0.8 Hz): its Welch estimate (4 s windows) gives
    var<n, e> as the exact lag sum does, for a signal where the noise is strong (0.3 Hz)
    and where it is 300 times weaker (15 Hz): mean of 10 draws within 10 % (each draw's
    spread about 10 %)."""
    rng = np.random.default_rng(3)
    n, phi, sigma, white = 20000, 0.95, 1.0, 0.1
    t = np.arange(n) / FS
    e = np.sin(2 * np.pi * f_hz * t) * np.exp(-(((t - 100.0) / 30.0) ** 2))
    exact = _exact_variance(_ar1_autocovariance(n, phi, sigma, white), e)
    got = [disturbance_variance(_ar1(rng, n, phi, sigma, white), e, 400) for _ in range(10)]
    assert np.mean(got) == pytest.approx(exact, rel=0.10)


def test_matched_filter_z_of_white_noise_and_of_nothing():
    """White residuals: z is <r0, e> / (sigma ||e||); a refit that changes nothing has z 0."""
    rng = np.random.default_rng(4)
    r1 = [rng.normal(0.0, 0.5, 6000), rng.normal(0.0, 0.5, 4000)]
    e = [0.2 * np.sin(np.arange(r.size) * 0.7) for r in r1]
    before = [a + b + 1.0 for a, b in zip(r1, e, strict=True)]  # record means do not count
    num = sum(float((a - a.mean()) @ (a - a.mean() - (b - b.mean()))) for a, b in zip(before, r1, strict=True))
    ref = num / np.sqrt(sum(np.var(r) * float(x @ x) for r, x in zip(r1, e, strict=True)))
    assert matched_filter_z(before, r1, FS) == pytest.approx(ref, rel=0.05)
    assert matched_filter_z(before, before, FS) == 0.0


def test_matched_filter_is_calibrated_under_coloured_noise():
    """No effect, one fitted amplitude of a 15 Hz sinusoid in strongly low-frequency
    noise: z^2 follows chi^2_1, so p < 0.05 about 5 % of the time."""
    rng = np.random.default_rng(11)
    n = 2000
    x = np.sin(2 * np.pi * 15.0 * np.arange(n) / FS + 0.3)
    z2, rejected = [], 0
    for _ in range(400):
        y = _ar1(rng, n, 0.95, 1.0, 0.1)
        beta = (x @ y) / (x @ x)
        z = matched_filter_z([y], [y - beta * x], FS)
        z2.append(z * z)
        rejected += matched_filter_p(z, 1) < 0.05
    assert np.mean(z2) == pytest.approx(1.0, abs=0.25)  # sd of the mean 0.07
    assert 0.02 <= rejected / 400 <= 0.09  # binomial sd 0.011


def test_matched_filter_sees_a_high_frequency_effect_through_low_frequency_noise():
    """A 15 Hz sinusoid whose analytic matched-filter z is 5 (the AR(1) autocovariance
    known): the estimate finds it, where the noise's total variance (ten times its power
    near 15 Hz) would hide it."""
    rng = np.random.default_rng(5)
    n, phi, sigma, white = 2000, 0.95, 1.0, 0.1
    x = np.sin(2 * np.pi * 15.0 * np.arange(n) / FS + 0.3)
    x_r_x = _exact_variance(_ar1_autocovariance(n, phi, sigma, white), x)
    amp = 5.0 * np.sqrt(x_r_x) / (x @ x)  # E z = amp x'x / sqrt(x'Rx) = 5
    zs, naive = [], []
    for _ in range(60):
        y = amp * x + _ar1(rng, n, phi, sigma, white)
        beta = (x @ y) / (x @ x)
        zs.append(matched_filter_z([y], [y - beta * x], FS))
        naive.append((y @ x) / np.sqrt(np.var(y - beta * x) * (x @ x)))
    assert np.mean(zs) == pytest.approx(5.0, abs=0.6)
    assert np.mean(naive) < 2.5  # white-noise scaling by the total variance
    assert matched_filter_p(float(np.mean(zs)), 1) < 1e-4
    assert matched_filter_p(-1.0, 3) == 1.0


@pytest.mark.parametrize("mode", [(14.0, 0.03, 0.2), None])
def test_a_resonance_refitted_by_output_error_passes_on_the_matched_filter(mode):
    """A 14 Hz resonance (pole damping 0.03) on the paper plant, one 0.3-20 Hz sweep in
    gusts: refitted by output error from the diagnosis's mode starts beside the null
    refit, it lands within 3 %, a resonance inside the box, and the matched filter passes
    it at ``alpha`` (1e-3) where the F-test on effective samples from the residual's
    correlation time does not reach 0.01.  Without the mode the refit passes neither."""
    import jax
    import jax.numpy as jnp

    from jaxgwo._diagnose import _resonance_in_box, _time_domain_mode_starts, _time_pairs
    from jaxgwo._diagnose_where import residual_tests
    from jaxgwo._diagnose_which import (ModelSpec, f_test_p, fit_nonlinear_candidates, refit_linear_time_domain,
                                        simulate_model)  # fmt: skip
    from jaxgwo._effects import EffectSet
    from jaxgwo._identify import IdentifySettings
    from jaxgwo._models import PaperModel
    from jaxgwo._plants import PaperPlant
    from jaxgwo._signals import frequency_sweep, pilot_corrections
    from jaxgwo._simulate import Disturbance, simulate

    k = jax.random.split(jax.random.key(0), 2)
    n = int(30.0 * FS)
    t = jnp.arange(n, dtype=jnp.float64) / FS
    sweep = frequency_sweep(t, f_start_hz=0.3, f_stop_hz=20.0, duration_s=25.0, amplitude=0.2, start_s=3.0)
    eff = EffectSet()
    if mode is not None:
        eff = eff.with_effect("structural_mode", freq_hz=mode[0], zeta_p=mode[1], zeta_z=mode[2])
    rec = simulate(PaperPlant.default(), jnp.stack([sweep, pilot_corrections(k[0], n, FS, rms=0.02)], 1), k[1],
                   sample_rate_hz=FS, disturbance=Disturbance(gust_rms=0.12, snr_db=35.0), effects=eff)  # fmt: skip
    tt = _time_pairs([rec.to_record()], "lateral", IdentifySettings())
    base = ModelSpec(np.asarray(PaperModel.from_array(jnp.asarray(PaperPlant.default().lateral)).to_array(), float))
    (null,) = fit_nonlinear_candidates(base, tt, [], key=jax.random.key(0), wolves=6, iterations=6, include_null=True)
    null_spec = null.spec(base)
    r0 = [y - simulate_model(null_spec, t, u) for t, u, _o, y in tt]
    tc = residual_tests([u for _t, u, _o, _y in tt], r0, 1.0 / FS).correlation_time_s
    n_eff = n / FS / tc
    nr = null.refit
    x_n = np.r_[0.0, np.log(100.0), 0.0, np.log([10.0, 1.0, 1.0]), np.log([nr["omega_s"], nr["zeta_s"], nr["tau"], nr["M"]])]
    fit = refit_linear_time_domain(null_spec, tt, ("structural_mode",), [x_n], screened=_time_domain_mode_starts(x_n))
    r1 = [y - simulate_model(fit.spec(null_spec), t, u) for t, u, _o, y in tt]
    p_mf = matched_filter_p(matched_filter_z(r0, r1, FS), 3)
    p_f = f_test_p(null.train_mse, fit.train_mse, 3, n_eff - 7)
    got = fit.params["structural_mode"]
    if mode is None:
        assert p_mf > 1e-2 and p_f > 1e-2
    else:
        assert abs(got["freq_hz"] / mode[0] - 1.0) < 0.03
        assert _resonance_in_box(got)
        assert p_mf < 1e-3 < 1e-2 < p_f


def test_only_a_resonance_inside_the_box_takes_the_matched_filter():
    """The shapes that keep the F-test: a notch, a pair whose peak is below the
    vocabulary's least (zeros 0.1 over poles 0.08), a broad pair, the box's edges, and a
    peak outside the vocabulary's 8-30 Hz by more than 5 %."""
    from jaxgwo._diagnose import _resonance_in_box

    def mode(f, zp, zz):
        return {"freq_hz": f, "zeta_p": zp, "zeta_z": zz}

    assert _resonance_in_box(mode(13.5, 0.069, 0.367))
    assert _resonance_in_box(mode(20.0, 0.011, 0.118))
    assert not _resonance_in_box(mode(13.5, 0.3, 0.2))  # a notch
    assert not _resonance_in_box(mode(8.5, 0.017, 0.020))  # peak x1.18: no resonance of the vocabulary
    assert not _resonance_in_box(mode(9.0, 0.3, 1.2))  # broad
    assert not _resonance_in_box(mode(45.0, 0.05, 0.2))  # top of the box
    assert not _resonance_in_box(mode(15.0, 0.01, 0.2))  # pole damping on the floor
    assert not _resonance_in_box(mode(15.0, 0.05, 1.5))  # zeros on the ceiling
    assert not _resonance_in_box(mode(6.35, 0.067, 0.101))  # below the band (seed-353 case_027, no effect)
    assert not _resonance_in_box(mode(7.55, 0.05, 0.2))  # 5.6 % below 8 Hz
    assert _resonance_in_box(mode(7.65, 0.05, 0.2))  # 4.4 % below: a fit's error
    assert _resonance_in_box(mode(31.4, 0.05, 0.2))
    assert not _resonance_in_box(mode(31.6, 0.05, 0.2))
