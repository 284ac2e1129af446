"""The seed axis sharded across every device: one host's devices, or several hosts'.

:func:`run_seeds_sharded` is :func:`jaxgwo.run_seeds` with the seed axis laid over a 1-D
device mesh (axis name ``"seeds"``) by :func:`jax.shard_map`: each device runs the same
vmapped scan on its own contiguous block of seeds, and nothing is communicated during the
run (seeds are independent), so it scales with the device count.  The seed count is padded
to a multiple of the device count with copies of the last key, and the padding dropped.
Result ``i`` equals ``run_seeds(..., keys)[i]`` (tested to 1e-12, in practice bit for bit).

**Several CPU devices on one machine.**  XLA's CPU client exposes one device unless told
otherwise; to use ``n`` cores as ``n`` devices, set the flag *before* JAX is imported::

    XLA_FLAGS=--xla_force_host_platform_device_count=2 python my_study.py

**Several hosts** (multi-controller JAX: one identical Python process per host; every
process runs the same program).  Start each process with::

    import jax
    jax.config.update("jax_cpu_collectives_implementation", "gloo")  # CPU hosts only
    jax.distributed.initialize(
        coordinator_address="10.0.0.1:1234",  # host:port of process 0, reachable by all
        num_processes=2,                      # total number of processes
        process_id=0,                         # this process: 0 .. num_processes - 1
    )
    import jaxgwo
    keys = jax.random.split(jax.random.key(0), 10_000)   # the same keys in every process
    result = jaxgwo._sharding.run_seeds_sharded(config, objective, lower, upper, keys)

for example ``python study.py --process-id 0`` on the first host and ``... 1`` on the second
(``initialize`` blocks until all ``num_processes`` have connected).  On GPU clusters with
SLURM or Open MPI, ``jax.distributed.initialize()`` without arguments reads these from the
environment.  After ``initialize``, ``jax.devices()`` lists every process's devices, the
default mesh spans them all, and the result is gathered back to every process
(:func:`jax.experimental.multihost_utils.process_allgather`), so each process holds the
whole ``(n_seeds, ...)`` result as host arrays.  ``tests/test_sharding.py`` runs exactly
this with two processes on 127.0.0.1 and CPU (gloo) collectives.
"""

from __future__ import annotations

from collections.abc import Callable

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jax.sharding import Mesh, NamedSharding, PartitionSpec
from jaxtyping import Array, Float, PRNGKeyArray

from ._gwo import GreyWolfConfig, GreyWolfResult, _check_problem, _filter_jit, _run, _strong

SEED_AXIS = "seeds"


def seed_mesh(devices=None) -> Mesh:
    """A 1-D mesh named ``"seeds"`` over ``devices`` (default: every device of every
    process, :func:`jax.devices`)."""
    devices = jax.devices() if devices is None else list(devices)
    return Mesh(np.asarray(devices), (SEED_AXIS,))


def run_seeds_sharded(
    config: GreyWolfConfig,
    objective: Callable[[Float[Array, " dim"]], Float[Array, ""]],
    lower: Float[Array, " dim"],
    upper: Float[Array, " dim"],
    keys: PRNGKeyArray,
    *,
    mesh: Mesh | None = None,
    init_wolves: Float[Array, "m dim"] | None = None,
    keep_history: bool = True,
) -> GreyWolfResult:
    """:func:`jaxgwo.run_seeds` with the seed axis sharded over a 1-D device mesh.

    Args:
        config, objective, lower, upper, init_wolves, keep_history: as for
            :func:`jaxgwo.run_seeds`; they are replicated on every device.
        keys: ``(n_seeds,)`` typed keys or ``(n_seeds, 2)`` raw ``uint32`` keys, the same in
            every process of a multi-host run.
        mesh: a 1-D :class:`jax.sharding.Mesh` whose axis is named ``"seeds"``; default
            :func:`seed_mesh` over all devices.

    Returns:
        The result with a leading seed axis of length ``n_seeds``.  Single process: JAX
        arrays, sharded over the mesh.  Several processes: NumPy arrays gathered to every
        process.
    """
    mesh = seed_mesh() if mesh is None else mesh
    if mesh.axis_names != (SEED_AXIS,):
        raise ValueError(f"mesh axes {mesh.axis_names}: pass a 1-D mesh with axis {SEED_AXIS!r}.")
    lower, upper, init_wolves = _check_problem(config, lower, upper, init_wolves)
    config, objective = _strong((config, objective))

    typed = jnp.issubdtype(keys.dtype, jax.dtypes.prng_key)
    impl = jax.random.key_impl(keys) if typed else None
    raw = np.asarray(jax.random.key_data(keys) if typed else keys)
    n_seeds, n_dev = raw.shape[0], mesh.devices.size
    if n_seeds < 1:
        raise ValueError("no keys: pass at least one key.")
    pad = -n_seeds % n_dev
    if pad:
        raw = np.concatenate([raw, np.repeat(raw[-1:], pad, axis=0)])
    # a global array built from the same host keys in every process (one process: plain
    # device_put semantics; several: each process fills only its addressable shards)
    sharding = NamedSharding(mesh, PartitionSpec(SEED_AXIS))
    global_keys = jax.make_array_from_callback(raw.shape, sharding, lambda idx: raw[idx])

    result = _run_sharded(config, objective, lower, upper, global_keys, init_wolves,
                          keep_history, mesh, impl)
    if jax.process_count() > 1:
        from jax.experimental import multihost_utils

        result = multihost_utils.process_allgather(result, tiled=True)
    return jax.tree.map(lambda v: v[:n_seeds], result)


@_filter_jit  # the engine's compiler options (YNNPACK for dot only), as run() has
def _run_sharded(config, objective, lower, upper, raw_keys, init_wolves, keep_history, mesh,
                 impl):
    replicated, static = eqx.partition((config, objective, lower, upper, init_wolves),
                                       eqx.is_array)

    def local(replicated, raw_block):
        config, objective, lower, upper, iw = eqx.combine(replicated, static)
        keys = raw_block if impl is None else jax.random.wrap_key_data(raw_block, impl=impl)
        return jax.vmap(
            lambda k: _run(config, objective, lower, upper, k, iw, keep_history)
        )(keys)

    in_specs = (jax.tree.map(lambda _: PartitionSpec(), replicated), PartitionSpec(SEED_AXIS))
    return jax.shard_map(local, mesh=mesh, in_specs=in_specs,
                         out_specs=PartitionSpec(SEED_AXIS))(replicated, raw_keys)
