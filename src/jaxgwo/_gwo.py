r"""Grey wolf optimisers: GWO (Mirjalili et al. 2014) and the paper's improved IGWO.

Both minimise ``objective(x) -> scalar`` over the box ``lower <= x <= upper``.  The pack is
one ``(wolves, dim)`` array whose fitness is one :func:`jax.vmap` call per iteration, and a
run is a single :func:`jax.lax.scan` of the pure :func:`step` under ``jit``.

**GWO** (paper eqs. (30)-(38)).  With leaders :math:`X_\alpha, X_\beta, X_\delta`, per wolf
and per dimension draws :math:`r_1, r_2 \sim U(0, 1)`,

.. math::

    A = 2 a r_1 - a, \qquad C = 2 r_2, \qquad
    D_\ell = |C X_\ell - X|, \qquad X_\ell' = X_\ell - A D_\ell \quad (\ell = \alpha, \beta, \delta)

    X(t+1) = \operatorname{clip}\big((X_1 + X_2 + X_3)/3,\ \text{lower},\ \text{upper}\big)

and :math:`a = 2 (1 - t/T)` for :math:`t = 0, \dots, T-1`.

**Leaders are the best ever seen** (elitist): after every evaluation the leaders are the
best three of the previous leaders and the newly evaluated wolves.  This is what
Mirjalili's reference code does (its ``Alpha_pos`` persists across iterations), and it
makes the best-fitness history monotone non-increasing.

**IGWO** (paper section 3.2.2) changes three things, each switchable for ablation:

1. *Nonlinear convergence factor*, eq. (39):
   :math:`a = a_l [1 - ((2^{t/T} - 1)/(e - 1))^k]`.  As printed this never reaches 0 (at
   :math:`t = T` it ends at :math:`0.418 a_l` for :math:`k=1`).  ``schedule="eq39"`` is the
   literal form; ``schedule="eq39-exp"`` uses :math:`e^{t/T}`, which does reach 0.
2. *Chase/encircle grouping*: the first ``wolves - encircle_size`` rows of the pack are
   the chasing group, which moves; the rest are the encircling group, which does not.
   ``grouping="swap"`` (the reading we judge faithful to section 3.2.2 and Fig. 2): after
   each iteration the worst chaser and the best encircler trade places; the encirclers keep
   their fitness, so only chasers are re-evaluated.  ``grouping="reinit"`` is the other
   reading of Step 4: the encircling group is redrawn uniformly each iteration, evaluated,
   and its best wolf replaces the worst chaser.  :attr:`GreyWolfResult.evaluations` counts
   every fitness evaluation honestly in both modes.
3. *Dynamic weights*, eqs. (40)-(43): :math:`X(t+1) = \tfrac12 X_1 + \tfrac{1-r}{2} X_2 +
   \tfrac{r}{2} X_3` with :math:`r \sim U(0,1)` per wolf and per dimension.

Non-finite fitness (an unstable candidate, an ill-conditioned solve) ranks as ``+inf``.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from typing import Literal

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float, Int, PRNGKeyArray

Schedule = Literal["linear", "eq39", "eq39-exp"]
Grouping = Literal["none", "swap", "reinit"]
_SCHEDULES = ("linear", "eq39", "eq39-exp")
_GROUPINGS = ("none", "swap", "reinit")


class GreyWolfConfig(eqx.Module):
    """Configuration of a GWO or IGWO run (a frozen PyTree).

    Shapes and structural switches are static fields; the schedule constants ``a_initial``
    and ``k`` are array leaves, so a study may ``vmap`` over them without recompiling.
    Build one with :func:`gwo` or :func:`igwo` rather than directly.
    """

    wolves: int = eqx.field(static=True)
    iterations: int = eqx.field(static=True)
    schedule: str = eqx.field(static=True)
    grouping: str = eqx.field(static=True)
    encircle_size: int = eqx.field(static=True)
    dynamic_weights: bool = eqx.field(static=True)
    a_initial: Float[Array, ""]
    k: Float[Array, ""]
    rng: str = eqx.field(static=True, default="splitmix")

    def __check_init__(self):
        if not isinstance(self.wolves, (int, np.integer)) or self.wolves < 4:
            raise ValueError(
                f"wolves={self.wolves!r}: a grey wolf pack needs at least 4 wolves "
                "(alpha, beta, delta and one omega); pass wolves >= 4 (the paper uses 50)."
            )
        if not isinstance(self.iterations, (int, np.integer)) or self.iterations < 1:
            raise ValueError(
                f"iterations={self.iterations!r}: pass iterations >= 1 (the paper uses 500)."
            )
        if self.schedule not in _SCHEDULES:
            raise ValueError(f"schedule={self.schedule!r}: choose one of {_SCHEDULES}.")
        if self.rng not in ("splitmix", "threefry"):
            raise ValueError(f"rng={self.rng!r}: choose 'splitmix' or 'threefry'.")
        if self.grouping not in _GROUPINGS:
            raise ValueError(f"grouping={self.grouping!r}: choose one of {_GROUPINGS}.")
        if self.grouping != "none":
            if not 1 <= self.encircle_size <= self.wolves - 1:
                raise ValueError(
                    f"encircle_size={self.encircle_size}: the encircling group needs between "
                    f"1 and wolves - 1 = {self.wolves - 1} wolves."
                )
        elif self.encircle_size != 0:
            raise ValueError("encircle_size must be 0 when grouping='none'.")
        if not isinstance(self.k, jax.core.Tracer):
            k = float(self.k)
            if not 1.0 <= k <= 10.0:
                raise ValueError(f"k={k}: eq. (39) takes k in [1, 10].")
        if not isinstance(self.a_initial, jax.core.Tracer):
            if not float(self.a_initial) > 0.0:
                raise ValueError(f"a_initial={float(self.a_initial)}: pass a positive a_l.")

    @property
    def chasers(self) -> int:
        """Number of wolves that move each iteration."""
        return self.wolves - self.encircle_size

    @property
    def evaluations_per_iteration(self) -> int:
        """Fitness evaluations per iteration (the initial pack adds ``wolves`` once)."""
        return self.wolves if self.grouping in ("none", "reinit") else self.chasers

    @property
    def total_evaluations(self) -> int:
        """Fitness evaluations of a whole run: the initial pack plus every iteration."""
        return self.wolves + self.iterations * self.evaluations_per_iteration


def gwo(wolves: int = 50, iterations: int = 500, *, rng: str = "splitmix") -> GreyWolfConfig:
    """The original grey wolf optimiser (Mirjalili et al. 2014; paper eqs. (30)-(38)).

    ``rng``: ``"splitmix"`` (fast counter hash, :func:`splitmix_uniform`) or ``"threefry"``
    (``jax.random``) for the per-iteration draws."""
    return GreyWolfConfig(
        wolves=wolves,
        iterations=iterations,
        schedule="linear",
        grouping="none",
        encircle_size=0,
        dynamic_weights=False,
        a_initial=jnp.asarray(2.0),
        k=jnp.asarray(1.0),
        rng=rng,
    )


def igwo(
    wolves: int = 50,
    iterations: int = 500,
    *,
    schedule: Schedule = "eq39-exp",
    k: float = 2.0,
    a_initial: float = 2.0,
    grouping: Grouping = "swap",
    encircle_size: int | None = None,
    dynamic_weights: bool = True,
    rng: str = "splitmix",
) -> GreyWolfConfig:
    """The paper's improved GWO (section 3.2.2), each improvement separately switchable.

    Args:
        wolves: pack size ``m`` (the paper uses 50).
        iterations: ``T`` (the paper uses 500).
        schedule: convergence factor: ``"eq39"`` (eq. (39) as printed, never reaching 0),
            ``"eq39-exp"`` (eq. (39) with ``e**(t/T)``, reaching 0 at ``t = T``) or
            ``"linear"`` (GWO's ``a = a_l (1 - t/T)``, which switches the improvement off).
            The default is chosen from the benchmark in ``benchmarks/gwo_vs_igwo.py``.
        k: eq. (39)'s control factor, in [1, 10]; larger keeps ``a`` high for longer.
        a_initial: ``a_l``, the initial convergence factor.
        grouping: ``"swap"``, ``"reinit"`` or ``"none"`` (see the module docstring).
        encircle_size: size of the encircling group; default ``wolves // 5``.
        dynamic_weights: eqs. (40)-(43) instead of the plain mean of eq. (36).
        rng: generator of the per-iteration draws, as in :func:`gwo`.
    """
    if grouping == "none":
        encircle_size = 0
    elif encircle_size is None:
        encircle_size = max(1, wolves // 5)
    return GreyWolfConfig(
        wolves=wolves,
        iterations=iterations,
        schedule=schedule,
        grouping=grouping,
        encircle_size=encircle_size,
        dynamic_weights=dynamic_weights,
        a_initial=jnp.asarray(float(a_initial)),
        k=jnp.asarray(float(k)),
        rng=rng,
    )


def convergence_factor(config: GreyWolfConfig, t: Array | float) -> Array:
    r"""The convergence factor :math:`a(t)` for iteration ``t`` of ``config.iterations``.

    ``linear``: :math:`a_l (1 - t/T)`;  ``eq39``: :math:`a_l[1 - ((2^{t/T}-1)/(e-1))^k]`
    (eq. (39) as printed);  ``eq39-exp``: the same with :math:`e^{t/T}`.
    """
    x = jnp.asarray(t, dtype=jnp.result_type(float)) / config.iterations
    if config.schedule == "linear":
        frac = x
    else:
        base = 2.0 if config.schedule == "eq39" else math.e
        frac = ((jnp.power(base, x) - 1.0) / (math.e - 1.0)) ** config.k
    return config.a_initial * (1.0 - frac)


class GreyWolfState(eqx.Module):
    """The optimiser's state between iterations."""

    positions: Float[Array, "wolves dim"]
    fitness: Float[Array, " wolves"]
    leaders: Float[Array, "3 dim"]
    leader_fitness: Float[Array, " 3"]
    iteration: Int[Array, ""]
    evaluations: Int[Array, ""]


class StepNoise(eqx.Module):
    """The random numbers one iteration consumes, drawn by :func:`draw_step_noise`.

    ``r1``, ``r2``: ``(3, wolves, dim)`` for A and C of the three leaders (eqs. (37)-(38));
    ``r_weight``: ``(wolves, dim)`` for eqs. (40)-(41); ``fresh``: ``(encircle, dim)`` unit
    draws for the re-initialised encircling group (empty unless ``grouping="reinit"``).
    """

    r1: Float[Array, "3 wolves dim"]
    r2: Float[Array, "3 wolves dim"]
    r_weight: Float[Array, "wolves dim"]
    fresh: Float[Array, "encircle dim"]


class GreyWolfResult(eqx.Module):
    """The outcome of a run.  Under :func:`run_seeds` every field gains a leading seed axis.

    Attributes:
        best_position: the alpha wolf at the end, shape ``(dim,)``.
        best_fitness: its fitness.
        history_best: best fitness after each iteration, shape ``(iterations,)``;
            ``None`` when the run was asked not to keep it.
        history_a: the convergence factor used at each iteration, ``(iterations,)``.
        evaluations: the number of objective evaluations actually made.
        final_state: the pack at the end (positions, fitness, leaders).
    """

    best_position: Float[Array, " dim"]
    best_fitness: Float[Array, ""]
    history_best: Float[Array, " iterations"] | None
    history_a: Float[Array, " iterations"] | None
    evaluations: Int[Array, ""]
    final_state: GreyWolfState

    @property
    def status(self) -> str:
        """``"ok"`` when a finite optimum was found, else a reason."""
        ok = np.all(np.isfinite(np.asarray(self.best_fitness)))
        return "ok" if ok else "no finite fitness: every candidate was non-finite or unstable"


def _fitness(objective: Callable, positions: Array) -> Array:
    """Fitness of the whole pack in one ``vmap``; non-finite values rank as ``+inf``."""
    f = jax.vmap(objective)(positions)
    return jnp.where(jnp.isfinite(f), f, jnp.inf)


def _best_three(positions: Array, fitness: Array) -> tuple[Array, Array]:
    """The three fittest rows, ranked as ``numpy.argsort(fitness, kind="stable")[:3]``.

    Up to 64 rows: rank ``i`` is the number of rows that beat row ``i`` (lower fitness, or
    equal fitness and a lower index), so ranks are a permutation and ties go to the earlier
    row, exactly as a stable sort.  That is one fused comparison of an ``(n, n)`` block,
    where ``lax.top_k`` lowers to a full sort that XLA:CPU runs through a comparator
    callback (about 4x slower per seed under ``vmap``).  The block grows as ``n**2``, so
    larger packs take three passes of "first row of least fitness not yet taken", ``O(n)``.
    """
    n = fitness.shape[0]
    i = jnp.arange(n, dtype=jnp.int32)  # int32 counts: half the work of the default int64
    if n <= 64:
        f_row, f_col = fitness[:, None], fitness[None, :]
        beats = (f_col < f_row) | ((f_col == f_row) & (i[None, :] < i[:, None]))
        rank = jnp.sum(beats, axis=1, dtype=jnp.int32)
        first3 = rank[None, :] == jnp.arange(3, dtype=jnp.int32)[:, None]
        idx = jnp.sum(jnp.where(first3, i[None, :], 0), axis=1, dtype=jnp.int32)
    else:
        free = jnp.ones(n, dtype=bool)
        picks = []
        for _ in range(3):
            least = jnp.min(jnp.where(free, fitness, jnp.inf))
            j = jnp.min(jnp.where(free & (fitness == least), i, n))
            free = free & (i != j)
            picks.append(j)
        idx = jnp.stack(picks)
    return positions[idx], fitness[idx]


def _merge_leaders(state_leaders, state_fit, positions, fitness):
    """Elitist leaders: the best three of the old leaders and the newly evaluated wolves."""
    return _best_three(
        jnp.concatenate([state_leaders, positions], axis=0),
        jnp.concatenate([state_fit, fitness], axis=0),
    )


def splitmix_uniform(key: PRNGKeyArray, shape: tuple[int, ...]) -> Float[Array, "..."]:
    r"""Uniform [0, 1) float64 numbers from ``key`` by the SplitMix64 counter hash.

    The key's raw bits seed the stream; number ``i`` is
    :math:`\mathrm{mix}(s + (i + 1)\,\gamma)` with :math:`\gamma` = 0x9E3779B97F4A7C15 and
    Steele, Lea & Flood's (2014) finaliser.  It is a pure function of the key and the
    index, so the same key gives the same numbers and ``vmap`` over keys equals a loop,
    as with ``jax.random``; it costs three multiplies and three shifts per number, where
    threefry costs twenty rounds (on a 2-core CPU it was 60-70 % of a GWO run's time).
    Statistical quality is ample for a metaheuristic (SplitMix64 passes BigCrush); it is
    not for cryptography.  Needs float64 mode (uint64 arithmetic).
    """
    data = jax.random.key_data(key).astype(jnp.uint64)
    seed = data[0] << jnp.uint64(32) | data[-1]
    n = math.prod(shape)
    z = seed + (jnp.arange(1, n + 1, dtype=jnp.uint64) * jnp.uint64(0x9E3779B97F4A7C15))
    z = (z ^ (z >> jnp.uint64(30))) * jnp.uint64(0xBF58476D1CE4E5B9)
    z = (z ^ (z >> jnp.uint64(27))) * jnp.uint64(0x94D049BB133111EB)
    z = z ^ (z >> jnp.uint64(31))
    u = (z >> jnp.uint64(11)).astype(jnp.float64) * (1.0 / 9007199254740992.0)
    return u.reshape(shape)


def draw_step_noise(config: GreyWolfConfig, key: PRNGKeyArray, dim: int) -> StepNoise:
    """Draw every random number one iteration uses, from one key.

    ``config.rng == "splitmix"`` (default) draws them with :func:`splitmix_uniform` in one
    call; ``"threefry"`` uses ``jax.random.uniform`` (JAX's default generator)."""
    n, e = config.wolves, (config.encircle_size if config.grouping == "reinit" else 0)
    n_w = n if config.dynamic_weights else 0
    if config.rng == "splitmix":
        flat = splitmix_uniform(key, (6 * n * dim + (n_w + e) * dim,))
        r12 = flat[: 6 * n * dim].reshape(2, 3, n, dim)
        r_w = flat[6 * n * dim: (6 * n + n_w) * dim].reshape(n_w, dim)
        fresh = flat[(6 * n + n_w) * dim:].reshape(e, dim)
    else:
        k_a, k_w, k_f = jax.random.split(key, 3)
        r12 = jax.random.uniform(k_a, (2, 3, n, dim))
        r_w = jax.random.uniform(k_w, (n_w, dim))
        fresh = jax.random.uniform(k_f, (e, dim))
    if not config.dynamic_weights:
        r_w = jnp.zeros((n, dim))
    return StepNoise(r1=r12[0], r2=r12[1], r_weight=r_w, fresh=fresh)


def move(
    config: GreyWolfConfig,
    positions: Float[Array, "n dim"],
    leaders: Float[Array, "3 dim"],
    a: Float[Array, ""],
    r1: Float[Array, "3 n dim"],
    r2: Float[Array, "3 n dim"],
    r_weight: Float[Array, "n dim"],
    lower: Float[Array, " dim"],
    upper: Float[Array, " dim"],
) -> Float[Array, "n dim"]:
    r"""The position update of eqs. (30)-(38), or (40)-(43) with dynamic weights, then clip.

    .. math::

        X_\ell' = X_\ell - (2 a r_{1\ell} - a)\,|2 r_{2\ell} X_\ell - X|, \quad
        X(t+1) = \begin{cases} (X_\alpha' + X_\beta' + X_\delta')/3 & \text{GWO} \\
                 \tfrac12 X_\alpha' + \tfrac{1-r}{2} X_\beta' + \tfrac r2 X_\delta' & \text{IGWO}
                 \end{cases}
    """
    big_a = 2.0 * a * r1 - a
    big_c = 2.0 * r2
    lead = leaders[:, None, :]
    x = lead - big_a * jnp.abs(big_c * lead - positions[None])
    if config.dynamic_weights:
        new = 0.5 * x[0] + 0.5 * (1.0 - r_weight) * x[1] + 0.5 * r_weight * x[2]
    else:
        new = (x[0] + x[1] + x[2]) / 3.0
    return jnp.clip(new, lower, upper)


def init(
    config: GreyWolfConfig,
    objective: Callable,
    lower: Float[Array, " dim"],
    upper: Float[Array, " dim"],
    key: PRNGKeyArray,
    init_wolves: Float[Array, "m dim"] | None = None,
) -> GreyWolfState:
    """Draw the pack uniformly in the box (after any seeded ``init_wolves``) and rank it."""
    dim = lower.shape[0]
    u = jax.random.uniform(key, (config.wolves, dim))
    positions = lower + u * (upper - lower)
    if init_wolves is not None:
        seeded = jnp.clip(init_wolves, lower, upper)
        positions = positions.at[: seeded.shape[0]].set(seeded)
    fitness = _fitness(objective, positions)
    leaders, leader_fit = _best_three(positions, fitness)
    return GreyWolfState(
        positions=positions,
        fitness=fitness,
        leaders=leaders,
        leader_fitness=leader_fit,
        iteration=jnp.asarray(0),
        evaluations=jnp.asarray(config.wolves),
    )


def step(
    config: GreyWolfConfig,
    objective: Callable,
    lower: Float[Array, " dim"],
    upper: Float[Array, " dim"],
    state: GreyWolfState,
    key: PRNGKeyArray,
) -> tuple[GreyWolfState, tuple[Array, Array]]:
    """One iteration: move, evaluate, update the leaders (and the groups for IGWO).

    Returns the new state and the metrics ``(best fitness, a)`` that :func:`run` stacks
    into the convergence history.
    """
    noise = draw_step_noise(config, key, lower.shape[0])
    return step_with_noise(config, objective, lower, upper, state, noise)


class _Moved(eqx.Module):
    """The part of an iteration that needs no fitness: the movers' new positions (all
    wolves, or the chasers) and the fresh encircling group of ``grouping="reinit"``."""

    positions: Float[Array, "movers dim"]
    fresh: Float[Array, "encircle dim"]


def _move_pack(config, lower, upper, state, noise: StepNoise) -> _Moved:
    a = convergence_factor(config, state.iteration)
    nc = config.wolves if config.grouping == "none" else config.chasers
    positions = move(config, state.positions[:nc], state.leaders, a, noise.r1[:, :nc],
                     noise.r2[:, :nc], noise.r_weight[:nc], lower, upper)
    return _Moved(positions=positions, fresh=lower + noise.fresh * (upper - lower))


def step_with_noise(config, objective, lower, upper, state, noise: StepNoise):
    """:func:`step` with its random numbers given; exposed so tests can feed a reference."""
    return _evaluate_pack(config, objective, state, _move_pack(config, lower, upper, state,
                                                               noise))


def _evaluate_pack(config, objective, state, moved: _Moved):
    """Evaluate the moved wolves and update the leaders (and the groups for IGWO)."""
    a = convergence_factor(config, state.iteration)
    nc = config.chasers
    if config.grouping == "none":
        positions = moved.positions
        fitness = _fitness(objective, positions)
        leaders, leader_fit = _merge_leaders(state.leaders, state.leader_fitness,
                                             positions, fitness)
        evals = config.wolves
    else:
        chasers = moved.positions
        chaser_fit = _fitness(objective, chasers)
        if config.grouping == "swap":
            enc, enc_fit = state.positions[nc:], state.fitness[nc:]
            evals = nc
        else:  # "reinit": a fresh encircling group each iteration (Step 4, second reading)
            enc = moved.fresh
            enc_fit = _fitness(objective, enc)
            evals = config.wolves
        new_pos = jnp.concatenate([chasers, enc])
        new_fit = jnp.concatenate([chaser_fit, enc_fit])
        leaders, leader_fit = _merge_leaders(state.leaders, state.leader_fitness,
                                             new_pos, new_fit)
        worst = jnp.argmax(chaser_fit)
        best_enc = nc + jnp.argmin(enc_fit)
        # Row selects rather than a permutation gather: one fused select per array.
        row = jnp.arange(config.wolves)
        is_worst, is_best = row == worst, row == best_enc
        if config.grouping == "swap":  # trade places: worst chaser <-> best encircler
            positions = jnp.where(is_worst[:, None], new_pos[best_enc],
                                  jnp.where(is_best[:, None], new_pos[worst], new_pos))
            fitness = jnp.where(is_worst, new_fit[best_enc],
                                jnp.where(is_best, new_fit[worst], new_fit))
        else:  # the best fresh wolf replaces the worst chaser
            positions = jnp.where(is_worst[:, None], new_pos[best_enc], new_pos)
            fitness = jnp.where(is_worst, new_fit[best_enc], new_fit)
    new_state = GreyWolfState(
        positions=positions,
        fitness=fitness,
        leaders=leaders,
        leader_fitness=leader_fit,
        iteration=state.iteration + 1,
        evaluations=state.evaluations + evals,
    )
    return new_state, (leader_fit[0], a)

# XLA:CPU hands elementwise and reduction fusions to YNNPACK by default.  For the block a
# frequency-domain objective evaluates (rows x frequencies, then a row mean) that runs each
# operation as a separate tiled kernel and, past a few thousand rows, materialises the
# intermediates: 3-10x slower than XLA's own fused loop on a 2-core CPU (benchmarks/
# speed_engine.py).  Keeping YNNPACK for dots only restores the fused loop.
_CPU_COMPILER_OPTIONS = {"xla_cpu_experimental_ynn_fusion_type": "LIBRARY_FUSION_TYPE_DOT"}


def _has_avx512() -> bool:
    try:
        with open("/proc/cpuinfo") as f:
            return any(line.startswith("flags") and " avx512f" in line for line in f)
    except OSError:
        return False


@functools.cache
def _compiler_options() -> tuple[tuple[str, str | int], ...]:
    """The XLA options for the optimiser's jitted entry points on this backend ((), if the
    backend is not a CPU or this XLA does not know the option)."""
    if jax.default_backend() != "cpu":
        return ()
    options = dict(_CPU_COMPILER_OPTIONS)
    if _has_avx512():
        # XLA:CPU prefers 256-bit vectors by default; with AVX-512 the fused objective and
        # the random-number hash run about 20 % faster with 512 (measured on AMD EPYC).
        options["xla_cpu_prefer_vector_width"] = 512
    try:
        jax.jit(lambda x: x + 1.0, compiler_options=options).lower(jnp.zeros(2)).compile()
    except Exception:  # noqa: BLE001  (an XLA without the option: compile without it)
        return ()
    return tuple(options.items())


def _filter_jit(fn):
    """``equinox.filter_jit`` with :func:`_compiler_options`: array leaves of the arguments
    are traced, everything else (configuration, callables, ``None``) is static and hashed."""

    @functools.cache
    def jitted(options):
        def call(static, dynamic):
            return fn(*eqx.combine(dynamic, static))

        return jax.jit(call, static_argnums=0, compiler_options=dict(options) or None)

    @functools.wraps(fn)
    def wrapper(*args):
        dynamic, static = eqx.partition(args, eqx.is_array)
        try:
            return jitted(_compiler_options())(static, dynamic)
        except ValueError as err:
            # Called inside another trace (vmap of run, sharding): only a top-level jit
            # takes options, and the outer one decides.
            if "compiler_options" not in str(err):
                raise
            return jitted(())(static, dynamic)

    return wrapper


def _strong(tree):
    """Drop JAX's weak-type flag from array leaves: a weakly typed array (``jnp.full(n, 2.0)``)
    and a strongly typed one of the same shape would otherwise compile twice."""
    return jax.tree.map(
        lambda v: jnp.asarray(v, dtype=v.dtype) if isinstance(v, jax.Array) else v, tree
    )


def _check_problem(config, lower, upper, init_wolves):
    lower = jnp.asarray(lower, dtype=jnp.result_type(float))
    upper = jnp.asarray(upper, dtype=jnp.result_type(float))
    if lower.ndim != 1 or upper.shape != lower.shape:
        raise ValueError(
            f"bounds must be two 1-D arrays of the same length; got lower {lower.shape} "
            f"and upper {upper.shape}."
        )
    if lower.shape[0] < 1:
        raise ValueError("bounds are empty: the problem needs at least one dimension.")
    concrete = not isinstance(lower, jax.core.Tracer) and not isinstance(upper, jax.core.Tracer)
    if concrete:
        lo, hi = np.asarray(lower), np.asarray(upper)
        bad = ~(np.isfinite(lo) & np.isfinite(hi))
        if bad.any():
            raise ValueError(
                f"bounds must be finite; dimension(s) {np.flatnonzero(bad).tolist()} are not. "
                "Give a finite search box."
            )
        inv = lo >= hi
        if inv.any():
            i = int(np.flatnonzero(inv)[0])
            raise ValueError(
                f"inverted bounds: lower[{i}] = {lo[i]} >= upper[{i}] = {hi[i]}. "
                "Each lower bound must be below its upper bound (swap them?)."
            )
    if init_wolves is not None:
        init_wolves = jnp.asarray(init_wolves, dtype=lower.dtype)
        if init_wolves.ndim == 1:
            init_wolves = init_wolves[None]
        if init_wolves.ndim != 2 or init_wolves.shape[1] != lower.shape[0]:
            raise ValueError(
                f"init_wolves has shape {init_wolves.shape} but the bounds have dimension "
                f"{lower.shape[0]}; pass an array of shape (m, {lower.shape[0]})."
            )
        if init_wolves.shape[0] > config.wolves:
            raise ValueError(
                f"{init_wolves.shape[0]} initial wolves given for a pack of {config.wolves}; "
                "pass at most `wolves` initial positions."
            )
        if not isinstance(init_wolves, jax.core.Tracer) and not np.all(
            np.isfinite(np.asarray(init_wolves))
        ):
            raise ValueError("init_wolves contains NaN or inf; pass finite positions.")
    return lower, upper, init_wolves


@_filter_jit
def _run(config, objective, lower, upper, key, init_wolves, keep_history):
    k_init, k_run = jax.random.split(key)
    state = init(config, objective, lower, upper, k_init, init_wolves)
    keys = jax.random.split(k_run, config.iterations)
    dim = lower.shape[0]

    # Software-pipelined: iteration t evaluates the pack moved at the end of t - 1 and then
    # moves the pack for t + 1 with the new leaders.  The moved pack is loop-carried, so XLA
    # computes the move (and its random numbers) once instead of fusing a copy into each
    # consumer; the arithmetic, and so the result, is that of calling :func:`step` T times.
    def body(carry, k_next):
        s, moved = carry
        s, (best, a) = _evaluate_pack(config, objective, s, moved)
        moved = _move_pack(config, lower, upper, s, draw_step_noise(config, k_next, dim))
        return (s, moved), ((best, a) if keep_history else None)

    moved = _move_pack(config, lower, upper, state, draw_step_noise(config, keys[0], dim))
    # the last iteration moves once more, for nothing, with a recycled key
    next_keys = jnp.concatenate([keys[1:], keys[:1]])
    (state, _), hist = jax.lax.scan(body, (state, moved), next_keys)
    hb, ha = hist if keep_history else (None, None)
    return GreyWolfResult(
        best_position=state.leaders[0],
        best_fitness=state.leader_fitness[0],
        history_best=hb,
        history_a=ha,
        evaluations=state.evaluations,
        final_state=state,
    )


def run(
    config: GreyWolfConfig,
    objective: Callable[[Float[Array, " dim"]], Float[Array, ""]],
    lower: Float[Array, " dim"],
    upper: Float[Array, " dim"],
    key: PRNGKeyArray,
    *,
    init_wolves: Float[Array, "m dim"] | None = None,
    keep_history: bool = True,
) -> GreyWolfResult:
    """Minimise ``objective`` over the box with GWO/IGWO; one compiled ``lax.scan``.

    Args:
        config: from :func:`gwo` or :func:`igwo`.
        objective: ``x -> scalar``.  A plain function, or an ``equinox.Module`` holding its
            data as array fields, so that new data of the same shape reuses the compiled run.
        lower, upper: the search box, shape ``(dim,)``, finite and ``lower < upper``.
        key: a JAX PRNG key; the same key gives the same result.
        init_wolves: optional ``(m, dim)`` seeded positions (for example around a WLS
            solution), clipped to the box; the other ``wolves - m`` are drawn uniformly.
        keep_history: keep the per-iteration best fitness and ``a`` (``iterations`` floats
            each); turn off for very large seed batches.

    Raises:
        ValueError: for bounds that are inverted, non-finite or mis-shaped, and for
            ``init_wolves`` of the wrong dimension or count.
    """
    lower, upper, init_wolves = _check_problem(config, lower, upper, init_wolves)
    config, objective = _strong((config, objective))
    return _run(config, objective, lower, upper, key, init_wolves, keep_history)


def run_seeds(
    config: GreyWolfConfig,
    objective: Callable[[Float[Array, " dim"]], Float[Array, ""]],
    lower: Float[Array, " dim"],
    upper: Float[Array, " dim"],
    keys: PRNGKeyArray,
    *,
    init_wolves: Float[Array, "m dim"] | None = None,
    keep_history: bool = True,
) -> GreyWolfResult:
    """Run one independent optimisation per key in a single compiled, vmapped call.

    Every field of the result gains a leading axis of length ``len(keys)``, and
    ``run_seeds(..., keys)[i]`` equals ``run(..., keys[i])``.
    """
    lower, upper, init_wolves = _check_problem(config, lower, upper, init_wolves)
    config, objective = _strong((config, objective))
    return _run_seeds(config, objective, lower, upper, keys, init_wolves, keep_history)


@_filter_jit
def _run_seeds(config, objective, lower, upper, keys, init_wolves, keep_history):
    return jax.vmap(
        lambda k: _run(config, objective, lower, upper, k, init_wolves, keep_history)
    )(keys)


def run_batch(
    config: GreyWolfConfig,
    objectives,
    lower: Float[Array, "batch dim"],
    upper: Float[Array, "batch dim"],
    keys: PRNGKeyArray,
    *,
    init_wolves: Float[Array, "batch m dim"] | None = None,
    keep_history: bool = True,
) -> GreyWolfResult:
    """Several *different* problems of the same shape in one compiled, vmapped call.

    ``objectives`` is a batch of objectives stacked leaf-wise (one ``equinox.Module`` whose
    array fields carry a leading batch axis, for example several records or channels);
    ``lower``, ``upper``, ``keys`` and ``init_wolves`` carry the same leading axis.  Result
    ``i`` equals ``run(config, objective_i, lower[i], upper[i], keys[i], ...)``.
    """
    lower = jnp.asarray(lower, dtype=jnp.result_type(float))
    upper = jnp.asarray(upper, dtype=jnp.result_type(float))
    if lower.ndim != 2 or upper.shape != lower.shape:
        raise ValueError(
            f"batched bounds must be two (batch, dim) arrays of the same shape; got "
            f"{lower.shape} and {upper.shape}."
        )
    for i in range(lower.shape[0]):
        _check_problem(config, lower[i], upper[i],
                       None if init_wolves is None else init_wolves[i])
    if init_wolves is not None:
        init_wolves = jnp.asarray(init_wolves, dtype=lower.dtype)
    config, objectives = _strong((config, objectives))
    return _run_batch(config, objectives, lower, upper, keys, init_wolves, keep_history)


@_filter_jit
def _run_batch(config, objectives, lower, upper, keys, init_wolves, keep_history):
    def one(obj, lo, hi, k, iw):
        return _run(config, obj, lo, hi, k, iw, keep_history)

    in_axes = (0, 0, 0, 0, None if init_wolves is None else 0)
    return eqx.filter_vmap(one, in_axes=in_axes)(objectives, lower, upper, keys, init_wolves)


def stack_objectives(objectives):
    """Stack objectives of identical structure leaf-wise, for :func:`run_batch`."""
    return jax.tree.map(lambda *xs: jnp.stack(xs), *objectives)
