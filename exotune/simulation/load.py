"""What ``exotune simulate`` runs: a controller file as it is (refused when it fails certify's
consistency checks), or a design file exported in memory at a sample rate."""

from __future__ import annotations

from ..config import read_yaml
from ..config.design import refuse_other_kind
from ..config.validate import fmt_outside, in_limits, limit_text
from ..controllerfile import ControllerFile, as_controller_file, build_export, checked_controller, design_at_rate, load_controller
from ..controllerfile.model import ScheduleEntry
from ..controllerfile.consistency import consistency_problems
from ..errors import ConfigError
from ..options import number_value
from ..units import fmt_num

__all__ = ["load_for_simulation", "schedule_entry", "at_joint_angle", "check_consistent", "check_human_inertia",
           "check_joint_angle"]


def check_human_inertia(value: float | None, field: str = "human_inertia") -> float | None:
    """A human inertia [kg·m²] for a simulation: None (the scenario's), or a number within the
    accepted range of a design file's inertias (:data:`exotune.config.validate.LIMITS`
    ``inertia``, [1e-9, 1e6] kg·m²: a design file's human family could not hold it otherwise),
    else :class:`ConfigError` naming ``field``.

    Parameters
    ----------
    value : float or None
        The inertia [kg·m²] (a number: a bool or a string is refused).
    field : str, optional
        Field named by the error.

    Returns
    -------
    float or None
        ``value`` as a float.

    Raises
    ------
    exotune.errors.ConfigError
        When ``value`` is not a finite number or lies outside the accepted range.

    References
    ----------
    docs/cli.md#simulate; docs/design-file.md#input-limits-and-accepted-ranges.

    Examples
    --------
    >>> check_human_inertia(0.02)
    0.02
    >>> check_human_inertia(1e300)
    Traceback (most recent call last):
    ...
    exotune.errors.ConfigError: human_inertia: 1e+300 kg·m² is out of the accepted range [1e-9, 1e6] kg·m² of an inertia in a design file (docs/design-file.md#input-limits-and-accepted-ranges)
    """
    if value is None:
        return None
    value = number_value(field, value, noun="a number of kg·m²", strings=False)
    if not in_limits(value, "inertia"):
        raise ConfigError(field, f"{fmt_num(value)} kg·m² is out of the accepted range {limit_text('inertia')} of an "
                                 "inertia in a design file (docs/design-file.md#input-limits-and-accepted-ranges)")
    return value


def check_joint_angle(value: float | None, field: str = "joint_angle") -> float | None:
    """A joint angle [rad] choosing a gain-schedule entry (``--joint-angle``): None, or a finite
    number (NaN or ±inf would pick an entry arbitrarily), else :class:`ConfigError` naming ``field``.

    Parameters
    ----------
    value : float or None
        The angle [rad] (a number: a bool or a string is refused).
    field : str, optional
        Field named by the error.

    Returns
    -------
    float or None
        ``value`` as a float.

    Raises
    ------
    exotune.errors.ConfigError
        When ``value`` is not a finite number.

    References
    ----------
    docs/cli.md#simulate.
    """
    return None if value is None else number_value(field, value, noun="a number of radians", strings=False)


def check_consistent(doc: dict) -> None:
    """Refuse a controller file that fails ``exotune certify``'s consistency checks: its golden
    vectors must be reproduced by the reference runtime and its predicted sampled-data results
    (free and locked verdicts and spectral radii, every family's stable intervals) must be those
    of its own plant, controller, sample rate and delay — an edited sample rate, delay or gain
    changes them. (An unstable but consistent file is simulated: that is what simulate is for.)

    Parameters
    ----------
    doc : dict
        The validated controller file's mapping.

    Raises
    ------
    ConfigError
        Naming the first inconsistent field.

    References
    ----------
    docs/cli.md#certify.
    """
    mism, golden = consistency_problems(doc)  # certify's checks, without the decision's margin searches
    if mism:
        raise ConfigError(mism[0].split(" (")[0], "disagrees with the sampled-data analysis of the file's own plant, "
                          "controller, sample_rate_hz and delay_s (was the file edited? re-export it; "
                          "`exotune certify` lists every mismatch)")
    bad = [p for p in golden if "golden vectors" in p]
    if bad:
        raise ConfigError("golden.tau_cmd", bad[0])


def load_for_simulation(path, sample_rate_hz: float | None = None, check: bool = True) -> dict:
    """A controller file as is (checked by :func:`check_consistent` unless ``check`` is False), or
    a design file exported in memory at ``sample_rate_hz`` (or at its own
    ``implementation.sample_rate_hz``) — only what the runtime executes, without the sampled-data
    predictions of a written controller file (seconds at 100 kHz instead of minutes).

    ``path`` may also be the content in memory: a controller document or a design mapping (both
    validated as their files are), or a loaded design (its ``raw`` mapping).

    Parameters
    ----------
    path : str, os.PathLike, Mapping or DesignConfig
        A controller or design file, or its content.
    sample_rate_hz : float or None, optional
        Sample rate [Hz] of a design's export; None for its own (refused for a controller file).
    check : bool, optional
        Check a controller file's consistency.

    Returns
    -------
    dict
        The controller document to simulate.

    Raises
    ------
    exotune.errors.ConfigError
        When the input cannot be read or does not validate, a controller file is inconsistent or is
        given a sample rate, or a design has no sample rate.

    References
    ----------
    docs/cli.md#simulate.
    """
    from collections.abc import Mapping

    if hasattr(path, "raw") and hasattr(path, "plant"):  # a loaded design
        raw, name, in_memory = path.raw, path.source or "<design>", True
    elif isinstance(path, Mapping):
        raw, name, in_memory = dict(path), "<mapping>", True
    else:
        raw, name, in_memory = read_yaml(path), str(path), False
    if isinstance(raw, dict) and "schema" in raw:
        if sample_rate_hz is not None:
            raise ConfigError("sample_rate_hz", "a controller file carries the sample rate it was certified at; "
                              "the option applies to design files only")
        doc = checked_controller(raw, name) if in_memory else load_controller(path)
        if check:
            check_consistent(doc)
        return doc
    refuse_other_kind(raw, "design", name)  # an SEA file is named as one, not asked for a sample rate
    fs = sample_rate_hz
    if fs is None and isinstance(raw, dict) and isinstance(raw.get("implementation"), dict):
        fs = raw["implementation"].get("sample_rate_hz")
    if fs is None:
        raise ConfigError("sample_rate_hz", "a design file needs a sample rate to be simulated (give "
                          "`sample_rate_hz` or implementation.sample_rate_hz, or simulate an exported controller file)")
    cfg = design_at_rate(raw, fs, name)
    fs = float(cfg.implementation.sample_rate_hz)
    return build_export(cfg, fs, source=name, analyses=False)  # the runtime's sections only


def schedule_entry(doc: ControllerFile | dict, joint_angle_rad: float) -> ScheduleEntry:
    """The gain-schedule entry ``simulate --joint-angle`` runs at ``joint_angle_rad`` [rad]: the
    entry nearest it, as the runtime picks it (:meth:`~exotune.controllerfile.model.GainSchedule.nearest`),
    for an angle within the schedule's angles. Beyond them the file describes no plant (the
    transmission table ends there) — the runtime would still run the end entry, but a simulation
    of that entry's plant would not be a simulation at the angle asked for — so such an angle is
    refused.

    Parameters
    ----------
    doc : ControllerFile or dict
        The controller file.
    joint_angle_rad : float
        Joint angle [rad].

    Returns
    -------
    ScheduleEntry
        The entry.

    Raises
    ------
    ConfigError
        ``joint_angle`` (``--joint-angle``): not a finite number (:func:`check_joint_angle`), the
        controller has no gain schedule, or the angle lies outside the schedule's angles (the
        range in the message).

    References
    ----------
    docs/cli.md#simulate; docs/design-file.md (the transmission's gain schedule).

    Examples
    --------
    >>> from exotune.controllerfile import build_export, design_at_rate
    >>> from exotune.config import read_yaml
    >>> doc = build_export(design_at_rate(read_yaml("examples/scheduled.yaml"), 1000.0), 1000.0, analyses=False)
    >>> schedule_entry(doc, 1.7).joint_angle_rad
    1.5
    >>> schedule_entry(doc, 100.0)
    Traceback (most recent call last):
    ...
    exotune.errors.ConfigError: joint_angle: 100 rad is outside the gain schedule's joint angles [0, 2] rad: the file describes no plant there (entries at 0, 0.5, 1, 1.5, 2 rad); the runtime would run the nearest entry (2 rad), but its plant is not the joint's at 100 rad; give an angle in [0, 2] rad
    """
    joint_angle_rad = check_joint_angle(joint_angle_rad)
    cf = as_controller_file(doc)
    if cf.gain_schedule is None:
        raise ConfigError("joint_angle", "the controller has no gain schedule (no transmission section)")
    angles = [float(e.joint_angle_rad) for e in cf.gain_schedule.entries]
    lo, hi = min(angles), max(angles)
    if not lo <= joint_angle_rad <= hi:
        end = hi if joint_angle_rad > hi else lo  # the end entry is the nearest
        at = (f"entries at {', '.join(fmt_num(a) for a in angles)} rad" if len(angles) <= 8
              else f"{len(angles)} entries")
        # the digits that show why (2.0000000000000004 printed "2" read as inside [0, 2])
        shown = fmt_outside(joint_angle_rad, lambda v: lo <= v <= hi)
        raise ConfigError("joint_angle", f"{shown} rad is outside the gain schedule's joint angles "
                          f"[{fmt_num(lo)}, {fmt_num(hi)}] rad: the file describes no plant there ({at}); "
                          "the runtime would run the nearest entry "
                          f"({fmt_num(end)} rad), but its plant is not the joint's at "
                          f"{shown} rad; give an angle in [{fmt_num(lo)}, {fmt_num(hi)}] rad")
    return cf.gain_schedule.nearest(joint_angle_rad)


def at_joint_angle(doc: ControllerFile | dict, joint_angle_rad: float) -> ControllerFile:
    """The controller document of the gain-schedule entry :func:`schedule_entry` picks at
    ``joint_angle_rad`` [rad] (the nearest, within the schedule's angles): its plant and controller
    in place of the nominal ones (``simulate --joint-angle``).

    Parameters
    ----------
    doc : ControllerFile or dict
        The controller file.
    joint_angle_rad : float
        Joint angle [rad].

    Returns
    -------
    ControllerFile
        The entry's view of the file (:meth:`~exotune.controllerfile.model.ControllerFile.entry_view`).

    Raises
    ------
    ConfigError
        ``joint_angle`` (``--joint-angle``), as :func:`schedule_entry`.

    References
    ----------
    docs/cli.md#simulate; paper §IV (the transmission's gain schedule).
    """
    cf = as_controller_file(doc)
    return cf.entry_view(schedule_entry(cf, joint_angle_rad))
