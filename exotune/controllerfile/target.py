"""The controller a target executes (docs/controller-file.md#precision): the runtime of a file in
its own arithmetic (:func:`runtime_of`: float32 realization or float64 reference), and a file
as if exported for another precision (:func:`with_precision`, ``certify --precision``).
"""

from __future__ import annotations

import copy

import numpy as np

from .precision import Float32Runtime, add_realizations, check_precision
from .runtime import Runtime

__all__ = ["runtime_of", "with_precision"]


def runtime_of(doc: dict, limit_nm: float | None = None, joint_angle_rad: float | None = None):
    """The runtime that executes the file's controller: :class:`~exotune.controllerfile.precision.Float32Runtime`
    for a float32 realization, else the reference (float64) :class:`~exotune.controllerfile.runtime.Runtime`.

    Parameters
    ----------
    doc : dict
        The validated controller file's mapping.
    limit_nm : float or None, optional
        Torque limit [N·m] of the command; None for none.
    joint_angle_rad : float or None, optional
        Joint angle [rad] choosing the gain-schedule entry; None for the nominal controller.

    Returns
    -------
    Runtime or Float32Runtime
        The runtime.

    Raises
    ------
    ValueError
        When ``limit_nm`` is not positive and finite, the angle is not finite, or the DOB's loop
        is singular.
    """
    if doc["controller"].get("realization") is not None:
        return Float32Runtime(doc, limit_nm, joint_angle_rad)
    return Runtime(doc, limit_nm, joint_angle_rad)


def with_precision(doc: dict, precision: str) -> dict:
    """A copy of the file as if exported for ``precision`` (``certify --precision``): realizations
    added (float32) or removed (float64), golden outputs recomputed by that arithmetic. Its
    ``predicted`` sampled sections are the file's (computed for its own precision).

    Parameters
    ----------
    doc : dict
        The validated controller file's mapping.
    precision : str
        ``"float64"`` or ``"float32"``.

    Returns
    -------
    dict
        The converted copy.

    Raises
    ------
    exotune.errors.ConfigError
        When ``precision`` is invalid or a coefficient does not fit in float32.
    """
    check_precision(precision, "--precision")
    d = copy.deepcopy(doc)
    if isinstance(d.get("implementation"), dict):
        d["implementation"]["precision"] = precision
    else:
        d["implementation"] = None
    ctrls = [d["controller"]] + [e["controller"] for e in (d.get("gain_schedule") or {}).get("entries") or []]
    for c in ctrls:
        c.pop("realization", None)
    if precision == "float32":
        add_realizations(d)
    ins = {s: np.asarray(v["values"], float) for s, v in d["golden"]["inputs"].items()}
    d["golden"]["tau_cmd"]["values"] = [float(x) for x in runtime_of(d).run(ins)]
    for e in (d.get("gain_schedule") or {}).get("entries") or []:
        view = {**d, "plant": e["plant"], "gains": e["gains"], "controller": {**d["controller"], **e["controller"]}}
        e["golden_tau_cmd"]["values"] = [float(x) for x in runtime_of(view).run(ins)]
    return d


