"""Lowered programs kept across runs (jaxgwo._aot): same bits as the plain jitted calls,
stored once, reused, and keyed by what the trace depends on."""

import os

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxgwo import _aot
from jaxgwo._identify import IdentifySettings, identify_channels
from jaxgwo._models import simulate_transfer_function

from test_identify import SMALL, _records


@pytest.fixture
def aot_dir(tmp_path):
    _aot.enable(str(tmp_path / "exported"))
    yield tmp_path / "exported"
    _aot.enable(None)


def _summary(results):
    out = {}
    for ch, r in results.items():
        v = r.validation
        out[ch] = (np.asarray(r.model.to_array()).tobytes(), r.cost_J, r.wls_cost_J, r.mse,
                   np.asarray(r.convergence).tobytes(), r.evaluations,
                   np.asarray(r.uncertainty.cramer_rao).tobytes(),
                   np.asarray(r.uncertainty.fisher).tobytes(),
                   None if v is None else (v.r2, v.tic, v.rms, v.per_record_r2))
    return out


def test_identify_is_bit_identical_with_stored_programs(aot_dir, monkeypatch):
    recs = _records(n=2)
    settings = IdentifySettings(method="wls-igwo+polish", **SMALL)
    args = ({"lateral": recs[:1]}, settings, {"lateral": recs[1:]})
    _aot.enable(None)
    plain = _summary(identify_channels(*args))
    _aot.enable(str(aot_dir))
    cold = _summary(identify_channels(*args))  # lowers and stores
    stored = sorted(p.name for p in aot_dir.iterdir())
    names = {n.split("-")[0] for n in stored}
    assert {"jaxgwo._identify._search", "jaxgwo._identify._polish_batch",
            "jaxgwo._metrics._uncertainty_arrays",
            "jaxgwo._models.simulate_transfer_function"} <= names
    # a new process: nothing in memory, and nothing may be traced again
    _aot.enable(str(aot_dir))

    def no_export(*a, **k):
        raise AssertionError("a stored program was lowered again")

    monkeypatch.setattr(jax.export, "export", no_export)
    warm = _summary(identify_channels(*args))
    assert sorted(p.name for p in aot_dir.iterdir()) == stored
    assert cold == plain
    assert warm == plain


def test_key_follows_shapes_and_statics(aot_dir):
    t = jnp.arange(100.0) * 0.01
    u = jnp.sin(t)
    num, den = jnp.asarray([2.0]), jnp.asarray([1.0, 0.5, 2.0])
    y = _aot.cached_jit(simulate_transfer_function, name="sim")(num, den, t, u)
    assert np.array_equal(np.asarray(y), np.asarray(simulate_transfer_function(num, den, t, u)))
    assert not y.committed  # later eager operations see the same arrays as without it
    _aot.cached_jit(simulate_transfer_function, name="sim")(num, den, t[:50], u[:50])
    assert len(list(aot_dir.iterdir())) == 2  # a new shape is a new program

    @_aot.cached_jit
    @jax.jit
    def double(x):
        return 2 * x

    double(t)
    double(t)
    assert len(list(aot_dir.iterdir())) == 3  # the same call is stored once


def test_unkeyable_arguments_take_the_plain_path(aot_dir):
    scale = 3.0

    @_aot.cached_jit
    def apply(fn, x):
        return jax.jit(fn)(x)

    out = apply(lambda x: scale * x, jnp.ones(3))  # a closure: its captures are not keyed
    assert np.array_equal(np.asarray(out), np.full(3, 3.0))
    assert not aot_dir.exists() or not list(aot_dir.iterdir())


def test_a_damaged_file_is_lowered_again(aot_dir):
    @_aot.cached_jit
    @jax.jit
    def square(x):
        return x * x

    square(jnp.arange(3.0))
    (path,) = aot_dir.iterdir()
    path.write_bytes(b"not a stored program")
    _aot.enable(str(aot_dir))  # a new process
    assert np.array_equal(np.asarray(square(jnp.arange(3.0))), [0.0, 1.0, 4.0])
    assert path.read_bytes() != b"not a stored program"


def test_a_stored_program_that_does_not_fit_is_lowered_again(aot_dir):
    # a file that deserializes but holds another program (say, written by a JAX that keys
    # differently): the call falls back to lowering and overwrites it
    @_aot.cached_jit
    @jax.jit
    def square(x):
        return x * x

    @_aot.cached_jit
    @jax.jit
    def cube(x):
        return x * x * x

    square(jnp.arange(3.0))
    cube(jnp.arange(4.0))
    by_name = {p.name.split("-")[0]: p for p in aot_dir.iterdir()}
    (sq,) = [p for n, p in by_name.items() if n.endswith("square")]
    (cu,) = [p for n, p in by_name.items() if n.endswith("cube")]
    sq.write_bytes(cu.read_bytes())  # shape (4,) program under the (3,) key
    _aot.enable(str(aot_dir))
    assert np.array_equal(np.asarray(square(jnp.arange(3.0))), [0.0, 1.0, 4.0])
    _aot.enable(str(aot_dir))
    assert np.array_equal(np.asarray(square(jnp.arange(3.0))), [0.0, 1.0, 4.0])


def test_programs_of_other_source_versions_are_removed(aot_dir, monkeypatch):
    @_aot.cached_jit(name="jaxgwo.test.square")
    @jax.jit
    def square(x):
        return x * x

    square(jnp.arange(3.0))
    square(jnp.arange(4.0))  # same version, other shape: kept
    first, second = sorted(aot_dir.iterdir())
    monkeypatch.setattr(_aot, "_fingerprint", lambda: "f" * 64)  # the sources changed
    os.utime(first, (0, 0))  # stored long ago; the other one recently
    _aot.enable(str(aot_dir))
    square(jnp.arange(3.0))
    names = sorted(p.name for p in aot_dir.iterdir())
    assert len(names) == 2 and second.name in names
    assert any(n.startswith("jaxgwo.test.square-ffffffffffff-") for n in names)


def test_transformed_calls_take_the_plain_path(aot_dir):
    # Regression: with the store enabled (as after the CLI's main() in the same
    # process), vmapping PaperModel.simulate failed: call_exported has no batching rule
    from jaxgwo._models import PaperModel

    t = jnp.linspace(0.0, 2.0, 200)
    u = jnp.sin(7.0 * t)
    truth = jnp.asarray([-500.0, 0.1, 150.0, 40.0, 0.7])
    ps = truth * jnp.asarray([[1.0] * 5, [0.8, 1.1, 1.2, 0.9, 1.3]])
    batched = jax.vmap(lambda p: PaperModel.from_array(p).simulate(t, u))(ps)
    loop = np.stack([np.asarray(PaperModel.from_array(p).simulate(t, u)) for p in ps])
    np.testing.assert_allclose(np.asarray(batched), loop, rtol=1e-12, atol=1e-12)
    grad = jax.grad(lambda k: jnp.sum(PaperModel.from_array(truth.at[0].set(k)).simulate(t, u)))(-500.0)
    assert np.isfinite(float(grad))
