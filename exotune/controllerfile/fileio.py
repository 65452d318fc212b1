"""Reading and writing controller files: :func:`load_controller` (safe YAML loader, schema, then
the consistency checks), :func:`write_controller` (YAML, written atomically), and the views of a
loaded file the analysis and the runtime use — its controller as one discrete state space, its
plant, and one gain-schedule entry as a controller file of its own.
"""

from __future__ import annotations

import numpy as np

from ..sampled import Measured, assemble
from .checks import check_controller_file
from .model import Controller, ControllerFile, as_controller_file
from .schema import validate_controller
from .sos import sos_ss

__all__ = ["load_controller", "load_controller_file", "checked_controller", "checked_controller_file", "check_file_limits",
           "write_controller", "discrete_from_file", "plant_from_file", "schedule_entry_doc", "position_feedback"]


def load_controller(path) -> dict:
    """Read (safe YAML loader) and validate a controller file (schema, then
    :func:`check_controller_file`); returns the mapping.

    Parameters
    ----------
    path : str or os.PathLike
        The controller file (YAML).

    Returns
    -------
    dict
        The validated controller file's mapping.

    Raises
    ------
    exotune.errors.ConfigError
        When the file cannot be read or parsed, or fails a check.
    """
    from ..config import read_yaml

    return checked_controller(read_yaml(path), str(path))


def load_controller_file(path) -> ControllerFile:
    """Read and validate a controller file exactly as :func:`load_controller` does; returns its
    typed model (:class:`~exotune.controllerfile.model.ControllerFile`).

    Parameters
    ----------
    path : str or os.PathLike
        The controller file (YAML).

    Returns
    -------
    ControllerFile
        The validated file.

    Raises
    ------
    exotune.errors.ConfigError
        When the file cannot be read or parsed, or fails a check.

    References
    ----------
    docs/controller-file.md.
    """
    from ..config import read_yaml

    return checked_controller_file(read_yaml(path), str(path))


def checked_controller(doc, source: str = "<mapping>") -> dict:
    """Validate a controller document already in memory exactly as :func:`load_controller`
    validates a file (the kind, the schema, the accepted ranges, the file's own consistency
    checks); returns it. ``source`` names it in errors.

    Parameters
    ----------
    doc : Any
        The controller document.
    source : str, optional
        What it is (a path), named by the errors.

    Returns
    -------
    dict
        ``doc`` itself.

    Raises
    ------
    exotune.errors.ConfigError
        When it is another kind of file, fails the schema, an accepted range or a consistency check,
        or its precision and realizations disagree.

    References
    ----------
    docs/controller-file.md.
    """
    checked_controller_file(doc, source)
    return doc


def checked_controller_file(doc, source: str = "<mapping>") -> ControllerFile:
    """Validate a controller document in memory as :func:`checked_controller` does (the kind, the
    schema, then on the typed model the accepted ranges, the consistency checks and the precision);
    returns the typed model.

    Parameters
    ----------
    doc : Any
        The controller document.
    source : str, optional
        What it is (a path), named by the errors.

    Returns
    -------
    ControllerFile
        The validated file (:meth:`~exotune.controllerfile.model.ControllerFile.to_dict` gives ``doc`` back).

    Raises
    ------
    exotune.errors.ConfigError
        As :func:`checked_controller`.
    """
    from ..config.design import refuse_other_kind
    from .precision import precision_of

    refuse_other_kind(doc, "controller", source)
    validate_controller(doc, source)
    cf = ControllerFile.from_dict(doc)
    check_file_limits(cf)
    check_controller_file(cf)
    precision_of(cf)  # implementation.precision valid, and a realization in every controller of a float32 file
    return cf


def check_file_limits(doc: dict) -> None:
    """Refuse a (schema-valid) controller file whose plant, design, sample rate or delay lies
    outside the ranges exotune analyses meaningfully, naming the field and the range, before any
    number reaches a kernel.

    Parameters
    ----------
    doc : ControllerFile or dict
        A controller file that passed :func:`exotune.controllerfile.schema.validate_controller`.

    Raises
    ------
    exotune.errors.ConfigError
        ``<section>.<key>.value: out of the accepted range: …``.

    References
    ----------
    docs/design-file.md#input-limits-and-accepted-ranges.
    """
    from ..config.batch import OVERRIDE_LIMITS
    from ..config.validate import check_limit
    from ..errors import ConfigError

    cf = as_controller_file(doc)
    checks = [(f"{sec}.{k}.value", OVERRIDE_LIMITS.get(f"{sec}.{k}"), v)
              for sec, s in (("plant", cf.plant), ("design", cf.design)) for k, v in s.values().items()]
    checks += [("sample_rate_hz.value", "frequency", cf.sample_rate_hz), ("delay_s.value", "delay", cf.delay_s)]
    for i, e in enumerate(cf.schedule_entries):
        checks += [(f"gain_schedule.entries[{i}].plant.{k}.value", OVERRIDE_LIMITS.get(f"plant.{k}"), v)
                   for k, v in e.plant.values().items()]
    for field, kind, v in checks:
        if kind is None:
            continue
        try:
            check_limit(float(v), kind)
        except ValueError as err:
            raise ConfigError(field, str(err)) from None


def write_controller(doc: dict, out) -> None:
    """Write the controller file ``doc`` to ``out`` as YAML, atomically.

    Parameters
    ----------
    doc : dict
        A controller file (as built by :func:`exotune.controllerfile.export.build_export`).
    out : str or os.PathLike
        The file to write; it is replaced atomically (a reader never sees half a file).

    Notes
    -----
    The format is schema ``exotune.controller/1`` (:mod:`exotune.controllerfile.schema`).
    """
    import yaml

    from ..jsonio import write_atomic

    text = ("# exotune runtime controller file (schema exotune.controller/1, see exotune/schemas/controller.schema.json)\n"
            + yaml.safe_dump(doc, sort_keys=False, allow_unicode=True, width=120))
    write_atomic(out, text)


def discrete_from_file(doc: dict):
    """The file's controller as one state space (:class:`exotune.sampled.DiscreteController`),
    built from its gains and sos filters only; for a float32 file, from its float32 realization as
    the target executes it (:func:`exotune.controllerfile.precision.discrete_from_realization`).

    Parameters
    ----------
    doc : ControllerFile or dict
        The validated controller file.

    Returns
    -------
    DiscreteController
        The controller at the file's sample rate [Hz], with the file's delay [s].

    Raises
    ------
    ValueError
        When the DOB's algebraic loop is singular.
    """
    cf = as_controller_file(doc)
    c = cf.controller
    if c.realization is not None:
        from .precision import discrete_from_realization

        return discrete_from_realization(c.realization, cf.sample_rate_hz, cf.delay_s)
    static = np.array([c.gain(s) for s in Measured], dtype=float)
    blocks = [(sos_ss(f.sos), f.input) for f in c.filters]
    return assemble(static, blocks, cf.sample_rate_hz, cf.delay_s)


def plant_from_file(doc: dict):
    """The file's plant (:class:`exotune.model.plant.Plant`) from its ``plant`` section.

    Parameters
    ----------
    doc : ControllerFile or dict
        The validated controller file.

    Returns
    -------
    Plant
        Its plant (J_m [kg·m²], B_m [N·m·s/rad], K_s [N·m/rad], J_j [kg·m²], K_c [N·m/rad]).
    """
    return as_controller_file(doc).plant.to_plant()


def schedule_entry_doc(doc: dict, entry: dict) -> dict:
    """The controller-file view of one gain-schedule entry (its plant, gains and controller), as a
    mapping: for the writer (``export`` builds the entries); the typed view is
    :meth:`~exotune.controllerfile.model.ControllerFile.entry_view`.

    Parameters
    ----------
    doc : dict
        The controller file's mapping.
    entry : dict
        One of its ``gain_schedule.entries``.

    Returns
    -------
    dict
        A shallow copy of ``doc`` with the entry's plant, gains and controller.
    """
    return {**doc, "plant": entry["plant"], "gains": entry["gains"],
            "controller": {**doc["controller"], **entry["controller"]}}


def position_feedback(controller: dict, rtol: float = 1e-12) -> bool:
    """Whether the file's controller feeds back the motor *position* at DC — from the controller
    the runtime executes (its θ_m gain and the DC gains of its filters on θ_m), never from the
    descriptive six-gain summary. Without it (and without a human or environment stiffness) the
    structure is ungrounded and the loop has its rigid-body eigenvalue at z = 1. For a float32
    file, that of its realization.

    Parameters
    ----------
    controller : Controller or dict
        The file's controller (or a schedule entry's).
    rtol : float, optional
        Relative size below which the total DC gain on θ_m counts as zero (also the rule for a
        section's zero at z = 1).

    Returns
    -------
    bool
        Whether the controller feeds back the motor position.
    """
    c = Controller.of(controller)
    if c.realization is not None:
        from .precision import realization_position_feedback

        return realization_position_feedback(c.realization, rtol)
    total = float(c.gain("theta_m"))
    scale = abs(total)
    for f in c.filters:
        if f.input != "theta_m":
            continue
        num, den = 1.0, 1.0
        for b0, b1, b2, _a0, a1, a2 in f.sos:
            sb = b0 + b1 + b2
            num *= 0.0 if abs(sb) <= rtol * (abs(b0) + abs(b1) + abs(b2)) else sb
            den *= 1.0 + a1 + a2
        if num == 0.0:
            continue
        if den == 0.0:  # an integrator on θ_m: position feedback of unbounded DC gain
            return True
        total += num / den
        scale += abs(num / den)
    return abs(total) > rtol * max(scale, 1e-300) and total != 0.0
