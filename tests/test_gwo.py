"""Tests of the GWO / IGWO engine against a plain NumPy reference and analytic values."""

import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxgwo import _gwo as G
from jaxgwo._testfunctions import FrequencyFit, helicopter_problem, sphere

DIM = 4
LO = jnp.full((DIM,), -5.0)
HI = jnp.full((DIM,), 5.0)


def _np_top3(pos, fit):
    order = np.argsort(fit, kind="stable")[:3]
    return pos[order], fit[order]


def _np_move(leaders, pos, a, r1, r2, rw, lo, hi, dynamic):
    """Eqs. (30)-(38) (and (40)-(43)) written out plainly, one leader at a time."""
    xs = []
    for ell in range(3):
        big_a = 2.0 * a * r1[ell] - a
        big_c = 2.0 * r2[ell]
        dist = np.abs(big_c * leaders[ell] - pos)
        xs.append(leaders[ell] - big_a * dist)
    if dynamic:
        new = 0.5 * xs[0] + (1.0 - rw) / 2.0 * xs[1] + rw / 2.0 * xs[2]
    else:
        new = (xs[0] + xs[1] + xs[2]) / 3.0
    return np.minimum(np.maximum(new, lo), hi)


def _np_step(cfg, f, lo, hi, state, noise):
    """A plain NumPy iteration of GWO or IGWO, fed the given random numbers."""
    pos, fit = np.asarray(state.positions), np.asarray(state.fitness)
    leaders, lfit = np.asarray(state.leaders), np.asarray(state.leader_fitness)
    t = int(state.iteration)
    T = cfg.iterations
    al, k = float(cfg.a_initial), float(cfg.k)
    if cfg.schedule == "linear":
        a = al * (1 - t / T)
    else:
        base = 2.0 if cfg.schedule == "eq39" else math.e
        a = al * (1 - ((base ** (t / T) - 1) / (math.e - 1)) ** k)
    r1, r2, rw = (np.asarray(v) for v in (noise.r1, noise.r2, noise.r_weight))
    lo, hi = np.asarray(lo), np.asarray(hi)
    fnp = lambda P: np.array([float(f(jnp.asarray(p))) for p in P])  # noqa: E731
    nc = cfg.wolves - cfg.encircle_size
    if cfg.grouping == "none":
        new_pos = _np_move(leaders, pos, a, r1, r2, rw, lo, hi, cfg.dynamic_weights)
        new_fit = fnp(new_pos)
    else:
        ch = _np_move(leaders, pos[:nc], a, r1[:, :nc], r2[:, :nc], rw[:nc], lo, hi,
                      cfg.dynamic_weights)
        ch_fit = fnp(ch)
        if cfg.grouping == "swap":
            enc, enc_fit = pos[nc:].copy(), fit[nc:].copy()
        else:
            enc = lo + np.asarray(noise.fresh) * (hi - lo)
            enc_fit = fnp(enc)
        new_pos = np.concatenate([ch, enc])
        new_fit = np.concatenate([ch_fit, enc_fit])
    l_pos, l_fit = _np_top3(np.concatenate([leaders, new_pos]), np.concatenate([lfit, new_fit]))
    if cfg.grouping != "none":
        w = int(np.argmax(new_fit[:nc]))
        b = nc + int(np.argmin(new_fit[nc:]))
        P, F = new_pos.copy(), new_fit.copy()
        P[w], F[w] = new_pos[b], new_fit[b]
        if cfg.grouping == "swap":
            P[b], F[b] = new_pos[w], new_fit[w]
        new_pos, new_fit = P, F
    return new_pos, new_fit, l_pos, l_fit, a


def _rosen(x):
    return jnp.sum(100.0 * (x[1:] - x[:-1] ** 2) ** 2 + (x[:-1] - 1.0) ** 2)


CONFIGS = {
    "gwo": G.gwo(8, 20),
    "igwo-swap": G.igwo(8, 20, grouping="swap", encircle_size=3),
    "igwo-reinit": G.igwo(8, 20, grouping="reinit", encircle_size=3, schedule="eq39", k=3.0),
    "igwo-no-weights": G.igwo(8, 20, dynamic_weights=False, grouping="none"),
    "gwo-threefry": G.gwo(8, 20, rng="threefry"),
    "igwo-threefry": G.igwo(8, 20, rng="threefry", grouping="reinit", encircle_size=2),
}


@pytest.mark.parametrize("name", list(CONFIGS))
def test_step_matches_numpy_reference(name):
    cfg = CONFIGS[name]
    state = G.init(cfg, _rosen, LO, HI, jax.random.key(3))
    # advance a few iterations so that a(t) and the leaders are non-trivial
    for i in range(4):
        state, _ = G.step(cfg, _rosen, LO, HI, state, jax.random.key(100 + i))
    noise = G.draw_step_noise(cfg, jax.random.key(7), DIM)
    new, (best, a) = G.step_with_noise(cfg, _rosen, LO, HI, state, noise)
    ref_pos, ref_fit, ref_lpos, ref_lfit, ref_a = _np_step(cfg, _rosen, LO, HI, state, noise)
    np.testing.assert_allclose(np.asarray(new.positions), ref_pos, rtol=0, atol=1e-12)
    np.testing.assert_allclose(np.asarray(new.fitness), ref_fit, rtol=1e-12, atol=0)
    np.testing.assert_allclose(np.asarray(new.leaders), ref_lpos, rtol=0, atol=1e-12)
    np.testing.assert_allclose(np.asarray(new.leader_fitness), ref_lfit, rtol=1e-12)
    assert float(a) == pytest.approx(ref_a, abs=1e-15)
    assert float(best) == pytest.approx(ref_lfit[0], rel=1e-12)
    assert int(new.evaluations - state.evaluations) == cfg.evaluations_per_iteration


@pytest.mark.parametrize("name", ["gwo", "igwo-swap", "igwo-reinit"])
def test_scan_run_equals_python_loop(name):
    cfg = CONFIGS[name]
    key = jax.random.key(11)
    res = G.run(cfg, _rosen, LO, HI, key)
    k_init, k_run = jax.random.split(key)
    state = G.init(cfg, _rosen, LO, HI, k_init)
    history = []
    for k in jax.random.split(k_run, cfg.iterations):
        state, (best, _a) = G.step(cfg, _rosen, LO, HI, state, k)
        history.append(float(best))
    np.testing.assert_allclose(np.asarray(res.history_best), history, rtol=1e-13, atol=0)
    np.testing.assert_allclose(np.asarray(res.best_position), np.asarray(state.leaders[0]),
                               rtol=1e-13, atol=1e-14)
    assert int(res.evaluations) == int(state.evaluations) == cfg.total_evaluations


def test_same_key_same_result_and_different_keys_differ():
    cfg = G.igwo(10, 30)
    r1 = G.run(cfg, _rosen, LO, HI, jax.random.key(5))
    r2 = G.run(cfg, _rosen, LO, HI, jax.random.key(5))
    r3 = G.run(cfg, _rosen, LO, HI, jax.random.key(6))
    assert np.array_equal(np.asarray(r1.best_position), np.asarray(r2.best_position))
    assert np.array_equal(np.asarray(r1.history_best), np.asarray(r2.history_best))
    assert not np.array_equal(np.asarray(r1.best_position), np.asarray(r3.best_position))


@pytest.mark.parametrize("name", ["gwo", "igwo-swap"])
def test_vmap_over_keys_equals_loop(name):
    cfg = CONFIGS[name]
    keys = jax.random.split(jax.random.key(0), 5)
    batched = G.run_seeds(cfg, _rosen, LO, HI, keys)
    user_vmap = jax.vmap(lambda k: G.run(cfg, _rosen, LO, HI, k))(keys)
    for i, k in enumerate(keys):
        single = G.run(cfg, _rosen, LO, HI, k)
        for got in (batched, user_vmap):
            np.testing.assert_allclose(np.asarray(got.best_position[i]),
                                       np.asarray(single.best_position), rtol=1e-12, atol=1e-14)
            np.testing.assert_allclose(np.asarray(got.history_best[i]),
                                       np.asarray(single.history_best), rtol=1e-12, atol=0)


def test_no_recompilation_for_new_data_of_same_shape():
    traces = []

    class Counting(eqx.Module):
        target: jax.Array

        def __call__(self, x):
            traces.append(1)  # runs only while JAX traces
            return jnp.sum((x - self.target) ** 2)

    cfg = G.igwo(6, 5)
    G.run(cfg, Counting(jnp.zeros(DIM)), LO, HI, jax.random.key(0))
    n_first = len(traces)
    assert n_first > 0
    G.run(cfg, Counting(jnp.ones(DIM)), LO, HI, jax.random.key(1))
    G.run(cfg, Counting(jnp.full((DIM,), 2.0)), LO + 0.5, HI, jax.random.key(2))
    assert len(traces) == n_first, "a second run with same shapes retraced"
    G.run_seeds(cfg, Counting(jnp.zeros(DIM)), LO, HI, jax.random.split(jax.random.key(0), 3))
    n_batch = len(traces)
    G.run_seeds(cfg, Counting(jnp.ones(DIM)), LO, HI, jax.random.split(jax.random.key(1), 3))
    assert len(traces) == n_batch


@pytest.mark.parametrize("schedule,k,expected", [
    # a_l = 2; hand-computed: x = t/T;  eq39: (2**x - 1)/(e - 1);  eq39-exp: (e**x - 1)/(e - 1)
    ("eq39", 1.0, (2.0, 2.0 * (1 - (math.sqrt(2) - 1) / (math.e - 1)), 2.0 * (1 - 1 / (math.e - 1)))),
    ("eq39", 2.0, (2.0, 2.0 * (1 - ((math.sqrt(2) - 1) / (math.e - 1)) ** 2),
                   2.0 * (1 - (1 / (math.e - 1)) ** 2))),
    ("eq39-exp", 1.0, (2.0, 2.0 * (1 - (math.sqrt(math.e) - 1) / (math.e - 1)), 0.0)),
    ("eq39-exp", 3.0, (2.0, 2.0 * (1 - ((math.sqrt(math.e) - 1) / (math.e - 1)) ** 3), 0.0)),
    ("linear", 1.0, (2.0, 1.0, 0.0)),
])
def test_convergence_factor_values(schedule, k, expected):
    cfg = G.igwo(10, 100, schedule=schedule, k=k)
    got = [float(G.convergence_factor(cfg, t)) for t in (0, 50, 100)]
    np.testing.assert_allclose(got, expected, rtol=1e-14, atol=1e-15)


def test_eq39_as_printed_ends_above_zero():
    # The numbers: 0.418 a_l for k=1 and 0.661 a_l for k=2 at t = T.
    for k, end in ((1.0, 0.418), (2.0, 0.661)):
        cfg = G.igwo(10, 100, schedule="eq39", k=k, a_initial=1.0)
        assert float(G.convergence_factor(cfg, 100)) == pytest.approx(end, abs=5e-4)


def test_leaders_are_best_ever_and_history_monotone():
    cfg = G.gwo(6, 40)
    res = G.run(cfg, _rosen, LO, HI, jax.random.key(2))
    h = np.asarray(res.history_best)
    assert np.all(np.diff(h) <= 0.0)
    # After a step the leaders are the top three of (old leaders ∪ new pack), so a
    # leader survives even when every wolf moves away from it.
    state = G.init(cfg, _rosen, LO, HI, jax.random.key(1))
    bad_pack = eqx.tree_at(lambda s: s.positions, state, jnp.full_like(state.positions, 5.0))
    new, _ = G.step(cfg, _rosen, LO, HI, bad_pack, jax.random.key(9))
    assert float(new.leader_fitness[0]) <= float(state.leader_fitness[0])


def test_non_finite_fitness_ranks_last():
    def objective(x):
        return jnp.where(x[0] > 0.0, jnp.nan, jnp.sum(x * x))

    cfg = G.gwo(12, 15)
    res = G.run(cfg, objective, LO, HI, jax.random.key(0))
    assert np.isfinite(float(res.best_fitness))
    assert float(res.best_position[0]) <= 0.0
    assert np.all(~np.isnan(np.asarray(res.final_state.fitness)))
    assert res.status == "ok"


def test_all_non_finite_reports_status():
    res = G.run(G.gwo(5, 3), lambda x: jnp.inf * jnp.sum(x), LO, HI, jax.random.key(0))
    assert res.status.startswith("no finite fitness")


def test_seeded_wolves_are_in_initial_pack_and_clipped():
    cfg = G.gwo(8, 1)
    seeds = jnp.array([[0.1, 0.2, 0.3, 0.4], [9.0, -9.0, 0.0, 1.0]])
    state = G.init(cfg, sphere, LO, HI, jax.random.key(0), seeds)
    np.testing.assert_array_equal(np.asarray(state.positions[0]), np.asarray(seeds[0]))
    np.testing.assert_array_equal(np.asarray(state.positions[1]), [5.0, -5.0, 0.0, 1.0])
    rest = np.asarray(state.positions[2:])
    assert np.all((rest >= -5.0) & (rest <= 5.0))


def test_evaluation_counts_are_honest():
    assert G.gwo(50, 500).total_evaluations == 25_050
    assert G.igwo(50, 500, grouping="swap", encircle_size=10).total_evaluations == 50 + 500 * 40
    assert G.igwo(50, 500, grouping="reinit", encircle_size=10).total_evaluations == 25_050
    calls = []
    cfg = G.igwo(7, 4, grouping="swap", encircle_size=2)
    res = G.run(cfg, sphere, LO, HI, jax.random.key(0))
    assert int(res.evaluations) == 7 + 4 * 5


@pytest.mark.parametrize("make,match", [
    (lambda: G.gwo(3, 10), "at least 4 wolves"),
    (lambda: G.gwo(10, 0), "iterations >= 1"),
    (lambda: G.igwo(10, 10, k=0.5), r"k in \[1, 10\]"),
    (lambda: G.igwo(10, 10, encircle_size=10), "encircling group"),
    (lambda: G.igwo(10, 10, schedule="cosine"), "schedule"),
])
def test_bad_configuration_raises(make, match):
    with pytest.raises(ValueError, match=match):
        make()


@pytest.mark.parametrize("lo,hi,init,match", [
    (jnp.array([1.0, 0.0]), jnp.array([0.0, 1.0]), None, r"inverted bounds: lower\[0\]"),
    (jnp.array([0.0, -jnp.inf]), jnp.array([1.0, 1.0]), None, "finite"),
    (jnp.array([0.0, jnp.nan]), jnp.array([1.0, 1.0]), None, "finite"),
    (jnp.zeros(2), jnp.ones(3), None, "same length"),
    (jnp.zeros(2), jnp.ones(2), jnp.zeros((2, 3)), "dimension 2"),
    (jnp.zeros(2), jnp.ones(2), jnp.zeros((9, 2)), "at most"),
    (jnp.zeros(2), jnp.ones(2), jnp.array([[jnp.nan, 0.0]]), "NaN"),
])
def test_bad_problem_raises(lo, hi, init, match):
    with pytest.raises(ValueError, match=match):
        G.run(G.gwo(8, 2), sphere, lo, hi, jax.random.key(0), init_wolves=init)


def test_sphere_10d_gwo_reaches_1e_8():
    res = G.run(G.gwo(50, 500), sphere, jnp.full((10,), -100.0), jnp.full((10,), 100.0),
                jax.random.key(0))
    assert float(res.best_fitness) < 1e-8


def test_float64_is_on_in_the_identification_path():
    import jaxgwo

    assert jaxgwo.float64_enabled()
    p = helicopter_problem(n_freq=20)
    assert p.objective.w.dtype == jnp.float64
    res = G.run(G.igwo(6, 2), p.objective, p.lower(), p.upper(), jax.random.key(0))
    assert res.best_position.dtype == jnp.float64
    assert res.best_fitness.dtype == jnp.float64


def test_helicopter_problem_truth_is_a_zero_and_alias_is_outside_box():
    from jaxgwo._testfunctions import HELICOPTER_TRUTH, HELICOPTER_UPPER

    p = helicopter_problem(n_freq=50)
    truth = jnp.asarray(HELICOPTER_TRUTH)
    assert float(p.objective(truth)) < 1e-28
    K, tau, M, ws, zs = HELICOPTER_TRUTH
    # swapped factors: rotor quadratic <-> servo quadratic; same response, M' = ws^2
    alias_M = ws * ws
    assert alias_M > HELICOPTER_UPPER[2]
    assert isinstance(p.objective, FrequencyFit)


def test_run_batch_equals_separate_runs():
    class Shifted(eqx.Module):
        centre: jax.Array

        def __call__(self, x):
            return jnp.sum((x - self.centre) ** 2)

    objs = [Shifted(jnp.full((DIM,), c)) for c in (-1.0, 0.5, 2.0)]
    lo = jnp.stack([LO, LO + 1.0, LO])
    hi = jnp.stack([HI, HI, HI - 1.0])
    keys = jax.random.split(jax.random.key(4), 3)
    seeds = jnp.zeros((3, 2, DIM))
    cfg = G.igwo(8, 12)
    batch = G.run_batch(cfg, G.stack_objectives(objs), lo, hi, keys, init_wolves=seeds)
    for i, obj in enumerate(objs):
        single = G.run(cfg, obj, lo[i], hi[i], keys[i], init_wolves=seeds[i])
        np.testing.assert_allclose(np.asarray(batch.best_position[i]),
                                   np.asarray(single.best_position), rtol=1e-12, atol=1e-14)
    with pytest.raises(ValueError, match="inverted bounds"):
        G.run_batch(cfg, G.stack_objectives(objs), hi, lo, keys)


def test_splitmix_uniform_is_uniform_deterministic_and_key_dependent():
    from scipy.stats import kstest

    u = np.asarray(G.splitmix_uniform(jax.random.key(0), (20000,)))
    assert u.dtype == np.float64 and u.min() >= 0.0 and u.max() < 1.0
    assert kstest(u, "uniform").pvalue > 1e-3
    # neighbouring numbers are uncorrelated, and two keys give unrelated streams
    assert abs(np.corrcoef(u[:-1], u[1:])[0, 1]) < 0.03
    v = np.asarray(G.splitmix_uniform(jax.random.key(1), (20000,)))
    assert abs(np.corrcoef(u, v)[0, 1]) < 0.03
    np.testing.assert_array_equal(u, np.asarray(G.splitmix_uniform(jax.random.key(0), (20000,))))
    keys = jax.random.split(jax.random.key(2), 4)
    batched = jax.vmap(lambda k: G.splitmix_uniform(k, (3, 5)))(keys)
    for i, k in enumerate(keys):
        np.testing.assert_array_equal(np.asarray(batched[i]), np.asarray(G.splitmix_uniform(k, (3, 5))))


def test_bad_rng_name_raises():
    with pytest.raises(ValueError, match="rng="):
        G.gwo(8, 2, rng="mersenne")


def test_best_three_is_a_stable_argsort_with_ties_and_infinities():
    rng = np.random.default_rng(0)
    best_three = jax.jit(G._best_three)  # as the optimisers call it: compiled, one program per pack size
    for trial in range(24):  # both branches: the (n, n) rank block and three passes
        n = int(rng.integers(4, 60)) if trial < 12 else int(rng.integers(60, 150))
        fit = rng.choice([0.0, 1.0, 2.0, 3.0, np.inf], size=n) if trial % 2 else rng.normal(size=n)
        pos = rng.normal(size=(n, 3))
        got_pos, got_fit = best_three(jnp.asarray(pos), jnp.asarray(fit))
        ref_pos, ref_fit = _np_top3(pos, fit)
        np.testing.assert_array_equal(np.asarray(got_fit), ref_fit)
        np.testing.assert_array_equal(np.asarray(got_pos), ref_pos)


def test_run_inside_user_jit_and_without_compiler_options_gives_the_same_result(monkeypatch):
    # The entry points compile with XLA:CPU options; called inside a user's jit they cannot
    # (only a top-level jit takes options) and must fall back, with the same arithmetic.
    cfg = CONFIGS["igwo-swap"]
    key = jax.random.key(8)
    ref = G.run(cfg, _rosen, LO, HI, key)
    nested = jax.jit(lambda k: G.run(cfg, _rosen, LO, HI, k).best_position)(key)
    np.testing.assert_allclose(np.asarray(nested), np.asarray(ref.best_position),
                               rtol=1e-12, atol=1e-14)
    monkeypatch.setattr(G, "_compiler_options", lambda: ())
    plain = G.run(cfg, _rosen, LO, HI, key)
    np.testing.assert_allclose(np.asarray(plain.history_best), np.asarray(ref.history_best),
                               rtol=1e-12, atol=0)
