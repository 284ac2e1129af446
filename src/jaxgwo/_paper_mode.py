r"""The paper's own parameterisation: IGWO over the Levy moment sums (sec. 3.3, Table 1).

The paper does not search the transfer function's coefficients.  It takes the weighted
moment sums of the WLS normal equations, eq. (29) (Table 1 lists nine of them),
lets the improved grey wolf optimiser move them within bounds, and every candidate is
turned into a transfer function by solving eq. (29):

.. math::

    x \;\xrightarrow{\;m = x \odot m^{\mathrm{wls}}\;}\;
    (W_0, T_1, T_3, S_2, S_4, R_2, R_4, R_6, R_8, S_0)
    \;\xrightarrow{\text{eq. (29)}}\; (b_0, a_1, a_2, a_3, a_4)
    \;\longrightarrow\; J\bigl(b_0/(a_4 s^4 + a_3 s^3 + a_2 s^2 + a_1 s + 1)\bigr).

**Search space.**  The moments span about :math:`10^3` (``W0``) to :math:`10^{16}`
(``R8``), and ``S2``, ``S4`` are negative, so a log search is impossible and a raw linear
one would give one wolf step the size of the largest moment.  The wolves therefore move
in *scaled units* :math:`x_i = m_i / m_i^{\mathrm{wls}}`, linear, inside
:math:`[1 - d, 1 + d]` (``half_width`` :math:`d`, default 0.1), i.e. every moment within
:math:`\pm 10\,\%` of its WLS value, ``S0`` included (Table 1 omits ``S0`` but eq. (29)
needs it).  :math:`x = 1` is the WLS solution itself.  Scaling keeps the sign of every
moment, so ``half_width`` must be below 1.

*Why 10 %, and a seed spread of 0.02.*  ``J`` is very sensitive to the moments.  On a
3 %-noise paper-plant response (``J`` = 1.79 at the WLS moments) random perturbations of
all ten moments by 1 %, 5 % and 20 % (standard deviation) gave median ``J`` 2.6, 23 and
273, and 0 %, 0.05 % and 34 % unstable quartics.  With 50 x 500 IGWO, boxes of
:math:`d` = 0.05, 0.1 and 0.3 and spreads 0.005-0.05 all ended within 0.4 % of the
least-squares optimum on five responses; :math:`d` = 0.1, spread 0.02 was as good as
any and leaves room for WLS starts that are further off.

**Redundancy.**  Ten numbers parameterise a five-coefficient model, and eq. (29) is
homogeneous of degree zero in the moments: multiplying all ten by one factor leaves the
solution unchanged.  The search therefore has flat directions (at least one exact ridge
and a five-dimensional family of moment vectors per transfer function), and a bound
around the WLS moments is *not* a bound around the WLS coefficients: a 30 % change of
one moment can move the poles a lot, or make the quartic unstable.

**Which weights.**  ``levy_fit_response`` solves with the weights
:math:`\gamma^2 / |H|^2` on the masked points, then refines them with
Sanathanan-Koerner passes, :math:`w / |D_{k-1}(j\omega)|^2`.  With ``weights="sk"``
(default) the WLS moments are taken with the weights of the *last* of those passes, so that
solving eq. (29) at :math:`x = 1` reproduces exactly the WLS quartic from which the
pipeline's other methods start; ``"levy"`` uses the plain weights (the quartic of
``sk_iterations=0``); an explicit array gives any per-frequency weights.

**Fitness.**  The paper's flow (sec. 3.3, step 1) scores a candidate by the time-domain
MSE of its prediction; the other methods in this package minimise the CIFER cost ``J``.
For a like-for-like comparison :func:`identify_paper_mode` uses ``J``, but
:class:`MomentObjective` accepts any quartic-kind objective of :mod:`jaxgwo._cost` (a
:class:`~jaxgwo._cost.TimeDomainObjective` gives the paper's MSE).  A candidate whose
solve is non-finite, or whose quartic is not Hurwitz-stable, scores ``+inf``.

**eq. (29)'s sign.**  The printed matrix has :math:`+S_4` in row 1, column 5; the
derivation gives :math:`-S_4` (:mod:`jaxgwo._wls`).  ``convention="derived"`` (default)
solves the corrected system; ``convention="paper"`` the printed one.  With the printed
matrix the WLS moments do *not* reproduce the WLS fit, so the search starts from a
different (usually much worse, often unstable) model.
"""

from __future__ import annotations

from typing import Literal

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float, Int, PRNGKeyArray

from . import _gwo as G
from ._cost import CiferObjective, ComplexErrorObjective, TimeDomainObjective
from ._models import PaperModel, ParameterMap, QuarticModel
from ._spectral import FrequencyResponse
from ._wls import (
    MOMENT_NAMES,
    LevyMoments,
    levy_fit_response,
    levy_moments,
    quartic_to_paper_params,
    solve_levy_moments,
)

__all__ = [
    "MomentObjective",
    "PaperModeResult",
    "hurwitz_stable_quartic",
    "wls_moment_weights",
    "identify_paper_mode",
]

Convention = Literal["derived", "paper"]
_CONVENTIONS = ("derived", "paper")
QuarticFitness = CiferObjective | ComplexErrorObjective | TimeDomainObjective


def hurwitz_stable_quartic(coefficients: Float[Array, "*batch 5"]) -> Array:
    r"""Whether :math:`a_4 s^4 + a_3 s^3 + a_2 s^2 + a_1 s + 1` has all poles in Re s < 0.

    ``coefficients`` is ``(b0, a1, a2, a3, a4)`` (``b0`` is ignored).  Routh-Hurwitz for a
    quartic with :math:`a_0 = 1`: every :math:`a_k > 0`,
    :math:`a_3 a_2 - a_4 a_1 > 0` and :math:`a_1 (a_3 a_2 - a_4 a_1) - a_3^2 > 0`.
    Pure JAX, no root finding (so it can run inside the optimiser's ``vmap``).
    """
    a1, a2, a3, a4 = (coefficients[..., i] for i in range(1, 5))
    d2 = a3 * a2 - a4 * a1
    d3 = a1 * d2 - a3 * a3
    return (a1 > 0) & (a2 > 0) & (a3 > 0) & (a4 > 0) & (d2 > 0) & (d3 > 0)


class MomentObjective(eqx.Module):
    r"""Fitness of a scaled moment vector: solve eq. (29), score the quartic (module doc).

    ``objective(x)`` with ``x`` of shape ``(10,)`` in :data:`~jaxgwo._wls.MOMENT_NAMES`
    order and scaled units (moments ``= x * scale``) returns the fitness of the quartic
    that eq. (29) gives, or ``+inf`` when the solve is non-finite or the quartic unstable.
    The data (``scale`` and the fitness's arrays) are array leaves and the convention is
    static, so new data of the same shape reuses the compiled optimiser run.
    """

    fitness: QuarticFitness
    scale: Float[Array, " 10"]
    convention: str = eqx.field(static=True, default="derived")

    def __check_init__(self):
        if self.convention not in _CONVENTIONS:
            raise ValueError(
                f"convention={self.convention!r}: choose 'derived' (eq. 29 with the sign "
                "of S4 corrected) or 'paper' (eq. 29 as printed)."
            )
        if self.fitness.parameter_map.kind != "quartic":
            raise ValueError(
                "MomentObjective scores the quartic b0/(a4 s^4 + ... + 1); build the fitness "
                "with a quartic ParameterMap (ParameterMap.for_model(QuarticModel(...)))."
            )

    def moments(self, x: Float[Array, "*batch 10"]) -> LevyMoments:
        """The moment sums of the scaled vector ``x``."""
        return LevyMoments.from_vector(x * self.scale)

    def coefficients(self, x: Float[Array, "*batch 10"]) -> Float[Array, "*batch 5"]:
        """``(b0, a1, a2, a3, a4)`` from eq. (29) at the moments of ``x``."""
        return solve_levy_moments(self.moments(x), self.convention)

    def __call__(self, x: Float[Array, " 10"]) -> Float[Array, ""]:
        p = self.coefficients(x)
        j = self.fitness.cost_from_params(p)
        ok = hurwitz_stable_quartic(p) & jnp.all(jnp.isfinite(p)) & jnp.isfinite(j)
        return jnp.where(ok, j, jnp.inf)


class PaperModeResult(eqx.Module):
    """Outcome of :func:`identify_paper_mode`.

    Attributes:
        moments: the best moment sums found (eq. 29 / Table 1 plus ``S0``).
        wls_moments: the WLS moments the search was centred on.
        scaled_position: the best ``x`` (moments / WLS moments), shape ``(10,)``.
        quartic: ``b0/(a4 s^4 + ... + a1 s + 1)`` from eq. (29) at ``moments``.
        wls_quartic: the same at the WLS moments (``x = 1``): the WLS fit itself with the
            derived convention, a different model with the printed one.
        paper_model: the quartic factored into ``(K, tau, M, omega_s, zeta_s)`` with the
            servo as the faster pair, or ``None`` when it does not factor.
        reason: ``"ok"`` or why ``paper_model`` is ``None``.
        cost_J: the fitness (CIFER ``J`` unless another was given) of ``quartic``.
        wls_cost_J: the fitness at the WLS moments (``inf`` if that quartic is unstable).
        convergence: best fitness after each iteration, shape ``(iterations,)``.
        evaluations: number of fitness evaluations made.
        convention: which eq. (29) was solved, ``"derived"`` or ``"paper"``.
    """

    moments: LevyMoments
    wls_moments: LevyMoments
    scaled_position: Float[Array, " 10"]
    quartic: QuarticModel
    wls_quartic: QuarticModel
    paper_model: PaperModel | None
    reason: str = eqx.field(static=True)
    cost_J: Float[Array, ""]
    wls_cost_J: Float[Array, ""]
    convergence: Float[Array, " iterations"]
    evaluations: Int[Array, ""]
    convention: str = eqx.field(static=True)

    @property
    def status(self) -> str:
        """``"ok"`` when a finite, stable optimum was found, else a reason."""
        if not np.isfinite(float(self.cost_J)):
            return "no finite fitness: every candidate moment vector gave an unstable quartic"
        return "ok"


def wls_moment_weights(
    response: FrequencyResponse,
    weights: Literal["sk", "levy"] = "sk",
    *,
    sk_iterations: int = 5,
) -> Float[Array, " freq"]:
    r"""Per-frequency weights whose moments reproduce the WLS fit (module doc, "Which weights").

    ``"levy"``: :math:`\gamma^2/|H|^2` on the masked points (zero elsewhere), the base
    weights of :func:`~jaxgwo._wls.levy_fit_response`.  ``"sk"``: those divided by
    :math:`|D(j\omega)|^2` of the fit after ``sk_iterations - 1`` Sanathanan-Koerner
    passes, the weights of the last pass of ``levy_fit_response(sk_iterations=...)``.
    """
    if weights not in ("sk", "levy"):
        raise ValueError(f"weights={weights!r}: choose 'sk', 'levy' or pass a weight array.")
    mask = jnp.asarray(response.mask) & jnp.isfinite(jnp.abs(response.H))
    h = jnp.where(mask, response.H, 1.0 + 0.0j)
    base = jnp.where(mask, jnp.asarray(response.coherence, dtype=float), 0.0) / jnp.abs(h) ** 2
    if weights == "levy" or sk_iterations == 0:
        return base
    prev = levy_fit_response(response, sk_iterations=sk_iterations - 1)
    d = QuarticModel.from_array(jnp.concatenate([jnp.ones((1,)), prev.theta[1:]]))
    # 1/D = G with b0 = 1
    return base * jnp.abs(d.frequency_response(response.w)) ** 2


def _masked_data(response: FrequencyResponse):
    mask = jnp.asarray(response.mask) & jnp.isfinite(jnp.abs(response.H))
    return jnp.asarray(response.w, dtype=float), jnp.where(mask, response.H, 1.0 + 0.0j), mask


def identify_paper_mode(
    response: FrequencyResponse,
    *,
    key: PRNGKeyArray,
    wolves: int = 50,
    iterations: int = 500,
    half_width: float = 0.1,
    spread: float = 0.02,
    seeded_fraction: float = 0.5,
    weights: Literal["sk", "levy"] | Float[Array, " freq"] = "sk",
    sk_iterations: int = 5,
    convention: Convention = "derived",
    optimiser: G.GreyWolfConfig | None = None,
) -> PaperModeResult:
    r"""WLS-IGWO as the paper parameterises it: IGWO over the moment sums of eq. (29).

    1. WLS moments :math:`m^{\mathrm{wls}}` = :func:`~jaxgwo._wls.levy_moments` of the
       measured response with ``weights`` (:func:`wls_moment_weights`).
    2. The pack searches scaled moments :math:`x \in [1 - d, 1 + d]^{10}` (``half_width``
       :math:`d`); ``seeded_fraction`` of the wolves start at
       :math:`x = 1 + \mathrm{spread}\cdot N(0, 1)` (clipped; wolf 0 exactly at the WLS
       moments), the rest uniformly in the box.
    3. Fitness: CIFER ``J`` of the quartic that eq. (29) gives (``+inf`` if unstable).
       The optimiser is elitist and wolf 0 is the WLS start, so ``cost_J <= wls_cost_J``
       (up to the rounding of the batched against the unbatched evaluation of that start,
       which shows only where ``J`` itself is at rounding level, on noise-free data).

    Args:
        response: the measured frequency response (any sign of gain).
        key: PRNG key; the same key gives the same result.
        wolves, iterations: pack size and iterations of the default ``igwo`` (paper: 50,
            500); ignored when ``optimiser`` is given.
        half_width: :math:`d`, in (0, 1): the box is every moment within :math:`\pm d`
            of its WLS value, relatively.
        spread: standard deviation of the seeded wolves, in scaled units (>= 0).
        seeded_fraction: share of the pack seeded around the WLS moments, in (0, 1].
        weights: ``"sk"``, ``"levy"`` or a per-frequency weight array (module doc).
        sk_iterations: Sanathanan-Koerner passes of the WLS fit (as ``levy_fit_response``).
        convention: ``"derived"`` (corrected eq. 29, default) or ``"paper"`` (as printed).
        optimiser: a :class:`~jaxgwo._gwo.GreyWolfConfig` to use instead of
            ``igwo(wolves, iterations)`` (for example ``gwo(...)`` for a GWO ablation).

    Raises:
        ValueError: for settings out of range, an unknown ``weights`` or ``convention``,
            fewer than 20 frequencies passing the coherence mask, or WLS moments that are
            zero or non-finite (a relative box around them would be empty).
    """
    if not 0.0 < half_width < 1.0:
        raise ValueError(
            f"half_width={half_width}: the box [1 - d, 1 + d] in units of the WLS moments "
            "needs 0 < d < 1 (d >= 1 would let a moment change sign)."
        )
    if not (np.isfinite(spread) and spread >= 0.0):
        raise ValueError(f"spread={spread}: pass a finite standard deviation >= 0.")
    if not 0.0 < seeded_fraction <= 1.0:
        raise ValueError(f"seeded_fraction={seeded_fraction}: pass a value in (0, 1].")
    if convention not in _CONVENTIONS:
        raise ValueError(
            f"convention={convention!r}: choose 'derived' (corrected eq. 29) or 'paper'."
        )
    if not isinstance(sk_iterations, (int, np.integer)) or sk_iterations < 0:
        raise ValueError(f"sk_iterations={sk_iterations!r}: pass an integer >= 0.")
    config = G.igwo(wolves, iterations) if optimiser is None else optimiser

    # first, so that too few passing points fail before any WLS work
    cifer = CiferObjective.from_response(
        response, ParameterMap(kind="quartic", log=(False,) * 5, signs=(1.0,) * 5)
    )
    w, h, mask = _masked_data(response)
    if isinstance(weights, str):
        wt = wls_moment_weights(response, weights, sk_iterations=sk_iterations)
    else:
        wt = jnp.asarray(weights, dtype=float)
        if wt.shape != w.shape or not bool(jnp.all(jnp.isfinite(wt) & (wt >= 0))):
            raise ValueError(
                f"weights must be {w.shape[0]} finite, non-negative numbers (one per "
                f"frequency); got shape {wt.shape}."
            )
        wt = jnp.where(mask, wt, 0.0)
    wls_m = levy_moments(w, h, wt)
    scale = wls_m.to_vector()
    bad = ~(np.isfinite(np.asarray(scale)) & (np.asarray(scale) != 0.0))
    if bad.any():
        names = ", ".join(MOMENT_NAMES[i] for i in np.flatnonzero(bad))
        raise ValueError(
            f"WLS moment(s) {names} are zero or non-finite; a box relative to them is empty."
        )

    objective = MomentObjective(cifer, scale, convention)

    dim = len(MOMENT_NAMES)
    lower = jnp.full((dim,), 1.0 - half_width)
    upper = jnp.full((dim,), 1.0 + half_width)
    k_seed, k_run = jax.random.split(key)
    n_seed = min(config.wolves, max(1, int(round(seeded_fraction * config.wolves))))
    seeded = 1.0 + spread * jax.random.normal(k_seed, (n_seed, dim))
    seeded = seeded.at[0].set(jnp.ones((dim,)))
    res = G.run(config, objective, lower, upper, k_run, init_wolves=seeded)

    x_best = res.best_position
    quartic = QuarticModel.from_array(objective.coefficients(x_best))
    wls_quartic = QuarticModel.from_array(objective.coefficients(jnp.ones((dim,))))
    fact = quartic_to_paper_params(*(float(v) for v in quartic.to_array()))
    paper = PaperModel.from_array(jnp.asarray(fact.params)) if fact.ok else None
    return PaperModeResult(
        moments=objective.moments(x_best),
        wls_moments=wls_m,
        scaled_position=x_best,
        quartic=quartic,
        wls_quartic=wls_quartic,
        paper_model=paper,
        reason=fact.reason,
        cost_J=res.best_fitness,
        wls_cost_J=objective(jnp.ones((dim,))),
        convergence=res.history_best,
        evaluations=res.evaluations,
        convention=convention,
    )
