"""HTML reports: one self-contained file, the tables in it, every text escaped."""

import base64
import html.parser
import os
import re
import shutil
import subprocess

import numpy as np
import pytest
from test_plots import assert_valid_png, channel_results

from jaxgwo import _report


@pytest.fixture(scope="module")
def results():
    return channel_results()


class _Collect(html.parser.HTMLParser):
    """Every tag with its attributes, every table as rows of cell text."""

    def __init__(self):
        super().__init__()
        self.tags, self.tables, self._cell = [], [], None

    def handle_starttag(self, tag, attrs):
        self.tags.append((tag, dict(attrs)))
        if tag == "table":
            self.tables.append([])
        elif tag == "tr":
            self.tables[-1].append([])
        elif tag in ("td", "th"):
            self._cell = []

    def handle_endtag(self, tag):
        if tag in ("td", "th"):
            self.tables[-1][-1].append("".join(self._cell).strip())
            self._cell = None

    def handle_data(self, data):
        if self._cell is not None:
            self._cell.append(data)


def parse(text):
    p = _Collect()
    p.feed(text)
    p.close()
    return p


def assert_self_contained(text):
    """No reference that a browser would fetch: every src/href is a data: URI or a fragment,
    no url(...) in the style sheet, and the CSP forbids anything else."""
    p = parse(text)
    for tag, attrs in p.tags:
        for key in ("src", "href", "data", "poster", "srcset", "action"):
            if key in attrs:
                assert attrs[key].startswith(("data:", "#")), (tag, key, attrs[key][:80])
    assert "url(" not in text and "@import" not in text
    assert not re.search(r"(?i)\b(?:https?|ftp|file)://", text)
    assert ("default-src 'none'" in text)
    return p


def test_identification_report_is_self_contained_with_tables(tmp_path, results):
    path = tmp_path / "r.html"
    _report.write_identification_report(results, path, source="a<b>&c.csv", wall_s=1.5,
                                        command="jaxgwo identify a<b>&c.csv")
    text = path.read_text(encoding="utf-8")
    p = assert_self_contained(text)
    # the figures are embedded PNGs (Bode, convergence, validation)
    imgs = [a["src"] for t, a in p.tags if t == "img"]
    assert len(imgs) == 3
    for src in imgs:
        assert src.startswith("data:image/png;base64,")
        assert_valid_png(base64.b64decode(src.split(",", 1)[1]))
    # the summary and the two parameter tables, with values from the results
    summary, lat, lon = p.tables
    assert summary[0][:5] == ["channel", "method", "seed", "J", "WLS start J"]
    assert "validation R²" in summary[0] and "TIC" in summary[0]
    r = results["lateral"]
    row = next(row for row in summary if row[0] == "lateral")
    assert row[3] == f"{r.cost_J:.4g}" and row[8] == "0.9300" and row[9] == "0.1200"
    assert lat[0] == ["parameter", "value", "Cramér-Rao bound (%)", "insensitivity (%)", "unit"]
    unc = r.uncertainty.as_dict()
    assert [row[0] for row in lat[1:]] == ["K", "tau", "M", "omega_s", "zeta_s"]
    for row in lat[1:]:
        assert row[1] == f"{unc[row[0]]['value']:.6g}"
        assert row[2] == f"{unc[row[0]]['cr_percent']:.3g}"
    # text is escaped: the file name appears only as entities
    assert "a<b>&c.csv" not in text and "a&lt;b&gt;&amp;c.csv" in text
    assert not list(tmp_path.glob(".*.tmp"))


def test_report_without_validation_or_iterations(results):
    import dataclasses

    bare = {ch: dataclasses.replace(r, validation=None, convergence=np.zeros(0))
            for ch, r in results.items()}
    text = _report.identification_report_html(bare)
    p = assert_self_contained(text)
    assert len([t for t, _ in p.tags if t == "img"]) == 1  # Bode only
    row = p.tables[0][1]
    assert row[8:11] == ["–", "–", "–"]
    with pytest.raises(ValueError, match="no identification results"):
        _report.identification_report_html({})


class FakeDiagnosis:
    """What the report reads of a jaxgwo._diagnose.Diagnosis: summary() and to_json()."""

    channel = "lateral"

    def summary(self):
        return "Gap lies mainly between 1 and 3 Hz <phase lag>.\nMost likely cause: delay & lag."

    def to_json(self):
        cand = {"effect": "time_delay", "params": {"delay_s": 0.031},
                "params_sigma": {"delay_s": 0.002}, "val_r2": 0.71, "val_tic": 0.2,
                "cost_J": 80.0, "gap_closed": 0.42, "score": 1.0, "delta_bic": -35.0,
                "z_score": 4.2, "beats_noise": True, "signature_agreement": 0.9}
        weak = dict(cand, effect="sensor_lag", params={"cutoff_hz": 9.0},
                    params_sigma={"cutoff_hz": None}, val_r2=0.52, gap_closed=0.02,
                    beats_noise=False, z_score=None)
        return {"channel": "lateral",
                "nominal": {"params": {"K": 200.0, "tau": 0.3, "M": 180.0, "omega_s": 43.0,
                                       "zeta_s": 0.25}, "cost_J": 120.0, "val_r2": 0.5,
                            "val_tic": 0.3},
                "where": {"bands_hz": [[1.0, 3.0], [5.0, 6.5]], "worst_hz": 2.1,
                          "residual_white": False, "input_residual_peak_lag_s": 0.03,
                          "amplitude_dependent": False, "noise_limited_bands_hz": [],
                          "equivalent_delay_s": 0.028, "amplitude_note": "one amplitude"},
                "ranking": [cand, weak], "verdict": "time_delay",
                "combined_top2": {"effects": ["time_delay", "sensor_lag"], "val_r2": 0.72,
                                  "gap_closed": 0.44, "val_tic": 0.2, "cost_J": 79.0,
                                  "params": {}},
                "skipped": {"cross_coupling": "no off-axis <input>"}, "suggestion": "",
                "time_domain_refit": {"params": {"K": 205.0, "tau": 0.31, "M": 176.0, "omega_s": 31.0,
                                                 "zeta_s": 0.4}, "effects": {}, "train_mse": 2.5e-4,
                                      "val_r2": 0.6, "val_tic": 0.25, "gap_closed": 0.2}}


def _fake_plot(d, path):
    from matplotlib.figure import Figure

    from jaxgwo._atomic import atomic_savefig

    fig = Figure(figsize=(2, 2))
    fig.subplots().plot([0, 1], [1, 0])
    atomic_savefig(fig, path)


def test_diagnosis_report_ranking_and_verdict(tmp_path, monkeypatch):
    import jaxgwo._diagnose

    monkeypatch.setattr(jaxgwo._diagnose, "plot_diagnosis", _fake_plot)
    path = tmp_path / "d.html"
    _report.write_diagnosis_report(FakeDiagnosis(), path, source="train.csv")
    text = path.read_text(encoding="utf-8")
    p = assert_self_contained(text)
    assert "Verdict: time_delay" in text
    assert "&lt;phase lag&gt;" in text and "delay &amp; lag" in text
    assert "no off-axis &lt;input&gt;" in text
    nominal, refit, where, ranking = p.tables
    assert ["K", "200"] in nominal and ["validation R²", "0.5000"] in nominal
    assert ["omega_s", "31"] in refit and ["validation R²", "0.6000"] in refit and ["gap closed", "0.200"] in refit
    assert ["bands (Hz)", "1–3, 5–6.5"] in where and ["residual white", "no"] in where
    assert ranking[0][:5] == ["rank", "effect", "parameters", "validation R²", "gap closed"]
    assert ranking[1][:2] == ["1", "time_delay"] and ranking[1][-1] == "yes"
    assert ranking[1][2] == "delay_s = 0.031 ± 0.002"
    assert ranking[2][1] == "sensor_lag" and ranking[2][-1] == "no" and ranking[2][5] == "–"
    imgs = [a["src"] for t, a in p.tags if t == "img"]
    assert len(imgs) == 1
    assert_valid_png(base64.b64decode(imgs[0].split(",", 1)[1]))


def test_failed_report_leaves_no_file(tmp_path, monkeypatch):
    import jaxgwo._diagnose

    def boom(d, path):
        raise RuntimeError("plot failed")

    monkeypatch.setattr(jaxgwo._diagnose, "plot_diagnosis", boom)
    with pytest.raises(RuntimeError, match="plot failed"):
        _report.write_diagnosis_report(FakeDiagnosis(), tmp_path / "d.html")
    assert list(tmp_path.iterdir()) == []


CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")


@pytest.mark.optional
@pytest.mark.skipif(CHROMIUM is None, reason="needs chromium (headless) to render the report")
def test_report_renders_in_headless_chromium(tmp_path, results):
    """Rendered offline (no network: the CSP and --disable-background-networking), the
    page gives a screenshot that is not blank."""
    page = tmp_path / "r.html"
    _report.write_identification_report(results, page, source="synthetic")
    shot = tmp_path / "shot.png"
    cmd = [CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu",
           "--disable-background-networking", "--disable-component-update", "--disable-sync",
           "--no-first-run", f"--user-data-dir={tmp_path / 'profile'}",
           "--window-size=1200,2400", f"--screenshot={shot}", page.as_uri()]
    subprocess.run(cmd, check=True, capture_output=True, timeout=120,
                   env={**os.environ, "HOME": str(tmp_path)})
    width, height = assert_valid_png(shot)
    assert (width, height) == (1200, 2400)
    from matplotlib.image import imread

    img = imread(shot)
    # text, tables and figures: far from a uniform (blank or error) page
    assert img[..., :3].std() > 0.05
