"""Figures: produced, valid PNGs, and nothing partial left behind when writing fails."""

import dataclasses
import struct
import zlib

import jax.numpy as jnp
import numpy as np
import pytest

from jaxgwo._identify import IdentifySettings, Validation, identify_responses
from jaxgwo._models import PaperModel
from jaxgwo._spectral import FrequencyResponse
from jaxgwo import _plots

TRUTH = jnp.asarray([-500.0, 0.1, 150.0, 40.0, 0.7])


def channel_results():
    """Two real ChannelIdentification results without flight records: WLS fits of a noisy
    analytic response whose coherence dips below the threshold in two bands, plus a
    synthetic validation overlay and convergence history (cheap: no optimiser run)."""
    w = jnp.geomspace(1.0, 60.0, 60)
    rng = np.random.default_rng(1)
    out = {}
    for ch, sign in (("lateral", 1.0), ("longitudinal", -0.5)):
        model = PaperModel.from_array(TRUTH * jnp.asarray([sign, 1, 1, 1, 1]))
        H = np.asarray(model.frequency_response(w))
        H = H * (1 + 0.03 * rng.standard_normal(w.size))
        coh = np.clip(0.95 - 0.6 * np.exp(-((np.log(np.asarray(w)) - np.log(3.0)) / 0.2) ** 2)
                      - 0.6 * (np.asarray(w) > 50), 0.0, 1.0)
        fr = FrequencyResponse.from_complex(w, jnp.asarray(H), jnp.asarray(coh))
        res = identify_responses({ch: fr}, IdentifySettings(method="wls", n_frequencies=60))[ch]
        t = np.arange(0.0, 5.0, 0.01)
        y = np.sin(3 * t) * np.exp(-0.2 * t)
        val = Validation(r2=0.93, tic=0.12, rms=0.01, per_record_r2=(0.95, 0.91),
                         time=(t, t), measured=(y, -y), predicted=(0.95 * y, -0.9 * y))
        out[ch] = dataclasses.replace(res, validation=val,
                                      convergence=np.geomspace(100.0, 10.0, 25))
    return out


@pytest.fixture(scope="module")
def results():
    return channel_results()


def assert_valid_png(path_or_bytes):
    """PNG signature, an IHDR first, an IEND last and every chunk's CRC correct."""
    data = path_or_bytes if isinstance(path_or_bytes, bytes) else path_or_bytes.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    pos, kinds = 8, []
    while pos < len(data):
        (length,) = struct.unpack(">I", data[pos:pos + 4])
        kind = data[pos + 4:pos + 8]
        body = data[pos + 8:pos + 8 + length]
        (crc,) = struct.unpack(">I", data[pos + 8 + length:pos + 12 + length])
        assert zlib.crc32(kind + body) == crc, kind
        kinds.append(kind)
        pos += 12 + length
    assert kinds[0] == b"IHDR" and kinds[-1] == b"IEND"
    width, height = struct.unpack(">II", data[16:24])
    return width, height


def test_each_figure_is_a_valid_png(tmp_path, results):
    res = list(results.values())
    _plots.plot_bode(res, tmp_path / "bode.png")
    _plots.plot_validation(res, tmp_path / "val.png")
    _plots.plot_identification(res, tmp_path / "all.png")
    bands = {"lateral": {"wls, seed 0": _plots.ConvergenceBand.from_histories(
        np.geomspace(100.0, 1.0, 30)[None] * np.linspace(1, 2, 8)[:, None])}}
    _plots.plot_convergence(bands, tmp_path / "conv.png", title="eight seeds")
    sizes = {p.name: assert_valid_png(p) for p in tmp_path.iterdir()}
    assert set(sizes) == {"bode.png", "val.png", "all.png", "conv.png"}
    assert sizes["all.png"] == (1320, 1320)  # 12 x 12 in at 110 dpi
    assert not list(tmp_path.glob(".*.tmp"))


def test_bode_shades_the_masked_band_and_fades_by_coherence(results):
    res = results["lateral"]
    fig = _plots.bode_figure([res])
    ax = fig.axes[0]
    mask = np.asarray(res.response.mask)
    assert (~mask).any() and mask.any()
    shaded = [p for p in ax.patches]  # axvspan rectangles, one per masked run
    assert len(shaded) == len(_plots._runs(~mask)) == 2
    alphas = ax.collections[0].get_facecolors()[:, 3]
    coh = np.asarray(res.response.coherence)
    np.testing.assert_allclose(alphas, _plots._MIN_ALPHA + (1 - _plots._MIN_ALPHA) * coh,
                               rtol=1e-12)
    assert_valid_png(_plots.figure_png(fig))


def test_convergence_bands_from_histories_and_studies():
    h = np.array([[4.0, 2.0, 1.0], [8.0, 4.0, 2.0], [6.0, 3.0, 1.5], [5.0, 1.0, 0.5]])
    b = _plots.ConvergenceBand.from_histories(h)
    np.testing.assert_array_equal(b.median, np.median(h, axis=0))
    np.testing.assert_array_equal(b.q25, np.percentile(h, 25, axis=0))
    np.testing.assert_array_equal(b.q75, np.percentile(h, 75, axis=0))
    assert b.seeds == 4
    one = _plots.ConvergenceBand.from_histories(h[0])
    assert one.seeds == 1 and one.q25 is one.median

    class Summary:  # what bands_from_montecarlo reads of a MonteCarloSummary
        n_seeds = 50
        history_quantiles = np.arange(15.0).reshape(5, 3)  # q05 q25 q50 q75 q95

    band = _plots.bands_from_montecarlo(Summary())["best cost"]
    np.testing.assert_array_equal(band.median, [6.0, 7.0, 8.0])
    np.testing.assert_array_equal(band.q25, [3.0, 4.0, 5.0])
    np.testing.assert_array_equal(band.q75, [9.0, 10.0, 11.0])
    Summary.history_quantiles = None
    with pytest.raises(ValueError, match="--histories"):
        _plots.bands_from_montecarlo(Summary())
    with pytest.raises(ValueError, match="no convergence curves"):
        _plots.convergence_figure({})


def test_failed_write_leaves_nothing(tmp_path, results, monkeypatch):
    res = list(results.values())
    with pytest.raises(ValueError, match="Format 'xyz' is not supported"):
        _plots.plot_bode(res, tmp_path / "bode.xyz")
    with pytest.raises(FileNotFoundError):
        _plots.plot_bode(res, tmp_path / "missing" / "bode.png")

    def boom(*a, **k):
        raise RuntimeError("disk full")

    from matplotlib.figure import Figure

    monkeypatch.setattr(Figure, "savefig", boom)
    (tmp_path / "keep.png").write_bytes(b"old")
    with pytest.raises(RuntimeError, match="disk full"):
        _plots.plot_validation(res, tmp_path / "keep.png")
    assert (tmp_path / "keep.png").read_bytes() == b"old"  # the old file is untouched
    assert sorted(p.name for p in tmp_path.iterdir()) == ["keep.png"]


def test_montecarlo_convergence_plot_from_the_cli(tmp_path):
    from jaxgwo.cli._main import main

    out = tmp_path / "conv.png"
    assert main(["--quiet", "montecarlo", "--seeds", "3", "--chunk", "2", "--wolves", "6",
                 "--iterations", "4", "--devices", "1", "--convergence-plot", str(out)]) == 0
    assert_valid_png(out)
    assert main(["montecarlo", "--convergence-plot", str(tmp_path / "no" / "c.png")]) == 2
    assert sorted(p.name for p in tmp_path.iterdir()) == ["conv.png"]


def test_log_frequency_axis_labels_one_two_five_in_plain_numbers():
    # a diagnosis's band, under two decades: matplotlib's default labels its minor ticks
    # as 2x10^-1 ... and they ran into each other on the half-page panels
    fig = _plots._figure(figsize=(6, 3))
    ax = fig.add_subplot()
    ax.plot([0.16, 7.7], [0.0, 1.0])
    _plots.log_frequency_axis(ax)
    ax.set_xlim(0.16, 7.7)
    fig.canvas.draw()
    major = [(t.get_position()[0], t.get_text()) for t in ax.get_xticklabels() if 0.16 <= t.get_position()[0] <= 7.7]
    assert major == [(0.2, "0.2"), (0.5, "0.5"), (1.0, "1"), (2.0, "2"), (5.0, "5")]
    assert all(t.get_text() == "" for t in ax.get_xticklabels(minor=True))
    assert ax.get_xscale() == "log"
