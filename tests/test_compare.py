"""The GWO-versus-IGWO comparison: statistics against scipy and the CLI end to end."""

import jax
import numpy as np
import pytest
from scipy.stats import ranksums

from jaxgwo import _gwo as G
from jaxgwo._compare import run_comparison
from jaxgwo._testfunctions import Problem, sphere
from jaxgwo.cli import main


def test_report_statistics_match_numpy_and_scipy():
    prob = Problem("sphere", sphere, -10.0, 10.0, 0.0)
    configs = {"gwo": G.gwo(6, 8), "igwo": G.igwo(6, 8)}
    key = jax.random.key(0)
    rep = run_comparison([prob], configs, dim=3, seeds=6, key=key)
    keys = jax.random.split(key, 6)
    finals = {n: np.asarray(G.run_seeds(c, sphere, prob.lower(3), prob.upper(3), keys).best_fitness)
              for n, c in configs.items()}
    row = {r.variant: r for r in rep.rows}
    for name in configs:
        assert row[name].median == pytest.approx(np.median(finals[name]), rel=1e-12)
        assert row[name].q25 == pytest.approx(np.percentile(finals[name], 25), rel=1e-12)
        assert row[name].best == pytest.approx(finals[name].min(), rel=1e-12)
    assert np.isnan(row["gwo"].p_value)
    assert row["igwo"].p_value == pytest.approx(ranksums(finals["igwo"], finals["gwo"]).pvalue)
    assert row["gwo"].evaluations == configs["gwo"].total_evaluations
    assert row["igwo"].evaluations == configs["igwo"].total_evaluations
    assert "| sphere | igwo |" in rep.to_markdown()


def test_cli_compare_writes_table_and_plot(tmp_path, capsys):
    md, png = tmp_path / "t.md", tmp_path / "c.png"
    rc = main(["compare", "--seeds", "3", "--wolves", "6", "--iterations", "5", "--dim", "3",
               "--problems", "F9,helicopter", "--variants", "gwo,igwo",
               "--markdown", str(md), "--plot", str(png), "--quiet"])
    assert rc == 0
    out = capsys.readouterr().out
    assert "| helicopter 5-parameter fit | igwo |" in out and "| F9 rastrigin | gwo |" in out
    assert md.read_text().startswith("Final error")
    assert png.stat().st_size > 1000
    assert not list(tmp_path.glob(".*.tmp"))


def test_cli_compare_bad_input_is_one_line_error(tmp_path, capsys):
    rc = main(["compare", "--seeds", "1", "--markdown", str(tmp_path / "x.md")])
    assert rc == 2
    err = capsys.readouterr().err
    assert "at least 2 seeds" in err and "Traceback" not in err
    assert not (tmp_path / "x.md").exists()
    rc = main(["compare", "--wolves", "3", "--seeds", "2", "--iterations", "2"])
    assert rc == 2
    assert "at least 4 wolves" in capsys.readouterr().err
    rc = main(["compare", "--problems", "F99"])
    assert rc == 2
    assert "unknown problem(s) ['f99']; choose from" in capsys.readouterr().err
