"""The scenarios of ``exotune simulate`` and the nonlinearities a real joint has.

Each :class:`Scenario` names what it exercises: ``locked-output`` (the delivered amplification
(τ_c − τ_s)/τ_c → α), ``dob-friction`` (Coulomb friction on the motor: the DOB's disturbance
estimate against the true friction), ``light-mass`` (a light human released from a cuff
deflection: does the oscillation grow or decay?), ``saturation`` (a push beyond the motor limit,
released: windup recovery with and without the runtime's clamp) and ``backlash`` (a dead zone in
the SEA spring: a limit cycle, or its absence, and its frequency).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["Nonlinearities", "Scenario", "SCENARIOS", "deadzone"]


@dataclass(frozen=True)
class Nonlinearities:
    """The joint's nonlinearities (all off by default).

    Attributes: ``coulomb_nm`` F_c [N·m] (motor-side Coulomb friction F_c·tanh(θ̇_m/ε)),
    ``friction_eps_rad_s`` ε [rad/s], ``backlash_rad`` total dead-zone width b [rad] in the SEA
    spring, ``saturation_nm`` motor torque limit [N·m].
    """

    coulomb_nm: float = 0.0
    friction_eps_rad_s: float = 1e-3
    backlash_rad: float = 0.0
    saturation_nm: float = math.inf


@dataclass(frozen=True)
class Scenario:
    """One time-domain experiment: the human (inertia, damping, stiffness), the muscle torque
    τ_h(t) (a step of ``push_nm`` from ``push_at_s`` until ``release_at_s``, or a sine of
    ``push_hz`` when > 0), the initial cuff deflection ``theta_h0`` [rad], the nonlinearities and
    the default duration [s]. ``reference_rad`` > 0: a motor-position reference
    θ_ref(t) = reference_rad · (1 − cos(2π ``reference_hz`` t)) (a sinusoid about reference_rad,
    starting at rest) tracked by the controller's own position
    and velocity gains (a position-control SEA, as in the paper's DOB test of Fig. 9): the runtime
    adds −g_θm θ_ref − g_ωm θ̇_ref to its command before the DOB's loop solve, so the DOB books it
    as commanded torque."""

    name: str
    description: str
    locked: bool
    human: dict
    push_nm: float
    push_at_s: float
    duration_s: float
    theta_h0: float = 0.0
    nonlinear: Nonlinearities = Nonlinearities()
    compare_without_dob: bool = False
    push_hz: float = 0.0
    release_at_s: float = math.inf
    reference_rad: float = 0.0
    reference_hz: float = 0.0

    def reference(self, t: float) -> tuple[float, float]:
        """Motor-position reference θ_ref [rad] and its rate θ̇_ref [rad/s] at time ``t`` [s]."""
        if self.reference_rad == 0.0:
            return 0.0, 0.0
        w = 2 * math.pi * self.reference_hz
        return self.reference_rad * (1.0 - math.cos(w * t)), self.reference_rad * w * math.sin(w * t)

    def push(self, t: float) -> float:
        """Muscle torque τ_h [N·m] at time ``t`` [s] (held over each sample)."""
        if t < self.push_at_s or t >= self.release_at_s:
            return 0.0
        if self.push_hz > 0:
            return self.push_nm * math.sin(2 * math.pi * self.push_hz * (t - self.push_at_s))
        return self.push_nm


SCENARIOS = {
    "locked-output": Scenario(
        "locked-output", "output locked; the human (0.5 kg·m², 2 N·m·s/rad) pushes a 5 N·m step",
        True, {"inertia": 0.5, "damping": 2.0}, 5.0, 0.05, 6.0),
    "dob-friction": Scenario(
        "dob-friction", "free output; the human (0.5 kg·m²) moves the joint with a 3 N·m, 0.5 Hz torque against "
        "2 N·m Coulomb friction on the motor; the DOB's friction estimate, and the joint with and without the DOB",
        False, {"inertia": 0.5, "damping": 2.0}, 3.0, 0.0, 6.0,  # 3 push periods: the envelope compares
        nonlinear=Nonlinearities(coulomb_nm=2.0), compare_without_dob=True, push_hz=0.5),  # one period with the next
    "light-mass": Scenario(
        "light-mass", "free output; a light human mass (default 5e-3 kg·m²) released from a 0.01 rad cuff "
        "deflection: does the oscillation grow or decay?", False, {"inertia": 5e-3}, 0.0, 0.0, 10.0, theta_h0=0.01),
    "saturation": Scenario(
        "saturation", "locked output; a 20 N·m push (released at 1 s) with the motor limited to 40 N·m: windup "
        "recovery with the runtime's clamp (the DOB sees the applied command) and without it",
        True, {"inertia": 0.5, "damping": 2.0}, 20.0, 0.05, 2.5,
        nonlinear=Nonlinearities(saturation_nm=40.0), release_at_s=1.0),
    "backlash": Scenario(
        "backlash", "free output; the human (0.5 kg·m², 2 N·m·s/rad) released from a 0.01 rad cuff deflection with "
        "a 0.005 rad dead zone in the SEA spring: is there a limit cycle (against the same run without backlash)?",
        False, {"inertia": 0.5, "damping": 2.0}, 0.0, 0.0, 4.0, theta_h0=0.01,
        nonlinear=Nonlinearities(backlash_rad=0.005)),
}


def deadzone(x: float, b: float) -> float:
    """Dead zone of total width ``b``: 0 for |x| ≤ b/2, else x ∓ b/2 (backlash in the spring).

    Parameters
    ----------
    x : float
        The input (e.g. a deflection [rad]).
    b : float
        Total width of the dead zone, in the unit of ``x``; ≤ 0 for none.

    Returns
    -------
    float
        The output.
    """
    if b <= 0:
        return x
    h = 0.5 * b
    return x - h if x > h else (x + h if x < -h else 0.0)
