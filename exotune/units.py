"""The one table of units: every number exotune reads or writes has its unit here (SI,
joint-reflected; docs/design-file.md). Dimensionless quantities are "1" in files and JSON, shown
as "–" in text and figures (:func:`path_unit` with ``dimensionless="–"``).

Gains have two conventions (the paper's deflection units and exotune's torque units): their tables
stay with the shaping in :mod:`exotune.model.shaping`.
"""

from __future__ import annotations

__all__ = ["PLANT_UNITS", "DESIGN_UNITS", "PARAM_UNITS", "SIGNAL_UNITS", "FILTER_UNITS", "IMPLEMENTATION_UNITS",
           "path_unit"]

#: plant section (joint-reflected)
PLANT_UNITS = {"motor_inertia": "kg·m²", "motor_damping": "N·m·s/rad", "sea_stiffness": "N·m/rad",
               "joint_inertia": "kg·m²", "cuff_stiffness": "N·m/rad"}
#: design section
DESIGN_UNITS = {"amplification": "1", "felt_inertia": "kg·m²", "felt_damping": "N·m·s/rad", "zeta": "1",
                "zeta_hat": "1"}
#: human and environment family parameters
PARAM_UNITS = {"stiffness": "N·m/rad", "inertia": "kg·m²", "damping": "N·m·s/rad", "eta": "1"}
#: runtime signals of a controller file
SIGNAL_UNITS = {"theta_m": "rad", "omega_m": "rad/s", "tau_s": "N·m", "dtau_s": "N·m/s", "tau_c": "N·m",
                "tau_cmd": "N·m"}
#: every filter of the implementation section
FILTER_UNITS = {"cutoff_hz": "Hz", "damping": "1"}
#: the implementation section's own numbers
IMPLEMENTATION_UNITS = {"delay_s": "s", "sample_rate_hz": "Hz"}


def path_unit(path: str, dimensionless: str = "1") -> str:
    """The unit of a dotted design-file path (``plant.cuff_stiffness``, ``implementation.dob.cutoff_hz``).

    Examples
    --------
    >>> path_unit("plant.cuff_stiffness"), path_unit("design.zeta", "–"), path_unit("implementation.dob.cutoff_hz")
    ('N·m/rad', '–', 'Hz')
    """
    head, _, rest = path.partition(".")
    if head == "plant":
        unit = PLANT_UNITS[rest]
    elif head == "design":
        unit = DESIGN_UNITS[rest]
    elif head == "implementation" and "." in rest:
        unit = FILTER_UNITS[rest.split(".", 1)[1]]
    elif head == "implementation":
        unit = IMPLEMENTATION_UNITS[rest]
    else:
        raise KeyError(path)
    return dimensionless if unit == "1" else unit
