"""The controller file's format (schema ``exotune.controller/1``): its units and its pydantic
model :class:`ControllerSchema`, whose JSON Schema ships as ``exotune/schemas/controller.schema.json``
(:func:`json_schema`, :func:`write_schema`; a test keeps them equal).

Every number of the file carries its unit, and the units are fixed (:data:`SIGNAL_UNITS`,
:data:`GAIN_UNITS`, :data:`PLANT_UNITS`, :data:`DESIGN_UNITS`, :data:`SIX_GAIN_UNITS`).
:func:`validate_controller` checks a mapping against the model (unknown keys refused, numbers strict
and finite); the checks the schema cannot express are in :mod:`exotune.controllerfile.checks`.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError

from ..errors import ConfigError
from ..units import DESIGN_UNITS, PLANT_UNITS, SIGNAL_UNITS  # re-exported: the file's sections' units
from ..units import SIGNAL_GAIN_UNITS as GAIN_UNITS, SIX_GAIN_UNITS  # re-exported

__all__ = [
    "SCHEMA_VERSION",
    "SIGNAL_UNITS",
    "GAIN_UNITS",
    "PLANT_UNITS",
    "DESIGN_UNITS",
    "SIX_GAIN_UNITS",
    "ControllerSchema",
    "validate_controller",
    "field_path",
    "json_schema",
    "write_schema",
    "schema_path",
]

SCHEMA_VERSION = "exotune.controller/1"

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


DeltaRow = tuple[SF, SF, SF, SF, SF]


class RealizationFilter(_S):
    name: str
    input: Literal["theta_m", "omega_m", "tau_s", "dtau_s", "tau_c", "tau_cmd"]
    sections: list[DeltaRow] = Field(min_length=1, description="rows [beta0, beta1, beta2, alpha1, alpha2], "
                                                               "delta = z - 1 (docs/controller-file.md#precision)")


class Realization(_S):
    """The float32 realization of a controller (``implementation.precision: float32``): what the
    target executes and certify analyses (exotune.controllerfile.precision)."""

    precision: Literal["float32"]
    form: Literal["delta_df2t"]
    note: str | None = None
    gains: dict[Literal["theta_m", "omega_m", "tau_s", "dtau_s", "tau_c"], SF]
    filters: list[RealizationFilter]
    loop_divisor: SF


class ControllerSection(_S):
    equation: str
    gains: dict[Literal["theta_m", "omega_m", "tau_s", "dtau_s", "tau_c"], Gain]
    filters: list[Filter]
    realization: Realization | None = None  # float32 files only


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
    realization: Realization | None = None  # float32 files only


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


class Requirements(_S):
    """What the file must keep (user intent, not a prediction): certify fails a file whose sampled-data
    latency margin is below ``latency_margin_s`` (0: no requirement)."""

    latency_margin_s: SF = Field(ge=0.0)
    unit: Literal["s"] = "s"
    source: str | None = None


class PredictedLatencyMargin(_Open):
    """The continuous latency margin of the design as exported (informational; certify reports it next
    to its own sampled-data margin)."""

    extra_delay_s: Annotated[float, Field(strict=True, ge=0.0)] | None = None
    extra_delay_samples: Annotated[float, Field(strict=True, ge=0.0)] | None = None
    critical: dict | None = None
    units: dict | None = None


class Predicted(_Open):
    """The file's predictions: ``continuous``, ``sampled`` (certify compares it) and, optionally,
    ``latency_margin`` (files written before it still load)."""

    latency_margin: PredictedLatencyMargin | None = None


# the file's schema; the package reads a validated file through the typed model
# exotune.controllerfile.model.ControllerFile (this docstring is the shipped schema's description)
class ProvenanceSection(_Open):
    """Where the file came from. Open (a hand-edited file may add notes), but the design file's hash
    is a SHA-256 hex digest or null."""

    input_sha256: Annotated[str, Field(strict=True, pattern=r"^[0-9a-f]{64}$")] | None = None


class ControllerSchema(_S):
    """The controller file (docs/controller-file.md). Extra keys are refused; numbers are finite."""

    schema_: Literal["exotune.controller/1"] = Field(alias="schema")
    sample_rate_hz: SampleRate
    delay_s: Delay
    plant: PlantSection
    design: DesignSection
    implementation: dict[str, Any] | None = None  # as in a design file; files written before 0.7 lack it
    gains: GainsSection
    signals: dict[str, dict[str, str]]
    controller: ControllerSection
    dob: _Open | None = None
    gain_schedule: GainSchedule | None = None
    gain_schedule_note: str | None = None
    transmission: Transmission | None = None
    certify: CertifySection
    requirements: Requirements | None = None
    predicted: Predicted
    golden: Golden
    provenance: ProvenanceSection


def schema_path() -> Path:
    """The path of the controller file's JSON Schema shipped with the package.

    Returns
    -------
    pathlib.Path
        ``exotune/controllerfile/schemas/controller.schema.json``.
    """
    return Path(__file__).resolve().parent / "schemas" / "controller.schema.json"


def json_schema() -> dict:
    """The JSON Schema (draft 2020-12) of a controller file, generated from :class:`ControllerSchema`.

    Returns
    -------
    dict
        The schema.
    """
    s = ControllerSchema.model_json_schema(by_alias=True)
    s["$schema"] = "https://json-schema.org/draft/2020-12/schema"
    s["$id"] = "https://exotune.invalid/schemas/controller/1"
    s["title"] = "exotune runtime controller file (schema exotune.controller/1)"
    return s


def write_schema(path: Path | None = None) -> None:
    """Write :func:`json_schema` atomically as JSON.

    Parameters
    ----------
    path : pathlib.Path or None, optional
        Where; None for :func:`schema_path`.
    """
    from ..jsonio import write_atomic

    write_atomic(path or schema_path(), json.dumps(json_schema(), indent=2, ensure_ascii=False) + "\n")


def validate_controller(doc: Any, source: str = "") -> ControllerSchema:
    """Validate a controller mapping; problems raise :class:`ConfigError` naming the field.

    Parameters
    ----------
    doc : Any
        The controller document.
    source : str, optional
        What it is (a path), named by a top-level error.

    Returns
    -------
    ControllerSchema
        The validated (pydantic) model.

    Raises
    ------
    exotune.errors.ConfigError
        When the document is not a mapping or fails the schema (the first error).
    """
    if not isinstance(doc, dict):
        raise ConfigError(source or "<controller>", "expected a mapping at the top level")
    try:
        return ControllerSchema.model_validate(doc)
    except ValidationError as e:
        from ..config.validate import pydantic_reason

        err = e.errors()[0]
        loc = field_path(err["loc"]) or (source or "<controller>")
        msg = pydantic_reason(err)  # exotune's wording, never pydantic's ("Input should be …")
        if err["type"] == "missing":
            msg = "missing field"
        elif err["type"] == "extra_forbidden":
            msg = "unknown field"
        elif tuple(err["loc"]) == ("provenance", "input_sha256"):
            msg = f"{err.get('input')!r}: expected the design file's SHA-256 (64 hex digits 0-9a-f) or null"
        elif "sos" in err["loc"] and err["loc"][-1] == 3 and err["type"] in ("less_than_equal", "greater_than_equal"):
            msg = (f"a0 = {err.get('input')!r}: must be 1 (sos rows are [b0, b1, b2, a0, a1, a2] with the "
                   "denominator normalized, scipy's convention)")
        raise ConfigError(loc, msg, in_file=True) from None


def field_path(loc) -> str:
    """A validation error's location as the file's field path: ``controller.filters[2].sos[0][3]``.

    Parameters
    ----------
    loc : sequence of str and int
        The location (pydantic's ``loc``: keys and list indices).

    Returns
    -------
    str
        Keys joined by dots, list indices in brackets.
    """
    out = ""
    for x in loc:
        out += f"[{x}]" if isinstance(x, int) else (f".{x}" if out else str(x))
    return out
