"""The physical model and the compliance-pair algebra (paper §II, Table II, Propositions 1-4).

Two representations live here:

* :class:`Plant` — the joint-reflected parameters of docs/method.md#physical-model (all fields numpy-broadcastable, so
  one object can hold a million designs).
* :class:`Tf` and :class:`CompliancePair` — transfer functions as *exact frequency-response
  expressions*: a ``Tf`` is evaluated at any array of complex ``s`` by composing the
  elementary rational and delay factors, so ``e^{-sT}`` in ``H1`` is exact (no Padé).
  Propositions 1-4 of the paper are the four operations :func:`parallel`, :func:`series`,
  :func:`virtual_parallel` and :func:`virtual_series`; :func:`seven_systems` builds paper
  Table II (plus the virtual motor system Ŝ5) from a plant and a set of controller blocks.

Sign conventions (paper Table II): ``τ_m = G_θ θ_m + τ_2``, ``τ_2 = G_s τ_s + τ_3``,
``τ_3 = G_c τ_c + τ_6``; with the compliance-shaping controller ``G_θ = −(K1 + B1 s)`` and
``G_s = K2 + B2 s`` (torque units, docs/method.md#double-compliance-shaping).
"""

from __future__ import annotations

from dataclasses import dataclass, fields, replace
from typing import Callable

import numpy as np

from ..units import PLANT_UNITS

from ..numerics.poly import pval

__all__ = [
    "Plant",
    "REFLECTED_FIELDS",
    "Tf",
    "CompliancePair",
    "parallel",
    "series",
    "virtual_parallel",
    "virtual_series",
    "seven_systems",
]


#: the plant fields a transmission ratio r reflects to the joint as r² (paper §IV gain scheduling)
REFLECTED_FIELDS = ("motor_inertia", "motor_damping", "sea_stiffness")


@dataclass(frozen=True)
class Plant:
    """Joint-reflected plant parameters (docs/method.md#physical-model). Units: kg·m², N·m·s/rad, N·m/rad.

    Every field may be a scalar or a numpy array (a batch of plants).
    """

    motor_inertia: np.ndarray  # J_m [kg·m²]
    motor_damping: np.ndarray  # B_m [N·m·s/rad]
    sea_stiffness: np.ndarray  # K_s [N·m/rad]
    joint_inertia: np.ndarray  # J_j [kg·m²]
    cuff_stiffness: np.ndarray = 300.0  # K_c [N·m/rad]

    UNITS = PLANT_UNITS

    @property
    def J_m(self):
        return np.asarray(self.motor_inertia, dtype=float)

    @property
    def B_m(self):
        return np.asarray(self.motor_damping, dtype=float)

    @property
    def K_s(self):
        return np.asarray(self.sea_stiffness, dtype=float)

    @property
    def J_j(self):
        return np.asarray(self.joint_inertia, dtype=float)

    @property
    def K_c(self):
        return np.asarray(self.cuff_stiffness, dtype=float)

    def reflected(self, ratio) -> "Plant":
        """The plant seen through a transmission ratio ``ratio`` [–] (a scalar or an array: one
        plant per ratio): J_m, B_m and K_s × ratio² (paper §IV gain scheduling).

        Parameters
        ----------
        ratio : float or numpy.ndarray
            Transmission ratio(s) [–].

        Returns
        -------
        Plant
            The reflected plant.
        """
        r2 = np.asarray(ratio, dtype=float) ** 2
        return replace(self, **{k: np.asarray(getattr(self, k), dtype=float) * r2 for k in REFLECTED_FIELDS})

    def to_control(self, index: int = 0):
        """The plant as a ``control.StateSpace`` (paper §II, Fig. 2; docs/method.md#physical-model):

        J_m θ̈_m + B_m θ̇_m = τ_s + τ_m,   J_j θ̈_j = τ_c − τ_s,   τ_s = K_s (θ_j − θ_m).

        States ``[θ_m, θ̇_m, θ_j, θ̇_j]`` [rad, rad/s]; inputs ``tau_m`` (motor torque) and
        ``tau_c`` (cuff torque on the joint) [N·m]; outputs ``theta_m``, ``theta_j`` [rad] and
        ``tau_s`` [N·m]. The cuff spring K_c joins θ_j to the human: close that loop with a human
        model. ``index`` picks one member of a batched plant.

        Examples
        --------
        >>> Plant(0.44, 17.9, 1180.0, 0.29, 300.0).to_control().nstates
        4
        """
        import control

        def v(x):
            a = np.asarray(x, dtype=float).ravel()
            return float(a[index] if a.size > 1 else a[0])

        Jm, Bm, Ks, Jj = v(self.motor_inertia), v(self.motor_damping), v(self.sea_stiffness), v(self.joint_inertia)
        A = np.array([[0.0, 1.0, 0.0, 0.0],
                      [-Ks / Jm, -Bm / Jm, Ks / Jm, 0.0],
                      [0.0, 0.0, 0.0, 1.0],
                      [Ks / Jj, 0.0, -Ks / Jj, 0.0]])
        B = np.array([[0.0, 0.0], [1.0 / Jm, 0.0], [0.0, 0.0], [0.0, 1.0 / Jj]])
        C = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [-Ks, 0.0, Ks, 0.0]])
        return control.ss(A, B, C, np.zeros((3, 2)), inputs=["tau_m", "tau_c"],
                          outputs=["theta_m", "theta_j", "tau_s"],
                          states=["theta_m", "omega_m", "theta_j", "omega_j"], name="plant")

    def as_dict(self) -> dict:
        return {f.name: getattr(self, f.name) for f in fields(self)}


class Tf:
    """A transfer function as an exact, lazily composed frequency-response expression.

    ``Tf(fn)(s)`` evaluates ``fn`` at an array of complex ``s``. Arithmetic (+, -, *, /, unary -,
    :meth:`inv`) composes expressions, so rational factors and exact delays mix freely.
    """

    __slots__ = ("_fn", "label")
    # make numpy defer to Tf's reflected operators (array * Tf -> Tf.__rmul__)
    __array_ufunc__ = None

    def __init__(self, fn: Callable[[np.ndarray], np.ndarray], label: str = ""):
        self._fn = fn
        self.label = label

    def __call__(self, s) -> np.ndarray:
        s = np.asarray(s, dtype=complex)
        return np.asarray(self._fn(s))

    # constructors -------------------------------------------------------------------------
    @staticmethod
    def const(k) -> "Tf":
        k = np.asarray(k)
        return Tf(lambda s: k * np.ones_like(s), "const")

    @staticmethod
    def rational(num, den) -> "Tf":
        """num/den with **ascending** coefficients (scalars per coefficient)."""
        num = np.asarray(num, dtype=float)
        den = np.asarray(den, dtype=float)
        return Tf(lambda s: pval(num, s) / pval(den, s), "rational")

    @staticmethod
    def s() -> "Tf":
        return Tf(lambda s: s, "s")

    @staticmethod
    def delay(T) -> "Tf":
        """The exact delay factor e^{-sT}."""
        T = np.asarray(T, dtype=float)
        return Tf(lambda s: np.exp(-s * T), "delay")

    @staticmethod
    def _lift(x) -> "Tf":
        return x if isinstance(x, Tf) else Tf.const(x)

    # algebra ------------------------------------------------------------------------------
    def __add__(self, o):
        o = Tf._lift(o)
        return Tf(lambda s: self(s) + o(s))

    __radd__ = __add__

    def __sub__(self, o):
        o = Tf._lift(o)
        return Tf(lambda s: self(s) - o(s))

    def __rsub__(self, o):
        return Tf._lift(o) - self

    def __mul__(self, o):
        o = Tf._lift(o)
        return Tf(lambda s: self(s) * o(s))

    __rmul__ = __mul__

    def __truediv__(self, o):
        o = Tf._lift(o)
        return Tf(lambda s: self(s) / o(s))

    def __rtruediv__(self, o):
        return Tf._lift(o) / self

    def __neg__(self):
        return Tf(lambda s: -self(s))

    def inv(self) -> "Tf":
        return Tf(lambda s: 1.0 / self(s))


@dataclass(frozen=True)
class CompliancePair:
    """A "system" of the paper: (external compliance C, motor compliance H) (paper §II)."""

    C: Tf
    H: Tf


def parallel(S: CompliancePair, C2: Tf) -> CompliancePair:
    """Proposition 1 (Systems in Parallel): ([C1⁻¹ + C2⁻¹]⁻¹, [C1⁻¹ + C2⁻¹]⁻¹ C1⁻¹ H1).

    Parameters
    ----------
    S : CompliancePair
        The system (C1, H1).
    C2 : Tf
        The compliance put in parallel [rad/(N·m)].

    Returns
    -------
    CompliancePair
        The interconnection.

    References
    ----------
    Paper Proposition 1 (systems in parallel).
    """
    C = (S.C.inv() + Tf._lift(C2).inv()).inv()
    return CompliancePair(C, C / S.C * S.H)


def series(S: CompliancePair, C2: Tf) -> CompliancePair:
    """Proposition 2 (Systems in Series): (C1 + C2, H1).

    Parameters
    ----------
    S : CompliancePair
        The system (C1, H1).
    C2 : Tf
        The compliance put in series [rad/(N·m)].

    Returns
    -------
    CompliancePair
        The interconnection.

    References
    ----------
    Paper Proposition 2 (systems in series).
    """
    return CompliancePair(S.C + C2, S.H)


def virtual_parallel(S: CompliancePair, G: Tf) -> Tf:
    """Proposition 3: a position controller ``τ_m = G θ + τ'`` equals the parallel compliance
    C' = −C1 / (H1 G).

    Parameters
    ----------
    S : CompliancePair
        The system (C1, H1).
    G : Tf
        The position controller [N·m/rad].

    Returns
    -------
    Tf
        The virtual parallel compliance C' [rad/(N·m)].

    References
    ----------
    Paper Proposition 3 (virtual parallel systems of a position controller).
    """
    return -S.C / (S.H * G)


def virtual_series(S: CompliancePair, G: Tf) -> Tf:
    """Proposition 4: a force controller ``τ_m = G τ + τ'`` equals the series compliance
    C' = G H1.

    Parameters
    ----------
    S : CompliancePair
        The system (C1, H1).
    G : Tf
        The force controller [–].

    Returns
    -------
    Tf
        The virtual series compliance C' [rad/(N·m)].

    References
    ----------
    Paper Proposition 4 (virtual series systems of a force controller).
    """
    return Tf._lift(G) * S.H


def seven_systems(
    plant: Plant,
    G_theta: Tf,
    G_s: Tf,
    G_c: Tf,
    delay_s: float = 0.0,
    actuator: Tf | None = None,
    J_m_hat=None,
    B_m_hat=None,
) -> dict[str, CompliancePair]:
    """Paper Table II: S1…S7 (and Ŝ5 when ``J_m_hat``/``B_m_hat`` are given).

    ``actuator`` replaces the pure delay e^{-sT} in H1 when given (e.g. the DOB-modified
    actuator path of docs/method.md#controller); by default H1 = e^{-sT}/(J_m s² + B_m s).

    Parameters
    ----------
    plant : Plant
        The plant (J_m [kg·m²], B_m [N·m·s/rad], K_s, K_c [N·m/rad], J_j [kg·m²]).
    G_theta : Tf
        Motor position block G_θ [N·m/rad].
    G_s : Tf
        Spring torque block G_s [–].
    G_c : Tf
        Cuff torque block G_c [–].
    delay_s : float, optional
        Actuation delay T [s] of H1.
    actuator : Tf or None, optional
        The actuator path replacing e^{-sT}; None for the pure delay.
    J_m_hat, B_m_hat : array_like or None, optional
        Virtual motor inertia Ĵ_m [kg·m²] and damping B̂_m [N·m·s/rad] of Ŝ5.

    Returns
    -------
    dict of str to CompliancePair
        ``S1`` … ``S7`` (and ``S5_hat``).

    References
    ----------
    Paper Table II (the seven system interconnections); docs/method.md#controller.
    """
    s = Tf.s()
    M = plant.J_m * s * s + plant.B_m * s
    C1 = M.inv()
    E = actuator if actuator is not None else Tf.delay(delay_s)
    S1 = CompliancePair(C1, E * C1)
    S2 = parallel(S1, virtual_parallel(S1, G_theta))
    S3 = series(S2, virtual_series(S2, G_s))
    S4 = series(S3, Tf.const(1.0 / plant.K_s))
    S5 = parallel(S4, (plant.J_j * s * s).inv())
    S6 = series(S5, virtual_series(S5, G_c))
    S7 = series(S6, Tf.const(1.0 / plant.K_c))
    out = {"S1": S1, "S2": S2, "S3": S3, "S4": S4, "S5": S5, "S6": S6, "S7": S7}
    if J_m_hat is not None:
        C5h = (J_m_hat * s * s + B_m_hat * s).inv()
        out["S5_hat"] = CompliancePair(C5h, C5h)
    return out
