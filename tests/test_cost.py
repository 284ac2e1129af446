"""Stage 5 fitness functions against hand computations and scipy."""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest
import scipy.signal

from jaxgwo._cost import (
    CiferObjective,
    ComplexErrorObjective,
    TimeDomainObjective,
    cifer_cost,
    coherence_weight,
    wrap_degrees,
)
from jaxgwo._models import PaperModel, ParameterMap
from jaxgwo._spectral import FrequencyResponse

TRUTH = jnp.array([-500.0, 0.1, 150.0, 40.0, 0.7])  # negative gain: lateral sign
W = jnp.geomspace(1.0, 60.0, 40)


def _measured(seed=0, noise=0.05):
    rng = np.random.default_rng(seed)
    h = np.asarray(PaperModel.from_array(TRUTH).frequency_response(W))
    h = h * (1 + noise * (rng.standard_normal(h.size) + 1j * rng.standard_normal(h.size)))
    coh = rng.uniform(0.45, 1.0, h.size)
    return FrequencyResponse.from_complex(W, jnp.asarray(h), jnp.asarray(coh))


def _hand_J(params, fr, weighting="tischler"):
    """Plain NumPy, one frequency at a time."""
    num, den = PaperModel.from_array(params).numerator, PaperModel.from_array(params).denominator
    tot, n = 0.0, 0
    for wi, hi, ci, mi in zip(*(np.asarray(a) for a in (fr.w, fr.H, fr.coherence, fr.mask))):
        if not mi:
            continue
        hm = np.polyval(np.asarray(num), 1j * wi) / np.polyval(np.asarray(den), 1j * wi)
        g = ci if weighting == "tischler" else ci**2
        wgt = (1.58 * (1 - np.exp(-g))) ** 2
        e_db = 20 * np.log10(abs(hm)) - 20 * np.log10(abs(hi))
        e_ph = np.degrees(np.angle(hm / hi))  # already in (-180, 180]
        tot += wgt * (e_db**2 + 0.01745 * e_ph**2)
        n += 1
    return 20.0 / n * tot


@pytest.mark.parametrize("weighting", ["tischler", "squared"])
def test_cifer_matches_hand_computation(weighting):
    fr = _measured()
    assert 20 <= fr.n_passing < W.size  # some points masked out
    off = TRUTH * jnp.array([1.2, 0.8, 1.1, 0.9, 1.3])
    for kind in ("paper", "quartic"):
        m = PaperModel.from_array(off)
        m = m if kind == "paper" else m.to_quartic()
        obj = CiferObjective.from_response(fr, ParameterMap.for_model(m), weighting=weighting)
        assert float(obj.cost(m)) == pytest.approx(_hand_J(off, fr, weighting), rel=1e-10)
        r = obj.residuals_from_params(m.to_array())
        assert float(jnp.sum(r**2)) == pytest.approx(float(obj.cost(m)), rel=1e-12)
        # a model given only by its complex response (as the diagnosis' augmented models are)
        h = m.frequency_response(obj.w)
        assert float(obj.cost_from_response(h)) == pytest.approx(_hand_J(off, fr, weighting), rel=1e-10)
        np.testing.assert_allclose(np.asarray(obj.residuals_from_response(h)), np.asarray(r),
                                   rtol=1e-9, atol=1e-12)


def test_cifer_zero_at_truth_and_convenience():
    fr = FrequencyResponse.from_complex(W, PaperModel.from_array(TRUTH).frequency_response(W))
    m = PaperModel.from_array(TRUTH)
    assert cifer_cost(m, fr) == pytest.approx(0.0, abs=1e-18)


def test_coherence_weight_and_wrap():
    # by hand: (1.58 (1 - e^-1))^2 = 0.997550..., at 0.6: tischler 0.5083, squared 0.2281
    w = coherence_weight(jnp.array([1.0, 0.6, 0.0]))
    np.testing.assert_allclose(np.asarray(w), [(1.58 * (1 - np.exp(-1))) ** 2,
                                               (1.58 * (1 - np.exp(-0.6))) ** 2, 0.0])
    assert float(coherence_weight(jnp.array(0.6), "squared")) == pytest.approx(
        (1.58 * (1 - np.exp(-0.36))) ** 2)
    np.testing.assert_allclose(np.asarray(wrap_degrees(jnp.array([350.0, -190.0, 180.0, -180.0, 10.0]))),
                               [-10.0, 170.0, 180.0, 180.0, 10.0])


def test_too_few_points_rejected():
    fr = _measured()
    fr = FrequencyResponse.from_complex(fr.w[:15], fr.H[:15])
    with pytest.raises(ValueError, match="at least 20"):
        CiferObjective.from_response(fr, ParameterMap.for_model(PaperModel.from_array(TRUTH)))


def test_vmap_over_pack_and_over_objectives():
    fr = _measured()
    pm = ParameterMap.for_model(PaperModel.from_array(TRUTH))
    obj = CiferObjective.from_response(fr, pm)
    key = jax.random.key(0)
    xs = pm.to_vector(PaperModel.from_array(TRUTH)) + 0.2 * jax.random.normal(key, (50, 5))
    batch = jax.jit(jax.vmap(obj))(xs)
    loop = jnp.stack([obj(x) for x in xs])
    np.testing.assert_allclose(np.asarray(batch), np.asarray(loop), rtol=1e-12)
    # several records in one call: stack objectives leaf-wise and vmap over both
    obj2 = CiferObjective.from_response(_measured(1), pm)
    stacked = jax.tree.map(lambda a, b: jnp.stack([a, b]), obj, obj2)
    two = jax.vmap(lambda o, x: o(x))(stacked, xs[:2])
    np.testing.assert_allclose(np.asarray(two), [float(obj(xs[0])), float(obj2(xs[1]))], rtol=1e-12)


def test_unstable_or_nonfinite_is_inf():
    fr = _measured()
    pm = ParameterMap.for_model(PaperModel.from_array(TRUTH))
    obj = CiferObjective.from_response(fr, pm)
    assert np.isinf(float(obj(jnp.array([jnp.nan, 0.0, 0.0, 0.0, 0.0]))))


def test_no_retrace_for_new_data_of_same_shape():
    pm = ParameterMap.for_model(PaperModel.from_array(TRUTH))
    x = pm.to_vector(PaperModel.from_array(TRUTH))

    @eqx.filter_jit
    @eqx.debug.assert_max_traces(max_traces=1)
    def run(obj, x):
        return obj(x)

    a = run(CiferObjective.from_response(_measured(0), pm), x)
    b = run(CiferObjective.from_response(_measured(1), pm), x)
    assert float(a) != float(b)


def test_complex_relative_error_by_hand():
    fr = _measured(2)
    off = TRUTH * jnp.array([1.1, 1.0, 0.9, 1.0, 1.0])
    obj = ComplexErrorObjective.from_response(fr, ParameterMap.for_model(PaperModel.from_array(off)))
    hm = np.asarray(PaperModel.from_array(off).frequency_response(W))
    m = np.asarray(fr.mask)
    ref = np.mean(np.abs(hm[m] / np.asarray(fr.H)[m] - 1) ** 2)
    assert float(obj.cost_from_params(off)) == pytest.approx(ref, rel=1e-12)


def test_time_domain_mse_against_lsim():
    fs = 100.0
    t = np.arange(600) / fs
    u = scipy.signal.chirp(t, 0.2, t[-1], 5.0)
    truth = PaperModel.from_array(TRUTH)
    _, y, _ = scipy.signal.lsim((np.asarray(truth.numerator), np.asarray(truth.denominator)), u, t,
                                interp=False)
    pm = ParameterMap.for_model(truth)
    obj = TimeDomainObjective.from_arrays(t, u, y, pm)
    assert float(obj(pm.to_vector(truth))) == pytest.approx(0.0, abs=1e-16 * np.mean(y**2))
    off = TRUTH * jnp.array([1.1, 1.0, 1.0, 1.0, 1.0])
    _, y_off, _ = scipy.signal.lsim((np.asarray(PaperModel.from_array(off).numerator),
                                     np.asarray(truth.denominator)), u, t, interp=False)
    assert float(obj.cost_from_params(off)) == pytest.approx(np.mean((y - y_off) ** 2), rel=1e-8)
