"""The schema of design and SEA files: strict pydantic models (unknown keys refused, every number
through the validators of :mod:`exotune.config.validate`).

:class:`DesignFileIn` is a design file's top level (``plant``, ``design``, ``implementation``,
``humans``, ``environment``, ``transmission``); the human and environment entries are validated one
by one against the model of their ``kind`` (:data:`HUMAN_MODELS`, :data:`ENV_MODELS`), so that an
error names the entry. :class:`SeaFileIn` is an SEA file (``exotune sea``).
"""

from __future__ import annotations

from typing import Annotated, Any, Literal, Optional

from pydantic import BaseModel, BeforeValidator, ConfigDict, field_validator

from ..model.controller import STRUCTURES
from .validate import Alpha, Eta, FeltDamping, NonNeg, Pos, Range, Real, fmt_value, range_or_number

__all__ = [
    "HUMAN_KINDS",
    "ENV_KINDS",
    "HUMAN_MODELS",
    "ENV_MODELS",
    "PlantIn",
    "SeaPlantIn",
    "DesignIn",
    "Filter2In",
    "Filter1In",
    "ImplementationIn",
    "TransmissionIn",
    "DesignFileIn",
    "SeaGainsIn",
    "SeaFileIn",
]

HUMAN_KINDS = ("mass", "spring", "msd", "complex_stiffness")
ENV_KINDS = ("locked", "free", "spring", "mass")


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


# --------------------------------------------------------------------------------------------
# Schema
# --------------------------------------------------------------------------------------------
class PlantIn(_Strict):
    motor_inertia: Pos
    motor_damping: NonNeg
    sea_stiffness: Pos
    joint_inertia: Pos
    cuff_stiffness: Pos


class SeaPlantIn(PlantIn):
    cuff_stiffness: Pos = 300.0


class DesignIn(_Strict):
    amplification: Alpha
    felt_inertia: Pos
    felt_damping: FeltDamping
    zeta: Pos
    zeta_hat: Pos


class Filter2In(_Strict):
    cutoff_hz: Pos
    damping: Pos


class Filter1In(_Strict):
    cutoff_hz: Pos


class ImplementationIn(_Strict):
    delay_s: NonNeg = 0.0
    sample_rate_hz: Optional[Pos] = None
    gv_filter: Optional[Filter2In] = None
    derivative_filter: Optional[Filter1In] = None
    dob: Optional[Filter2In] = None
    velocity_filter: Optional[Filter1In] = None
    structure: str = "default"

    @field_validator("structure", mode="before")
    @classmethod
    def _structure(cls, v):
        if not isinstance(v, str) or v not in STRUCTURES:
            raise ValueError(f"must be one of {', '.join(sorted(STRUCTURES))}, got {fmt_value(v)}")
        return v


class TransmissionIn(_Strict):
    """Joint-angle dependent transmission (paper §VI gain scheduling): at ``joint_angle_rad[i]``
    the transmission Jacobian is ``ratio[i]`` times the one the plant section is reflected with,
    so the joint-reflected motor inertia, motor damping and SEA stiffness scale with ratio²."""

    joint_angle_rad: list[Real]
    ratio: list[Pos]

    @field_validator("joint_angle_rad")
    @classmethod
    def _angles(cls, v):
        if len(v) < 2:
            raise ValueError(f"at least two joint angles are needed for a schedule, got {len(v)}")
        if any(b <= a for a, b in zip(v, v[1:])):
            raise ValueError("joint angles must be strictly increasing")
        return v

    @field_validator("ratio")
    @classmethod
    def _ratios(cls, v, info):
        n = len(info.data.get("joint_angle_rad") or [])
        if n and len(v) != n:
            raise ValueError(f"one ratio per joint angle: {n} angle(s), {len(v)} ratio(s)")
        return v


class DesignFileIn(_Strict):
    plant: PlantIn
    design: DesignIn
    implementation: Optional[ImplementationIn] = None
    humans: Optional[list[Any]] = None
    environment: Optional[list[Any]] = None
    transmission: Optional[TransmissionIn] = None


class HumanMassIn(_Strict):
    kind: Literal["mass"]
    inertia: Range
    damping: NonNeg = 0.0


class HumanSpringIn(_Strict):
    kind: Literal["spring"]
    stiffness: Range
    damping: NonNeg = 0.0


class HumanMsdIn(_Strict):
    kind: Literal["msd"]
    inertia: Annotated[Any, BeforeValidator(range_or_number)] = None
    damping: Annotated[Any, BeforeValidator(range_or_number)] = None
    stiffness: Annotated[Any, BeforeValidator(range_or_number)] = None


class HumanComplexIn(_Strict):
    kind: Literal["complex_stiffness"]
    stiffness: Range
    eta: Eta


class EnvLockedIn(_Strict):
    kind: Literal["locked"]


class EnvFreeIn(_Strict):
    kind: Literal["free"]


class EnvSpringIn(_Strict):
    kind: Literal["spring"]
    stiffness: Range
    damping: NonNeg = 0.0


class EnvMassIn(_Strict):
    kind: Literal["mass"]
    inertia: Range
    damping: NonNeg = 0.0


HUMAN_MODELS = {"mass": HumanMassIn, "spring": HumanSpringIn, "msd": HumanMsdIn, "complex_stiffness": HumanComplexIn}
ENV_MODELS = {"locked": EnvLockedIn, "free": EnvFreeIn, "spring": EnvSpringIn, "mass": EnvMassIn}


class SeaGainsIn(_Strict):
    K1: Real
    B1: Real
    K2: Real
    B2: Real
    units: str

    @field_validator("units", mode="before")
    @classmethod
    def _units(cls, v):
        if v not in ("deflection", "torque"):
            raise ValueError(
                f"must be 'deflection' (paper eq. extracted: K2 [N·m/rad], B2 [N·m·s/rad]) or "
                f"'torque' (K2 [–], B2 [s]), got {fmt_value(v)}"
            )
        return v


class SeaFileIn(_Strict):
    plant: SeaPlantIn
    gains: SeaGainsIn
