"""Numbers of ``exotune sea``: a plain SEA compliance-shaping controller (paper §II-B).

The compliance shape of the gains, the closed-loop low-frequency stiffness, the resonance and the
poles of C5 = θ_j/τ_j (paper eq. (10), the nominal passivity conditions and the phase
extremes of C4(jω).
"""

from __future__ import annotations

import math

from ..units import SEA_UNITS  # re-exported
from ..version import __version__
from .results import SeaReport
from ..numerics.poly import Rational
from .design_summary import phase_extremum, resonance, root_entries

__all__ = ["sea_report", "SEA_UNITS"]

def _notes(K1t, rigid, stable, res_hz, max_ph) -> list[str]:
    notes = []
    if K1t == 0:
        notes.append("K1 = 0: no motor-position feedback, so the closed-loop SEA has zero static stiffness")
    if rigid:
        notes.append("C5 has a pole at s = 0 (rigid-body mode of the free joint, not an instability)")
    if not stable:
        notes.append("C5 has poles with Re ≥ 0 (other than a rigid-body pole at 0): the SEA with the joint inertia is unstable")
    if res_hz is None:
        notes.append("|C5(jω)| has no resonant peak")
    if max_ph > 0:
        notes.append("C4 phase exceeds 0°: the SEA compliance is not passive at those frequencies")
    return notes


def sea_report(cfg) -> SeaReport:
    """Everything ``exotune sea`` prints, as a typed :class:`~exotune.analysis.results.SeaReport`.

    Compliance shape, closed-loop stiffness, resonance of C5 (paper eq. (10), nominal
    passivity conditions and the phase extremes of C4(jω) (a compliance is passive where its phase
    is in [−180°, 0°]).

    Parameters
    ----------
    cfg : exotune.config.design.SeaConfig
        A loaded SEA file (plant and gains).

    Returns
    -------
    SeaReport
        ``to_dict()`` is the ``--json`` object of ``exotune sea``.

    References
    ----------
    Paper §II-B (SEA compliance shaping), eq. (10); docs/method.md#passivity.
    """
    import numpy as np

    from ..model.plant import Plant
    from ..numerics.poly import as_poly, is_hurwitz, padd, pmul, pscale
    from ..model.shaping import (
        GAIN_UNITS_DEFLECTION,
        GAIN_UNITS_TORQUE,
        SHAPE_UNITS,
        sea_passivity_conditions,
        sea_shape_from_gains,
        to_deflection_units,
        to_torque_units,
    )

    plant, gains = cfg.plant, cfg.gains
    sh = sea_shape_from_gains(plant, gains)
    K1t, B1t, K2t, B2t = (float(x) for x in (sh.K1_tilde, sh.B1_tilde, sh.K2_tilde, sh.B2_tilde))
    K_s, J_j = float(plant.K_s), float(plant.J_j)
    num2 = as_poly(K2t, B2t, 1.0)
    den1 = as_poly(K1t, B1t, 1.0)
    c4 = Rational(num2, pscale(den1, K_s)).minimal()
    s2 = as_poly(0.0, 0.0, 1.0)
    c5_den_full = padd(pscale(pmul(s2, num2), J_j), pscale(den1, K_s))
    c5 = Rational(num2, c5_den_full).minimal()

    # stiffness = 1/C4(0) = K_s K̃1/K̃2 (after cancelling common roots at 0)
    n0, d0 = c4.num[0], c4.den[0]
    stiffness = math.inf if n0 == 0 else float(d0 / n0)

    poles = c5.poles()
    rigid = bool(c5.den[0] == 0)  # exact pole at s = 0 (K1 = 0): rigid-body mode, not an instability
    # every other pole in Re s < 0, decided exactly (Routh on the coefficients): poles on the
    # imaginary axis (a lossless SEA, B_m + B1 = 0) come back from the eigenvalue solver with
    # rounding-sized real parts of either sign, and a pole that K1 puts within 1e-300 of 0 as 0
    stable = is_hurwitz(np.ravel(c5.den)[1:] if rigid else np.ravel(c5.den))
    res_hz, res_peak = resonance(c5)
    max_ph, max_hz = phase_extremum(c4, sign=+1)
    min_ph, min_hz = phase_extremum(c4, sign=-1)
    cond = sea_passivity_conditions(plant, gains)
    gt, gd = to_torque_units(plant, gains), to_deflection_units(plant, gains)
    notes = _notes(K1t, rigid, stable, res_hz, max_ph)
    return SeaReport.from_record({
        "exotune_version": __version__,
        "source": cfg.source,
        "plant": {k: float(v) for k, v in plant.as_dict().items()},
        "plant_units": dict(Plant.UNITS),
        "input_gain_units": gains.units,
        "gains_torque": {k: float(getattr(gt, k)) for k in ("K1", "B1", "K2", "B2")},
        "gains_torque_units": {k: GAIN_UNITS_TORQUE[k] for k in ("K1", "B1", "K2", "B2")},
        "gains_deflection": {k: float(getattr(gd, k)) for k in ("K1", "B1", "K2", "B2")},
        "gains_deflection_units": dict(GAIN_UNITS_DEFLECTION),
        "shape": {"K1_tilde": K1t, "B1_tilde": B1t, "K2_tilde": K2t, "B2_tilde": B2t},
        "shape_units": {k: SHAPE_UNITS[k] for k in ("K1_tilde", "B1_tilde", "K2_tilde", "B2_tilde")},
        "low_frequency_stiffness": stiffness,
        "resonance_hz": res_hz,
        "resonance_peak_compliance": res_peak,
        "c5_poles": root_entries(poles),
        "c5_stable": stable,
        "c5_rigid_body_mode": rigid,
        "passivity": {
            "passive": all(cond.values()),
            "conditions": cond,
            "failed_conditions": [k for k, ok in cond.items() if not ok],
        },
        "max_phase_deg": max_ph,
        "max_phase_hz": max_hz,
        "min_phase_deg": min_ph,
        "min_phase_hz": min_hz,
        "units": dict(SEA_UNITS),
        "notes": notes,
    })
