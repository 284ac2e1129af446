"""Monte-Carlo studies: chunking equals the per-seed run, no recompiles, bounded summary, CLI."""

import argparse
import json

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxgwo
from jaxgwo import _montecarlo as MC
from jaxgwo._testfunctions import HELICOPTER_TRUTH, helicopter_problem
from jaxgwo.cli import _montecarlo as cli_mc

PROBLEM = helicopter_problem(n_freq=20)
LO, HI = PROBLEM.lower(), PROBLEM.upper()
CFG = jaxgwo.igwo(8, 12)


@pytest.fixture(scope="module")
def study():
    calls = []
    s = MC.monte_carlo(CFG, PROBLEM.objective, LO, HI, jax.random.key(3), 5, chunk=2,
                       truth=HELICOPTER_TRUTH, tolerance=0.5, keep_histories=True,
                       progress=lambda done, total: calls.append((done, total)))
    return s, calls


def test_each_seed_equals_a_single_run_across_chunk_boundaries(study):
    s, _ = study
    keys = jax.random.split(jax.random.key(3), 5)
    # seeds 1|2 straddle the first boundary and 4 sits in the padded last chunk
    for i in (0, 1, 2, 4):
        single = jaxgwo.run(CFG, PROBLEM.objective, LO, HI, keys[i])
        np.testing.assert_allclose(s.best_position[i], np.asarray(single.best_position),
                                   rtol=1e-12, atol=1e-14)
        np.testing.assert_allclose(s.best_fitness[i], float(single.best_fitness),
                                   rtol=1e-12, atol=1e-14)


def test_progress_once_per_chunk_and_padding_dropped(study):
    s, calls = study
    assert calls == [(2, 5), (4, 5), (5, 5)]
    assert s.best_position.shape == (5, 5) and s.best_fitness.shape == (5,)
    assert s.chunk == 2 and s.n_seeds == 5
    assert s.evaluations_per_seed == CFG.total_evaluations


def test_summary_statistics_against_numpy(study):
    s, _ = study
    js = s.to_json()
    json.dumps(js)  # serialisable
    x = s.best_position
    truth = np.asarray(HELICOPTER_TRUTH)
    ok = np.all(np.abs(x - truth) <= 0.5 * truth, axis=1)
    assert js["success_rate"] == pytest.approx(ok.mean(), abs=0)
    for j, name in enumerate(s.parameter_names):
        st = js["parameters"][name]
        assert st["q50"] == pytest.approx(np.median(x[:, j]), rel=1e-15)
        assert st["q05"] == pytest.approx(np.quantile(x[:, j], 0.05), rel=1e-15)
        assert st["std"] == pytest.approx(np.std(x[:, j]), rel=1e-12)
    assert js["cost"]["q95"] == pytest.approx(np.quantile(s.best_fitness, 0.95), rel=1e-15)
    assert js["cost"]["non_finite"] == 0


def test_history_quantiles_match_exact_quantiles_to_bin_width(study):
    s, _ = study
    keys = jax.random.split(jax.random.key(3), 5)
    full = jaxgwo.run_seeds(CFG, PROBLEM.objective, LO, HI, keys).history_best
    exact = np.quantile(np.asarray(full), MC.QUANTILE_LEVELS, axis=0, method="inverted_cdf")
    assert s.history_quantiles.shape == (len(MC.QUANTILE_LEVELS), CFG.iterations)
    # the histogram reads bin centres: within half a bin, 10**(0.5/50) ~ 1.023, in ratio
    ratio = s.history_quantiles / exact
    assert np.all(np.abs(np.log10(ratio)) <= 0.5 / MC.HISTORY_BINS_PER_DECADE + 1e-12)
    # a per-iteration summary, not per seed
    assert s.history_quantiles.size == len(MC.QUANTILE_LEVELS) * CFG.iterations


def test_chunks_reuse_one_compilation():
    traces = []

    def counting(tag):
        def objective(x):
            traces.append(tag)
            return PROBLEM.objective(x)
        return objective

    key = jax.random.key(9)
    MC.monte_carlo(CFG, counting("one"), LO, HI, key, 3, chunk=3)
    one_chunk = traces.count("one")
    # four chunks, the last padded: the same number of traces as one chunk
    MC.monte_carlo(CFG, counting("four"), LO, HI, key, 10, chunk=3)
    assert traces.count("four") == one_chunk


def test_no_history_kept_unless_asked():
    s = MC.monte_carlo(CFG, PROBLEM.objective, LO, HI, jax.random.key(0), 3, chunk=8)
    assert s.history_quantiles is None and s.chunk == 3  # chunk capped at n_seeds
    assert "history_quantiles" not in s.to_json()
    assert s.success_rate is None


@pytest.mark.parametrize("kw,match", [
    (dict(n_seeds=0), "n_seeds"), (dict(chunk=0), "chunk"), (dict(tolerance=0.0), "tolerance"),
    (dict(truth=(1.0, 2.0)), "truth"),
])
def test_bad_input(kw, match):
    args = dict(n_seeds=2, chunk=2)
    args.update(kw)
    n = args.pop("n_seeds")
    with pytest.raises(ValueError, match=match):
        MC.monte_carlo(CFG, PROBLEM.objective, LO, HI, jax.random.key(0), n, **args)


def _parser():
    parser = argparse.ArgumentParser(prog="jaxgwo")
    cli_mc.add_parser(parser.add_subparsers(dest="command"))
    return parser


def test_cli_writes_json_and_plot(tmp_path, capsys):
    out, png = tmp_path / "mc.json", tmp_path / "mc.png"
    args = _parser().parse_args(["montecarlo", "--devices", "1", "--seeds", "3", "--chunk", "2", "--wolves", "6",
                                 "--iterations", "5", "--json", str(out), "--plot", str(png)])
    assert args.func(args) == 0
    report = json.loads(out.read_text())
    assert report["n_seeds"] == 3 and report["chunk"] == 2 and report["method"] == "igwo"
    assert set(report["parameters"]) == set(cli_mc.PARAMETER_NAMES)
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "3 seeds" in capsys.readouterr().out
    assert not list(tmp_path.glob(".*.tmp"))  # atomic writes left no temporaries


@pytest.mark.parametrize("argv,match", [
    (["--seeds", "0"], "--seeds"), (["--chunk", "0"], "--chunk"),
    (["--tolerance", "-1"], "--tolerance"), (["--json", "/nonexistent/x.json"], "--json"),
])
def test_cli_bad_input(argv, match):
    args = _parser().parse_args(["montecarlo", *argv])
    with pytest.raises(ValueError, match=match):
        args.func(args)


def test_cpu_cores_become_host_devices_only_when_not_already_set(monkeypatch):
    from jaxgwo.cli._montecarlo import _use_cpu_cores

    monkeypatch.delenv("XLA_FLAGS", raising=False)
    _use_cpu_cores(1)
    assert "XLA_FLAGS" not in __import__("os").environ
    monkeypatch.setenv("XLA_FLAGS", "--xla_cpu_enable_fast_math=false")
    _use_cpu_cores(2)
    assert __import__("os").environ["XLA_FLAGS"] == (
        "--xla_cpu_enable_fast_math=false --xla_force_host_platform_device_count=2")
    monkeypatch.setenv("XLA_FLAGS", "--xla_force_host_platform_device_count=3")
    _use_cpu_cores(2)
    assert __import__("os").environ["XLA_FLAGS"] == "--xla_force_host_platform_device_count=3"
