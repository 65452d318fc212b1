"""The controller a design builds, as a controller file writes it: the static gains and Tustin
``sos`` filters of one design at a sample rate (:func:`controller_section`), and the design mapping
at a transmission ratio (:func:`reflected_mapping`). A leaf shared by ``export`` (which writes them)
and ``certify`` (which rebuilds them from the file's design, plant and implementation sections and
compares).

References
----------
docs/controller-file.md; paper §IV (double compliance shaping), the end of §IV (gain scheduling).
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import ConfigError
from ..model.plant import REFLECTED_FIELDS
from ..sampled import Measured, controller_blocks
from ..sampled.loop import default_prewarp
from .model import Controller, ControllerFile, Filter, as_controller_file
from .schema import GAIN_UNITS, SIGNAL_UNITS, SIX_GAIN_UNITS
from .sos import tustin_sos

__all__ = ["controller_section", "reflected_mapping", "quantity", "implementation_mismatches", "close"]

FILTER_DOC = {
    "motor_position": "proper part of G_θ (velocity filter)",
    "spring_torque": "proper part of G_s (velocity filter)",
    "cuff_path": "G_c: the filtered cuff compensator G_v (K̂2 + B̂2 s) (docs/method.md#controller)",
    "dob_motor": "−Q(s)(J_m s² + B_m s): the DOB's inverse motor model on θ_m",
    "dob_spring": "+Q(s) on τ_s",
    "dob_command": "+Q(s) on τ_cmd itself (the DOB's algebraic loop, see runtime)",
}


def quantity(value: float, unit: str) -> dict:
    """A number with its unit, as the controller file writes numbers.

    Parameters
    ----------
    value : float
        The number.
    unit : str
        Its unit.

    Returns
    -------
    dict
        ``{"value": float, "unit": str}``.
    """
    return {"value": float(value), "unit": unit}


def controller_section(cfg, fs: float) -> tuple[dict, list[dict], dict]:
    """(static gains on the signals, sos filters, the six design gains with units) of one design.

    Parameters
    ----------
    cfg : DesignConfig
        A validated single design.
    fs : float
        Sample rate [Hz].

    Returns
    -------
    gains : dict
        Static gain per signal with a nonzero one: ``{"gain", "unit"}``.
    filters : list of dict
        Per block: name, input and units, the continuous num/den (ascending powers of s), the
        prewarp frequency [Hz] and its ``sos`` rows.
    six : dict
        K1 [N·m/rad], B1 [N·m·s/rad], K2 [–], B2 [s], K2_hat [–], B2_hat [s] as quantities.
    """
    from ..model.controller import build_controller

    cs, _ = build_controller(cfg.plant, cfg.design, cfg.implementation)
    six = {k: quantity(float(np.ravel(getattr(cs.gains, k))[0]), u) for k, u in SIX_GAIN_UNITS.items()}
    static, blocks = controller_blocks(cs, cfg.plant)
    pw = default_prewarp(cfg.implementation)
    gains = {sig: {"gain": float(static[i]), "unit": GAIN_UNITS[sig]} for i, sig in enumerate(Measured) if static[i] != 0}
    filters = []
    for b in blocks:
        sos = tustin_sos(b.num, b.den, fs, pw.get(b.prewarp))
        filters.append({
            "name": b.name,
            "input": b.input,
            "input_unit": SIGNAL_UNITS[b.input],
            "output_unit": "N·m",
            "unit": GAIN_UNITS[b.input],
            "description": FILTER_DOC.get(b.name, b.name),
            "discretization": "tustin",
            "prewarp_hz": None if pw.get(b.prewarp) is None else float(pw[b.prewarp]),
            "continuous": {"num": [float(x) for x in np.asarray(b.num, float)],
                           "den": [float(x) for x in np.asarray(b.den, float)],
                           "order": "ascending powers of s"},
            "sos": [[float(x) for x in row] for row in sos],
        })
    return gains, filters, six


def reflected_mapping(raw: dict, ratio: float) -> dict:
    """The design mapping at transmission ratio ``ratio`` (J_m, B_m, K_s × ratio²), without the
    transmission section.

    Parameters
    ----------
    raw : dict
        The design mapping (with its ``plant`` section).
    ratio : float
        Transmission ratio [–].

    Returns
    -------
    dict
        A deep copy with the reflected motor inertia [kg·m²], damping [N·m·s/rad] and SEA stiffness
        [N·m/rad].
    """
    import copy

    r = copy.deepcopy(raw)
    r.pop("transmission", None)
    for k in REFLECTED_FIELDS:  # as Plant.reflected
        r["plant"][k] = float(r["plant"][k]) * ratio * ratio
    return r


# the families do not enter the controller; a valid one completes the mapping for validation
_ANY_HUMAN = {"kind": "mass", "inertia": [0.1, 1.0], "damping": 0.0}


def close(a: float, b: float, rtol: float) -> bool:
    """|a − b| within ``rtol`` of the larger magnitude (two zeros are close).

    Parameters
    ----------
    a, b : float
        The two numbers.
    rtol : float
        Relative tolerance.

    Returns
    -------
    bool
        Whether they are close.
    """
    return abs(a - b) <= rtol * max(abs(a), abs(b), 1e-300)


def implementation_mismatches(doc: ControllerFile | dict, rtol: float = 1e-9) -> list[str]:
    """Where the file's controllers (the main one and each gain-schedule entry's) differ from the
    ones its ``plant``, ``design`` and ``implementation`` sections build (static gains and every
    filter's sos, :func:`exotune.controllerfile.build.controller_section`), and whether the
    implementation's delay is the file's. An invalid implementation section is a ConfigError
    naming its field.

    Parameters
    ----------
    doc : ControllerFile or dict
        The controller file (with its ``implementation`` section).
    rtol : float, optional
        Relative tolerance of the comparison.

    Returns
    -------
    list of str
        The mismatches: the delay and sample rate first, then each controller's gains and filters.

    Raises
    ------
    exotune.errors.ConfigError
        When the plant, design or implementation section does not validate, or the ``dob``
        summary's Q cutoff or damping is not the implementation section's (its filters being the
        section's).
    """
    from ..config import design_from_mapping

    cf = as_controller_file(doc)
    fs = float(cf.sample_rate_hz)
    impl = cf.implementation
    out = []
    views = [("", cf)] + [(f"gain_schedule.entries[{j}].", cf.entry_view(e)) for j, e in enumerate(cf.schedule_entries)]
    for where, v in views:
        mapping = {"plant": v.plant.values(), "design": cf.design.values(),
                   "implementation": impl.mapping, "humans": [_ANY_HUMAN], "environment": []}
        cfg = design_from_mapping(mapping)
        if not where:
            dob = cfg.implementation.dob
        gains, filters, _six = controller_section(cfg, fs)
        have, built = v.controller, Controller.from_dict({"gains": gains, "filters": filters})
        got_gains = {k: float(g) for k, g in have.gains.items()}
        for sig in sorted(set(built.gains) | set(got_gains)):
            if not close(got_gains.get(sig, 0.0), float(built.gain(sig)), rtol):
                out.append(f"{where}controller.gains.{sig} is not the gain the implementation section builds")
        names = [f.name for f in have.filters]
        if names != [f.name for f in built.filters]:
            out.append(f"{where}controller.filters are {names}, the implementation section builds "
                       f"{[f.name for f in built.filters]}")
            continue
        for f_have, f_built in zip(have.filters, built.filters):
            a, b = np.asarray(f_have.sos, float), np.asarray(f_built.sos, float)
            if (f_have.input != f_built.input or a.shape != b.shape
                    or not np.allclose(a, b, rtol=rtol, atol=rtol * max(float(np.max(np.abs(b))), 1e-300))):
                out.append(f"{where}controller.filters[{f_have.name}] is not the filter the implementation "
                           "section builds")
            elif not _same_origin(f_have, f_built, rtol):
                out.append(f"{where}controller.filters[{f_have.name}]: prewarp_hz or continuous block not the "
                           "implementation section's")
    # after design_from_mapping has validated the section (a non-number is a ConfigError naming its field)
    # (a missing or null value is NaN, never close; 0.0 is a value: a delay-free runtime)
    timing = [f"implementation.{key} {given!r} is not the file's {key} {own!r}"
              for key, given, own in (("delay_s", impl.delay_s, cf.delay_s), ("sample_rate_hz", impl.sample_rate_hz,
                                                                               cf.sample_rate_hz))
              if not close(math.nan if given is None else float(given), float(own), rtol)]
    if not out:  # the filters are the implementation's: the summary must state their Q
        _check_dob_summary(cf, dob, rtol)
    return timing + out


def _same_origin(have: Filter, built: Filter, rtol: float) -> bool:
    """The filter's stated origin — its prewarp frequency and the continuous block (num, den) it
    was discretized from — is the rebuilt filter's (a file states them to its reader; the runtime
    runs the sos alone)."""
    if (have.prewarp_hz is None) != (built.prewarp_hz is None):
        return False
    if have.prewarp_hz is not None and not close(float(have.prewarp_hz), float(built.prewarp_hz), rtol):
        return False
    if have.continuous is None:  # optional in the schema
        return True
    for key in ("num", "den"):
        try:
            a = np.asarray(have.continuous.get(key, ()), float)
        except (TypeError, ValueError, AttributeError):  # not a list of numbers: not the built block
            return False
        b = np.asarray(built.continuous[key], float)
        if a.shape != b.shape or not np.allclose(a, b, rtol=rtol, atol=rtol * max(float(np.max(np.abs(b))), 1e-300)):
            return False
    return True


def _check_dob_summary(cf: ControllerFile, dob, rtol: float) -> None:
    """The ``dob`` summary (Q's cutoff and damping, as the file states them to its reader) must be
    the implementation section's ``dob``, which built the filters: a ConfigError naming the
    summary's field otherwise (an edited summary, not an edited controller)."""
    if cf.dob is None or dob is None:  # the filters already tie a missing summary to a missing DOB
        return
    for key, have, src, want in (("q_cutoff_hz", cf.dob.q_cutoff_hz, "cutoff_hz", dob.cutoff_hz),
                                 ("q_damping", cf.dob.q_damping, "damping", dob.damping)):
        if not close(float(have), float(want), rtol):
            raise ConfigError(f"dob.{key}.value", f"{have!r}, but the implementation section's dob.{src}, which "
                                                  f"built the DOB's filters, is {float(want)!r}")
