"""Stage 4 models against scipy.signal (freqs, lsim, dlsim) and round trips."""

import importlib.util

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest
import scipy.signal
from _references import lsim_of_delayed_held_input

from jaxgwo._models import (
    PaperModel,
    ParameterMap,
    QuarticModel,
    canonicalize_paper_params,
    paper_model_from_physical,
    simulate_transfer_function,
    simulate_transfer_function_delayed,
)

TRUTH = jnp.array([500.0, 0.1, 150.0, 40.0, 0.7])
W = jnp.geomspace(1.0, 60.0, 50)


def _chirp(n=1500, fs=100.0):
    t = np.arange(n) / fs
    return t, scipy.signal.chirp(t, 0.1, t[-1], 8.0) * np.hanning(n) ** 0.2


@pytest.mark.parametrize("kind", ["paper", "quartic"])
def test_frequency_response_matches_scipy_freqs(kind):
    m = PaperModel.from_array(TRUTH)
    if kind == "quartic":
        m = m.to_quartic()
    _, ref = scipy.signal.freqs(np.asarray(m.numerator), np.asarray(m.denominator), np.asarray(W))
    np.testing.assert_allclose(np.asarray(m.frequency_response(W)), ref, rtol=1e-12)
    tf = m.to_scipy()
    np.testing.assert_allclose(tf.num, np.asarray(m.numerator) / float(m.denominator[0]))
    np.testing.assert_allclose(tf.den, np.asarray(m.denominator) / float(m.denominator[0]))


def test_quartic_and_paper_agree():
    p = PaperModel.from_array(TRUTH)
    q = p.to_quartic()
    np.testing.assert_allclose(np.asarray(q.frequency_response(W)),
                               np.asarray(p.frequency_response(W)), rtol=1e-12)
    np.testing.assert_allclose(np.asarray(q.to_paper().to_array()), np.asarray(TRUTH), rtol=1e-9)
    assert q.denominator.shape == (5,) and float(q.denominator[-1]) == 1.0
    assert set(p.params) == {"K", "tau", "M", "omega_s", "zeta_s"}


def test_from_quartic_explains_failure():
    bad = QuarticModel(1.0, 0.1, -0.01, 0.001, 1e-6)
    with pytest.raises(ValueError, match="no paper-model form: unstable"):
        PaperModel.from_quartic(bad)


def test_to_control():
    m = PaperModel.from_array(TRUTH)
    if importlib.util.find_spec("control") is None:
        with pytest.raises(ImportError, match="python-control is not installed"):
            m.to_control()
    else:
        sys = m.to_control()
        np.testing.assert_allclose(np.ravel(sys.den[0][0]), np.asarray(m.denominator))


@pytest.mark.parametrize("kind", ["paper", "quartic"])
def test_simulate_matches_lsim_and_dlsim(kind):
    t, u = _chirp()
    m = PaperModel.from_array(TRUTH)
    if kind == "quartic":
        m = m.to_quartic()
    y = np.asarray(m.simulate(jnp.asarray(t), jnp.asarray(u)))
    num, den = np.asarray(m.numerator), np.asarray(m.denominator)
    _, y_lsim, _ = scipy.signal.lsim((num, den), u, t, interp=False)
    ss = scipy.signal.tf2ss(num, den)
    _, y_dlsim, _ = scipy.signal.dlsim(scipy.signal.cont2discrete(ss, t[1] - t[0], "zoh"), u)
    scale = np.max(np.abs(y_lsim))
    np.testing.assert_allclose(y, y_lsim, atol=1e-9 * scale)
    np.testing.assert_allclose(y, y_dlsim.ravel(), atol=1e-9 * scale)


@pytest.mark.parametrize("delay", [0.0, 0.01225, 0.0275, 0.03, 0.07975])
def test_delayed_simulation_matches_lsim_of_the_held_input_on_a_fine_grid(delay):
    """The held input delayed by a fraction of a sample: ``scipy.signal.lsim`` of the same
    staircase on a grid 40 times finer (where the delay is a whole number of fine steps,
    so the reference is exact), read at the coarse samples.  A whole-sample delay is the
    plain simulation of the shifted samples."""
    m = PaperModel.from_array(TRUTH)
    num, den = np.asarray(m.numerator), np.asarray(m.denominator)
    dt, n, fine = 0.01, 400, 40
    t = np.arange(n) * dt
    u = np.repeat(np.asarray(jax.random.normal(jax.random.key(1), (n // 8,))), 8)
    y = np.asarray(simulate_transfer_function_delayed(num, den, t, u, delay))
    ref = lsim_of_delayed_held_input(num, den, t, u, delay, fine)
    scale = np.max(np.abs(ref))
    np.testing.assert_allclose(y, ref, atol=1e-9 * scale)
    if delay / dt == round(delay / dt):
        k = int(round(delay / dt))
        plain = simulate_transfer_function(num, den, t, np.r_[np.zeros(k), u[: n - k]])
        np.testing.assert_allclose(y, np.asarray(plain), atol=1e-12 * scale)


def test_delayed_simulation_is_smooth_in_the_delay_across_a_whole_sample():
    """An output error's slope in the delay just below and just above a whole sample (30 ms
    at 100 Hz, the truth 28.7 ms): equal to 2 % for the exact held-input delay; for linear
    interpolation of the samples, the form the output-error refit used before, the slope
    jumps (here 20-fold), a kink where a fit can stop.  Gradients by forward mode agree
    with the one-sided differences."""
    m = PaperModel.from_array(TRUTH)
    num, den = jnp.asarray(m.numerator), jnp.asarray(m.denominator)
    t = jnp.arange(400, dtype=float) * 0.01
    u = jnp.repeat(jax.random.normal(jax.random.key(1), (50,)), 8)
    y = simulate_transfer_function_delayed(num, den, t, u, 0.0287)

    def exact(d):
        return jnp.mean((simulate_transfer_function_delayed(num, den, t, u, d) - y) ** 2)

    def interp(d):
        return jnp.mean((simulate_transfer_function(num, den, t, jnp.interp(t - d, t, u, left=0.0)) - y) ** 2)

    h = 1e-6
    for f, smooth in ((exact, True), (interp, False)):
        left = (float(f(0.03)) - float(f(0.03 - h))) / h
        right = (float(f(0.03 + h)) - float(f(0.03))) / h
        assert left > 0.0 and (abs(right / left - 1.0) < 0.02) == smooth, (left, right)
    grad = jax.jacfwd(exact)
    for d in (0.03 - 1e-4, 0.03 + 1e-4):
        fd = (float(exact(d + 1e-7)) - float(exact(d - 1e-7))) / 2e-7
        assert float(grad(jnp.asarray(d))) == pytest.approx(fd, rel=1e-4)


def test_simulate_vmaps_over_models():
    t, u = _chirp(400)
    ps = TRUTH * jnp.array([[1.0] * 5, [0.8, 1.1, 1.2, 0.9, 1.3], [1.2, 0.9, 0.7, 1.1, 0.8]])
    batch = jax.vmap(lambda p: PaperModel.from_array(p).simulate(t, u))(ps)
    for i in range(3):
        one = PaperModel.from_array(ps[i]).simulate(t, u)
        np.testing.assert_allclose(np.asarray(batch[i]), np.asarray(one), rtol=1e-12, atol=1e-12)


def test_canonicalization_resolves_the_swap_alias():
    k, tau, m, ws, zs = np.asarray(TRUTH)
    swapped = jnp.array([k * ws**2 / m, 1 / (2 * zs * ws), ws**2, np.sqrt(m), 1 / (2 * tau * np.sqrt(m))])
    a, b = PaperModel.from_array(TRUTH), PaperModel.from_array(swapped)
    # same transfer function, different vectors: the alias
    np.testing.assert_allclose(np.asarray(b.frequency_response(W)),
                               np.asarray(a.frequency_response(W)), rtol=1e-12)
    np.testing.assert_allclose(np.asarray(b.canonical().to_array()), np.asarray(TRUTH), rtol=1e-12)
    np.testing.assert_allclose(np.asarray(a.canonical().to_array()), np.asarray(TRUTH), rtol=0)
    both = jax.vmap(canonicalize_paper_params)(jnp.stack([TRUTH, swapped]))
    np.testing.assert_allclose(np.asarray(both), np.asarray(jnp.stack([TRUTH, TRUTH])), rtol=1e-12)


def test_physical_derivatives_round_trip():
    geo = dict(tau_m=0.05, stabilizer_gain=0.4, cyclic_gain=0.3, stabilizer_input_gain=0.5)
    m = paper_model_from_physical(705.0, 0.105, **geo, omega_s=40.0, zeta_s=0.7)
    phys = m.physical_derivatives(**geo, channel="lateral")
    d = phys.as_dict()
    assert d["L_b1"] == pytest.approx(705.0) and d["L_b1_from_gain"] == pytest.approx(705.0)
    assert d["tau_sp"] == pytest.approx(0.105)
    lon = m.physical_derivatives(**geo, channel="longitudinal").as_dict()
    assert set(lon) == {"M_a1", "M_a1_from_gain", "tau_sq"}
    # by hand, eq. (15): M = L_b1 (tau_m + B_d1 tau_sp)/tau_sp
    assert float(m.M) == pytest.approx(705.0 * (0.05 + 0.4 * 0.105) / 0.105)


def test_parameter_map_round_trip_with_negative_gain():
    p = TRUTH.at[0].set(-500.0)
    m = PaperModel.from_array(p)
    pm = ParameterMap.for_model(m)
    assert pm.signs[0] == -1.0 and pm.dim == 5 and pm.names[0] == "K"
    x = pm.to_vector(m)
    np.testing.assert_allclose(np.asarray(x), np.log(np.abs(np.asarray(p))), rtol=1e-15)
    np.testing.assert_allclose(np.asarray(pm.from_vector(x).to_array()), np.asarray(p), rtol=1e-14)
    xs = jnp.stack([x, x + 0.1])
    models = jax.vmap(pm.from_vector)(xs)
    assert models.K.shape == (2,)
    qm = ParameterMap.for_model(m.to_quartic())
    assert qm.kind == "quartic" and qm.names == ("b0", "a1", "a2", "a3", "a4")


def test_models_are_frozen():
    m = PaperModel.from_array(TRUTH)
    with pytest.raises(Exception):
        m.K = 1.0
    assert isinstance(m, eqx.Module)
