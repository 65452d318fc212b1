"""Consistency checks of a schema-valid controller file that the JSON Schema cannot express:
units, the delay in samples, unique filter names, a non-singular DOB loop, the six-gain summary
against the static gains, the ``dob`` section, the gain schedule against the transmission table,
and the golden vectors (:func:`check_controller_file`).
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import ConfigError
from ..options import MAX_LATENCY_REQUIREMENT_S
from ..sampled import Measured
from .model import Controller, Dob, PlantSection, SixGains, as_controller_file
from .schema import DESIGN_UNITS, GAIN_UNITS, PLANT_UNITS, SIGNAL_UNITS, SIX_GAIN_UNITS

__all__ = ["check_controller_file", "MIN_GOLDEN_SAMPLES"]


def _unit(field: str, got, want: str) -> None:
    if got != want:
        raise ConfigError(field, f"unit {got!r}, expected {want!r} (exotune.controller/1 fixes every unit)")


def _check_controller(c: Controller, where: str) -> None:
    """Units, filter names and the DOB's algebraic loop of one controller section."""
    for sig, unit in c.gain_units.items():
        _unit(f"{where}.gains.{sig}.unit", unit, GAIN_UNITS[sig])
    names = [f.name for f in c.filters]
    for i, f in enumerate(c.filters):
        fw = f"{where}.filters[{i}]"
        if not f.name or f.name in names[:i]:
            raise ConfigError(f"{fw}.name", f"filter names must be non-empty and unique, got {f.name!r}")
        _unit(f"{fw}.input_unit", f.input_unit, SIGNAL_UNITS[f.input])
        _unit(f"{fw}.output_unit", f.output_unit, "N·m")
        _unit(f"{fw}.unit", f.unit, GAIN_UNITS[f.input])
    # the runtime solves τ_cmd = (rest + h)/(1 − g), g = Σ Π b0 over the filters on τ_cmd
    g = sum(float(np.prod([row[0] for row in f.sos])) for f in c.filters if f.input == "tau_cmd")
    if abs(1.0 - g) < 1e-9:
        raise ConfigError(f"{where}.filters", f"the DOB's algebraic loop is singular: the feed-throughs Π b0 of the "
                                              f"filters on tau_cmd add up to {g!r} (must not be 1)")


def _check_plant(p: PlantSection, where: str) -> None:
    for k, unit in p.units.items():
        _unit(f"{where}.{k}.unit", unit, PLANT_UNITS[k])


def check_controller_file(doc) -> None:
    """Checks of a schema-valid controller file that the JSON Schema cannot express (found by
    fuzzing: each was accepted, some by ``certify``): every unit is the schema's; the delay in
    samples agrees with the delay and the rate; filter names are unique; the DOB's algebraic loop
    is not singular in any controller; the six-gain summary agrees with the static gains it names;
    the ``dob`` section describes every controller; the gain schedule agrees with the transmission
    table and each entry's plant is the top-level plant reflected at its ratio; golden vectors
    have at least MIN_GOLDEN_SAMPLES samples, all of one length. Problems raise
    :class:`ConfigError` naming the field.

    Parameters
    ----------
    doc : ControllerFile or dict
        A schema-valid controller file.

    Raises
    ------
    exotune.errors.ConfigError
        At the first problem, naming its field.
    """
    from ..config.validate import check_delay_samples

    cf = as_controller_file(doc)
    fs, T = cf.sample_rate_hz, cf.delay_s
    check_delay_samples(T, fs, "delay_s.value")
    n = cf.delay.samples
    if n is not None and abs(n - T * fs) > 1e-9 * max(1.0, T * fs):
        raise ConfigError("delay_s.samples", f"{n!r} samples, but {T!r} s at {fs!r} Hz is {T * fs!r}")
    req = cf.requirements
    if req is not None and not req.latency_margin_s <= MAX_LATENCY_REQUIREMENT_S:  # ≥ 0: the schema
        raise ConfigError("requirements.latency_margin_s",
                          f"out of the accepted range: must be in [0, {MAX_LATENCY_REQUIREMENT_S:g}] s, got "
                          f"{req.latency_margin_s:g} s (as in a design file: no analysis checks an extra delay "
                          "beyond the accepted delays)")
    _check_plant(cf.plant, "plant")
    for k, unit in cf.design.units.items():
        _unit(f"design.{k}.unit", unit, DESIGN_UNITS[k])
    for k, u in SIX_GAIN_UNITS.items():
        _unit(f"gains.{k}.unit", cf.gains.units[k], u)
    want = {"inputs": {s: SIGNAL_UNITS[s] for s in Measured}, "output": {"tau_cmd": "N·m"}}
    if cf.signals != want:
        raise ConfigError("signals", f"must be {want} (the runtime's signals and their units)")
    _check_controller(cf.controller, "controller")
    _check_six_gains(cf.gains, cf.controller, "gains")
    for s_, unit in cf.golden.input_units.items():
        _unit(f"golden.inputs.{s_}.unit", unit, SIGNAL_UNITS[s_])
    _unit("golden.tau_cmd.unit", cf.golden.tau_cmd_unit, "N·m")
    n_golden = len(cf.golden.tau_cmd)
    if n_golden < MIN_GOLDEN_SAMPLES:
        raise ConfigError("golden.tau_cmd.values", f"{n_golden} samples; a golden vector has at least {MIN_GOLDEN_SAMPLES}")
    for s_, values in cf.golden.inputs.items():
        if len(values) != n_golden:
            raise ConfigError(f"golden.inputs.{s_}.values", f"{len(values)} samples, golden.tau_cmd has {n_golden}")
    sched, tr = cf.gain_schedule, cf.transmission
    controllers = [("controller", cf.controller)] + [
        (f"gain_schedule.entries[{i}].controller", e.controller) for i, e in enumerate(cf.schedule_entries)]
    _check_dob_section(cf.dob, controllers)
    if (sched is None) != (tr is None):
        raise ConfigError("gain_schedule" if sched is None else "transmission",
                          "a gain schedule and a transmission table come together (one is missing)")
    if sched is not None:
        angles = [e.joint_angle_rad for e in sched.entries]
        if len(set(angles)) != len(angles):
            raise ConfigError("gain_schedule.entries", "two entries have the same joint angle")
        if len(tr.joint_angle_rad) != len(tr.ratio):
            raise ConfigError("transmission.ratio", "needs one ratio per joint angle")
        if sorted(zip(angles, (e.ratio for e in sched.entries))) != sorted(zip(tr.joint_angle_rad, tr.ratio)):
            raise ConfigError("gain_schedule.entries", "the entries' (joint angle, ratio) pairs must be the "
                                                       "transmission table's")
        top = cf.plant.values()
        for i, e in enumerate(sched.entries):
            w = f"gain_schedule.entries[{i}]"
            _check_plant(e.plant, f"{w}.plant")
            for k, v in e.plant.values().items():  # the plant reflected at the entry's ratio (paper §IV, gain scheduling)
                reflected = top[k] * (e.ratio ** 2 if k in _REFLECTED else 1.0)
                if abs(v - reflected) > 1e-9 * max(abs(reflected), 1e-300):
                    raise ConfigError(f"{w}.plant.{k}.value",
                                      f"{v!r}, but the plant at ratio {e.ratio!r} has {reflected!r} "
                                      f"({'× ratio²' if k in _REFLECTED else 'as at ratio 1'})")
            _check_controller(e.controller, f"{w}.controller")
            _check_six_gains(e.gains, e.controller, f"{w}.gains")
            _unit(f"{w}.golden_tau_cmd.unit", e.golden_tau_cmd_unit, "N·m")


_REFLECTED = ("motor_inertia", "motor_damping", "sea_stiffness")  # × ratio² in a gain-schedule entry


def _check_dob_section(dob: Dob | None, controllers) -> None:
    """The ``dob`` summary must describe the controllers: without it no filter closes the DOB's
    loop (acts on τ_cmd); with it, its filters exist in every controller and its units are fixed."""
    for where, c in controllers:
        cmd = [f.name for f in c.filters if f.input == "tau_cmd"]
        if dob is None and cmd:
            raise ConfigError("dob", f"null, but {where} runs the DOB filter {cmd[0]!r} (on tau_cmd)")
    if dob is None:
        return
    listed = dob.filters
    if not isinstance(listed, tuple) or not listed:  # the model holds the file's list as a tuple
        raise ConfigError("dob.filters", "expected the (non-empty) list of the DOB's filter names")
    for where, c in controllers:
        names = [f.name for f in c.filters]
        for i, name in enumerate(listed):
            if name not in names:
                raise ConfigError(f"dob.filters[{i}]", f"{where} has no filter named {name!r}")
        if not any(f.input == "tau_cmd" for f in c.filters):
            raise ConfigError(f"{where}.filters", "a DOB is declared (dob) but no filter closes its loop on tau_cmd")
    for key, v, got, unit in (("q_cutoff_hz", dob.q_cutoff_hz, dob.q_cutoff_unit, "Hz"),
                              ("q_damping", dob.q_damping, dob.q_damping_unit, "1")):
        if not (isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) and v > 0):
            raise ConfigError(f"dob.{key}", "expected {value: a positive number, unit: ...}")
        _unit(f"dob.{key}.unit", got, unit)


# the six gains that act as static gains on a sensed signal when no filter carries them
# (sign: τ_cmd = −K1 θ_m − B1 θ̇_m + K2 τ_s + B2 τ̇_s + …, docs/method.md#controller)
_SIX_ON_SIGNAL = {"K1": ("theta_m", -1.0, "motor_position"), "B1": ("omega_m", -1.0, "motor_position"),
                  "K2": ("tau_s", 1.0, "spring_torque"), "B2": ("dtau_s", 1.0, "spring_torque")}
_CARRIER_INPUT = {"motor_position": "theta_m", "spring_torque": "tau_s"}  # exotune.sampled.controller_blocks
MIN_GOLDEN_SAMPLES = 10


def _check_six_gains(six: SixGains, c: Controller, where: str) -> None:
    """The six-gain summary must state the controller's static gains (when no filter carries them:
    with a velocity filter, K1/B1 and K2/B2 live inside the motor_position/spring_torque filters)."""
    carried = {(f.name, f.input) for f in c.filters}
    for k, (sig, sign, carrier) in _SIX_ON_SIGNAL.items():
        if (carrier, _CARRIER_INPUT[carrier]) in carried:
            continue
        run = c.gain(sig)
        stated = getattr(six, k)
        said = sign * stated
        if abs(run - said) > 1e-9 * max(abs(run), abs(said), 1e-300):
            raise ConfigError(f"{where}.{k}.value", f"{stated!r} disagrees with the controller, which runs "
                                                    f"{run!r} on {sig} (i.e. {k} = {sign * run!r})")
