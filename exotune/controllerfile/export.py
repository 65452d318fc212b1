"""Export of the runtime controller file (SPEC §7 ``exotune export``).

The file is what a real-time runtime loads: at ``sample_rate_hz`` it reads the sampled signals
θ_m [rad], θ̇_m [rad/s], τ_s [N·m], τ̇_s [N·m/s], τ_c [N·m] and computes (SPEC §3)

    τ_cmd[k] = Σ_signals gain · signal[k] + Σ_filters filter(input)[k]

with every filter a cascade of second-order sections in scipy's ``sos`` convention (rows
[b0, b1, b2, a0, a1, a2], a0 = 1, direct form II transposed). One filter, ``dob_command``, acts on
τ_cmd[k] itself: the DOB's algebraic loop (Tustin gives Q a feed-through). A cascade's output is
affine in its input, y = g·x + h (g = Π b0 of its sections, h its output for x = 0), so the runtime
solves τ_cmd = (rest + h)/(1 − g) and then advances the cascade with x = τ_cmd
(:mod:`exotune.runtime`). The blocks are those of :func:`exotune.sampled.controller_blocks`, each
discretized by the bilinear transform prewarped at its cutoff (:func:`exotune.sampled.default_prewarp`),
here through zeros/poles (``scipy.signal.bilinear_zpk`` → ``zpk2sos``); the analysis side
(:func:`exotune.sampled.discretize`) goes through state space, and the tests check that both agree.

Every number carries its unit ({value, unit}, or a ``unit`` next to a list). The file also holds
the plant, the design, the delay it was designed for, the predicted metrics (continuous SPEC §5
analysis and the sampled-data intervals that ``exotune certify`` recomputes from this file), the
human/environment families to certify against, golden input/output vectors of the reference
runtime, and provenance. Its JSON Schema ships as ``exotune/schemas/controller.schema.json``
(generated from :class:`ControllerFile`; a test keeps them equal).
"""

from __future__ import annotations

import datetime as _dt
import json
import math
from pathlib import Path
from typing import Annotated, Any, Literal

import numpy as np
import scipy.signal
from pydantic import BaseModel, ConfigDict, Field, ValidationError

from ..errors import ConfigError
from ..sampled.loop import Measured, assemble, controller_blocks, default_prewarp, prewarped

__all__ = [
    "SCHEMA_VERSION",
    "SIGNAL_UNITS",
    "tustin_sos",
    "sos_ss",
    "build_export",
    "ControllerFile",
    "validate_controller",
    "load_controller",
    "discrete_from_file",
    "plant_from_file",
    "schema_path",
]

SCHEMA_VERSION = "exotune.controller/1"

SIGNAL_UNITS = {"theta_m": "rad", "omega_m": "rad/s", "tau_s": "N·m", "dtau_s": "N·m/s", "tau_c": "N·m",
                "tau_cmd": "N·m"}
_GAIN_UNITS = {"theta_m": "N·m/rad", "omega_m": "N·m·s/rad", "tau_s": "1 (N·m/N·m)", "dtau_s": "s",
               "tau_c": "1 (N·m/N·m)", "tau_cmd": "1 (N·m/N·m)"}
_PLANT_UNITS = {"motor_inertia": "kg·m²", "motor_damping": "N·m·s/rad", "sea_stiffness": "N·m/rad",
                "joint_inertia": "kg·m²", "cuff_stiffness": "N·m/rad"}
_DESIGN_UNITS = {"amplification": "1", "felt_inertia": "kg·m²", "felt_damping": "N·m·s/rad", "zeta": "1",
                 "zeta_hat": "1"}
_FILTER_DOC = {
    "motor_position": "proper part of G_θ (velocity filter)",
    "spring_torque": "proper part of G_s (velocity filter)",
    "cuff_path": "G_c: the filtered cuff compensator G_v (K̂2 + B̂2 s) (SPEC §3)",
    "dob_motor": "−Q(s)(J_m s² + B_m s): the DOB's inverse motor model on θ_m",
    "dob_spring": "+Q(s) on τ_s",
    "dob_command": "+Q(s) on τ_cmd itself (the DOB's algebraic loop, see runtime)",
}


def _q(value: float, unit: str) -> dict:
    return {"value": float(value), "unit": unit}


# --------------------------------------------------------------------------------------------
# discretization to second-order sections
# --------------------------------------------------------------------------------------------
def tustin_sos(num_asc, den_asc, sample_rate_hz: float, prewarp_hz: float | None = None) -> np.ndarray:
    """Second-order sections (scipy ``sos``) of the proper num/den (ascending powers of s) by the
    bilinear transform, prewarped at ``prewarp_hz`` (exact response there): s ← ω/tan(ωT_s/2)·(z−1)/(z+1)."""
    num = np.trim_zeros(np.atleast_1d(np.asarray(num_asc, dtype=float)), "b")
    den = np.trim_zeros(np.atleast_1d(np.asarray(den_asc, dtype=float)), "b")
    if num.size > den.size:
        raise ValueError("an improper block cannot be discretized")
    num, den = prewarped(num, den, 1.0 / float(sample_rate_hz), prewarp_hz)
    z, p, k = scipy.signal.tf2zpk(num[::-1], den[::-1])
    zd, pd, kd = scipy.signal.bilinear_zpk(z, p, k, float(sample_rate_hz))
    return scipy.signal.zpk2sos(zd, pd, kd)


def sos_ss(sos) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Discrete state space (A, B, C, D) of a cascade of second-order sections, each section in
    the direct form II transposed states the runtime uses (y = b0 x + s1, s1⁺ = b1 x − a1 y + s2,
    s2⁺ = b2 x − a2 y; rows normalized by a0), chained in order."""
    A = np.zeros((0, 0))
    B = np.zeros((0, 1))
    C = np.zeros((1, 0))
    D = np.ones((1, 1))
    for row in np.atleast_2d(np.asarray(sos, dtype=float)):
        b0, b1, b2, a0, a1, a2 = row
        b0, b1, b2, a1, a2 = b0 / a0, b1 / a0, b2 / a0, a1 / a0, a2 / a0
        As = np.array([[-a1, 1.0], [-a2, 0.0]])
        Bs = np.array([[b1 - a1 * b0], [b2 - a2 * b0]])
        Cs = np.array([[1.0, 0.0]])
        Ds = np.array([[b0]])
        # series: section input = previous output y = C x + D u
        n0 = A.shape[0]
        An = np.zeros((n0 + 2, n0 + 2))
        An[:n0, :n0] = A
        An[n0:, :n0] = Bs @ C
        An[n0:, n0:] = As
        Bn = np.vstack([B, Bs @ D])
        Cn = np.hstack([Ds @ C, Cs])
        A, B, C, D = An, Bn, Cn, Ds @ D
    return A, B, C, D


# --------------------------------------------------------------------------------------------
# the file's contents
# --------------------------------------------------------------------------------------------
def _golden_inputs(n: int = 200, fs: float = 1000.0, seed: int = 20251122) -> dict[str, np.ndarray]:
    """Deterministic, broadband test signals in realistic ranges (steps, sines, noise)."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) / fs
    step = (np.arange(n) >= n // 10).astype(float)
    sig = {
        "theta_m": 0.1 * step + 0.05 * np.sin(2 * np.pi * 3.0 * t) + 0.002 * rng.standard_normal(n),
        "omega_m": 0.5 * np.cos(2 * np.pi * 3.0 * t) + 0.05 * rng.standard_normal(n),
        "tau_s": 5.0 * step + 2.0 * np.sin(2 * np.pi * 7.0 * t) + 0.1 * rng.standard_normal(n),
        "dtau_s": 80.0 * np.cos(2 * np.pi * 7.0 * t) + 5.0 * rng.standard_normal(n),
        "tau_c": 2.0 * step + 1.0 * np.sin(2 * np.pi * 11.0 * t) + 0.05 * rng.standard_normal(n),
    }
    return sig


_SIX_GAIN_UNITS = {"K1": "N·m/rad", "B1": "N·m·s/rad", "K2": "1 (N·m/N·m)", "B2": "s", "K2_hat": "1 (N·m/N·m)",
                   "B2_hat": "s"}


def _controller_section(cfg, fs: float) -> tuple[dict, list[dict], dict]:
    """(static gains on the signals, sos filters, the six design gains with units) of one design."""
    from ..model.controller import build_controller

    cs, _ = build_controller(cfg.plant, cfg.design, cfg.implementation)
    six = {k: _q(float(np.ravel(getattr(cs.gains, k))[0]), u) for k, u in _SIX_GAIN_UNITS.items()}
    static, blocks = controller_blocks(cs, cfg.plant)
    pw = default_prewarp(cfg.implementation)
    gains = {sig: {"gain": float(static[i]), "unit": _GAIN_UNITS[sig]} for i, sig in enumerate(Measured) if static[i] != 0}
    filters = []
    for b in blocks:
        sos = tustin_sos(b.num, b.den, fs, pw.get(b.prewarp))
        filters.append({
            "name": b.name,
            "input": b.input,
            "input_unit": SIGNAL_UNITS[b.input],
            "output_unit": "N·m",
            "unit": _GAIN_UNITS[b.input],
            "description": _FILTER_DOC.get(b.name, b.name),
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
    transmission section."""
    import copy

    r = copy.deepcopy(raw)
    r.pop("transmission", None)
    for k in ("motor_inertia", "motor_damping", "sea_stiffness"):
        r["plant"][k] = float(r["plant"][k]) * ratio * ratio
    return r


def _gain_schedule(cfg, fs: float, doc: dict) -> dict:
    from .certify import sampled_analysis
    from ..config.design import design_from_mapping

    tr = cfg.raw["transmission"]
    entries = []
    for angle, ratio in zip(tr["joint_angle_rad"], tr["ratio"]):
        cfg_i = design_from_mapping(reflected_mapping(cfg.raw, ratio))
        gains_sig, filters, six = _controller_section(cfg_i, fs)
        entry = {
            "joint_angle_rad": float(angle),
            "ratio": float(ratio),
            "plant": {k: _q(v, _PLANT_UNITS[k]) for k, v in cfg_i.raw["plant"].items()},
            "gains": six,
            "controller": {"gains": gains_sig, "filters": filters},
        }
        entry["predicted_sampled"] = sampled_analysis(schedule_entry_doc(doc, entry))
        entries.append(entry)
    return {"variable": "joint_angle_rad", "unit": "rad", "entries": entries}


def schedule_entry_doc(doc: dict, entry: dict) -> dict:
    """The controller-file view of one gain-schedule entry (its plant, gains and controller)."""
    return {**doc, "plant": entry["plant"], "gains": entry["gains"],
            "controller": {**doc["controller"], **entry["controller"]}}


def _predicted(cfg) -> dict:
    """The continuous SPEC §5 metrics of the design (exotune.analysis), with units."""
    import dataclasses

    from ..analysis.core import analyze_design

    # continuous metrics only: the sampled-data intervals are computed once, by certify's own
    # analysis of the file (predicted.sampled), not a second time inside analyze_design
    cont = dataclasses.replace(cfg, implementation=dataclasses.replace(cfg.implementation, sample_rate_hz=None))
    r = analyze_design(cont)
    humans = [{"kind": h["kind"], "parameter": h["parameter"], "unit": h["unit"], "range": h["range"],
               "stable_intervals": h["stable_intervals"], "robust": bool(h["robust"])} for h in r["humans"]]
    dob = r["dob"]
    return {
        "model": "continuous time, exact delay (exotune analyze)",
        "free_stable": bool(r["free_stable"]),
        "locked_stable": bool(r["locked_stable"]),
        "humans": humans,
        "passivity": {"max_phase_excess_deg": _q(r["passivity"]["max_phase_excess_deg"], "deg"),
                      "nonpassive_band_hz": {"value": r["passivity"]["nonpassive_band_hz"], "unit": "Hz"},
                      "kyp": {name: (c if name == "error" else
                                     {"model": c["model"], "passive": c["passive"],
                                      "shortage": _q(c["shortage"], c["shortage_unit"])})
                              for name, c in r["passivity"]["kyp"].items()}},
        "dob": None if dob is None else {
            "gain_margin_db": _q(dob["gain_margin_db"], "dB"),
            "phase_margin_deg": _q(dob["phase_margin_deg"], "deg"),
            "delay_margin_s": _q(dob["delay_margin_s"], "s"),
        },
        "amplification": {"dc": _q(r["amplification"]["dc"], "1"),
                          "bandwidth_hz": _q(r["amplification"]["bandwidth_hz"], "Hz")},
    }


def build_export(cfg, sample_rate_hz: float, source: str | None = None, input_hash: str | None = None,
                 now: _dt.datetime | None = None) -> dict:
    """The controller file of a validated single design ``cfg`` at ``sample_rate_hz``
    (the configuration must already carry that sample rate: see :func:`exotune.cli` export)."""
    from ..version import __version__
    from .certify import sampled_analysis
    from .runtime import Runtime

    fs = float(sample_rate_hz)
    g = lambda x: float(np.ravel(x)[0])  # noqa: E731
    raw = cfg.raw
    delay = g(cfg.implementation.delay_s)
    gains_sig, filters, gains = _controller_section(cfg, fs)
    doc: dict[str, Any] = {
        "schema": SCHEMA_VERSION,
        "sample_rate_hz": _q(fs, "Hz"),
        "delay_s": {"value": delay, "unit": "s", "samples": delay * fs,
                    "note": "total measured-to-applied latency the controller was designed and certified for"},
        "plant": {k: _q(v, _PLANT_UNITS[k]) for k, v in raw["plant"].items()},
        "design": {k: _q(v, _DESIGN_UNITS[k]) for k, v in raw["design"].items()},
        "gains": {**gains, "convention": "torque units (SPEC §4): K2, B2 act on τ_s, K2_hat, B2_hat on τ_c"},
        "signals": {"inputs": {s: SIGNAL_UNITS[s] for s in Measured}, "output": {"tau_cmd": "N·m"}},
        "controller": {
            "equation": "tau_cmd[k] = sum(gain * signal[k]) + sum(filter(input)[k]); sos rows [b0, b1, b2, a0, a1, a2] "
                        "(scipy convention, a0 = 1), direct form II transposed; the filter on tau_cmd closes an "
                        "algebraic loop: tau_cmd = (rest + h)/(1 - g) with g = prod(b0), h = its output for input 0",
            "gains": gains_sig,
            "filters": filters,
        },
        "dob": None if cfg.implementation.dob is None else {
            "q_cutoff_hz": _q(g(cfg.implementation.dob.cutoff_hz), "Hz"),
            "q_damping": _q(g(cfg.implementation.dob.damping), "1"),
            "filters": [f["name"] for f in filters if f["name"].startswith("dob_")],
        },
        "gain_schedule": None,
        "gain_schedule_note": ("no transmission model in the design file: the gains are constant over the joint "
                               "angle"),
        "transmission": raw.get("transmission"),
        "certify": {"humans": raw["humans"], "environment": raw["environment"]},
    }
    doc["predicted"] = {"continuous": _predicted(cfg)}
    doc["predicted"]["sampled"] = sampled_analysis(doc)
    if raw.get("transmission"):
        doc["gain_schedule"] = _gain_schedule(cfg, fs, doc)
        doc["gain_schedule_note"] = (
            "paper §VI: the gains are recomputed from the joint-reflected J_m, B_m, K_s at each scheduled joint angle "
            "(transmission ratio r: J_m, B_m, K_s scale with r²), so the compliance the human feels stays the "
            "same; each entry is a complete controller, certified frozen at its angle (LTI) — the time-varying "
            "schedule itself has no stability guarantee (paper); the reference runtime uses the nearest entry")
    ins = _golden_inputs(fs=fs)
    out = Runtime(doc).run(ins)
    for e in (doc["gain_schedule"] or {}).get("entries", []):
        e["golden_tau_cmd"] = {"unit": "N·m", "values": [float(x) for x in Runtime(schedule_entry_doc(doc, e)).run(ins)]}
    doc["golden"] = {"note": "reference-runtime outputs (exotune.runtime) for these inputs from the zero state",
                     "inputs": {s: {"unit": SIGNAL_UNITS[s], "values": [float(x) for x in v]} for s, v in ins.items()},
                     "tau_cmd": {"unit": "N·m", "values": [float(x) for x in out]}}
    doc["provenance"] = {
        "exotune_version": __version__,
        "source": None if source is None else Path(source).name,
        "input_sha256": input_hash,
        "created_utc": (now or _dt.datetime.now(_dt.timezone.utc)).replace(microsecond=0).isoformat(),
    }
    validate_controller(doc)
    return doc


# --------------------------------------------------------------------------------------------
# validation (pydantic model; its JSON Schema ships with the package)
# --------------------------------------------------------------------------------------------
class _S(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)


# numbers are strict: a quoted "1000" or a boolean is refused (pydantic's lax mode would convert
# them); integers are accepted as floats
SF = Annotated[float, Field(strict=True)]


class _Open(BaseModel):
    model_config = ConfigDict(extra="allow")


class Quantity(_S):
    value: SF
    unit: str


class Gain(_S):
    gain: SF
    unit: str


_A0 = Annotated[float, Field(strict=True, ge=1.0, le=1.0, description="a0 = 1 (scipy sos convention)")]
SosRow = tuple[SF, SF, SF, _A0, SF, SF]


class Filter(_S):
    name: str
    input: Literal["theta_m", "omega_m", "tau_s", "dtau_s", "tau_c", "tau_cmd"]
    input_unit: str
    output_unit: str
    unit: str
    description: str | None = None
    discretization: str
    prewarp_hz: Annotated[float, Field(strict=True, gt=0.0)] | None = None
    continuous: dict | None = None
    sos: list[SosRow] = Field(min_length=1, description="rows [b0, b1, b2, a0, a1, a2], a0 = 1, DF-II transposed")


class ControllerSection(_S):
    equation: str
    gains: dict[Literal["theta_m", "omega_m", "tau_s", "dtau_s", "tau_c"], Gain]
    filters: list[Filter]


class SignalValues(_S):
    unit: str
    values: list[SF]


class GoldenInputs(_S):
    theta_m: SignalValues
    omega_m: SignalValues
    tau_s: SignalValues
    dtau_s: SignalValues
    tau_c: SignalValues


class Golden(_S):
    note: str | None = None
    inputs: GoldenInputs
    tau_cmd: SignalValues


class Delay(_S):
    value: SF = Field(ge=0.0)
    unit: Literal["s"]
    samples: SF | None = None
    note: str | None = None


class SampleRate(_S):
    value: SF = Field(gt=0.0)
    unit: Literal["Hz"]


class Positive(Quantity):
    value: SF = Field(gt=0.0)


class NonNegative(Quantity):
    value: SF = Field(ge=0.0)


class PlantSection(_S):
    motor_inertia: Positive
    motor_damping: NonNegative
    sea_stiffness: Positive
    joint_inertia: Positive
    cuff_stiffness: Positive


class AtLeastOne(Quantity):
    value: SF = Field(ge=1.0)


class DesignSection(_S):
    amplification: AtLeastOne
    felt_inertia: Positive
    felt_damping: Positive
    zeta: NonNegative
    zeta_hat: NonNegative


class GainsSection(_S):
    K1: Quantity
    B1: Quantity
    K2: Quantity
    B2: Quantity
    K2_hat: Quantity
    B2_hat: Quantity
    convention: str | None = None


class CertifySection(_S):
    humans: list[dict] = Field(default_factory=list)
    environment: list[dict] = Field(default_factory=list)


class ScheduleController(_S):
    gains: dict[Literal["theta_m", "omega_m", "tau_s", "dtau_s", "tau_c"], Gain]
    filters: list[Filter]


class ScheduleEntry(_S):
    joint_angle_rad: SF
    ratio: SF = Field(gt=0.0)
    plant: PlantSection
    gains: GainsSection
    controller: ScheduleController
    predicted_sampled: _Open
    golden_tau_cmd: SignalValues


class GainSchedule(_S):
    variable: Literal["joint_angle_rad"]
    unit: Literal["rad"]
    entries: list[ScheduleEntry] = Field(min_length=1)


class Transmission(_S):
    joint_angle_rad: list[SF]
    ratio: list[SF]


class ControllerFile(_S):
    """The controller file (SPEC §7). Extra keys are refused; numbers are finite."""

    schema_: Literal["exotune.controller/1"] = Field(alias="schema")
    sample_rate_hz: SampleRate
    delay_s: Delay
    plant: PlantSection
    design: DesignSection
    gains: GainsSection
    signals: dict[str, dict[str, str]]
    controller: ControllerSection
    dob: _Open | None = None
    gain_schedule: GainSchedule | None = None
    gain_schedule_note: str | None = None
    transmission: Transmission | None = None
    certify: CertifySection
    predicted: _Open
    golden: Golden
    provenance: _Open


def schema_path() -> Path:
    return Path(__file__).resolve().parent / "schemas" / "controller.schema.json"


def json_schema() -> dict:
    s = ControllerFile.model_json_schema(by_alias=True)
    s["$schema"] = "https://json-schema.org/draft/2020-12/schema"
    s["$id"] = "https://exotune.invalid/schemas/controller/1"
    s["title"] = "exotune runtime controller file (schema exotune.controller/1)"
    return s


def write_schema(path: Path | None = None) -> None:
    from ..jsonio import write_atomic

    write_atomic(path or schema_path(), json.dumps(json_schema(), indent=2, ensure_ascii=False) + "\n")


def validate_controller(doc: Any, source: str = "") -> ControllerFile:
    """Validate a controller mapping; problems raise :class:`ConfigError` naming the field."""
    if not isinstance(doc, dict):
        raise ConfigError(source or "<controller>", "expected a mapping at the top level")
    try:
        return ControllerFile.model_validate(doc)
    except ValidationError as e:
        err = e.errors()[0]
        loc = ".".join(str(x) for x in err["loc"]) or (source or "<controller>")
        msg = err["msg"]
        if err["type"] == "missing":
            msg = "missing field"
        elif err["type"] == "extra_forbidden":
            msg = "unknown field"
        raise ConfigError(loc, msg) from None


def _unit(field: str, got, want: str) -> None:
    if got != want:
        raise ConfigError(field, f"unit {got!r}, expected {want!r} (exotune.controller/1 fixes every unit)")


def _check_controller(c: dict, where: str) -> None:
    """Units, filter names and the DOB's algebraic loop of one controller section."""
    for sig, gn in c["gains"].items():
        _unit(f"{where}.gains.{sig}.unit", gn["unit"], _GAIN_UNITS[sig])
    names = [f["name"] for f in c["filters"]]
    for i, f in enumerate(c["filters"]):
        fw = f"{where}.filters[{i}]"
        if not f["name"] or f["name"] in names[:i]:
            raise ConfigError(f"{fw}.name", f"filter names must be non-empty and unique, got {f['name']!r}")
        _unit(f"{fw}.input_unit", f["input_unit"], SIGNAL_UNITS[f["input"]])
        _unit(f"{fw}.output_unit", f["output_unit"], "N·m")
        _unit(f"{fw}.unit", f["unit"], _GAIN_UNITS[f["input"]])
    # the runtime solves τ_cmd = (rest + h)/(1 − g), g = Σ Π b0 over the filters on τ_cmd
    g = sum(float(np.prod([row[0] for row in f["sos"]])) for f in c["filters"] if f["input"] == "tau_cmd")
    if abs(1.0 - g) < 1e-9:
        raise ConfigError(f"{where}.filters", f"the DOB's algebraic loop is singular: the feed-throughs Π b0 of the "
                                              f"filters on tau_cmd add up to {g!r} (must not be 1)")


def _check_plant(p: dict, where: str) -> None:
    for k, q in p.items():
        _unit(f"{where}.{k}.unit", q["unit"], _PLANT_UNITS[k])


def check_controller_file(doc: dict) -> None:
    """Checks of a schema-valid controller file that the JSON Schema cannot express (found by
    fuzzing: each was accepted, some by ``certify``): every unit is the schema's; the delay in
    samples agrees with the delay and the rate; filter names are unique; the DOB's algebraic loop
    is not singular in any controller; the six-gain summary agrees with the static gains it names;
    the ``dob`` section describes every controller; the gain schedule agrees with the transmission
    table and each entry's plant is the top-level plant reflected at its ratio; golden vectors
    have at least MIN_GOLDEN_SAMPLES samples, all of one length. Problems raise
    :class:`ConfigError` naming the field."""
    from ..config.design import check_delay_samples

    fs, T = doc["sample_rate_hz"]["value"], doc["delay_s"]["value"]
    check_delay_samples(T, fs, "delay_s.value")
    n = doc["delay_s"].get("samples")
    if n is not None and abs(n - T * fs) > 1e-9 * max(1.0, T * fs):
        raise ConfigError("delay_s.samples", f"{n!r} samples, but {T!r} s at {fs!r} Hz is {T * fs!r}")
    _check_plant(doc["plant"], "plant")
    for k, q in doc["design"].items():
        _unit(f"design.{k}.unit", q["unit"], _DESIGN_UNITS[k])
    for k, u in _SIX_GAIN_UNITS.items():
        _unit(f"gains.{k}.unit", doc["gains"][k]["unit"], u)
    want = {"inputs": {s: SIGNAL_UNITS[s] for s in Measured}, "output": {"tau_cmd": "N·m"}}
    if doc["signals"] != want:
        raise ConfigError("signals", f"must be {want} (the runtime's signals and their units)")
    _check_controller(doc["controller"], "controller")
    _check_six_gains(doc["gains"], doc["controller"], "gains")
    for s_, v in doc["golden"]["inputs"].items():
        _unit(f"golden.inputs.{s_}.unit", v["unit"], SIGNAL_UNITS[s_])
    _unit("golden.tau_cmd.unit", doc["golden"]["tau_cmd"]["unit"], "N·m")
    n_golden = len(doc["golden"]["tau_cmd"]["values"])
    if n_golden < MIN_GOLDEN_SAMPLES:
        raise ConfigError("golden.tau_cmd.values", f"{n_golden} samples; a golden vector has at least {MIN_GOLDEN_SAMPLES}")
    for s_, v in doc["golden"]["inputs"].items():
        if len(v["values"]) != n_golden:
            raise ConfigError(f"golden.inputs.{s_}.values", f"{len(v['values'])} samples, golden.tau_cmd has {n_golden}")
    sched, tr = doc.get("gain_schedule"), doc.get("transmission")
    controllers = [("controller", doc["controller"])] + [
        (f"gain_schedule.entries[{i}].controller", e["controller"]) for i, e in enumerate((sched or {}).get("entries", []))]
    _check_dob_section(doc.get("dob"), controllers)
    if (sched is None) != (tr is None):
        raise ConfigError("gain_schedule" if sched is None else "transmission",
                          "a gain schedule and a transmission table come together (one is missing)")
    if sched is not None:
        angles = [e["joint_angle_rad"] for e in sched["entries"]]
        if len(set(angles)) != len(angles):
            raise ConfigError("gain_schedule.entries", "two entries have the same joint angle")
        if len(tr["joint_angle_rad"]) != len(tr["ratio"]):
            raise ConfigError("transmission.ratio", "needs one ratio per joint angle")
        if sorted(zip(angles, (e["ratio"] for e in sched["entries"]))) != sorted(zip(tr["joint_angle_rad"], tr["ratio"])):
            raise ConfigError("gain_schedule.entries", "the entries' (joint angle, ratio) pairs must be the "
                                                       "transmission table's")
        for i, e in enumerate(sched["entries"]):
            w = f"gain_schedule.entries[{i}]"
            _check_plant(e["plant"], f"{w}.plant")
            for k, q in e["plant"].items():  # the plant reflected at the entry's ratio (paper §VI)
                reflected = doc["plant"][k]["value"] * (e["ratio"] ** 2 if k in _REFLECTED else 1.0)
                if abs(q["value"] - reflected) > 1e-9 * max(abs(reflected), 1e-300):
                    raise ConfigError(f"{w}.plant.{k}.value",
                                      f"{q['value']!r}, but the plant at ratio {e['ratio']!r} has {reflected!r} "
                                      f"({'× ratio²' if k in _REFLECTED else 'as at ratio 1'})")
            _check_controller(e["controller"], f"{w}.controller")
            _check_six_gains(e["gains"], e["controller"], f"{w}.gains")
            _unit(f"{w}.golden_tau_cmd.unit", e["golden_tau_cmd"]["unit"], "N·m")


_REFLECTED = ("motor_inertia", "motor_damping", "sea_stiffness")  # × ratio² in a gain-schedule entry


def _check_dob_section(dob, controllers) -> None:
    """The ``dob`` summary must describe the controllers: without it no filter closes the DOB's
    loop (acts on τ_cmd); with it, its filters exist in every controller and its units are fixed."""
    for where, c in controllers:
        cmd = [f["name"] for f in c["filters"] if f["input"] == "tau_cmd"]
        if dob is None and cmd:
            raise ConfigError("dob", f"null, but {where} runs the DOB filter {cmd[0]!r} (on tau_cmd)")
    if dob is None:
        return
    listed = dob.get("filters")
    if not isinstance(listed, list) or not listed:
        raise ConfigError("dob.filters", "expected the (non-empty) list of the DOB's filter names")
    for where, c in controllers:
        names = [f["name"] for f in c["filters"]]
        for i, name in enumerate(listed):
            if name not in names:
                raise ConfigError(f"dob.filters[{i}]", f"{where} has no filter named {name!r}")
        if not any(f["input"] == "tau_cmd" for f in c["filters"]):
            raise ConfigError(f"{where}.filters", "a DOB is declared (dob) but no filter closes its loop on tau_cmd")
    for key, unit in (("q_cutoff_hz", "Hz"), ("q_damping", "1")):
        q = dob.get(key)
        if not (isinstance(q, dict) and isinstance(q.get("value"), (int, float)) and not isinstance(q.get("value"), bool)
                and math.isfinite(q["value"]) and q["value"] > 0):
            raise ConfigError(f"dob.{key}", "expected {value: a positive number, unit: ...}")
        _unit(f"dob.{key}.unit", q.get("unit"), unit)


# the six gains that act as static gains on a sensed signal when no filter carries them
# (sign: τ_cmd = −K1 θ_m − B1 θ̇_m + K2 τ_s + B2 τ̇_s + …, SPEC §3)
_SIX_ON_SIGNAL = {"K1": ("theta_m", -1.0, "motor_position"), "B1": ("omega_m", -1.0, "motor_position"),
                  "K2": ("tau_s", 1.0, "spring_torque"), "B2": ("dtau_s", 1.0, "spring_torque")}
_CARRIER_INPUT = {"motor_position": "theta_m", "spring_torque": "tau_s"}  # exotune.sampled.controller_blocks
MIN_GOLDEN_SAMPLES = 10


def _check_six_gains(six: dict, c: dict, where: str) -> None:
    """The six-gain summary must state the controller's static gains (when no filter carries them:
    with a velocity filter, K1/B1 and K2/B2 live inside the motor_position/spring_torque filters)."""
    carried = {(f["name"], f["input"]) for f in c["filters"]}
    for k, (sig, sign, carrier) in _SIX_ON_SIGNAL.items():
        if (carrier, _CARRIER_INPUT[carrier]) in carried:
            continue
        run = c["gains"].get(sig, {"gain": 0.0})["gain"]
        said = sign * six[k]["value"]
        if abs(run - said) > 1e-9 * max(abs(run), abs(said), 1e-300):
            raise ConfigError(f"{where}.{k}.value", f"{six[k]['value']!r} disagrees with the controller, which runs "
                                                    f"{run!r} on {sig} (i.e. {k} = {sign * run!r})")


def load_controller(path) -> dict:
    """Read (safe YAML loader) and validate a controller file (schema, then
    :func:`check_controller_file`); returns the mapping."""
    from ..config.design import read_yaml

    doc = read_yaml(path)
    validate_controller(doc, str(path))
    check_controller_file(doc)
    return doc


def discrete_from_file(doc: dict):
    """The file's controller as one state space (:class:`exotune.sampled.DiscreteController`),
    built from its gains and sos filters only."""
    c = doc["controller"]
    static = np.array([c["gains"].get(s, {"gain": 0.0})["gain"] for s in Measured], dtype=float)
    blocks = [(sos_ss(f["sos"]), f["input"]) for f in c["filters"]]
    return assemble(static, blocks, doc["sample_rate_hz"]["value"], doc["delay_s"]["value"])


def plant_from_file(doc: dict):
    from ..model.plant import Plant

    p = {k: v["value"] for k, v in doc["plant"].items()}
    return Plant(p["motor_inertia"], p["motor_damping"], p["sea_stiffness"], p["joint_inertia"], p["cuff_stiffness"])


def export_design(design_file, sample_rate_hz: float, out) -> dict:
    """``exotune export``: validate the design at ``sample_rate_hz`` (cutoffs below Nyquist), build
    the controller file and write it atomically as YAML. Returns the document."""
    import hashlib

    import yaml

    from ..config.design import read_yaml
    from ..jsonio import write_atomic

    raw = read_yaml(design_file)
    cfg = design_at_rate(raw, sample_rate_hz, str(design_file))
    fs = float(cfg.implementation.sample_rate_hz)
    digest = hashlib.sha256(Path(design_file).read_bytes()).hexdigest()
    doc = build_export(cfg, fs, source=str(design_file), input_hash=digest)
    text = ("# exotune runtime controller file (schema exotune.controller/1, see exotune/schemas/controller.schema.json)\n"
            + yaml.safe_dump(doc, sort_keys=False, allow_unicode=True, width=120))
    write_atomic(out, text)
    return doc


def check_sample_rate(value, field: str = "--sample-rate-hz") -> float:
    """A sample rate [Hz] from the command line: a positive, finite number (else ConfigError)."""
    try:
        fs = float(value)
    except (TypeError, ValueError):
        raise ConfigError(field, f"expected a number of Hz, got {value!r}") from None
    if not (math.isfinite(fs) and fs > 0):
        raise ConfigError(field, f"must be a positive, finite number of Hz, got {fs:g}")
    return fs


def design_at_rate(raw, sample_rate_hz, source: str | None = None):
    """Validate a design mapping with ``implementation.sample_rate_hz`` set to ``sample_rate_hz``
    (so every filter cutoff is checked against that Nyquist frequency)."""
    from ..config.design import design_from_mapping

    fs = check_sample_rate(sample_rate_hz)
    if isinstance(raw, dict) and (raw.get("implementation") is None or isinstance(raw.get("implementation"), dict)):
        raw = {**raw, "implementation": {**(raw.get("implementation") or {}), "sample_rate_hz": fs}}
    return design_from_mapping(raw, source=source)
