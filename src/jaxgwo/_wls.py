r"""Stage 3: the weighted least-squares (Levy) initial model, paper eqs. (17)-(29).

The model is :math:`G(s) = N(s)/D(s)` with :math:`N = \sum_{k=0}^{m} b_k s^k` and
:math:`D = 1 + \sum_{k=1}^{n} a_k s^k` (eq. 17); for the paper, :math:`m = 0`, :math:`n = 4`
(eq. 28).  Levy's linearisation multiplies the error by :math:`D` (eq. 22):

.. math::

    J = \sum_i w_i \,\bigl| D(j\omega_i)\,G^*(j\omega_i) - N(j\omega_i) \bigr|^2 ,

which is linear in :math:`\theta = (b_0..b_m, a_1..a_n)`: with :math:`G^* = R + jI`,

.. math::

    D G^* - N = G^* - \Bigl[\sum_k b_k (j\omega)^k - \sum_k a_k (j\omega)^k G^*\Bigr],

so the stacked real and imaginary parts give an ordinary least-squares problem
:math:`\min \|W^{1/2}(A\theta - y)\|` with ``y = (R, I)``.

**Numerics.**  The paper solves the normal equations, eq. (29), whose entries (Table 1)
span :math:`10^3` to :math:`10^{16}`.  Here the rows are solved directly (no normal
equations, so the condition number is not squared) with ``jnp.linalg.lstsq`` (SVD) after
(i) scaling frequency by :math:`\omega_0` (geometric mean of the band), i.e. solving for
:math:`a_k\omega_0^{-k}`, and (ii) normalising every column to unit length.  On 200
points over 1-60 rad/s the scaled design has a condition number of about 3 (raw: 4e5; the
normal-equation matrix of eq. (29): 1.6e11), measured
in ``tests/test_wls.py``).

**Sanathanan-Koerner** iterations (IEEE TAC 1963) divide the weights by
:math:`|D_{k-1}(j\omega)|^2` from the previous iterate, so the solution tends to the
minimiser of the true output error :math:`\sum w |G^* - N/D|^2` rather than Levy's
:math:`D`-weighted one, which over-weights high frequencies.

**Moment sums, eq. (29).**  For :math:`b_0/(a_4 s^4 + \dots + a_1 s + 1)` the normal
equations are sums of weighted moments (Levy 1959):

.. math::

    W_0=\sum w,\; S_h=\sum w\,\omega^h R,\; T_h=\sum w\,\omega^h I,\;
    R_h=\sum w\,\omega^h (R^2+I^2).

Deriving them from eq. (22) (``derived`` convention; rows 4 and 5 multiplied by -1 to
match the paper's layout) gives

.. math::

    \begin{bmatrix} W_0 & T_1 & S_2 & -T_3 & \mathbf{-S_4} \\
                    T_1 & R_2 & 0 & -R_4 & 0 \\
                    S_2 & 0 & R_4 & 0 & -R_6 \\
                    T_3 & R_4 & 0 & -R_6 & 0 \\
                    S_4 & 0 & R_6 & 0 & -R_8 \end{bmatrix}
    \begin{bmatrix} b_0\\a_1\\a_2\\a_3\\a_4 \end{bmatrix} =
    \begin{bmatrix} S_0\\0\\R_2\\0\\R_4 \end{bmatrix}.

The printed eq. (29) has :math:`+S_4` in row 1, column 5.  Row 1 is
:math:`\partial J/\partial b_0 = 0`:
:math:`\sum w\,[R(1 - a_2\omega^2 + a_4\omega^4) - I(a_1\omega - a_3\omega^3) - b_0] = 0`,
i.e. :math:`W_0 b_0 + T_1 a_1 + S_2 a_2 - T_3 a_3 - S_4 a_4 = S_0`: the coefficient of
:math:`a_4` is :math:`-S_4`, exactly as that of :math:`a_3` is :math:`-T_3` (which the
paper prints correctly).  The full derived matrix is the symmetric :math:`A^T W A` with
rows 4 and 5 negated; the paper's other 24 entries agree with it.  So the printed sign is
a misprint (it changes the solution; the tests show the derived matrix reproduces
``numpy.linalg.lstsq`` and the printed one does not).
``convention="paper"`` keeps the printed matrix for a
faithful reproduction.  Separately: Table 1 with eq. (29) does not reproduce eq. (44)
or (45) for *any* value of :math:`S_0` (which Table 1 omits), under either sign; see
``tests/test_wls.py::test_paper_table1_does_not_give_eq44``.
"""

from __future__ import annotations

from typing import Literal

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Complex, Float

__all__ = [
    "LevyFit",
    "levy_design",
    "levy_fit",
    "levy_fit_response",
    "LevyMoments",
    "MOMENT_NAMES",
    "levy_moments",
    "levy_moment_matrix",
    "solve_levy_moments",
    "QuarticFactorisation",
    "quartic_to_paper_params",
]


class LevyFit(eqx.Module):
    """Result of :func:`levy_fit`.

    ``numerator`` and ``denominator`` are s-polynomials, highest power first, with the
    constant of the denominator equal to 1 (eq. 17).  ``theta`` is
    ``(b_0..b_m, a_1..a_n)``, ascending powers (the unknowns of eq. 29 for m=0, n=4).
    ``condition_number`` is that of the scaled, column-normalised design matrix.
    """

    theta: Float[Array, " p"]
    numerator: Float[Array, " m1"]
    denominator: Float[Array, " n1"]
    residual_norm: Float[Array, ""]
    condition_number: Float[Array, ""]
    frequency_scale: Float[Array, ""]
    sk_iterations: int = eqx.field(static=True)


def _jw(x: Float[Array, " freq"]) -> Complex[Array, " freq"]:
    # j*x without a Python-complex scalar, which strict dtype promotion rejects under jit
    return jax.lax.complex(jnp.zeros_like(x), x)


def _powers(s: Complex[Array, " freq"], kmax: int) -> Complex[Array, "freq k"]:
    return jnp.stack([s**k for k in range(kmax + 1)], axis=-1)


def levy_design(
    w: Float[Array, " freq"],
    H: Complex[Array, " freq"],
    num_order: int = 0,
    den_order: int = 4,
    frequency_scale: float | Float[Array, ""] = 1.0,
) -> tuple[Float[Array, "rows p"], Float[Array, " rows"]]:
    """Real design matrix and target of Levy's problem (eq. 22), rows ``(Re; Im)``.

    Columns: ``b_k`` for ``k = 0..num_order`` then ``a_k`` for ``k = 1..den_order``, in
    the frequency-scaled variable ``s/frequency_scale``.
    """
    s = _jw(w / frequency_scale)
    pw = _powers(s, max(num_order, den_order))
    cols_b = pw[:, : num_order + 1]
    cols_a = -pw[:, 1 : den_order + 1] * H[:, None]
    A = jnp.concatenate([cols_b, cols_a], axis=1)
    return jnp.concatenate([A.real, A.imag], axis=0), jnp.concatenate([H.real, H.imag])


def _lstsq_scaled(A, y, row_w):
    Aw = A * row_w[:, None]
    yw = y * row_w
    col = jnp.linalg.norm(Aw, axis=0)
    col = jnp.where(col > 0, col, 1.0)
    z, _, _, sv = jnp.linalg.lstsq(Aw / col, yw)
    theta = z / col
    resid = jnp.linalg.norm(Aw @ theta - yw)
    return theta, resid, sv[0] / sv[-1]


@eqx.filter_jit
def levy_fit(
    w: Float[Array, " freq"],
    H: Complex[Array, " freq"],
    weights: Float[Array, " freq"] | None = None,
    *,
    num_order: int = 0,
    den_order: int = 4,
    sk_iterations: int = 0,
    frequency_scale: float | Float[Array, ""] | None = None,
) -> LevyFit:
    """Weighted Levy least-squares fit of ``N(s)/D(s)`` to ``H(j w)`` (eqs. 17-29).

    ``weights`` (e.g. the coherence, or coherence times the mask) multiply each
    frequency's squared error; zero drops a point.  ``frequency_scale`` defaults to the
    geometric mean of ``w``.  ``sk_iterations`` Sanathanan-Koerner re-weightings follow the
    plain Levy solve.  Comparable to ``numpy.linalg.lstsq`` on the same stacked rows.
    """
    w = jnp.asarray(w, dtype=float)
    H = jnp.asarray(H, dtype=complex)
    weights = jnp.ones_like(w) if weights is None else jnp.asarray(weights, dtype=float)
    # points with zero weight may hold NaN (masked-out estimates); keep them out of the SVD
    H = jnp.where(weights > 0, H, jnp.zeros_like(H))
    w0 = jnp.exp(jnp.mean(jnp.log(w))) if frequency_scale is None else frequency_scale
    A, y = levy_design(w, H, num_order, den_order, w0)
    row_w = jnp.sqrt(jnp.concatenate([weights, weights]))
    nb = num_order + 1
    s = _jw(w / w0)
    pw = _powers(s, den_order)
    theta, resid, cond = _lstsq_scaled(A, y, row_w)
    for _ in range(sk_iterations):
        d_prev = 1.0 + pw[:, 1:] @ theta[nb:].astype(complex)
        sk = weights / jnp.abs(d_prev) ** 2
        theta, resid, cond = _lstsq_scaled(A, y, jnp.sqrt(jnp.concatenate([sk, sk])))
    # undo the frequency scaling: coefficient of (s/w0)^k is c_k w0^k
    b = theta[:nb] / w0 ** jnp.arange(nb, dtype=float)
    a = theta[nb:] / w0 ** jnp.arange(1, den_order + 1, dtype=float)
    return LevyFit(
        theta=jnp.concatenate([b, a]),
        numerator=b[::-1],
        denominator=jnp.concatenate([a[::-1], jnp.ones((1,))]),
        residual_norm=resid,
        condition_number=cond,
        frequency_scale=jnp.asarray(w0, dtype=float),
        sk_iterations=sk_iterations,
    )


def levy_fit_response(
    response,
    *,
    sk_iterations: int = 5,
    relative: bool = True,
    num_order: int = 0,
    den_order: int = 4,
) -> LevyFit:
    """WLS initial model from a :class:`~jaxgwo._spectral.FrequencyResponse`.

    Weights are the coherence on the masked points, divided by :math:`|H|^2` when
    ``relative`` (so the fit approximates the relative/log error that the CIFER cost
    measures rather than being dominated by the largest magnitudes), followed by
    ``sk_iterations`` Sanathanan-Koerner passes.
    """
    mask = jnp.asarray(response.mask) & jnp.isfinite(jnp.abs(response.H))
    h = jnp.where(mask, response.H, 1.0 + 0.0j)
    wt = jnp.where(mask, jnp.asarray(response.coherence, dtype=float), 0.0)
    if relative:
        wt = wt / jnp.abs(h) ** 2
    return levy_fit(
        response.w, h, wt, num_order=num_order, den_order=den_order, sk_iterations=sk_iterations
    )


MOMENT_NAMES = ("W0", "T1", "T3", "S2", "S4", "R2", "R4", "R6", "R8", "S0")
"""Order of :meth:`LevyMoments.to_vector`: Table 1's nine sums, then ``S0``."""


class LevyMoments(eqx.Module):
    """The weighted moment sums of eq. (29) / Table 1 (module docstring for definitions)."""

    W0: Float[Array, "*batch"]
    T1: Float[Array, "*batch"]
    T3: Float[Array, "*batch"]
    S2: Float[Array, "*batch"]
    S4: Float[Array, "*batch"]
    R2: Float[Array, "*batch"]
    R4: Float[Array, "*batch"]
    R6: Float[Array, "*batch"]
    R8: Float[Array, "*batch"]
    S0: Float[Array, "*batch"]

    def to_vector(self) -> Float[Array, "*batch 10"]:
        """Stack in :data:`MOMENT_NAMES` order."""
        return jnp.stack([getattr(self, k) for k in MOMENT_NAMES], axis=-1)

    @classmethod
    def from_vector(cls, v: Float[Array, "*batch 10"]) -> "LevyMoments":
        """Inverse of :meth:`to_vector`."""
        return cls(**{k: v[..., i] for i, k in enumerate(MOMENT_NAMES)})

    def as_dict(self) -> dict[str, float]:
        """Names to floats (unbatched moments only)."""
        return {k: float(getattr(self, k)) for k in MOMENT_NAMES}


def levy_moments(
    w: Float[Array, " freq"],
    H: Complex[Array, " freq"],
    weights: Float[Array, " freq"] | None = None,
) -> LevyMoments:
    """Weighted Levy moment sums (Table 1 plus ``S0``) of a response ``H(j w)``.

    :math:`W_0=\\sum w`, :math:`S_h=\\sum w\\omega^h\\,\\mathrm{Re}H`,
    :math:`T_h=\\sum w\\omega^h\\,\\mathrm{Im}H`, :math:`R_h=\\sum w\\omega^h|H|^2`.
    """
    w = jnp.asarray(w, dtype=float)
    H = jnp.asarray(H, dtype=complex)
    wt = jnp.ones_like(w) if weights is None else jnp.asarray(weights, dtype=float)
    re, im, mag2 = H.real, H.imag, jnp.abs(H) ** 2
    S = lambda h: jnp.sum(wt * w**h * re)  # noqa: E731
    T = lambda h: jnp.sum(wt * w**h * im)  # noqa: E731
    R = lambda h: jnp.sum(wt * w**h * mag2)  # noqa: E731
    return LevyMoments(
        W0=jnp.sum(wt), T1=T(1), T3=T(3), S2=S(2), S4=S(4),
        R2=R(2), R4=R(4), R6=R(6), R8=R(8), S0=S(0),
    )  # fmt: skip


def levy_moment_matrix(
    m: LevyMoments, convention: Literal["derived", "paper"] = "derived"
) -> tuple[Float[Array, "5 5"], Float[Array, " 5"]]:
    """Matrix and right-hand side of eq. (29) for unknowns ``(b0, a1, a2, a3, a4)``.

    ``"derived"`` has ``-S4`` in row 1, column 5 (the derivation from eq. 22);
    ``"paper"`` is the matrix as printed, with ``+S4`` (module docstring).
    """
    z = jnp.zeros_like(m.W0)
    s4 = -m.S4 if convention == "derived" else m.S4
    if convention not in ("derived", "paper"):
        raise ValueError("convention must be 'derived' or 'paper'")
    M = jnp.stack(
        [
            jnp.stack([m.W0, m.T1, m.S2, -m.T3, s4], axis=-1),
            jnp.stack([m.T1, m.R2, z, -m.R4, z], axis=-1),
            jnp.stack([m.S2, z, m.R4, z, -m.R6], axis=-1),
            jnp.stack([m.T3, m.R4, z, -m.R6, z], axis=-1),
            jnp.stack([m.S4, z, m.R6, z, -m.R8], axis=-1),
        ],
        axis=-2,
    )
    rhs = jnp.stack([m.S0, z, m.R2, z, m.R4], axis=-1)
    return M, rhs


def solve_levy_moments(
    m: LevyMoments, convention: Literal["derived", "paper"] = "derived"
) -> Float[Array, " 5"]:
    """Solve eq. (29) for ``(b0, a1, a2, a3, a4)`` given the moment sums.

    The entries span ~13 decades, so rows and columns are first equilibrated by
    :math:`1/\\sqrt{|M_{kk}|}` (a diagonal similarity that leaves the solution unchanged)
    and the scaled system is solved by LU.  Batched moments give batched solutions, so
    the optimiser can ``vmap`` over a pack of moment vectors.
    """
    M, rhs = levy_moment_matrix(m, convention)
    d = jnp.abs(jnp.diagonal(M, axis1=-2, axis2=-1))
    d = 1.0 / jnp.sqrt(jnp.where(d > 0, d, 1.0))
    Ms = M * d[..., :, None] * d[..., None, :]
    z = jnp.linalg.solve(Ms, (rhs * d)[..., None])[..., 0]
    return z * d


class QuarticFactorisation(eqx.Module):
    """The quartic ``b0/(a4 s^4 + a3 s^3 + a2 s^2 + a1 s + 1)`` as paper parameters.

    ``params`` is ``(K, tau, M, omega_s, zeta_s)`` (eqs. 15-16) or ``None`` when the
    denominator does not factor into two stable real quadratics; ``reason`` says why.
    ``roots`` are the four poles.
    """

    params: tuple[float, float, float, float, float] | None = eqx.field(static=True)
    reason: str = eqx.field(static=True)
    roots: tuple[complex, ...] = eqx.field(static=True)

    @property
    def ok(self) -> bool:
        return self.params is not None


def quartic_to_paper_params(
    b0: float, a1: float, a2: float, a3: float, a4: float
) -> QuarticFactorisation:
    """Factor the quartic into rotor/fuselage and servo quadratics (eqs. 14-16).

    The monic denominator :math:`s^4 + (a_3/a_4)s^3 + \\dots + 1/a_4` is split into
    :math:`(s^2 + s/\\tau + M)(s^2 + 2\\zeta_s\\omega_s s + \\omega_s^2)`.  Complex poles
    pair with their conjugates; with four real poles the two of largest modulus pair.
    **Identifiability rule:** the product is symmetric in the two factors, so the pair
    with the larger natural frequency :math:`\\sqrt{q}` is the servo (actuators are faster
    than the rotor/fuselage mode).  Then :math:`K = (b_0/a_4)/\\omega_s^2`.  Host-side
    (NumPy); fails with a reason for a non-positive :math:`a_4`, non-finite input, or an
    unstable factor.
    """
    c = np.array([a4, a3, a2, a1, 1.0], dtype=float)
    if not (np.all(np.isfinite(c)) and np.isfinite(b0)):
        return QuarticFactorisation(None, "non-finite coefficients", ())
    if a4 <= 0:
        return QuarticFactorisation(None, f"a4 = {a4:.4g} <= 0: not a stable quartic", ())
    r = np.roots(c)
    roots = tuple(complex(x) for x in sorted(r, key=lambda z: (abs(z), z.imag)))
    if np.any(r.real >= 0):
        bad = ", ".join(f"{z:.4g}" for z in r if z.real >= 0)
        return QuarticFactorisation(None, f"unstable: pole(s) with Re >= 0: {bad}", roots)
    tol = 1e-9 * max(1.0, float(np.max(np.abs(r))))
    cplx = r[np.abs(r.imag) > tol]
    real = np.sort(r[np.abs(r.imag) <= tol].real)
    upper = cplx[cplx.imag > 0]
    pairs = [(z, np.conj(z)) for z in upper]
    real_by_size = real[np.argsort(np.abs(real))]
    pairs += [tuple(real_by_size[i : i + 2]) for i in range(0, real_by_size.size, 2)]
    if len(pairs) != 2:
        return QuarticFactorisation(None, "poles do not form two real quadratics", roots)
    quads = []
    for z1, z2 in pairs:
        quads.append((float(-(z1 + z2).real), float((z1 * z2).real)))
    quads.sort(key=lambda pq: pq[1])  # slower (smaller omega_n^2) first: rotor, then servo
    (p1, q1), (p2, q2) = quads
    ws = float(np.sqrt(q2))
    params = (float(b0 / a4) / q2, 1.0 / p1, q1, ws, p2 / (2.0 * ws))
    return QuarticFactorisation(params, "ok", roots)

