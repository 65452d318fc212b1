"""The controller the runtime executes, as an explicit, swappable structure (docs/method.md#controller, paper §II-B–§IV).

A :class:`ControllerStructure` is a set of rational blocks acting on the three sensed signals plus
an optional transmission disturbance observer and the actuation delay:

    τ_cmd = G_θ(s) θ_m + G_s(s) τ_s + G_c(s) τ_c − δ̂,      τ_m(t) = τ_cmd(t − T)
    δ̂ = Q(s) [ (J_m s² + B_m s) θ_m − τ_s − τ_cmd ]              (paper eq. (15)

The analysis engine (:mod:`exotune.analysis`) works on *any* such structure; this module builds
the named structures from a plant, a design and an implementation:

``"default"``   docs/method.md#controller: G_c,impl = (J_m/Ĵ_m)[1 + (J_j/K_s) F_v s(s²+B̃2 s+K̃2)/(s+B̃1)] (K̂2 + B̂2 s F_d)
``"full_filter"``  the paper's prediction-step structure (paper §IV): the whole improper
                cuff path G_v (K̂2 + B̂2 s) is multiplied by F_v F_d (one filter on the signal).

Velocities in the B1 and B2 terms are ideal (plant states) unless ``velocity_filter`` is given,
in which case ``B1 s`` and ``B2 s`` are replaced by ``B1 s F_vel`` and ``B2 s F_vel`` with
F_vel = ω/(s + ω) (a named option).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .plant import Plant
from ..numerics.poly import Rational, as_poly, padd, pmul, pscale
from .shaping import DesignParams, DoubleShaping, Gains, double_compliance_shaping

__all__ = [
    "SecondOrderFilter",
    "FirstOrderFilter",
    "Implementation",
    "ControllerStructure",
    "STRUCTURES",
    "build_controller",
    "second_order_lowpass",
    "first_order_lowpass",
]


@dataclass(frozen=True)
class SecondOrderFilter:
    """ω²/(s² + 2ζω s + ω²), ω = 2π·cutoff_hz."""

    cutoff_hz: np.ndarray
    damping: np.ndarray = 0.7


@dataclass(frozen=True)
class FirstOrderFilter:
    """ω/(s + ω), ω = 2π·cutoff_hz."""

    cutoff_hz: np.ndarray


@dataclass(frozen=True)
class Implementation:
    """What the runtime really does (docs/method.md#controller, config ``implementation:``)."""

    delay_s: np.ndarray = 0.0
    sample_rate_hz: float | None = None
    gv_filter: SecondOrderFilter | None = None
    derivative_filter: FirstOrderFilter | None = None
    dob: SecondOrderFilter | None = None
    velocity_filter: FirstOrderFilter | None = None
    structure: str = "default"


def second_order_lowpass(f: SecondOrderFilter) -> Rational:
    """The low-pass ω²/(s² + 2ζω s + ω²), ω = 2π·cutoff (a batch when the filter's fields are arrays).

    Parameters
    ----------
    f : SecondOrderFilter
        Cutoff [Hz] and damping ratio ζ [–].

    Returns
    -------
    Rational
        The filter, unit DC gain.
    """
    w = 2.0 * np.pi * np.asarray(f.cutoff_hz, dtype=float)
    z = np.asarray(f.damping, dtype=float)
    w, z = np.broadcast_arrays(w, z)
    return Rational((w * w)[..., None], as_poly(w * w, 2.0 * z * w, np.ones_like(w)))


def first_order_lowpass(f: FirstOrderFilter) -> Rational:
    """The low-pass ω/(s + ω), ω = 2π·cutoff (a batch when the cutoff is an array).

    Parameters
    ----------
    f : FirstOrderFilter
        Cutoff [Hz].

    Returns
    -------
    Rational
        The filter, unit DC gain.
    """
    w = 2.0 * np.pi * np.asarray(f.cutoff_hz, dtype=float)
    return Rational(w[..., None], as_poly(w, np.ones_like(w)))


@dataclass(frozen=True)
class ControllerStructure:
    """Rational controller blocks (batched) + DOB + delay. See the module docstring."""

    motor_position: Rational  # G_θ, acts on θ_m  [N·m/rad]
    spring_torque: Rational  # G_s, acts on τ_s  [–]
    cuff_torque: Rational  # G_c, acts on τ_c  [–]
    dob_q: Rational | None  # Q(s) or None
    delay_s: np.ndarray  # T [s]
    name: str = "default"
    gains: Gains | None = field(default=None, compare=False)

    def blocks(self) -> dict[str, Rational]:
        return {"theta_m": self.motor_position, "tau_s": self.spring_torque, "tau_c": self.cuff_torque}

    def to_control(self, index: int = 0) -> dict:
        """The blocks of paper Fig. 3 as python-control transfer functions (docs/method.md#controller):
        τ_cmd = G_θ θ_m + G_s τ_s + G_c τ_c (minus the DOB's estimate), applied after ``delay_s``.

        Returns ``{"G_theta": [N·m/rad], "G_s": [–], "G_c": [–], "Q": DOB filter or None,
        "delay_s": float [s]}`` for member ``index`` of a batch.
        """
        d = np.asarray(self.delay_s, dtype=float).ravel()
        return {
            "G_theta": self.motor_position.to_control(index),
            "G_s": self.spring_torque.to_control(index),
            "G_c": self.cuff_torque.to_control(index),
            "Q": None if self.dob_q is None else self.dob_q.to_control(index),
            "delay_s": float(d[index] if d.size > 1 else d[0]),
        }


def _sea_blocks(g: Gains, impl: Implementation) -> tuple[Rational, Rational]:
    K1, B1, K2, B2 = (np.asarray(x, dtype=float) for x in (g.K1, g.B1, g.K2, g.B2))
    if impl.velocity_filter is None:
        return Rational.poly(as_poly(-K1, -B1)), Rational.poly(as_poly(K2, B2))
    F = first_order_lowpass(impl.velocity_filter)
    s = Rational.poly(as_poly(0.0, 1.0))
    Gt = Rational.const(-K1) + (s * F) * Rational.const(-B1)
    Gs = Rational.const(K2) + (s * F) * Rational.const(B2)
    return Gt, Gs


def _cuff_default(plant: Plant, ds: DoubleShaping, impl: Implementation) -> Rational:
    """docs/method.md#controller default G_c,impl (uses K̃1 = 0)."""
    if impl.gv_filter is None or impl.derivative_filter is None:
        raise ValueError(
            "implementation.gv_filter and implementation.derivative_filter are required: the ideal "
            "cuff path G_v(s)(K̂2 + B̂2 s) is improper and cannot be implemented or analysed"
        )
    sh, g = ds.shape, ds.gains
    Fv = second_order_lowpass(impl.gv_filter)
    Fd = first_order_lowpass(impl.derivative_filter)
    c = plant.J_j / plant.K_s
    num2 = as_poly(0.0 * sh.K2_tilde, sh.K2_tilde, sh.B2_tilde, np.ones_like(sh.K2_tilde))  # s(s²+B̃2 s+K̃2)
    den1 = as_poly(sh.B1_tilde, np.ones_like(sh.B1_tilde))  # s + B̃1
    inner = Rational(
        padd(pmul(Fv.den, den1), pscale(pmul(Fv.num, num2), c)),
        pmul(Fv.den, den1),
    )
    outer = Rational.const(g.K2_hat) + Rational.poly(as_poly(0.0 * g.B2_hat, g.B2_hat)) * Fd
    return Rational.const(plant.J_m / ds.J_m_hat) * inner * outer


def _cuff_full_filter(plant: Plant, ds: DoubleShaping, impl: Implementation) -> Rational:
    """Alternative: F_v F_d · G_v (K̂2 + B̂2 s) with G_v in its K̃1 = 0 reduced form."""
    if impl.gv_filter is None or impl.derivative_filter is None:
        raise ValueError("implementation.gv_filter and implementation.derivative_filter are required")
    sh, g = ds.shape, ds.gains
    c = plant.J_j / plant.K_s
    num2 = as_poly(0.0 * sh.K2_tilde, sh.K2_tilde, sh.B2_tilde, np.ones_like(sh.K2_tilde))
    den1 = as_poly(sh.B1_tilde, np.ones_like(sh.B1_tilde))
    Gv = Rational(padd(den1, pscale(num2, c)), den1) * Rational.const(plant.J_m / ds.J_m_hat)
    return second_order_lowpass(impl.gv_filter) * first_order_lowpass(impl.derivative_filter) * Gv * Rational.poly(
        as_poly(g.K2_hat, g.B2_hat)
    )


STRUCTURES = {
    "default": _cuff_default,
    "full_filter": _cuff_full_filter,
}


def build_controller(
    plant: Plant, design: DesignParams, impl: Implementation
) -> tuple[ControllerStructure, DoubleShaping]:
    """Double compliance shaping → the implemented controller structure named by ``impl.structure``.

    Parameters
    ----------
    plant : Plant
        The plant.
    design : DesignParams
        The design parameters.
    impl : Implementation
        The implementation (structure, filters, DOB, delay [s]).

    Returns
    -------
    cs : ControllerStructure
        The controller blocks G_θ, G_s, G_c, the DOB's Q and the delay [s].
    ds : DoubleShaping
        The shaping it was built from.

    Raises
    ------
    ValueError
        When ``impl.structure`` is unknown.
    """
    ds = double_compliance_shaping(plant, design)
    if impl.structure not in STRUCTURES:
        raise ValueError(f"unknown controller structure {impl.structure!r}; known: {sorted(STRUCTURES)}")
    Gt, Gs = _sea_blocks(ds.gains, impl)
    Gc = STRUCTURES[impl.structure](plant, ds, impl)
    Q = second_order_lowpass(impl.dob) if impl.dob is not None else None
    cs = ControllerStructure(Gt, Gs, Gc, Q, np.asarray(impl.delay_s, dtype=float), impl.structure, ds.gains)
    return cs, ds
