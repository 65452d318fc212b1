"""The physical joint, integrated exactly where it is linear.

State x = [θ_m, ω_m, θ_j, ω_j, θ_h, ω_h] (θ_j ≡ ω_j ≡ 0 when the output is locked), inputs the
motor torque τ_m and the muscle torque τ_h, both held over each integration interval:

    J_m θ̈_m + B_m θ̇_m + F_c tanh(θ̇_m/ε) = τ_s + τ_m
    τ_s = K_s · dz(θ_j − θ_m)                     (backlash: dead zone of total width b)
    J_j θ̈_j = τ_c − τ_s,   τ_c = K_c (θ_h − θ_j)
    m θ̈_h + b_h θ̇_h + k_h θ_h = −τ_c + τ_h

Within one *mode* — the spring region (in contact on either side, or in the gap) and the sign of
the friction (|θ̇_m| > 20 ε, where tanh(θ̇_m/ε) is ±1 to double precision) — the plant is affine,
ẋ = A x + B [τ_m, τ_h, 1]ᵀ, and an interval of length h is exact:
[x; u] ← expm([A B; 0 0] h) [x; u] (the zero-order hold of the sampled-data model, paper §V;
:mod:`exotune.sampled`). The propagators are computed once per mode and interval length. An
interval whose start or end leaves its mode (a friction sign change, a backlash edge) is
integrated by ``scipy.integrate.solve_ivp`` (LSODA, stiff-safe) on the nonlinear equations.
"""

from __future__ import annotations

import math

import numpy as np
import scipy.integrate
import scipy.linalg

__all__ = ["JointPlant", "FRICTION_LINEAR", "MIN_HUMAN_INERTIA"]

MIN_HUMAN_INERTIA = 1e-15  # [kg·m²] below it the cuff mode √(K_c/m) (~1e9 rad/s) is beyond double precision

FRICTION_LINEAR = 20.0  # |θ̇_m|/ε above which tanh(θ̇_m/ε) = ±1 exactly in double precision


class JointPlant:
    """The joint of a controller file with a human and nonlinearities (see the module docstring).

    Parameters
    ----------
    plant : dict
        ``{motor_inertia, motor_damping, sea_stiffness, joint_inertia, cuff_stiffness}`` values.
    human : dict
        ``{inertia (> 0), damping, stiffness}`` of the human.
    locked : bool
        Output locked (θ_j ≡ 0).
    nonlinear : Nonlinearities
        Friction, backlash (saturation is applied to τ_m by the caller).

    References
    ----------
    Paper §II (plant) and §V (sampled-data model); docs/method.md#simulation.
    """

    def __init__(self, plant: dict, human: dict, locked: bool, nonlinear):
        self.Jm, self.Bm, self.Ks, self.Jj, self.Kc = (float(plant[k]) for k in (
            "motor_inertia", "motor_damping", "sea_stiffness", "joint_inertia", "cuff_stiffness"))
        self.hm = float(human.get("inertia", 0.0))
        self.hb = float(human.get("damping", 0.0))
        self.hk = float(human.get("stiffness", 0.0))
        if not (math.isfinite(self.hm) and self.hm >= MIN_HUMAN_INERTIA):
            raise ValueError(f"simulate: the human needs a finite inertia ≥ {MIN_HUMAN_INERTIA:g} kg·m² "
                             "(below it the "
                             f"cuff mode is beyond double precision), got {self.hm!r}")
        self.locked = bool(locked)
        self.Fc = float(nonlinear.coulomb_nm)
        self.eps = float(nonlinear.friction_eps_rad_s)
        self.half_gap = 0.5 * float(nonlinear.backlash_rad) if nonlinear.backlash_rad > 0 else 0.0
        self._prop: dict = {}
        self.nonlinear_intervals = 0

    # -- signals ---------------------------------------------------------------------------
    def deflection(self, x) -> float:
        return (0.0 if self.locked else x[2]) - x[0]

    def region(self, x) -> int:
        """Spring region: +1 / −1 in contact beyond the dead zone, 0 in the gap (always +1
        without backlash)."""
        if not self.half_gap:
            return 1
        d = self.deflection(x)
        return 1 if d > self.half_gap else (-1 if d < -self.half_gap else 0)

    def tau_s(self, x) -> float:
        d = self.deflection(x)
        h = self.half_gap
        return self.Ks * (d - h if d > h else (d + h if d < -h else 0.0)) if h else self.Ks * d

    def dtau_s(self, x) -> float:
        """Rate of the spring torque [N·m/s] (0 in the dead zone)."""
        if self.half_gap and self.region(x) == 0:
            return 0.0
        return self.Ks * ((0.0 if self.locked else x[3]) - x[1])

    def tau_c(self, x) -> float:
        return self.Kc * (x[4] - (0.0 if self.locked else x[2]))

    def friction(self, x) -> float:
        return self.Fc * math.tanh(x[1] / self.eps) if self.Fc else 0.0

    def measure(self, x) -> dict:
        """The runtime's sampled signals (θ_m, θ̇_m, τ_s, τ̇_s, τ_c)."""
        return {"theta_m": float(x[0]), "omega_m": float(x[1]), "tau_s": self.tau_s(x), "dtau_s": self.dtau_s(x),
                "tau_c": self.tau_c(x)}

    # -- exact affine pieces ---------------------------------------------------------------
    def mode(self, x):
        """(spring region, friction sign) when the interval starting at x is affine, else None."""
        fs = 0
        if self.Fc:
            if abs(x[1]) <= FRICTION_LINEAR * self.eps:
                return None
            fs = 1 if x[1] > 0 else -1
        return self.region(x), fs

    def in_mode(self, X: np.ndarray, mode) -> np.ndarray:
        """Per row of states ``X`` (K × 6): whether :meth:`mode` of that state is ``mode``."""
        region, fs = mode
        ok = np.ones(X.shape[0], dtype=bool)
        if self.Fc:
            ok &= fs * X[:, 1] > FRICTION_LINEAR * self.eps
        if self.half_gap:
            d = (0.0 if self.locked else X[:, 2]) - X[:, 0]
            ok &= np.where(d > self.half_gap, 1, np.where(d < -self.half_gap, -1, 0)) == region
        return ok

    def affine(self, mode):
        """(A, B) of ẋ = A x + B [τ_m, τ_h, 1] in ``mode``."""
        region, fs = mode
        ks = 0.0 if region == 0 else self.Ks
        c = -region * self.Ks * self.half_gap if region else 0.0  # τ_s = ks·δ + c
        A = np.zeros((6, 6))
        B = np.zeros((6, 3))
        # τ_s as a row over the states
        ts = np.zeros(6)
        ts[0] = -ks
        if not self.locked:
            ts[2] = ks
        tc = np.zeros(6)
        tc[4] = self.Kc
        if not self.locked:
            tc[2] = -self.Kc
        A[0, 1] = 1.0
        A[1] = ts / self.Jm
        A[1, 1] -= self.Bm / self.Jm
        B[1] = [1.0 / self.Jm, 0.0, (c - self.Fc * fs) / self.Jm]
        if not self.locked:
            A[2, 3] = 1.0
            A[3] = (tc - ts) / self.Jj
            B[3, 2] = -c / self.Jj
        A[4, 5] = 1.0
        A[5] = -tc / self.hm
        A[5, 4] -= self.hk / self.hm
        A[5, 5] -= self.hb / self.hm
        B[5, 1] = 1.0 / self.hm
        return A, B

    def propagator(self, mode, h: float):
        """(Φ, Γ) = blocks of expm([A B; 0 0]·h), computed once per (mode, h)."""
        key = (mode, h)
        if key not in self._prop:
            A, B = self.affine(mode)
            M = np.zeros((9, 9))
            M[:6, :6] = A
            M[:6, 6:] = B
            E = scipy.linalg.expm(M * h)
            self._prop[key] = (np.ascontiguousarray(E[:6, :6]), np.ascontiguousarray(E[:6, 6:]))
        return self._prop[key]

    # -- one interval --------------------------------------------------------------------------
    def deriv(self, x, tau_m: float, tau_h: float) -> np.ndarray:
        """ẋ of the nonlinear equations."""
        ts = self.tau_s(x)
        tc = self.tau_c(x)
        dx = np.empty(6)
        dx[0] = x[1]
        dx[1] = (ts + tau_m - self.Bm * x[1] - self.friction(x)) / self.Jm
        dx[2] = 0.0 if self.locked else x[3]
        dx[3] = 0.0 if self.locked else (tc - ts) / self.Jj
        dx[4] = x[5]
        dx[5] = (-tc - self.hb * x[5] - self.hk * x[4] + tau_h) / self.hm
        return dx

    def advance(self, x: np.ndarray, tau_m: float, tau_h: float, h: float) -> np.ndarray:
        """The state after ``h`` seconds with τ_m, τ_h held: exact when the interval stays in one
        affine mode (checked at its end), else by ``solve_ivp`` (LSODA)."""
        if h <= 0:
            return x
        mode = self.mode(x)
        if mode is not None:
            Phi, G = self.propagator(mode, h)
            y = Phi @ x + G @ np.array([tau_m, tau_h, 1.0])
            if self.mode(y) == mode:
                return y
        self.nonlinear_intervals += 1
        scale = 1e-12 * (1.0 + float(np.max(np.abs(x))))
        sol = scipy.integrate.solve_ivp(lambda _t, z: self.deriv(z, tau_m, tau_h), (0.0, h), x, method="LSODA",
                                        rtol=1e-10, atol=scale)
        return sol.y[:, -1] if sol.success else np.full(6, np.nan)
