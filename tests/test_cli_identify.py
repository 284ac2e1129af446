"""`jaxgwo identify/diagnose --export/--report`, small shapes; and the help texts."""

import json

import jax.numpy as jnp
import numpy as np
import pytest
from test_report import FakeDiagnosis, _fake_plot, assert_self_contained

import jaxgwo
from jaxgwo._data import make_record, save_record
from jaxgwo.cli._main import build_parser, main

TRUTH = np.array([-500.0, 0.1, 150.0, 40.0, 0.7])
FS, T = 100.0, 40.0
SMALL = ["--method", "wls-igwo", "--wolves", "8", "--iterations", "10"]


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    truth = jaxgwo.PaperModel.from_array(jnp.asarray(TRUTH))
    t = np.arange(0.0, T, 1.0 / FS)
    f0, f1 = 0.15, 12.0
    u = 0.1 * np.sin(2 * np.pi * f0 * T / np.log(f1 / f0) * (np.exp(t / T * np.log(f1 / f0)) - 1))
    y = np.asarray(truth.simulate(jnp.asarray(t), jnp.asarray(u)))
    rng = np.random.default_rng(0)
    d = tmp_path_factory.mktemp("records")
    paths = []
    for name in ("a.csv", "b.csv"):
        noisy = y + 0.02 * np.std(y) * rng.standard_normal(y.size)
        save_record(make_record(t, {"delta_lat": u, "p": noisy}), d / name)
        paths.append(str(d / name))
    return paths


def test_identify_exports_and_reports(tmp_path, files, capsys):
    out = {k: tmp_path / f"r.{k}" for k in ("json", "png", "html")}
    model_json = tmp_path / "model.json"
    rc = main(["identify", files[0], "--validate", files[1], "--channel", "lateral", *SMALL,
               "--json", str(out["json"]), "--plot", str(out["png"]), "--report",
               str(out["html"]), "--export", str(model_json)])
    assert rc == 0, capsys.readouterr().err
    result = json.loads(out["json"].read_text())["channels"]["lateral"]
    f = jaxgwo.load_model_file(model_json)
    model = f.model("lateral")
    # the export holds the same float64 values the result document shows
    assert model.params == result["model"]["params"]
    assert f.metadata["lateral"]["cost_J"] == result["fit"]["cost_J"]
    assert f.metadata["lateral"]["validation_r2"] == result["validation"]["r2"]
    assert f.metadata["lateral"]["method"] == "wls-igwo"
    assert set(f.metadata["lateral"]["cramer_rao_percent"]) == set(model.names)
    assert f.provenance["source"] == files[0] and "identify" in f.provenance["command"]
    html = out["html"].read_text(encoding="utf-8")
    p = assert_self_contained(html)
    assert "lateral channel" in html and len([t for t, _ in p.tags if t == "img"]) == 3
    assert out["png"].stat().st_size > 10_000
    # npz by --export-format (any file name), quiet, the same model
    npz = tmp_path / "model.bin"
    assert main(["--quiet", "identify", files[0], "--channel", "lateral", *SMALL,
                 "--export", str(npz), "--export-format", "npz"]) == 0
    with np.load(npz, allow_pickle=False) as d:
        assert str(d["channel"]) == "lateral"
        np.testing.assert_array_equal(d["num"], result["model"]["numerator"])
        np.testing.assert_array_equal(d["den"], result["model"]["denominator"])
    assert not list(tmp_path.glob(".*.tmp"))


@pytest.mark.parametrize("extra, match", [
    (["--export", "m.txt"], "cannot tell the export format from 'm.txt'"),
    (["--export-format", "npz"], "--export-format needs --export FILE"),
    (["--report", "nodir/r.html"], "--report directory does not exist"),
    (["--export", "nodir/m.json"], "--export directory does not exist"),
    (["--plot", "r.xyz"], "--plot format 'xyz' is not supported; use a name ending in one of"),
    (["--report", "."], "--report . is a directory; give a file name"),
])
def test_identify_rejects_bad_outputs_before_any_work(tmp_path, monkeypatch, files, capsys,
                                                      extra, match):
    monkeypatch.chdir(tmp_path)
    import jaxgwo._identify as I

    def never(*a, **k):
        raise AssertionError("the identification ran")

    monkeypatch.setattr(I, "_prepare", never)
    rc = main(["identify", files[0], "--channel", "lateral", *SMALL, "--json", "r.json", *extra])
    assert rc == 2
    err = capsys.readouterr().err
    assert match in err and "Traceback" not in err
    assert list(tmp_path.iterdir()) == []


class _Diag(FakeDiagnosis):
    nominal_params = {"K": 200.0, "tau": 0.3, "M": 180.0, "omega_s": 43.0, "zeta_s": 0.25}


def test_diagnose_exports_nominal_model_and_reports(tmp_path, monkeypatch, files, capsys):
    import jaxgwo._diagnose as D

    monkeypatch.setattr(D, "diagnose", lambda train, val, channel, settings, progress=None: _Diag())
    monkeypatch.setattr(D, "plot_diagnosis", _fake_plot)
    model_path, report = tmp_path / "nominal.json", tmp_path / "d.html"
    rc = main(["diagnose", files[0], "--validate", files[1], "--channel", "lateral",
               "--export", str(model_path), "--report", str(report)])
    assert rc == 0, capsys.readouterr().err
    f = jaxgwo.load_model_file(model_path)
    assert f.model("lateral").params == _Diag.nominal_params
    meta = f.metadata["lateral"]
    assert meta["verdict"] == "time_delay"
    assert meta["top_candidate"]["effect"] == "time_delay"
    assert meta["top_candidate"]["params"] == {"delay_s": 0.031}
    assert meta["combined_top2"]["effects"] == ["time_delay", "sensor_lag"]
    assert meta["time_domain_refit"]["params"]["omega_s"] == 31.0 and meta["time_domain_refit"]["val_r2"] == 0.6
    text = report.read_text(encoding="utf-8")
    assert_self_contained(text)
    assert "Verdict: time_delay" in text


def test_diagnose_runs_the_configuration_the_blind_study_validates(monkeypatch, files, capsys):
    """By default `jaxgwo diagnose` runs ``DiagnoseSettings()``, the configuration of the
    published blind study (its thresholds were set on those search sizes); --wolves,
    --iterations and --seed change the nominal fit and the refits alike."""
    import jaxgwo._diagnose as D

    seen = []
    monkeypatch.setattr(D, "diagnose", lambda train, val, channel, settings, progress=None: seen.append(settings) or _Diag())
    base = ["diagnose", files[0], "--validate", files[1], "--channel", "lateral", "--quiet"]
    assert main(base) == 0, capsys.readouterr().err
    assert main([*base, "--wolves", "16", "--iterations", "40", "--seed", "3"]) == 0, capsys.readouterr().err
    default, sized = seen
    assert default == D.DiagnoseSettings()
    # the sizes the seed-113 blind study (benchmarks/results/blind_diagnosis_seed113.md) ran
    # with: change them and that study no longer describes the command's default
    ids = default.identify
    assert (ids.method, ids.wolves, ids.iterations, ids.n_frequencies, ids.polish_steps, ids.w_max) == (
        "wls-igwo+polish", 12, 30, 80, 40, 120.0)
    assert (default.wolves, default.iterations, default.nonlinear_wolves, default.nonlinear_iterations) == (12, 30, 12, 15)
    assert (default.nonlinear_profile_points, default.nonlinear_refine_rows, default.nonlinear_polish_steps) == (12, 6, 60)
    assert (sized.wolves, sized.iterations, sized.seed) == (16, 40, 3)
    assert (sized.identify.wolves, sized.identify.iterations, sized.identify.seed) == (16, 40, 3)
    assert sized.identify.n_frequencies == ids.n_frequencies and sized.alpha == default.alpha
    assert main([*base, "--wolves", "3"]) != 0 and "--wolves must be >= 4" in capsys.readouterr().err
    assert len(seen) == 2


def _help(argv, capsys):
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 0
    return capsys.readouterr().out


def test_help_texts(capsys):
    top = _help(["--help"], capsys)
    for cmd in ("identify", "diagnose", "simulate", "compare", "montecarlo"):
        assert cmd in top
    assert "--quiet" in top and "examples:" in top
    assert _help(["--version"], capsys).strip() == f"jaxgwo {jaxgwo.__version__}"
    sub = build_parser()._subparsers._group_actions[0].choices
    for cmd, parser in sub.items():
        text = _help([cmd, "--help"], capsys)
        assert "(default: None)" not in text and "(default: False)" not in text, cmd
        for action in parser._actions:  # every option explains itself
            assert action.help, (cmd, action.option_strings)
    ident = _help(["identify", "--help"], capsys)
    assert "--export FILE" in ident and "--report OUT.html" in ident
    assert "(default: wls-igwo+polish)" in ident and "lateral_num" in ident
    # diagnose's help states the defaults it runs (DiagnoseSettings(), not the parser's None)
    from jaxgwo._diagnose import DiagnoseSettings

    ds = DiagnoseSettings()
    diag = " ".join(_help(["diagnose", "--help"], capsys).split())
    assert f"(default {ds.wolves}:" in diag and f"(default {ds.iterations}," in diag
    assert f"(default: {ds.identify.w_max:g})" in diag or f"(default: {ds.identify.w_max})" in diag


def test_only_the_console_script_freezes_the_heap(tmp_path):
    # the script spares the interpreter's final collection (gc.freeze); main(argv) called
    # from Python must not, or nothing alive at that point would ever be collected
    import gc
    import subprocess
    import sys

    before = gc.get_freeze_count()
    assert main(["identify", str(tmp_path / "missing.csv")]) == 2
    assert gc.get_freeze_count() == before
    code = ("import gc, sys; from jaxgwo.cli import main; "
            f"sys.argv = ['jaxgwo', 'identify', {str(tmp_path / 'missing.csv')!r}]; "
            "rc = main(); print(rc, gc.get_freeze_count() > 0)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.split()
    assert out == ["2", "True"]
