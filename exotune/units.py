"""The one table of units: every number exotune reads or writes has its unit here (SI,
joint-reflected; docs/design-file.md). Dimensionless quantities are "1" in files and JSON, shown
as "–" in text and figures (:func:`path_unit` with ``dimensionless="–"``).

Gains have two conventions (the paper's deflection units, eq. (9), and exotune's torque units):
both tables are here, next to the units of the shaping parameters, of the runtime controller's
gains, and of the metrics that ``analyze`` and ``design --sea`` report (those carry a short note
where the number needs one).
"""

from __future__ import annotations

import math

__all__ = ["PLANT_UNITS", "DESIGN_UNITS", "PARAM_UNITS", "SIGNAL_UNITS", "FILTER_UNITS", "IMPLEMENTATION_UNITS",
           "GAIN_UNITS_TORQUE", "GAIN_UNITS_DEFLECTION", "SHAPE_UNITS", "SIGNAL_GAIN_UNITS", "SIX_GAIN_UNITS",
           "METRIC_UNITS", "SEA_UNITS", "path_unit", "fmt_num", "fmt_distinct"]

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
#: Units of each controller gain in exotune's (torque) convention.
GAIN_UNITS_TORQUE = {
    "K1": "N·m/rad",
    "B1": "N·m·s/rad",
    "K2": "1 (N·m/N·m, spring-torque feedback)",
    "B2": "s (spring-torque-rate feedback)",
    "K2_hat": "1 (N·m/N·m, cuff-torque feedback)",
    "B2_hat": "s (cuff-torque-rate feedback)",
}
#: Units of the SEA gains in the paper's eq. (9) (deflection) convention.
GAIN_UNITS_DEFLECTION = {
    "K1": "N·m/rad",
    "B1": "N·m·s/rad",
    "K2": "N·m/rad (spring-deflection feedback)",
    "B2": "N·m·s/rad (spring-deflection-rate feedback)",
}
#: the shaping parameters of the SEA (the paper's eq. (8)–(9) ~ quantities) and the felt motor
SHAPE_UNITS = {
    "K1_tilde": "1/s²",
    "B1_tilde": "1/s",
    "K2_tilde": "1/s²",
    "B2_tilde": "1/s",
    "J_m_hat": "kg·m²",
    "B_m_hat": "N·m·s/rad",
}
#: the runtime controller's static gain on each signal (controller file ``controller.gains``)
SIGNAL_GAIN_UNITS = {"theta_m": "N·m/rad", "omega_m": "N·m·s/rad", "tau_s": "1 (N·m/N·m)", "dtau_s": "s",
                     "tau_c": "1 (N·m/N·m)", "tau_cmd": "1 (N·m/N·m)"}
#: the six-gain summary of a controller file (``gains``)
SIX_GAIN_UNITS = {"K1": "N·m/rad", "B1": "N·m·s/rad", "K2": "1 (N·m/N·m)", "B2": "s", "K2_hat": "1 (N·m/N·m)",
                  "B2_hat": "s"}
#: metrics of ``exotune analyze`` (dotted JSON paths; ``*``: any certificate)
METRIC_UNITS = {
    "passivity.max_phase_excess_deg": "deg",
    "passivity.nonpassive_band_hz": "Hz",
    "passivity.kyp.*.shortage": "rad/(N·m·s) (admittance: −min Re{jω C7(jω)}, 0 when passive)",
    "passivity.kyp.*.lossless_compliance": "rad/(N·m) (the q1 of the lossless term q1·s of s·C7; 1/K_c)",
    "passivity.kyp.*.relative_shortage": "1 (shortage / largest Hankel singular value of the strictly proper part)",
    "passivity.kyp.*.truncation_bound": "rad/(N·m·s)",
    "passivity.kyp.*.shortage_upper": "rad/(N·m·s) (the SDP's d*, an upper bound on the shortage)",
    "passivity.kyp.*.witness_frequency_hz": "Hz (where Re{jω C7} is smallest: the non-passivity witness)",
    "passivity.kyp.*.certificate_residual": "1 (largest eigenvalue of the LMI at the solution / its norm)",
    "dob.gain_margin_db": "dB",
    "dob.phase_margin_deg": "deg",
    "dob.delay_margin_s": "s (extra delay on top of the modelled T)",
    "dob.crossover_hz": "Hz",
    "amplification.dc": "1 (|C6/C5| at ω → 0)",
    "amplification.bandwidth_hz": "Hz (first −3 dB frequency of |C6/C5|)",
    "delay_s": "s",
}
#: ``exotune design --sea`` metrics
SEA_UNITS = {
    "low_frequency_stiffness": "N·m/rad",
    "resonance_hz": "Hz",
    "resonance_peak_compliance": "rad/(N·m)",
    "c5_poles": "rad/s (natural_frequency_hz in Hz, damping_ratio 1)",
    "max_phase_deg": "deg",
    "max_phase_hz": "Hz",
    "min_phase_deg": "deg",
    "min_phase_hz": "Hz",
}


def path_unit(path: str, dimensionless: str = "1") -> str:
    """The unit of a dotted design-file path (``plant.cuff_stiffness``, ``implementation.dob.cutoff_hz``).

    Parameters
    ----------
    path : str
        The dotted path.
    dimensionless : str, optional
        What a dimensionless unit ("1") is written as.

    Returns
    -------
    str
        The unit.

    Raises
    ------
    KeyError
        When the path names no known parameter.

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


def fmt_num(x, digits=6) -> str:
    """A number as text with ``digits`` significant digits.

    Parameters
    ----------
    x : float, int, numpy scalar, str or None
        The value; a string is returned as is.
    digits : int
        Significant digits (``format(x, ".{digits}g")``).

    Returns
    -------
    str
        ``"—"`` for None and NaN (undefined), ``"∞"``/``"−∞"`` for infinities, else the number.

    References
    ----------
    docs/cli.md#output (every printed number carries its unit next to it).

    Examples
    --------
    >>> fmt_num(3.14159265, 3), fmt_num(float("inf")), fmt_num(None)
    ('3.14', '∞', '—')
    """
    if x is None:
        return "—"
    if isinstance(x, str):
        return x
    x = float(x)
    if math.isinf(x):
        return "∞" if x > 0 else "−∞"
    if math.isnan(x):
        return "—"
    return f"{x:.{digits}g}"


def fmt_distinct(values, digits: int = 6) -> str:
    """Numbers as a comma-separated list, with as many significant digits (from ``digits`` up to
    17) as it takes to tell different values apart; equal values are listed once, with their count.

    Parameters
    ----------
    values : iterable of float
        The values (e.g. members of a family bisected to 1e-10 relative, which six digits would
        print as one number several times).
    digits : int
        The fewest significant digits.

    Returns
    -------
    str
        The list, e.g. ``"0.00555216 (×2), 0.5"``.

    References
    ----------
    docs/cli.md#output.

    Examples
    --------
    >>> fmt_distinct([0.0055521601, 0.0055521602, 0.5])
    '0.0055521601, 0.0055521602, 0.5'
    >>> fmt_distinct([2.0, 2.0, 3.0])
    '2 (×2), 3'
    """
    vals = [float(v) for v in values]
    distinct = sorted(set(vals), key=vals.index)
    d = int(digits)
    while d < 17 and len({fmt_num(v, d) for v in distinct}) < len(distinct):
        d += 1
    return ", ".join(fmt_num(v, d) + (f" (×{vals.count(v)})" if vals.count(v) > 1 else "") for v in distinct)
