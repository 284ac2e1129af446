"""Sharding the seed axis: two forced host devices, and two processes on 127.0.0.1.

Each check runs in a fresh interpreter because ``XLA_FLAGS`` and ``jax.distributed`` must
be set up before JAX initialises its backend, which the test session has already done.
"""

import os
import socket
import subprocess
import sys
import textwrap

import jax
import numpy as np
import pytest

import jaxgwo
from jaxgwo._sharding import run_seeds_sharded, seed_mesh
from jaxgwo._testfunctions import helicopter_problem

_PRELUDE = """
import os, sys
import jax
jax.config.update("jax_enable_x64", True)
jax.config.update("jax_numpy_dtype_promotion", "strict")
import numpy as np
import jaxgwo
from jaxgwo._sharding import run_seeds_sharded
from jaxgwo._testfunctions import helicopter_problem

p = helicopter_problem(n_freq=8)
cfg = jaxgwo.igwo(6, 10)
"""

_COMPARE = """
KEYS = jax.random.split(jax.random.key(7), 5)
REF = jaxgwo.run_seeds(cfg, p.objective, p.lower(), p.upper(), KEYS)

def compare(sharded, n):
    for name in ("best_position", "best_fitness", "history_best", "evaluations"):
        got, want = np.asarray(getattr(sharded, name)), np.asarray(getattr(REF, name))[:n]
        assert got.shape == want.shape, (name, got.shape, want.shape)
        np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-14, err_msg=name)
"""


def _env(**extra):
    env = dict(os.environ)
    env.pop("XLA_FLAGS", None)
    env.update(JAX_PLATFORMS="cpu", **extra)
    return env


def _python(code, env):
    return subprocess.Popen([sys.executable, "-c", textwrap.dedent(code)], env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def _check(proc, timeout=120):
    try:
        out, err = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        proc.kill()
        out, err = proc.communicate()
        pytest.fail(f"subprocess timed out\nstdout:\n{out}\nstderr:\n{err[-3000:]}")
    assert proc.returncode == 0, f"stdout:\n{out}\nstderr:\n{err[-3000:]}"
    return out


_TWO_DEVICES = _PRELUDE + _COMPARE + """
assert jax.device_count() == 2, jax.devices()
for n in (5, 1):  # padded to 6; fewer seeds than devices
    out = run_seeds_sharded(cfg, p.objective, p.lower(), p.upper(), KEYS[:n])
    if n == 5:  # the seed axis really was split over both devices
        assert len(out.best_fitness.sharding.device_set) == 2, out.best_fitness.sharding
    compare(out, n)
print("OK")
"""


def _free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


_TWO_PROCESSES = """
import jax
jax.config.update("jax_cpu_collectives_implementation", "gloo")
jax.distributed.initialize(coordinator_address="127.0.0.1:{port}", num_processes=2,
                           process_id={pid}, initialization_timeout=60)
""" + _PRELUDE + _COMPARE + """
assert jax.process_count() == 2 and jax.device_count() == 2, jax.devices()
assert jax.local_device_count() == 1
out = run_seeds_sharded(cfg, p.objective, p.lower(), p.upper(), KEYS)
assert isinstance(out.best_fitness, np.ndarray)  # gathered to every process
compare(out, 5)
print("OK", jax.process_index())
"""


@pytest.fixture(scope="module")
def launched():
    """Start every subprocess at once (they overlap on a 2-core machine)."""
    port = _free_port()
    procs = {
        "devices": _python(_TWO_DEVICES,
                           _env(XLA_FLAGS="--xla_force_host_platform_device_count=2")),
        "processes": [_python(_TWO_PROCESSES.replace("{port}", str(port))
                              .replace("{pid}", str(i)), _env()) for i in range(2)],
    }
    yield procs
    for proc in [procs["devices"], *procs["processes"]]:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()


def test_two_host_devices_equal_unsharded(launched):
    assert "OK" in _check(launched["devices"])


def test_two_processes_on_localhost_equal_unsharded(launched):
    outs = [_check(proc) for proc in launched["processes"]]
    assert "OK 0" in outs[0] and "OK 1" in outs[1]


def test_single_device_mesh_in_process():
    """In the test session (one CPU device), with raw uint32 keys and no history."""
    p = helicopter_problem(n_freq=8)
    cfg = jaxgwo.igwo(6, 10)
    keys = jax.random.split(jax.random.PRNGKey(1), 3)
    got = run_seeds_sharded(cfg, p.objective, p.lower(), p.upper(), keys, mesh=seed_mesh(),
                            keep_history=False)
    ref = jaxgwo.run_seeds(cfg, p.objective, p.lower(), p.upper(), keys, keep_history=False)
    assert got.history_best is None
    np.testing.assert_allclose(np.asarray(got.best_position), np.asarray(ref.best_position),
                               rtol=1e-12, atol=1e-14)
    with pytest.raises(ValueError, match="seeds"):
        run_seeds_sharded(cfg, p.objective, p.lower(), p.upper(), keys,
                          mesh=jax.sharding.Mesh(np.asarray(jax.devices()), ("x",)))
