r"""The unmodelled-effect vocabulary: names, parameters, ranges and frequency responses.

Eight effects can be added to either plant (:mod:`jaxgwo._plants`) in the simulator
(:mod:`jaxgwo._simulate`).  Their names and parameter names are fixed: the sim-to-real
diagnosis uses them as its vocabulary.

============================  ==========================  =======  =======================================
name                          parameters                   linear   definition
============================  ==========================  =======  =======================================
``time_delay``                ``delay_s``                  yes      :math:`e^{-s\,\tau_d}` between command and measured rate
``sensor_lag``                ``cutoff_hz``                yes      :math:`1/(s/\omega_c + 1)` on the measured rate (gyro filter)
``rotor_flapping``            ``tau_f``                    yes      :math:`K/((s^2+s/\tau)(\tau_f s+1)+M)`: lag *inside* the rotor/fuselage loop
``cross_coupling``            ``gain``                     yes      off-axis cyclic drives the on-axis plant: :math:`G(\delta_{on} + g\,\delta_{off})`
``structural_mode``           ``freq_hz, zeta_p, zeta_z``  yes      :math:`(s^2+2\zeta_z\omega s+\omega^2)/(s^2+2\zeta_p\omega s+\omega^2)` on the gyro
``rate_limit``                ``rate``                     no       servo output rate limited to ``rate`` (input units/s)
``backlash``                  ``width``                    no       play of total ``width`` between servo and swashplate
``saturation``                ``limit``                    no       servo position limited to ``+-limit``
============================  ==========================  =======  =======================================

In the simulator every effect is always present, with per-axis parameters of shape
``(2,)`` (lateral, longitudinal) that default to a *neutral* value which switches it off
(delay 0, cutoff inf, ``tau_f`` 0, gain 0, ``zeta_p = zeta_z``, rate inf, width 0, limit
inf).  One compiled simulator therefore serves every combination, and parameters can be
vmapped over.

The linear effects also have a frequency response (:func:`effect_response`,
:func:`paper_model_with_effect`), so a diagnosis can fit "paper model times effect".
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable, Mapping

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Complex, Float, PRNGKeyArray

from ._plants import servo_response
from ._transfer import paper_model_response

__all__ = [
    "AXES",
    "EFFECTS",
    "EffectSpec",
    "EffectSet",
    "TimeDelay",
    "SensorLag",
    "RotorFlapping",
    "CrossCoupling",
    "StructuralMode",
    "RateLimit",
    "Backlash",
    "Saturation",
    "parse_effect",
    "effects_from_strings",
    "draw_effect_params",
    "effect_response",
    "paper_model_with_effect",
    "time_delay_response",
    "sensor_lag_response",
    "structural_mode_response",
    "rotor_flapping_response",
    "cross_coupling_response",
]

AXES = ("lateral", "longitudinal")
"""Axis order of every per-axis ``(2,)`` parameter."""


def _pair(x) -> Float[Array, "2"]:
    return jnp.broadcast_to(jnp.asarray(x, dtype=jnp.float64), (2,))


class TimeDelay(eqx.Module):
    """Pure transport delay between the commanded input and the measured output."""

    delay_s: Float[Array, "2"] = eqx.field(converter=_pair, default=0.0)


class SensorLag(eqx.Module):
    """First-order low-pass on the measured rate (gyro filter), cutoff in Hz."""

    cutoff_hz: Float[Array, "2"] = eqx.field(converter=_pair, default=math.inf)


class RotorFlapping(eqx.Module):
    """Explicit first-order flapping lag ``tau_f`` (s) inside the rotor/fuselage loop."""

    tau_f: Float[Array, "2"] = eqx.field(converter=_pair, default=0.0)


class CrossCoupling(eqx.Module):
    """Off-axis cyclic drives the on-axis plant (same servo and rotor dynamics) times ``gain``."""

    gain: Float[Array, "2"] = eqx.field(converter=_pair, default=0.0)


class StructuralMode(eqx.Module):
    """Lightly damped resonance seen by the gyro: pole damping ``zeta_p``, zero damping ``zeta_z``."""

    freq_hz: Float[Array, "2"] = eqx.field(converter=_pair, default=10.0)
    zeta_p: Float[Array, "2"] = eqx.field(converter=_pair, default=1.0)
    zeta_z: Float[Array, "2"] = eqx.field(converter=_pair, default=1.0)


class RateLimit(eqx.Module):
    """Servo output rate limit, in input units per second."""

    rate: Float[Array, "2"] = eqx.field(converter=_pair, default=math.inf)


class Backlash(eqx.Module):
    """Total play ``width`` (input units) between servo and swashplate."""

    width: Float[Array, "2"] = eqx.field(converter=_pair, default=0.0)


class Saturation(eqx.Module):
    """Servo position limit ``+-limit`` (input units)."""

    limit: Float[Array, "2"] = eqx.field(converter=_pair, default=math.inf)


@dataclasses.dataclass(frozen=True)
class EffectSpec:
    """Registry entry: what the diagnosis needs to know about one effect."""

    name: str
    cls: type
    params: tuple[str, ...]
    units: tuple[str, ...]
    default: tuple[float, ...]
    """A typical *active* value of each parameter (what the CLI uses when none is given)."""
    neutral: tuple[float, ...]
    """The value(s) that switch the effect off."""
    ranges: tuple[tuple[float, float], ...]
    """Realistic range of each parameter for random draws."""
    log_uniform: tuple[bool, ...]
    linear: bool
    description: str


EFFECTS: dict[str, EffectSpec] = {
    s.name: s
    for s in (
        EffectSpec(
            "time_delay", TimeDelay, ("delay_s",), ("s",), (0.03,), (0.0,), ((0.01, 0.08),), (False,), True,
            "pure transport delay between commanded input and measured output",
        ),
        EffectSpec(
            "sensor_lag", SensorLag, ("cutoff_hz",), ("Hz",), (10.0,), (math.inf,), ((5.0, 40.0),), (True,), True,
            "first-order low-pass on the measured rate (gyro filter)",
        ),
        EffectSpec(
            "rotor_flapping", RotorFlapping, ("tau_f",), ("s",), (0.02,), (0.0,), ((0.01, 0.06),), (False,), True,
            "first-order flapping lag inside the rotor/fuselage loop",
        ),
        EffectSpec(
            "cross_coupling", CrossCoupling, ("gain",), ("1",), (0.2,), (0.0,), ((-0.3, 0.3),), (False,), True,
            "off-axis cyclic drives the on-axis rate through the same dynamics, scaled by gain",
        ),
        EffectSpec(
            "structural_mode", StructuralMode, ("freq_hz", "zeta_p", "zeta_z"), ("Hz", "1", "1"),
            (12.0, 0.04, 0.2), (10.0, 1.0, 1.0), ((8.0, 30.0), (0.02, 0.08), (0.1, 0.3)), (True, False, False), True,
            "lightly damped resonance seen by the gyro",
        ),
        EffectSpec(
            "rate_limit", RateLimit, ("rate",), ("1/s",), (3.0,), (math.inf,), ((1.0, 10.0),), (True,), False,
            "servo output rate limit (amplitude-dependent)",
        ),
        EffectSpec(
            "backlash", Backlash, ("width",), ("1",), (0.02,), (0.0,), ((0.005, 0.04),), (True,), False,
            "linkage play between servo and swashplate (amplitude-dependent)",
        ),
        EffectSpec(
            "saturation", Saturation, ("limit",), ("1",), (0.2,), (math.inf,), ((0.1, 0.4),), (False,), False,
            "servo position limit",
        ),
    )
}


def _check_params(name: str, params: Mapping[str, object]) -> EffectSpec:
    if name not in EFFECTS:
        raise ValueError(f"unknown effect {name!r}; known effects: {', '.join(EFFECTS)}")
    spec = EFFECTS[name]
    extra = set(params) - set(spec.params)
    if extra:
        raise ValueError(
            f"effect {name!r} has no parameter(s) {sorted(extra)}; its parameters are: {', '.join(spec.params)}"
        )
    return spec


class EffectSet(eqx.Module):
    """Every effect with per-axis ``(2,)`` parameters; all neutral by default (no effect).

    Fields are named exactly as the vocabulary.  Build one with :meth:`with_effect` or
    :func:`effects_from_strings`; it is a PyTree of arrays, so it can be vmapped over.
    """

    time_delay: TimeDelay = eqx.field(default_factory=TimeDelay)
    sensor_lag: SensorLag = eqx.field(default_factory=SensorLag)
    rotor_flapping: RotorFlapping = eqx.field(default_factory=RotorFlapping)
    cross_coupling: CrossCoupling = eqx.field(default_factory=CrossCoupling)
    structural_mode: StructuralMode = eqx.field(default_factory=StructuralMode)
    rate_limit: RateLimit = eqx.field(default_factory=RateLimit)
    backlash: Backlash = eqx.field(default_factory=Backlash)
    saturation: Saturation = eqx.field(default_factory=Saturation)

    def with_effect(self, name: str, axis: str = "both", **params: float) -> EffectSet:
        """A copy with effect ``name`` switched on for ``axis`` (``lateral``, ``longitudinal``, ``both``).

        Parameters not given take the registry default (a typical active value).
        """
        spec = _check_params(name, params)
        if axis not in ("both", *AXES):
            raise ValueError(f"axis must be 'lateral', 'longitudinal' or 'both'; got {axis!r}")
        mask = jnp.array([axis in ("both", "lateral"), axis in ("both", "longitudinal")])
        old = getattr(self, name)
        values = {}
        for p, default in zip(spec.params, spec.default):
            new = _pair(params.get(p, default))
            values[p] = jnp.where(mask, new, getattr(old, p))
        return eqx.tree_at(lambda s: getattr(s, name), self, spec.cls(**values))

    def active(self) -> tuple[str, ...]:
        """Names of the effects that are not neutral on some axis (needs concrete values)."""
        out = []
        for name, spec in EFFECTS.items():
            eff = getattr(self, name)
            if name == "structural_mode":
                on = np.any(np.asarray(eff.zeta_p) != np.asarray(eff.zeta_z))
            else:
                (p,) = spec.params
                on = np.any(np.asarray(getattr(eff, p)) != spec.neutral[0])
            if on:
                out.append(name)
        return tuple(out)

    def describe(self) -> str:
        """One line per active effect, e.g. ``time_delay: delay_s=(0.03, 0.03)``."""
        lines = []
        for name in self.active():
            eff = getattr(self, name)
            parts = [f"{p}=({', '.join(f'{v:g}' for v in np.asarray(getattr(eff, p)))})" for p in EFFECTS[name].params]
            lines.append(f"{name}: {' '.join(parts)}")
        return "; ".join(lines) if lines else "none"


def parse_effect(text: str) -> tuple[str, dict[str, float], str]:
    """Parse ``NAME[:param=value,...]`` (plus an optional ``axis=lateral|longitudinal|both``).

    Returns ``(name, params, axis)``.  Raises ``ValueError`` naming the problem.
    """
    name, _, rest = text.strip().partition(":")
    name = name.strip()
    params: dict[str, float] = {}
    axis = "both"
    if rest.strip():
        for item in rest.split(","):
            key, eq, value = item.partition("=")
            key = key.strip()
            if not eq or not key:
                raise ValueError(f"effect {text!r}: expected param=value, got {item!r}")
            if key == "axis":
                axis = value.strip()
                continue
            try:
                params[key] = float(value)
            except ValueError:
                raise ValueError(f"effect {text!r}: value of {key!r} is not a number: {value!r}") from None
            if not math.isfinite(params[key]) and key not in ("cutoff_hz", "rate", "limit"):
                raise ValueError(f"effect {text!r}: {key} must be finite")
    _check_params(name, params)
    for p, v in params.items():
        if p == "gain":
            continue  # cross_coupling gain may have either sign
        if p in ("zeta_p", "zeta_z"):
            if not 0.0 < v < 2.0:
                raise ValueError(f"effect {text!r}: {p} must be in (0, 2), got {v:g}")
        elif p in ("delay_s", "tau_f", "width"):
            if v < 0.0:
                raise ValueError(f"effect {text!r}: {p} must be >= 0, got {v:g}")
        elif not v > 0.0:
            raise ValueError(f"effect {text!r}: {p} must be positive, got {v:g}")
    if axis not in ("both", *AXES):
        raise ValueError(f"effect {text!r}: axis must be lateral, longitudinal or both, got {axis!r}")
    return name, params, axis


def effects_from_strings(specs: Iterable[str], base: EffectSet | None = None) -> EffectSet:
    """An :class:`EffectSet` from CLI-style strings ``NAME[:param=value,...,axis=...]``."""
    out = EffectSet() if base is None else base
    for text in specs:
        name, params, axis = parse_effect(text)
        out = out.with_effect(name, axis=axis, **params)
    return out


def draw_effect_params(key: PRNGKeyArray, name: str) -> dict[str, Float[Array, ""]]:
    """One draw of ``name``'s parameters from its realistic range (log-uniform where flagged)."""
    spec = _check_params(name, {})
    keys = jax.random.split(key, len(spec.params))
    out = {}
    for k, p, (lo, hi), log in zip(keys, spec.params, spec.ranges, spec.log_uniform):
        u = jax.random.uniform(k, (), dtype=jnp.float64)
        out[p] = jnp.exp(math.log(lo) + u * math.log(hi / lo)) if log else lo + u * (hi - lo)
    return out


# -- frequency responses of the linear effects (w in rad/s) ---------------------------


def _cdiv(a_re, a_im, b_re, b_im) -> Complex[Array, "..."]:
    """``(a_re + j a_im) / (b_re + j b_im)`` in real arithmetic (strict dtype promotion safe)."""
    mag2 = b_re * b_re + b_im * b_im
    return jax.lax.complex((a_re * b_re + a_im * b_im) / mag2, (a_im * b_re - a_re * b_im) / mag2)


def time_delay_response(w: Float[Array, " freq"], delay_s) -> Complex[Array, " freq"]:
    r""":math:`e^{-j\omega\tau_d}`."""
    phase = w * delay_s
    return jax.lax.complex(jnp.cos(phase), -jnp.sin(phase))


def sensor_lag_response(w: Float[Array, " freq"], cutoff_hz) -> Complex[Array, " freq"]:
    r""":math:`1/(1 + j\omega/\omega_c)`, :math:`\omega_c = 2\pi f_c`: -3 dB and -45 deg at the cutoff."""
    x = w / (2.0 * jnp.pi * cutoff_hz)
    return jax.lax.complex(1.0 / (1.0 + x * x), -x / (1.0 + x * x))


def structural_mode_response(w: Float[Array, " freq"], freq_hz, zeta_p, zeta_z) -> Complex[Array, " freq"]:
    r""":math:`(s^2+2\zeta_z\omega_n s+\omega_n^2)/(s^2+2\zeta_p\omega_n s+\omega_n^2)` at :math:`s=j\omega`.

    At :math:`\omega=\omega_n` the gain is exactly :math:`\zeta_z/\zeta_p`.
    """
    wn = 2.0 * jnp.pi * freq_hz
    base = wn * wn - w * w
    return _cdiv(base, 2.0 * zeta_z * wn * w, base, 2.0 * zeta_p * wn * w)


def rotor_flapping_response(params: Float[Array, " 5"], w: Float[Array, " freq"], tau_f) -> Complex[Array, " freq"]:
    r"""The paper model with an explicit flapping lag inside the loop:

    .. math:: \frac{K}{(s^2 + s/\tau)(\tau_f s + 1) + M}\;\frac{\omega_s^2}{s^2+2\zeta_s\omega_s s+\omega_s^2}

    ``params = (K, tau, M, omega_s, zeta_s)``; equals eqs. (15)-(16) at ``tau_f = 0``.
    """
    k, tau, m, ws, zs = params[0], params[1], params[2], params[3], params[4]
    # (s^2 + s/tau)(tau_f s + 1) + M at s = jw, with s^2 + s/tau = -w^2 + j w/tau
    a_re, a_im = -w * w, w / tau
    den_re = a_re - a_im * tau_f * w + m
    den_im = a_im + a_re * tau_f * w
    rotor = _cdiv(k * jnp.ones_like(w), jnp.zeros_like(w), den_re, den_im)
    return rotor * servo_response(w, ws, zs)


def cross_coupling_response(
    params: Float[Array, " 5"], w: Float[Array, " freq"], gain, cross_ratio: Complex[Array, " freq"] | float = 0.0
) -> Complex[Array, " freq"]:
    r"""On-axis response seen by a single-input estimate when the off-axis cyclic leaks in.

    With :math:`y = G(\delta_{on} + g\,\delta_{off})`, the single-input estimate
    :math:`\hat G = S_{\delta_{on} y}/S_{\delta_{on}\delta_{on}}` is
    :math:`G\,(1 + g\,S_{\delta_{on}\delta_{off}}/S_{\delta_{on}\delta_{on}})`; ``cross_ratio`` is
    that input cross-spectrum ratio (0 for uncorrelated inputs, where the estimate is
    unbiased).  The response to the off-axis input alone is ``gain * G`` (``cross_ratio=inf``
    is not meaningful; call with ``gain`` and use ``paper_model_response`` for that).
    """
    ratio = jnp.asarray(cross_ratio)
    ratio = ratio.astype(jnp.complex128) if not jnp.iscomplexobj(ratio) else ratio
    return paper_model_response(params, w) * (1.0 + jnp.asarray(gain, dtype=jnp.float64).astype(jnp.complex128) * ratio)


def effect_response(name: str, w: Float[Array, " freq"], **params) -> Complex[Array, " freq"]:
    """Series frequency-response factor of a linear effect that multiplies the plant.

    Defined for ``time_delay``, ``sensor_lag`` and ``structural_mode``.  ``rotor_flapping``
    and ``cross_coupling`` act inside the plant, not in series: use
    :func:`paper_model_with_effect`.  The nonlinear effects have no frequency response.
    """
    spec = _check_params(name, params)
    missing = [p for p in spec.params if p not in params]
    if missing:
        raise ValueError(f"effect {name!r} needs parameter(s) {missing}")
    if name == "time_delay":
        return time_delay_response(w, params["delay_s"])
    if name == "sensor_lag":
        return sensor_lag_response(w, params["cutoff_hz"])
    if name == "structural_mode":
        return structural_mode_response(w, params["freq_hz"], params["zeta_p"], params["zeta_z"])
    if not spec.linear:
        raise ValueError(f"effect {name!r} is nonlinear (amplitude-dependent): it has no frequency response")
    raise ValueError(f"effect {name!r} acts inside the plant: use paper_model_with_effect")


def paper_model_with_effect(
    params: Float[Array, " 5"], w: Float[Array, " freq"], name: str, **effect_params
) -> Complex[Array, " freq"]:
    """The paper model, eqs. (15)-(16), with one linear effect applied as the simulator applies it.

    ``time_delay``, ``sensor_lag``, ``structural_mode`` multiply the response;
    ``rotor_flapping`` replaces the rotor/fuselage quadratic (:func:`rotor_flapping_response`);
    ``cross_coupling`` takes an optional ``cross_ratio`` (:func:`cross_coupling_response`).
    """
    if name == "rotor_flapping":
        _check_params(name, effect_params)
        return rotor_flapping_response(params, w, effect_params["tau_f"])
    if name == "cross_coupling":
        ratio = effect_params.pop("cross_ratio", 0.0)
        _check_params(name, effect_params)
        return cross_coupling_response(params, w, effect_params["gain"], ratio)
    return paper_model_response(params, w) * effect_response(name, w, **effect_params)
