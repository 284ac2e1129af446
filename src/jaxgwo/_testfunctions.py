r"""Benchmark problems for comparing optimisers.

* F1-F13 of Mirjalili, Mirjalili & Lewis (2014), "Grey Wolf Optimizer", Adv. Eng. Softw.
  69, Tables 1-2 (unimodal F1-F7, multimodal F8-F13), with their search boxes and minima.
* A helicopter-like problem: fit the 5 parameters of the paper model, eqs. (15)-(16), to
  its own noise-free frequency response.

Each problem is a :class:`Problem` with ``objective(x) -> scalar``, bounds and the known
minimum, so ``run(config, p.objective, p.lower(dim), p.upper(dim), key)`` benchmarks it.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import equinox as eqx
import jax
import jax.numpy as jnp
from jaxtyping import Array, Float, PRNGKeyArray

from ._transfer import paper_model_response


def sphere(x):
    """F1: :math:`\\sum x_i^2`."""
    return jnp.sum(x * x)


def schwefel_2_22(x):
    """F2: :math:`\\sum |x_i| + \\prod |x_i|`."""
    ax = jnp.abs(x)
    return jnp.sum(ax) + jnp.prod(ax)


def schwefel_1_2(x):
    """F3: :math:`\\sum_i (\\sum_{j \\le i} x_j)^2`."""
    return jnp.sum(jnp.cumsum(x) ** 2)


def schwefel_2_21(x):
    """F4: :math:`\\max_i |x_i|`."""
    return jnp.max(jnp.abs(x))


def rosenbrock(x):
    """F5: :math:`\\sum 100 (x_{i+1} - x_i^2)^2 + (x_i - 1)^2`."""
    return jnp.sum(100.0 * (x[1:] - x[:-1] ** 2) ** 2 + (x[:-1] - 1.0) ** 2)


def step_function(x):
    """F6: :math:`\\sum \\lfloor x_i + 0.5 \\rfloor^2`."""
    return jnp.sum(jnp.floor(x + 0.5) ** 2)


class QuarticNoise(eqx.Module):
    """F7: :math:`\\sum i x_i^4 + U[0, 1)`.

    The noise is drawn from an explicit key folded with the bits of ``x``, so it is
    reproducible: the same key and the same ``x`` give the same value.
    """

    key: PRNGKeyArray

    def __call__(self, x):
        i = jnp.arange(1, x.shape[0] + 1, dtype=x.dtype)
        bits = jax.lax.bitcast_convert_type(jnp.sum(x * i), jnp.uint64).astype(jnp.uint32)
        noise = jax.random.uniform(jax.random.fold_in(self.key, bits), (), dtype=x.dtype)
        return jnp.sum(i * x**4) + noise


def schwefel_2_26(x):
    """F8: :math:`\\sum -x_i \\sin\\sqrt{|x_i|}`; minimum :math:`-418.9829 n`."""
    return jnp.sum(-x * jnp.sin(jnp.sqrt(jnp.abs(x))))


def rastrigin(x):
    """F9: :math:`\\sum x_i^2 - 10 \\cos(2\\pi x_i) + 10`."""
    return jnp.sum(x * x - 10.0 * jnp.cos(2.0 * math.pi * x) + 10.0)


def ackley(x):
    """F10: Ackley's function."""
    n = x.shape[0]
    return (
        -20.0 * jnp.exp(-0.2 * jnp.sqrt(jnp.sum(x * x) / n))
        - jnp.exp(jnp.sum(jnp.cos(2.0 * math.pi * x)) / n)
        + 20.0
        + math.e
    )


def griewank(x):
    """F11: Griewank's function."""
    i = jnp.arange(1, x.shape[0] + 1, dtype=x.dtype)
    return jnp.sum(x * x) / 4000.0 - jnp.prod(jnp.cos(x / jnp.sqrt(i))) + 1.0


def _u(x, a, k, m):
    return jnp.where(x > a, k * (x - a) ** m, jnp.where(x < -a, k * (-x - a) ** m, 0.0))


def penalized_1(x):
    """F12: the first generalised penalised function."""
    n = x.shape[0]
    y = 1.0 + (x + 1.0) / 4.0
    core = (
        10.0 * jnp.sin(math.pi * y[0]) ** 2
        + jnp.sum((y[:-1] - 1.0) ** 2 * (1.0 + 10.0 * jnp.sin(math.pi * y[1:]) ** 2))
        + (y[-1] - 1.0) ** 2
    )
    return math.pi / n * core + jnp.sum(_u(x, 10.0, 100.0, 4))


def penalized_2(x):
    """F13: the second generalised penalised function."""
    core = (
        jnp.sin(3.0 * math.pi * x[0]) ** 2
        + jnp.sum((x[:-1] - 1.0) ** 2 * (1.0 + jnp.sin(3.0 * math.pi * x[1:]) ** 2))
        + (x[-1] - 1.0) ** 2 * (1.0 + jnp.sin(2.0 * math.pi * x[-1]) ** 2)
    )
    return 0.1 * core + jnp.sum(_u(x, 5.0, 100.0, 4))


@dataclass(frozen=True)
class Problem:
    """A benchmark problem: objective, box (per dimension, or fixed) and known minimum."""

    name: str
    objective: Callable
    low: float | tuple
    high: float | tuple
    minimum: float | Callable[[int], float]
    fixed_dim: int | None = None

    def lower(self, dim: int | None = None) -> Float[Array, " dim"]:
        return self._box(self.low, dim)

    def upper(self, dim: int | None = None) -> Float[Array, " dim"]:
        return self._box(self.high, dim)

    def _box(self, v, dim):
        if isinstance(v, tuple):
            return jnp.asarray(v, dtype=jnp.result_type(float))
        return jnp.full((dim,), v, dtype=jnp.result_type(float))

    def optimum(self, dim: int | None = None) -> float:
        return self.minimum(dim) if callable(self.minimum) else self.minimum


def mirjalili_functions(key: PRNGKeyArray) -> tuple[Problem, ...]:
    """F1-F13 with Mirjalili's boxes; ``key`` seeds F7's noise."""
    return (
        Problem("F1 sphere", sphere, -100.0, 100.0, 0.0),
        Problem("F2 schwefel_2_22", schwefel_2_22, -10.0, 10.0, 0.0),
        Problem("F3 schwefel_1_2", schwefel_1_2, -100.0, 100.0, 0.0),
        Problem("F4 schwefel_2_21", schwefel_2_21, -100.0, 100.0, 0.0),
        Problem("F5 rosenbrock", rosenbrock, -30.0, 30.0, 0.0),
        Problem("F6 step", step_function, -100.0, 100.0, 0.0),
        Problem("F7 quartic_noise", QuarticNoise(key), -1.28, 1.28, 0.0),
        Problem("F8 schwefel_2_26", schwefel_2_26, -500.0, 500.0, lambda n: -418.9829 * n),
        Problem("F9 rastrigin", rastrigin, -5.12, 5.12, 0.0),
        Problem("F10 ackley", ackley, -32.0, 32.0, 0.0),
        Problem("F11 griewank", griewank, -600.0, 600.0, 0.0),
        Problem("F12 penalized_1", penalized_1, -50.0, 50.0, 0.0),
        Problem("F13 penalized_2", penalized_2, -50.0, 50.0, 0.0),
    )


# Truth and box of the helicopter problem.  sqrt(M) <= 25 rad/s <= omega_s keeps the servo
# the faster quadratic, which removes the factor-swap alias (the swapped solution has
# M' = omega_s**2 >= 625, outside the box).
HELICOPTER_TRUTH = (250.0, 0.1, 144.0, 38.2261, 0.5118)  # K, tau, M, omega_s, zeta_s
HELICOPTER_LOWER = (10.0, 0.01, 25.0, 25.0, 0.1)
HELICOPTER_UPPER = (1000.0, 1.0, 625.0, 80.0, 1.5)


# Frequencies per block of the objective's row sum.  XLA rewrites a reduction with a
# dimension longer than 32 into a windowed tree reduction that it cannot fuse with the
# elementwise work, so the (rows x frequencies) block would be written to memory and read
# back.  Shaping the frequencies as (blocks, 32), or (blocks, 32, 32) past 1,024 points,
# keeps every reduced dimension at 32 or less and the whole objective in one fused loop
# (benchmarks/scaling.py).  Padding carries weight 0.
_BLOCK = 32


def _blocks(v: Array, fill: float) -> Array:
    """``v`` padded with ``fill`` and shaped so that no dimension exceeds :data:`_BLOCK`
    (up to 32,768 points; beyond that the leading dimension is longer)."""
    n = v.shape[-1]
    tile = (_BLOCK,) if n <= _BLOCK * _BLOCK else (_BLOCK, _BLOCK)
    size = math.prod(tile)
    v = jnp.concatenate([v, jnp.full((-n % size,), fill, dtype=v.dtype)])
    return v.reshape((-1, *tile))


class FrequencyFit(eqx.Module):
    r"""Mean squared complex relative error of the paper model against a target response.

    .. math:: f(x) = \frac1n \sum_i |G(j\omega_i; x) - G_i|^2 / |G_i|^2

    With :math:`G = N / D`, :math:`N = K\omega_s^2` and the denominator of eqs. (15)-(16)
    expanded in powers of :math:`\omega` (so that :math:`\omega^2, \omega^4` are data,
    computed once),

    .. math::

        D(j\omega) = \omega^4 - a_2 \omega^2 + a_0 + j\,\omega (b_1 - b_3 \omega^2), \quad
        a_0 = M\omega_s^2,\ a_2 = M + \omega_s^2 + 2\zeta_s\omega_s/\tau,\
        b_1 = 2\zeta_s\omega_s M + \omega_s^2/\tau,\ b_3 = 2\zeta_s\omega_s + 1/\tau,

    each term is :math:`|N - G_i D|^2 / (|D|^2 |G_i|^2)`: one division per frequency and no
    complex arithmetic.  The data are array fields (flat, as given, and blocked for the
    fused row sum), so a new target of the same shape reuses the compiled run.  Build one
    with :meth:`from_response`.
    """

    w: Float[Array, " freq"]
    target_re: Float[Array, " freq"]
    target_im: Float[Array, " freq"]
    inv_mag2: Float[Array, " freq"]
    # blocked copies, (blocks, 32) or (blocks, 32, 32); padding has weight 0
    w_blocks: Float[Array, "*blocks"]
    w2_blocks: Float[Array, "*blocks"]
    re_blocks: Float[Array, "*blocks"]
    im_blocks: Float[Array, "*blocks"]
    weight_blocks: Float[Array, "*blocks"]

    @classmethod
    def from_response(cls, w, target) -> FrequencyFit:
        w = jnp.asarray(w)
        target = jnp.asarray(target)
        re, im = jnp.real(target), jnp.imag(target)
        inv_mag2 = 1.0 / (re * re + im * im)
        return cls(
            w=w,
            target_re=re,
            target_im=im,
            inv_mag2=inv_mag2,
            w_blocks=_blocks(w, 1.0),
            w2_blocks=_blocks(w * w, 1.0),
            re_blocks=_blocks(re, 1.0),
            im_blocks=_blocks(im, 0.0),
            weight_blocks=_blocks(inv_mag2 / w.shape[0], 0.0),
        )

    def __call__(self, x: Float[Array, " 5"]) -> Float[Array, ""]:
        k, tau, m, ws, zs = x[0], x[1], x[2], x[3], x[4]
        inv_tau = 1.0 / tau
        ws2 = ws * ws
        c = 2.0 * zs * ws
        num = k * ws2
        a0 = m * ws2
        a2 = m + ws2 + c * inv_tau
        b1 = m * c + ws2 * inv_tau
        b3 = c + inv_tau
        w, w2 = self.w_blocks, self.w2_blocks
        d_re = (w2 - a2) * w2 + a0
        d_im = (b1 - b3 * w2) * w
        g_re, g_im = self.re_blocks, self.im_blocks
        e_re = num - (g_re * d_re - g_im * d_im)
        e_im = g_re * d_im + g_im * d_re
        terms = (e_re * e_re + e_im * e_im) * self.weight_blocks / (d_re * d_re + d_im * d_im)
        return jnp.sum(terms)


def helicopter_problem(n_freq: int = 200, w_min: float = 1.0, w_max: float = 60.0) -> Problem:
    """Fit ``(K, tau, M, omega_s, zeta_s)`` to the paper model's own noise-free response on
    ``n_freq`` log-spaced points from ``w_min`` to ``w_max`` rad/s.  Minimum 0 at
    :data:`HELICOPTER_TRUTH`, unique in the box (the servo is the faster pair)."""
    w = jnp.logspace(math.log10(w_min), math.log10(w_max), n_freq)
    target = paper_model_response(jnp.asarray(HELICOPTER_TRUTH), w)
    return Problem(
        "helicopter 5-parameter fit",
        FrequencyFit.from_response(w, target),
        HELICOPTER_LOWER,
        HELICOPTER_UPPER,
        0.0,
        fixed_dim=5,
    )
