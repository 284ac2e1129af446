"""Plants: the R-50 model against its reference file, the paper plant, and random draws."""

import json
import pathlib
import re
import warnings

import jax
import jax.numpy as jnp
import numpy as np
import pytest
import scipy.signal

from jaxgwo._plants import (
    R50_PARAM_NAMES,
    R50_STATE_NAMES,
    PaperPlant,
    R50Plant,
    draw_paper_plant,
    draw_r50_plant,
    paper_params_from_r50,
    r50_matrices,
    r50_reference,
)
from jaxgwo._simulate import HoldLoop, closed_loop_stability
from jaxgwo._transfer import paper_model_response

SHARED = pathlib.Path(__file__).resolve().parents[2] / "shared" / "reference" / "r50_hover.json"


def _matrices_from_equation_text(ref):
    """Independent reference: parse the JSON's equation strings into A and B with NumPy."""
    P = dict(ref["params"], g=32.2)
    states = ref["state_order"]
    inputs = ref["inputs"]
    A = np.zeros((13, 13))
    B = np.zeros((13, 4))
    eqs = []
    for e in ref["equations"]:
        eqs.extend(part.strip() for part in e.split(";"))
    for e in eqs:
        lhs, rhs = (s.strip() for s in e.split("="))
        m = re.fullmatch(r"(?:(\w+)\*)?(\w+)'", lhs)
        scale = P[m.group(1)] if m.group(1) else 1.0
        row = states.index(m.group(2))
        for sign, term in re.findall(r"([+-]?)\s*([\w*]+)", rhs):
            factors = term.split("*")
            var = factors[-1]
            coef = np.prod([P[f] for f in factors[:-1]]) if len(factors) > 1 else 1.0
            coef = -coef if sign == "-" else coef
            if var in states:
                A[row, states.index(var)] += coef / scale
            else:
                B[row, inputs.index(var)] += coef / scale
    return A, B


def test_packaged_reference_is_the_shared_file():
    ref = r50_reference()
    assert tuple(ref["state_order"]) == R50_STATE_NAMES
    assert tuple(ref["params"]) == R50_PARAM_NAMES
    if SHARED.exists():
        assert json.loads(SHARED.read_text()) == ref


def test_r50_matrices_match_equation_text():
    ref = r50_reference()
    A_ref, B_ref = _matrices_from_equation_text(ref)
    A, B = r50_matrices(R50Plant.default().params)
    np.testing.assert_allclose(np.asarray(A), A_ref, rtol=1e-13, atol=1e-13)
    np.testing.assert_allclose(np.asarray(B), B_ref, rtol=1e-13, atol=1e-13)


def test_r50_eigenvalues_match_derived_check():
    ref = r50_reference()
    A, _ = r50_matrices(R50Plant.default().params)
    eig = np.linalg.eigvals(np.asarray(A))
    osc = eig[eig.imag > 1e-9]
    modes = sorted((abs(e), -e.real / abs(e)) for e in osc)
    fast = [m for m in modes if m[0] > 1.0]
    expected = sorted(tuple(m) for m in ref["derived_check"]["modes_rad_s"])
    assert len(fast) == len(expected)
    for (wn, z), (wn_ref, z_ref) in zip(fast, expected):
        # the file rounds to 0.1 rad/s and 0.01 in damping
        assert wn == pytest.approx(wn_ref, abs=0.051)
        assert z == pytest.approx(z_ref, abs=0.006)
    # the unstable low-frequency hover oscillation near 0.32 rad/s
    unstable = eig[eig.real > 0.0]
    assert unstable.size == 2
    assert np.all(np.abs(np.abs(unstable) - 0.32) < 0.005)
    assert np.all(np.abs(unstable.imag) > 0.0)


@pytest.mark.filterwarnings("ignore::scipy.signal.BadCoefficients")
def test_r50_frequency_response_matches_scipy():
    plant = R50Plant.default()
    A, B = (np.asarray(m) for m in r50_matrices(plant.params))
    C = np.zeros((2, 13))
    C[0, R50_STATE_NAMES.index("p")] = 1.0
    C[1, R50_STATE_NAMES.index("q")] = 1.0
    w = np.logspace(-1, 2, 40)
    H = np.asarray(plant.frequency_response(jnp.asarray(w)))
    ws, zs = np.asarray(plant.servo_omega), np.asarray(plant.servo_zeta)
    for j in range(2):
        servo = scipy.signal.freqs([ws[j] ** 2], [1, 2 * zs[j] * ws[j], ws[j] ** 2], w)[1]
        for i in range(2):
            sys_ij = scipy.signal.StateSpace(A, B[:, j : j + 1], C[i : i + 1], np.zeros((1, 1)))
            _, Hij = scipy.signal.freqresp(sys_ij, w)
            # scipy goes through ss2tf polynomials of a 13th-order model: ~1e-6 conditioning
            np.testing.assert_allclose(H[:, i, j], Hij * servo, rtol=2e-5)


def test_paper_plant_from_r50_eqs_10_13():
    """Eqs. (10), (13) by hand from the published R-50 parameters."""
    P = r50_reference()["params"]
    paper = paper_params_from_r50()
    lat, lon = np.asarray(paper.lateral), np.asarray(paper.longitudinal)
    assert lat[0] == pytest.approx(P["Lb"] * (P["Blat"] + P["Bd"] * P["Dlat"]) / P["Ts"])
    assert lat[2] == pytest.approx(P["Lb"] * (P["Tf"] + P["Bd"] * P["Ts"]) / P["Ts"])
    assert lon[0] == pytest.approx(P["Ma"] * (P["Alon"] + P["Ac"] * P["Clon"]) / P["Ts"])
    assert lon[2] == pytest.approx(P["Ma"] * (P["Tf"] + P["Ac"] * P["Ts"]) / P["Ts"])
    assert lat[1] == lon[1] == pytest.approx(P["Ts"])
    # the reduced rotor/fuselage modes sit near the full model's 11.9 and 8.4 rad/s modes
    assert np.sqrt(lat[2]) == pytest.approx(11.9, abs=0.2)
    assert np.sqrt(lon[2]) == pytest.approx(8.4, abs=0.5)
    w = jnp.logspace(-1, 2, 30)
    np.testing.assert_array_equal(np.asarray(paper.frequency_response(w))[0], np.asarray(paper_model_response(paper.lateral, w)))


def test_hold_loop_stabilises_r50():
    plant = R50Plant.default()
    assert float(closed_loop_stability(plant, None, None).max_real) == pytest.approx(0.306, abs=0.01)
    stab = closed_loop_stability(plant, None, HoldLoop.r50())
    assert float(stab.max_real) < -0.2
    assert float(stab.min_damping) > 0.15


def _paper_cubic_stable(params, tau_f):
    """Routh-Hurwitz of (s^2 + s/tau)(tau_f s + 1) + M, independent of the simulator."""
    _, tau, m, _, _ = params
    a3, a2, a1, a0 = tau_f, 1.0 + tau_f / tau, 1.0 / tau, m
    return a2 * a1 > a3 * a0


def test_draw_paper_plant_ranges_and_rejection():
    key = jax.random.key(7)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        draw = draw_paper_plant(key, effects=("rotor_flapping",), max_tries=64)
    assert bool(draw.found)
    p = np.asarray(draw.plant.params)
    assert np.all((np.sqrt(p[:, 2]) >= 7.0) & (np.sqrt(p[:, 2]) <= 20.0))
    assert np.all((p[:, 3] >= 25.0) & (p[:, 3] <= 60.0)) and np.all((p[:, 4] >= 0.4) & (p[:, 4] <= 0.8))
    assert p[0, 0] > 0 and p[1, 0] < 0
    tau_f = np.asarray(draw.effects.rotor_flapping.tau_f)
    assert np.all((tau_f >= 0.01) & (tau_f <= 0.06))
    for axis in range(2):
        assert _paper_cubic_stable(p[axis], tau_f[axis])
    assert float(draw.min_damping) >= 0.05
    n = int(draw.n_rejected)
    if n:
        assert any(f"rejected {n} unstable" in str(w.message) for w in caught)
    # rotor_flapping at the top of its range destabilises most stiff loops: the rejection
    # count over many draws is large, and every accepted draw passes Routh-Hurwitz.
    keys = jax.random.split(key, 8)
    draws = jax.vmap(lambda k: draw_paper_plant(k, effects=("rotor_flapping",), max_tries=16))(keys)
    assert int(jnp.sum(draws.n_rejected)) > 0
    for i in range(8):
        one = jax.tree.map(lambda a: a[i], draws)  # noqa: B023
        if bool(one.found):
            pi = np.asarray(one.plant.params)
            ti = np.asarray(one.effects.rotor_flapping.tau_f)
            assert all(_paper_cubic_stable(pi[a], ti[a]) for a in range(2))


def test_draw_without_any_stable_candidate_says_so():
    with pytest.raises(ValueError, match="no stable candidate in 2 draws"):
        draw_paper_plant(jax.random.key(0), effects=("rotor_flapping",), max_tries=2, min_damping=0.99)


def test_draw_r50_plant_is_stable_with_hold():
    draw = draw_r50_plant(jax.random.key(3), spread=0.1)
    nominal = np.asarray(R50Plant.default().params)
    ratio = np.asarray(draw.plant.params) / np.where(nominal == 0, 1.0, nominal)
    assert np.all((ratio[nominal != 0] >= 0.9) & (ratio[nominal != 0] <= 1.1))
    assert float(closed_loop_stability(draw.plant, draw.effects, HoldLoop.r50()).max_real) <= -0.02


def test_plants_are_pytrees_vmappable_over_parameters():
    base = PaperPlant.default()
    scales = jnp.array([0.8, 1.0, 1.2])
    plants = jax.vmap(lambda s: PaperPlant(base.lateral * s, base.longitudinal))(scales)
    w = jnp.array([1.0, 10.0])
    batched = jax.vmap(lambda p: p.frequency_response(w))(plants)
    for i, s in enumerate(np.asarray(scales)):
        np.testing.assert_allclose(np.asarray(batched[i, 0]), np.asarray(paper_model_response(base.lateral * s, w)))
