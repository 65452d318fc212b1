"""The controller a target executes (docs/controller-file.md#precision): the runtime of a file in
its own arithmetic (:func:`runtime_of`: float32 realization or float64 reference), and a file
as if exported for another precision (:func:`with_precision`, ``certify --precision``).
"""

from __future__ import annotations

import numpy as np

from .model import ControllerFile, as_controller_file
from .precision import Float32Runtime, add_realizations, check_precision
from .runtime import Runtime

__all__ = ["runtime_of", "with_precision"]


def runtime_of(doc: ControllerFile | dict, limit_nm: float | None = None, joint_angle_rad: float | None = None):
    """The runtime that executes the file's controller: :class:`~exotune.controllerfile.precision.Float32Runtime`
    for a float32 realization, else the reference (float64) :class:`~exotune.controllerfile.runtime.Runtime`.

    Parameters
    ----------
    doc : ControllerFile or dict
        The validated controller file.
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
    cf = as_controller_file(doc)
    if cf.controller.realization is not None:
        return Float32Runtime(cf, limit_nm, joint_angle_rad)
    return Runtime(cf, limit_nm, joint_angle_rad)


def with_precision(doc: ControllerFile | dict, precision: str) -> ControllerFile:
    """A copy of the file as if exported for ``precision`` (``certify --precision``): realizations
    added (float32) or removed (float64), golden outputs recomputed by that arithmetic. Its
    ``predicted`` sampled sections are the file's (computed for its own precision).

    Parameters
    ----------
    doc : ControllerFile or dict
        The validated controller file.
    precision : str
        ``"float64"`` or ``"float32"``.

    Returns
    -------
    ControllerFile
        The converted copy.

    Raises
    ------
    exotune.errors.ConfigError
        When ``precision`` is invalid or a coefficient does not fit in float32.
    """
    check_precision(precision, "precision")
    cf = as_controller_file(doc)
    d = cf.to_dict()  # the new document (a deep copy), written here
    if isinstance(d.get("implementation"), dict):
        d["implementation"]["precision"] = precision
    else:
        d["implementation"] = None
    ctrls = [d["controller"]] + [e["controller"] for e in (d.get("gain_schedule") or {}).get("entries") or []]
    for c in ctrls:
        c.pop("realization", None)
    if precision == "float32":
        add_realizations(d)
    ins = {s: np.asarray(v, float) for s, v in cf.golden.inputs.items()}
    new = ControllerFile.from_dict(d)
    d["golden"]["tau_cmd"]["values"] = [float(x) for x in runtime_of(new).run(ins)]
    for e, raw in zip(new.schedule_entries, (d.get("gain_schedule") or {}).get("entries") or []):
        raw["golden_tau_cmd"]["values"] = [float(x) for x in runtime_of(new.entry_view(e)).run(ins)]
    return ControllerFile.from_dict(d)


