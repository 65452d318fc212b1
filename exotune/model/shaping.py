"""SEA compliance shaping and double compliance shaping (paper §II-B, §IV; docs/method.md#double-compliance-shaping).

Two gain-unit conventions exist in the paper (docs/method.md#double-compliance-shaping errata):

* ``"deflection"`` — paper eq. (9): the spring gains multiply the spring *deflection*
  θ_s, so K2 [N·m/rad] and B2 [N·m·s/rad].
* ``"torque"`` — the double-compliance-shaping formulas: the spring gains multiply the spring
  *torque* τ_s = K_s θ_s, so K2 [–] and B2 [s]. exotune uses torque units everywhere else.

They differ by the factor K_s: K2_deflection = K_s · K2_torque, B2_deflection = K_s · B2_torque.
All functions are pure and vectorized (numpy broadcasting over every argument).
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import Literal

import numpy as np

from .plant import Plant
from ..units import GAIN_UNITS_DEFLECTION, GAIN_UNITS_TORQUE, SHAPE_UNITS  # re-exported
from ..numerics.poly import Rational, as_poly, padd, pmul, pscale

GainUnits = Literal["torque", "deflection"]

__all__ = [
    "GainUnits",
    "GAIN_UNITS_TORQUE",
    "GAIN_UNITS_DEFLECTION",
    "SHAPE_UNITS",
    "DesignParams",
    "SeaShape",
    "SeaGains",
    "Gains",
    "DoubleShaping",
    "sea_gains_from_shape",
    "sea_shape_from_gains",
    "to_torque_units",
    "to_deflection_units",
    "double_compliance_shaping",
    "nominal_transfer_functions",
    "sea_passivity_conditions",
]


@dataclass(frozen=True)
class DesignParams:
    """The design parameters of double compliance shaping (docs/method.md#double-compliance-shaping, config ``design:``)."""

    amplification: np.ndarray  # α ≥ 1 [–]
    felt_inertia: np.ndarray  # Ĵ_m/α [kg·m²]
    felt_damping: np.ndarray  # B̂_m/α [N·m·s/rad]
    zeta: np.ndarray  # ζ [–]
    zeta_hat: np.ndarray  # ζ̂ [–]


@dataclass(frozen=True)
class SeaShape:
    """Compliance shape of C4(s) = (s² + B̃2 s + K̃2) / (K_s (s² + B̃1 s + K̃1)) (paper eq. (8))."""

    K1_tilde: np.ndarray  # [1/s²]
    B1_tilde: np.ndarray  # [1/s]
    K2_tilde: np.ndarray  # [1/s²]
    B2_tilde: np.ndarray  # [1/s]


@dataclass(frozen=True)
class SeaGains:
    """Full-state SEA gains ``τ_m = −(K1 + B1 s) θ_m + (K2 + B2 s) x`` with x = θ_s (deflection
    units) or x = τ_s (torque units), as named by ``units``."""

    K1: np.ndarray
    B1: np.ndarray
    K2: np.ndarray
    B2: np.ndarray
    units: GainUnits = "torque"


@dataclass(frozen=True)
class Gains:
    """The six gains of docs/method.md#controller in torque units (see :data:`GAIN_UNITS_TORQUE`)."""

    K1: np.ndarray
    B1: np.ndarray
    K2: np.ndarray
    B2: np.ndarray
    K2_hat: np.ndarray
    B2_hat: np.ndarray

    UNITS = GAIN_UNITS_TORQUE

    def as_dict(self) -> dict:
        return {f.name: getattr(self, f.name) for f in fields(self)}

    def sea(self) -> SeaGains:
        return SeaGains(self.K1, self.B1, self.K2, self.B2, "torque")


def to_torque_units(plant: Plant, g: SeaGains) -> SeaGains:
    """Convert SEA gains to the torque convention (divide the spring gains by K_s).

    Parameters
    ----------
    plant : Plant
        The plant (its K_s [N·m/rad]).
    g : SeaGains
        SEA gains in either convention.

    Returns
    -------
    SeaGains
        The gains in torque units: K1 [N·m/rad], B1 [N·m·s/rad], K2 [–], B2 [s].
    """
    if g.units == "torque":
        return g
    return SeaGains(g.K1, g.B1, g.K2 / plant.K_s, g.B2 / plant.K_s, "torque")


def to_deflection_units(plant: Plant, g: SeaGains) -> SeaGains:
    """Convert SEA gains to the paper's eq. (9) deflection convention (× K_s).

    Parameters
    ----------
    plant : Plant
        The plant (its K_s [N·m/rad]).
    g : SeaGains
        SEA gains in either convention.

    Returns
    -------
    SeaGains
        The gains in deflection units: K1, K2 [N·m/rad], B1, B2 [N·m·s/rad].

    References
    ----------
    Paper eq. (9) (the SEA gains in deflection units).
    """
    if g.units == "deflection":
        return g
    return SeaGains(g.K1, g.B1, g.K2 * plant.K_s, g.B2 * plant.K_s, "deflection")


def sea_gains_from_shape(plant: Plant, shape: SeaShape, units: GainUnits = "torque") -> SeaGains:
    """Compliance shape → gains, paper eq. (9) (deflection units), converted if asked.

    K1 = J_m K̃1, K2 = J_m (K̃2 − K̃1) − K_s, B1 = J_m B̃1 − B_m, B2 = J_m (B̃2 − B̃1).

    Parameters
    ----------
    plant : Plant
        The plant (J_m [kg·m²], B_m [N·m·s/rad], K_s [N·m/rad]).
    shape : SeaShape
        The C4 compliance shape (K̃ [1/s²], B̃ [1/s]).
    units : {"torque", "deflection"}, optional
        The convention of the returned gains.

    Returns
    -------
    SeaGains
        The SEA gains in ``units``.

    References
    ----------
    Paper eq. (9) (the SEA gains from the compliance shape, deflection units).
    """
    J_m, B_m, K_s = plant.J_m, plant.B_m, plant.K_s
    g = SeaGains(
        K1=J_m * shape.K1_tilde,
        B1=J_m * shape.B1_tilde - B_m,
        K2=J_m * (shape.K2_tilde - shape.K1_tilde) - K_s,
        B2=J_m * (shape.B2_tilde - shape.B1_tilde),
        units="deflection",
    )
    return to_torque_units(plant, g) if units == "torque" else g


def sea_shape_from_gains(plant: Plant, gains: SeaGains) -> SeaShape:
    """Gains → compliance shape (inverse of eq. (9); from eq. (7):
    K̃1 = K1/J_m, K̃2 = (K_s + K1 + K2)/J_m, B̃1 = (B_m + B1)/J_m, B̃2 = (B_m + B1 + B2)/J_m with
    K2, B2 in deflection units.

    Parameters
    ----------
    plant : Plant
        The plant (J_m [kg·m²], B_m [N·m·s/rad], K_s [N·m/rad]).
    gains : SeaGains
        SEA gains in either convention.

    Returns
    -------
    SeaShape
        The C4 compliance shape (K̃ [1/s²], B̃ [1/s]).

    References
    ----------
    Paper eqs. (7) and (9) (the SEA compliance C4 and its gains).
    """
    g = to_deflection_units(plant, gains)
    J_m, B_m, K_s = plant.J_m, plant.B_m, plant.K_s
    return SeaShape(
        K1_tilde=g.K1 / J_m,
        B1_tilde=(B_m + g.B1) / J_m,
        K2_tilde=(K_s + g.K1 + g.K2) / J_m,
        B2_tilde=(B_m + g.B1 + g.B2) / J_m,
    )


@dataclass(frozen=True)
class DoubleShaping:
    """Result of double compliance shaping: gains, the C4 shape and the virtual motor."""

    gains: Gains
    shape: SeaShape
    J_m_hat: np.ndarray  # Ĵ_m = α · felt_inertia [kg·m²]
    B_m_hat: np.ndarray  # B̂_m = α · felt_damping [N·m·s/rad]
    warnings: tuple[str, ...] = ()


def double_compliance_shaping(plant: Plant, design: DesignParams) -> DoubleShaping:
    """Double compliance shaping (paper §IV, verified form of docs/method.md#double-compliance-shaping).

    K̃1 = 0, K̃2 = K_s/Ĵ_m, B̃1 = B̂_m/Ĵ_m, B̃2 = 2ζ√(K_s/Ĵ_m);
    K1 = 0, B1 = J_m B̃1 − B_m, K2 = J_m/Ĵ_m − 1 [–], B2 = (B̃2 − B̃1) J_m/K_s [s];
    K̂2 = α − 1, B̂2 = (2ζ̂ √(α K_c Ĵ_m) − B̂_m)/K_c [s].

    Parameters
    ----------
    plant : Plant
        The plant (J_m [kg·m²], B_m [N·m·s/rad], K_s, K_c [N·m/rad]); scalars or batches.
    design : DesignParams
        α [–], felt inertia [kg·m²], felt damping [N·m·s/rad], ζ and ζ̂ [–]; scalars or batches.

    Returns
    -------
    DoubleShaping
        The six gains (torque units), the C4 shape, Ĵ_m [kg·m²], B̂_m [N·m·s/rad] and the
        warnings of assumptions the design breaks.

    References
    ----------
    Paper §IV (double compliance shaping design of the gains).
    """
    a = np.asarray(design.amplification, dtype=float)
    J_m_hat = a * np.asarray(design.felt_inertia, dtype=float)
    B_m_hat = a * np.asarray(design.felt_damping, dtype=float)
    zeta = np.asarray(design.zeta, dtype=float)
    zeta_hat = np.asarray(design.zeta_hat, dtype=float)
    K_s, K_c = plant.K_s, plant.K_c
    K2t = K_s / J_m_hat
    shape = SeaShape(
        K1_tilde=np.zeros(np.broadcast(K2t, B_m_hat).shape),
        B1_tilde=B_m_hat / J_m_hat,
        K2_tilde=K2t,
        B2_tilde=2.0 * zeta * np.sqrt(K2t),
    )
    sea = sea_gains_from_shape(plant, shape, "torque")
    gains = Gains(
        K1=sea.K1,
        B1=sea.B1,
        K2=sea.K2,
        B2=sea.B2,
        K2_hat=a - 1.0,
        B2_hat=(2.0 * zeta_hat * np.sqrt(a * K_c * J_m_hat) - B_m_hat) / K_c,
    )
    return DoubleShaping(gains, shape, J_m_hat, B_m_hat, tuple(_assumption_warnings(plant, gains, J_m_hat, zeta, zeta_hat)))


def _assumption_warnings(plant: Plant, gains: Gains, J_m_hat, zeta, zeta_hat) -> list[str]:
    """Warnings when a (scalar) design leaves the method's assumptions (paper §IV)."""
    out: list[str] = []
    if np.ndim(J_m_hat) or np.ndim(gains.B2_hat):
        return out  # batch: callers use the per-design flags of the analysis instead
    ratio = float(J_m_hat / plant.J_j)
    err = float(plant.J_j / (J_m_hat + plant.J_j))
    if err > 0.1:
        out.append(
            f"J_m_hat/J_j = {ratio:.3g}: the virtual motor inertia is not >> the joint inertia "
            f"(paper §II-C assumes Ĵ_m ≫ J_j), so above the B̂_m/Ĵ_m corner C5 deviates from Ĉ5 by "
            f"≈ J_j/(Ĵ_m + J_j) = {100 * err:.3g} % (the joint inertia adds to the felt inertia)"
        )
    if float(gains.B2_hat) < 0:
        out.append(
            f"B2_hat = {float(gains.B2_hat):.4g} s < 0: negative cuff-torque-rate feedback "
            "(increase zeta_hat or reduce felt_damping); the nominal operator compliance C7 is then not "
            f"passive, short of {-float(gains.B2_hat) / float(J_m_hat):.4g} rad/(N·m·s) (−B̂2/Ĵ_m)"
        )
    if float(gains.B1) < -float(plant.B_m):
        out.append("B1 < -B_m: the closed-loop motor damping is negative")
    if float(gains.B2) < 0:
        out.append(f"B2 = {float(gains.B2):.4g} s < 0: negative spring-torque-rate feedback")
    if not (0 < float(zeta) < 2.0) or not (0 < float(zeta_hat) < 2.0):
        out.append("zeta or zeta_hat outside (0, 2): unusual zero-pair damping")
    return out


def nominal_transfer_functions(plant: Plant, design: DesignParams, ds: DoubleShaping) -> dict[str, Rational]:
    """The nominal (zero delay, no filters) transfer functions of the design, as rationals:

    C4 (paper eq. (8), C5 (eq. (10), Ĉ5 = 1/(Ĵ_m s² + B̂_m s), nominal C7
    (eq. (16) with the erratum fixed: the middle term is 2ζ̂√(αK_c/Ĵ_m)·s) and G_v.

    Parameters
    ----------
    plant : Plant
        The plant.
    design : DesignParams
        The design parameters.
    ds : DoubleShaping
        Its double compliance shaping (:func:`double_compliance_shaping`).

    Returns
    -------
    dict of str to Rational
        ``C4``, ``C5`` [rad/(N·m)], ``C5_hat``, ``C7_nominal`` [rad/(N·m)] and ``G_v`` [–].

    References
    ----------
    Paper eq. (8) (C4), eq. (10) (C5) and eq. (16) (the nominal C7).
    """
    sh = ds.shape
    K_s, J_j, K_c = plant.K_s, plant.J_j, plant.K_c
    num2 = as_poly(sh.K2_tilde, sh.B2_tilde, np.ones_like(sh.K2_tilde))
    den1 = as_poly(sh.K1_tilde, sh.B1_tilde, np.ones_like(sh.K1_tilde))
    C4 = Rational(num2, pscale(den1, K_s))
    s2 = as_poly(0.0 * K_s, 0.0 * K_s, np.ones_like(K_s))
    C5 = Rational(num2, padd(pscale(pmul(s2, num2), J_j), pscale(den1, K_s)))
    C5h = Rational(np.ones_like(ds.J_m_hat)[..., None], as_poly(0.0 * ds.J_m_hat, ds.B_m_hat, ds.J_m_hat))
    w2 = np.asarray(design.amplification, dtype=float) * K_c / ds.J_m_hat
    zh = np.asarray(design.zeta_hat, dtype=float)
    C7 = Rational(
        as_poly(w2, 2.0 * zh * np.sqrt(w2), np.ones_like(w2)),
        pscale(as_poly(0.0 * w2, ds.B_m_hat / ds.J_m_hat, np.ones_like(w2)), K_c),
    )
    ratio = plant.J_m / ds.J_m_hat
    # G_v = (J_m/Ĵ_m)[1 + (J_j/K_s) s²(s² + B̃2 s + K̃2)/(s² + B̃1 s + K̃1)]
    Gv_num = padd(den1, pscale(pmul(s2, num2), J_j / K_s))
    Gv = Rational(pscale(Gv_num, ratio), den1)
    return {"C4": C4, "C5": C5, "C5_hat": C5h, "C7_nominal": C7, "G_v": Gv}


def sea_passivity_conditions(plant: Plant, gains: SeaGains) -> dict[str, bool]:
    """Nominal full-state-feedback passivity conditions of the SEA (deflection units):
    K1 ≥ 0, B1 ≥ −B_m, B2 ≥ 0, K2 ≥ −K_s + B2·K1/(B_m + B1).

    Parameters
    ----------
    plant : Plant
        The plant (B_m [N·m·s/rad], K_s [N·m/rad]).
    gains : SeaGains
        SEA gains in either convention.

    Returns
    -------
    dict of str to bool
        Each condition's text → whether it holds (for every member of a batch).
    """
    g = to_deflection_units(plant, gains)
    B_m, K_s = plant.B_m, plant.K_s
    denom = B_m + g.B1
    with np.errstate(divide="ignore", invalid="ignore"):
        k2_bound = -K_s + np.where(denom != 0, g.B2 * g.K1 / denom, np.inf)
    return {
        "K1 >= 0": bool(np.all(g.K1 >= 0)),
        "B1 >= -B_m": bool(np.all(g.B1 >= -B_m)),
        "B2 >= 0": bool(np.all(g.B2 >= 0)),
        "K2 >= -K_s + B2*K1/(B_m + B1)": bool(np.all(g.K2 >= k2_bound)),
    }


def table_ii(plant: Plant, design: DesignParams, delay_s: float = 0.0) -> dict:
    """Paper Table II (S1…S7 and Ŝ5) for a double-compliance-shaping design with the *nominal*
    (unfiltered) cuff path G_c = G_v (K̂2 + B̂2 s) and the exact delay e^{−sT} in H1.

    Returns the :class:`~exotune.model.plant.CompliancePair` of each system, evaluable at any array of
    complex s. (The implemented, filtered controller is analysed by :mod:`exotune.analysis`.)
    """
    from .plant import Tf, seven_systems

    ds = double_compliance_shaping(plant, design)
    g = ds.gains
    s = Tf.s()
    G_theta = -(Tf.const(g.K1) + g.B1 * s)
    G_s = Tf.const(g.K2) + g.B2 * s
    sh = ds.shape
    G_v = (plant.J_m / ds.J_m_hat) * (
        1.0 + (plant.J_j / plant.K_s) * s * s * (s * s + sh.B2_tilde * s + sh.K2_tilde) / (s * s + sh.B1_tilde * s + sh.K1_tilde)
    )
    G_c = G_v * (Tf.const(g.K2_hat) + g.B2_hat * s)
    return seven_systems(plant, G_theta, G_s, G_c, delay_s=delay_s, J_m_hat=ds.J_m_hat, B_m_hat=ds.B_m_hat)
