"""Benchmark functions: values at their known minimisers and at hand-computed points."""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxgwo import _testfunctions as T

N = 6


def _by_name():
    return {p.name.split()[0]: p for p in T.mirjalili_functions(jax.random.key(0))}


@pytest.mark.parametrize("fid,xstar", [
    ("F1", 0.0), ("F2", 0.0), ("F3", 0.0), ("F4", 0.0), ("F5", 1.0), ("F6", 0.0),
    ("F9", 0.0), ("F10", 0.0), ("F11", 0.0), ("F12", -1.0), ("F13", 1.0),
])
def test_minimum_value_at_minimiser(fid, xstar):
    p = _by_name()[fid]
    x = jnp.full((N,), xstar)
    assert float(p.objective(x)) == pytest.approx(p.optimum(N), abs=1e-12)


def test_schwefel_2_26_minimum():
    p = _by_name()["F8"]
    x = jnp.full((N,), 420.968746)
    assert float(p.objective(x)) == pytest.approx(p.optimum(N), rel=1e-6)


def test_hand_computed_values():
    x = jnp.array([1.0, -2.0, 3.0])
    assert float(T.schwefel_2_22(x)) == 6.0 + 6.0
    assert float(T.schwefel_1_2(x)) == 1.0 + 1.0 + 4.0
    assert float(T.schwefel_2_21(x)) == 3.0
    assert float(T.rosenbrock(x)) == pytest.approx(100 * 9 + 0 + 100 * 1 + 9)
    assert float(T.step_function(jnp.array([0.4, 0.6, -1.6]))) == 0 + 1 + 4
    ref_ackley = (-20 * math.exp(-0.2 * math.sqrt(14 / 3))
                  - math.exp((math.cos(2 * math.pi) * 2 + math.cos(6 * math.pi)) / 3) + 20 + math.e)
    assert float(T.ackley(x)) == pytest.approx(ref_ackley, rel=1e-12)


def test_quartic_noise_is_reproducible_and_bounded():
    f = T.QuarticNoise(jax.random.key(3))
    x = jnp.array([0.1, 0.2, -0.3])
    base = float(jnp.sum(jnp.arange(1.0, 4.0) * x**4))
    v1, v2 = float(f(x)), float(f(x))
    assert v1 == v2
    assert base <= v1 < base + 1.0
    assert float(T.QuarticNoise(jax.random.key(4))(x)) != v1


@pytest.mark.parametrize("n_freq", [20, 32, 33, 200, 1025, 2000])
def test_frequency_fit_matches_the_factored_response(n_freq):
    # FrequencyFit expands the denominator in powers of w and sums in blocks of 32 (padding
    # weighted 0); compare with the plain definition on the factored response.  Cancellation
    # in the expanded polynomial near the resonances costs a few ulps, hence 1e-10.
    from jaxgwo._transfer import paper_model_response

    p = T.helicopter_problem(n_freq=n_freq)
    obj = p.objective
    target = np.asarray(obj.target_re) + 1j * np.asarray(obj.target_im)
    rng = np.random.default_rng(n_freq)
    lo, hi = np.asarray(p.lower()), np.asarray(p.upper())
    for x in lo + rng.random((10, 5)) * (hi - lo):
        g = np.asarray(paper_model_response(jnp.asarray(x), obj.w))
        ref = np.mean(np.abs(g - target) ** 2 / np.abs(target) ** 2)
        assert float(obj(jnp.asarray(x))) == pytest.approx(ref, rel=1e-10)
    truth = jnp.asarray(T.HELICOPTER_TRUTH)
    assert float(obj(truth)) < 1e-28
