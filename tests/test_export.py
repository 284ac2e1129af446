"""Model export: bit-exact round trips, scipy/control references, and clear errors."""

import json
import struct

import jax.numpy as jnp
import numpy as np
import pytest
import scipy.signal

import jaxgwo
from jaxgwo._export import export_model, load_model, load_model_file, model_to_dict, save_model

PAPER = jnp.asarray([-512.3456789012345, 0.1 + 0.2, 150.0 / 7.0, 40.0 * np.pi, 0.7071067811865476])


def _bits(model) -> bytes:
    return np.asarray(model.to_array(), dtype=np.float64).tobytes()


def _random_floats(rng, n, max_exp):
    """Float64 values with random mantissa bits, random sign and binary exponents in
    ``[-max_exp, max_exp)``."""
    out = []
    for _ in range(n):
        bits = struct.unpack("<Q", rng.bytes(8))[0]
        mant = (bits & ((1 << 52) - 1)) | (1 << 52)
        out.append((-1) ** (bits >> 63) * float(mant) * 2.0 ** (int(rng.integers(-max_exp, max_exp)) - 52))
    return out


@pytest.mark.parametrize("cls", [jaxgwo.PaperModel, jaxgwo.QuarticModel])
def test_json_round_trip_is_bit_exact(tmp_path, cls):
    rng = np.random.default_rng(0)
    # the quartic's coefficients are stored as they are, so any finite value round-trips,
    # subnormals included; the paper model's transfer function must stay finite too
    extreme = [5e-324, -1.7976931348623157e308, 2.2250738585072014e-308, 1.0 / 3.0, -0.0]
    for i in range(20):
        if i == 0:
            vals = np.asarray(PAPER)
        elif i == 1 and cls is jaxgwo.QuarticModel:
            vals = np.asarray(extreme)
        else:
            vals = np.asarray(_random_floats(rng, 5, 40))
        model = cls.from_array(jnp.asarray(vals))
        path = tmp_path / f"m{i}.json"
        save_model(model, path, method="test", note="<&>")
        back = load_model(path)
        assert type(back) is cls
        assert _bits(back) == _bits(model), vals


def test_npz_round_trip_and_several_channels(tmp_path):
    lat = jaxgwo.PaperModel.from_array(PAPER)
    lon = jaxgwo.PaperModel.from_array(PAPER * jnp.asarray([-0.3, 1.1, 0.9, 1.2, 0.8])).to_quartic()
    for ext in ("json", "npz"):
        path = tmp_path / f"both.{ext}"
        export_model({"lateral": lat, "longitudinal": lon}, path)
        f = load_model_file(path)
        assert set(f.models) == {"lateral", "longitudinal"}
        assert _bits(f.model("lateral")) == _bits(lat)
        assert _bits(f.model("longitudinal")) == _bits(lon)
        assert type(f.model("longitudinal")) is jaxgwo.QuarticModel
        with pytest.raises(ValueError, match="holds 2 models"):
            f.model()
        with pytest.raises(ValueError, match="no model for channel 'yaw'"):
            f.model("yaw")
    # one model: scipy-style num/den at the top level, no pickles needed
    export_model(lat, tmp_path / "one.npz")
    with np.load(tmp_path / "one.npz", allow_pickle=False) as d:
        np.testing.assert_array_equal(d["num"], np.asarray(lat.numerator))
        np.testing.assert_array_equal(d["den"], np.asarray(lat.denominator))
    assert _bits(load_model(tmp_path / "one.npz")) == _bits(lat)
    # the format argument overrides the extension
    export_model(lat, tmp_path / "model.dat", format="json")
    assert _bits(load_model_file(tmp_path / "model.dat").model()) == _bits(lat)


def test_exported_transfer_function_matches_frequency_response(tmp_path):
    """scipy.signal.freqresp of the exported num/den against the model's own (factored)
    response.  rtol 1e-11: the expanded quartic evaluated by Horner's rule and the product
    of two quadratics round differently, by ~1e-15 per operation times coefficients that
    span 1e0..1e5."""
    w = np.geomspace(0.5, 200.0, 300)
    for model in (jaxgwo.PaperModel.from_array(PAPER),
                  jaxgwo.PaperModel.from_array(PAPER).to_quartic()):
        export_model(model, tmp_path / "m.npz")
        with np.load(tmp_path / "m.npz", allow_pickle=False) as d:
            _, H = scipy.signal.freqresp((d["num"], d["den"]), w)
        np.testing.assert_allclose(H, np.asarray(model.frequency_response(jnp.asarray(w))),
                                   rtol=1e-11, atol=0)
        # and through the JSON file and the loaded model's to_scipy()
        save_model(model, tmp_path / "m.json")
        _, H2 = scipy.signal.freqresp(load_model(tmp_path / "m.json").to_scipy(), w)
        np.testing.assert_allclose(H2, H, rtol=1e-13, atol=0)


def test_control_transfer_function(tmp_path):
    control = pytest.importorskip("control")
    model = jaxgwo.PaperModel.from_array(PAPER)
    save_model(model, tmp_path / "m.json")
    sys = load_model(tmp_path / "m.json").to_control()
    assert isinstance(sys, control.TransferFunction)
    w = np.geomspace(0.5, 200.0, 50)
    H = np.asarray([complex(np.squeeze(sys(complex(0.0, x)))) for x in w])
    # same tolerance reasoning as the scipy test
    np.testing.assert_allclose(H, np.asarray(model.frequency_response(jnp.asarray(w))),
                               rtol=1e-11)


def test_metadata_and_provenance_are_kept(tmp_path):
    model = jaxgwo.PaperModel.from_array(PAPER)
    path = save_model({"lateral": model}, tmp_path / "m.json", provenance={"source": "a.csv"},
                      method="wls-igwo", mse=float("nan"), cost=np.float64(12.5),
                      per_channel={"lateral": {"r2": 0.9}})
    f = load_model_file(path)
    assert f.metadata["lateral"] == {"method": "wls-igwo", "mse": None, "cost": 12.5, "r2": 0.9}
    assert f.provenance["source"] == "a.csv"
    assert f.provenance["jaxgwo_version"] == jaxgwo.__version__ and "created_utc" in f.provenance
    doc = json.loads((tmp_path / "m.json").read_text())
    assert doc["schema_version"] == 1 and doc["format"] == "jaxgwo-model"
    entry = doc["models"][0]
    assert entry["kind"] == "paper" and entry["parameter_names"] == list(model.names)
    assert entry["numerator"] == [float(c) for c in model.numerator]
    assert len(entry["denominator"]) == 5 and entry["denominator"][0] == 1.0


def _write(tmp_path, doc, name="bad.json") -> str:
    p = tmp_path / name
    p.write_text(doc if isinstance(doc, str) else json.dumps(doc))
    return str(p)


def _good(**changes) -> dict:
    doc = {"format": "jaxgwo-model", "schema_version": 1,
           "models": [model_to_dict(jaxgwo.PaperModel.from_array(PAPER), "lateral")]}
    entry = doc["models"][0]
    for key, value in changes.items():
        if key.startswith("param_"):
            entry["parameters"][key[6:]] = value
        elif key.startswith("drop_"):
            target = entry["parameters"] if key[5:] in entry["parameters"] else entry
            target.pop(key[5:])
        elif key in doc:
            doc[key] = value
        else:
            entry[key] = value
    return doc


@pytest.mark.parametrize("content, match", [
    ("", "is empty"),
    ("  \n", "is empty"),
    ("{not json", "not valid JSON: .* line 1, column 2"),
    (json.dumps({"schema": 1, "channels": {}}), "not a jaxgwo model file.*--export"),
    (json.dumps([1, 2]), "not a jaxgwo model file"),
    (_good(schema_version=99), "schema_version 99.*Upgrade jaxgwo"),
    (_good(schema_version="1"), "'schema_version' must be an integer"),
    (_good(models=[]), "'models' must be a non-empty list"),
    (_good(drop_kind=True), r"models\[0\] has no 'kind' field"),
    (_good(kind="pade"), r"models\[0\]\.kind 'pade' is unknown.*'paper', 'quartic'"),
    (_good(kind=3), r"models\[0\]\.kind must be a str"),
    (_good(drop_parameters=True), r"models\[0\] has no 'parameters' field"),
    (_good(drop_tau=True), r"models\[0\]\.parameters lacks tau"),
    (_good(param_tau="0.1"), r"models\[0\]\.parameters\.tau must be a number, got '0.1'"),
    (_good(param_M=True), r"models\[0\]\.parameters\.M must be a number"),
    (_good(param_Kp=1.0), r"unknown name\(s\) Kp"),
    (_good(parameter_names=["b0", "a1", "a2", "a3", "a4"]), r"parameter_names .* do not match"),
    (json.dumps(_good()).replace('"zeta_s": 0.7071067811865476', '"zeta_s": NaN'),
     r"models\[0\]\.parameters\.zeta_s is nan; model values must be finite"),
    (json.dumps(_good()).replace('"K": -512.3456789012345', '"K": -Infinity'),
     r"parameters\.K is -inf"),
    (_good(numerator=[1.0]), r"models\[0\]\.numerator .* disagrees with the parameters"),
    (_good(denominator="1 2 3"), r"denominator must be a list"),
    (_good(channel=5), r"channel must be a string or null"),
])
def test_bad_model_files_say_which_field(tmp_path, content, match):
    path = _write(tmp_path, content)
    with pytest.raises(ValueError, match=match):
        load_model(path)


def test_numbers_beyond_float64_and_deep_nesting(tmp_path):
    doc = _good(param_K=10**400)
    with pytest.raises(ValueError, match=r"parameters\.K is an integer of 401 digits"):
        load_model(_write(tmp_path, doc))
    doc = _good(numerator=[10**400])
    with pytest.raises(ValueError, match=r"numerator\[0\] is an integer of 401 digits"):
        load_model(_write(tmp_path, doc))
    with pytest.raises(ValueError, match="nests JSON arrays/objects too deeply"):
        load_model(_write(tmp_path, "[" * 100_000 + "]" * 100_000))


def test_parameters_with_infinite_coefficients_are_rejected(tmp_path):
    """tau = 0 is a finite parameter whose transfer function divides by zero; without the
    file's numerator/denominator to disagree with, the parameters themselves are checked."""
    doc = _good(param_tau=0.0)
    del doc["models"][0]["numerator"], doc["models"][0]["denominator"]
    with pytest.raises(ValueError, match=r"models\[0\]\.parameters: K = .*, tau = 0\.0, .* give non-finite"):
        load_model(_write(tmp_path, doc))


def test_duplicate_channel_and_missing_file(tmp_path):
    doc = _good()
    doc["models"].append(dict(doc["models"][0]))
    with pytest.raises(ValueError, match=r"models\[1\]: a second model for channel 'lateral'"):
        load_model(_write(tmp_path, doc))
    with pytest.raises(FileNotFoundError, match="no such model file"):
        load_model(tmp_path / "missing.json")
    (tmp_path / "x.npz").write_bytes(b"not a zip")
    with pytest.raises(ValueError, match="not a readable .npz"):
        load_model(tmp_path / "x.npz")


def test_export_refuses_what_it_cannot_write_and_leaves_no_file(tmp_path):
    good = jaxgwo.PaperModel.from_array(PAPER)
    bad = jaxgwo.PaperModel.from_array(PAPER.at[1].set(jnp.nan))
    with pytest.raises(ValueError, match="tau are not finite"):
        save_model(bad, tmp_path / "a.json")
    with pytest.raises(ValueError, match="overflow"):  # finite parameters, infinite 1/tau
        save_model(jaxgwo.PaperModel.from_array(PAPER.at[1].set(5e-324)), tmp_path / "a.json")
    with pytest.raises(ValueError, match="export one model at a time"):
        save_model(jaxgwo.PaperModel.from_array(jnp.stack([PAPER, PAPER])), tmp_path / "a.json")
    with pytest.raises(TypeError, match="PaperModel or jaxgwo.QuarticModel"):
        save_model(PAPER, tmp_path / "a.json")
    with pytest.raises(TypeError, match="metadata.extra is a object"):
        save_model(good, tmp_path / "a.json", extra=object())
    with pytest.raises(ValueError, match="cannot tell the export format from 'a.txt'"):
        export_model(good, tmp_path / "a.txt")
    with pytest.raises(ValueError, match="unknown export format 'mat'"):
        export_model(good, tmp_path / "a.mat", format="mat")
    with pytest.raises(FileNotFoundError):
        save_model(good, tmp_path / "nodir" / "a.json")
    # a model that fails half-way through a multi-channel npz leaves nothing behind
    with pytest.raises(ValueError, match="not finite"):
        export_model({"lateral": good, "longitudinal": bad}, tmp_path / "b.npz")
    assert sorted(p.name for p in tmp_path.iterdir()) == []
