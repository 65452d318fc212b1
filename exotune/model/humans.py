"""Human and environment models (docs/method.md#physical-model "Human and environment models").

A human attaches at θ_h with impedance Z_h(s) (torque on the cuff = −Z_h θ_h):

=====================  ===========================  ==========================================
kind                   Z_h(s)                       ranged parameter
=====================  ===========================  ==========================================
``spring``             k + b s                      stiffness k [N·m/rad]
``mass``               m s² + b s                   inertia m [kg·m²]
``msd``                m s² + b s + k               exactly one of inertia/damping/stiffness
``complex_stiffness``  k (1 + j η sign ω)           stiffness k [N·m/rad]; η fixed [–]
=====================  ===========================  ==========================================

Environments attach at θ_j: ``locked`` (θ_j = 0), ``free``, ``spring`` or ``mass`` with a range.

Each family is *linear in its ranged parameter* p: Z(s) = Z0(s) + p·φ(s), which is what makes
the exact stability intervals of :mod:`exotune.analysis` possible.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..units import PARAM_UNITS  # re-exported: the family parameters' units

__all__ = ["HumanFamily", "EnvModel", "PARAM_UNITS", "family_split"]


@dataclass(frozen=True)
class HumanFamily:
    """A human model family over a range of one parameter (the others fixed)."""

    kind: str  # spring | mass | msd | complex_stiffness
    param: str  # the ranged parameter: stiffness | inertia | damping
    lo: float
    hi: float
    inertia: float = 0.0  # fixed values of the non-ranged parameters
    damping: float = 0.0
    stiffness: float = 0.0
    eta: float = 0.0
    #: further ranged parameters of an msd *box* family: ((param, lo, hi), ...). A box is stable
    #: iff every edge is (the Edge Theorem for polytopes of retarded quasi-polynomials, Fu,
    #: Olbrot & Polis 1989), so exotune analyses the box through its edges.
    box: tuple = ()

    @property
    def range(self) -> tuple[float, float]:
        return (self.lo, self.hi)

    @property
    def unit(self) -> str:
        return PARAM_UNITS[self.param]

    def fixed(self) -> dict[str, float]:
        return {"inertia": self.inertia, "damping": self.damping, "stiffness": self.stiffness}

    def edges(self) -> list["HumanFamily"]:
        """The edges of a box family (itself when it has a single ranged parameter): for every
        ranged parameter, one 1-D family per corner of the other ranged parameters."""
        if not self.box:
            return [self]
        import itertools

        ranges = {self.param: (self.lo, self.hi), **{q: (lo, hi) for q, lo, hi in self.box}}
        out = []
        for p, (lo, hi) in ranges.items():
            others = [q for q in ranges if q != p]
            for corner in itertools.product(*[ranges[q] for q in others]):
                fixed = {**self.fixed(), **dict(zip(others, corner))}
                out.append(HumanFamily(self.kind, p, lo, hi, inertia=fixed["inertia"], damping=fixed["damping"],
                                       stiffness=fixed["stiffness"], eta=self.eta))
        return out


@dataclass(frozen=True)
class EnvModel:
    """Environment at the joint: ``locked``, ``free``, or a ``spring``/``mass`` family."""

    kind: str  # locked | free | spring | mass
    param: str | None = None  # stiffness | inertia
    lo: float | None = None
    hi: float | None = None
    damping: float = 0.0


def family_split(kind: str, param: str, fixed: dict[str, float], eta: float = 0.0):
    """Z(s) = Z0(s) + p φ(s): return (z0 ascending coeffs [k, b, m], phi ascending coeffs,
    complex factor applied to φ for ω > 0 (1 + jη for complex stiffness)).

    Parameters
    ----------
    kind : str
        The family's kind (``mass``, ``spring``, ``complex_stiffness``, ``msd``).
    param : str
        The varied parameter (``inertia``, ``damping`` or ``stiffness``).
    fixed : dict of str to float
        The fixed parameters: inertia [kg·m²], damping [N·m·s/rad], stiffness [N·m/rad].
    eta : float, optional
        Loss factor η [–] of a complex stiffness.

    Returns
    -------
    z0 : numpy.ndarray
        Ascending coefficients [k, b, m] of Z0 (the varied slot zero).
    phi : numpy.ndarray
        Ascending coefficients of φ (one 1 in the varied slot).
    factor : complex
        The factor applied to φ for ω > 0.
    """
    m = fixed.get("inertia", 0.0) if kind in ("mass", "msd") else 0.0
    b = fixed.get("damping", 0.0)
    k = fixed.get("stiffness", 0.0) if kind in ("spring", "msd", "complex_stiffness") else 0.0
    z0 = np.array([k, b, m], dtype=float)
    phi = np.zeros(3)
    slot = {"stiffness": 0, "damping": 1, "inertia": 2}[param]
    z0[slot] = 0.0
    phi[slot] = 1.0
    factor = complex(1.0, eta) if kind == "complex_stiffness" else 1.0 + 0j
    return z0, phi, factor
