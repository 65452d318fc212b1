"""The schema of design and SEA files: strict pydantic models (unknown keys refused, every number
through the validators of :mod:`exotune.config.validate`).

:class:`DesignFileIn` is a design file's top level (``plant``, ``design``, ``implementation``,
``humans``, ``environment``, ``transmission``); the human and environment entries are validated one
by one against the model of their ``kind`` (:data:`HUMAN_MODELS`, :data:`ENV_MODELS`), so that an
error names the entry. :class:`SeaFileIn` is an SEA file (``exotune sea``).
"""

from __future__ import annotations

from typing import Any, Literal, Optional

from pydantic import BaseModel, ConfigDict, field_validator

from ..model.controller import STRUCTURES
from .validate import (
    RelativeRange,
    Amplification,
    Angle,
    Damping,
    DampingRatio,
    Delay,
    Eta,
    FeltDamping,
    Frequency,
    Inertia,
    InertiaRange,
    MsdDamping,
    MsdInertia,
    MsdStiffness,
    Ratio,
    SeaGain,
    Stiffness,
    StiffnessRange,
    fmt_value,
)

__all__ = [
    "HUMAN_KINDS",
    "ENV_KINDS",
    "HUMAN_MODELS",
    "ENV_MODELS",
    "MAX_SCHEDULE_ENTRIES",
    "PlantIn",
    "SeaPlantIn",
    "DesignIn",
    "Filter2In",
    "Filter1In",
    "ImplementationIn",
    "TransmissionIn",
    "RequirementsIn",
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
    motor_inertia: Inertia
    motor_damping: Damping
    sea_stiffness: Stiffness
    joint_inertia: Inertia
    cuff_stiffness: Stiffness


class SeaPlantIn(PlantIn):
    cuff_stiffness: Stiffness = 300.0


class DesignIn(_Strict):
    amplification: Amplification
    felt_inertia: Inertia
    felt_damping: FeltDamping
    zeta: DampingRatio
    zeta_hat: DampingRatio


class Filter2In(_Strict):
    cutoff_hz: Frequency
    damping: DampingRatio


class Filter1In(_Strict):
    cutoff_hz: Frequency


class ImplementationIn(_Strict):
    delay_s: Delay = 0.0
    sample_rate_hz: Optional[Frequency] = None
    gv_filter: Optional[Filter2In] = None
    derivative_filter: Optional[Filter1In] = None
    dob: Optional[Filter2In] = None
    velocity_filter: Optional[Filter1In] = None
    structure: str = "default"
    precision: Optional[str] = None  # the target's arithmetic (docs/controller-file.md#precision); None: float64

    @field_validator("structure", mode="before")
    @classmethod
    def _structure(cls, v):
        if not isinstance(v, str) or v not in STRUCTURES:
            raise ValueError(f"must be one of {', '.join(sorted(STRUCTURES))}, got {fmt_value(v)}")
        return v

    @field_validator("precision", mode="before")
    @classmethod
    def _precision(cls, v):
        if v is not None and (not isinstance(v, str) or v not in ("float64", "float32")):
            raise ValueError(f"must be float64 or float32 (the arithmetic of the target that runs the controller), "
                             f"got {fmt_value(v)}")
        return v


#: The most joint angles of a transmission table (1° steps over 127°): the controller file
#: ``export`` writes holds one controller per angle (up to ~15 kB and ~800 values each), which must
#: stay within the limits of ``exotune.config.yamlio`` (``MAX_YAML_BYTES``, ``MAX_YAML_NODES``).
MAX_SCHEDULE_ENTRIES = 128


class TransmissionIn(_Strict):
    """Joint-angle dependent transmission (paper §IV gain scheduling): at ``joint_angle_rad[i]``
    the transmission Jacobian is ``ratio[i]`` times the one the plant section is reflected with,
    so the joint-reflected motor inertia, motor damping and SEA stiffness scale with ratio²."""

    joint_angle_rad: list[Angle]
    ratio: list[Ratio]

    @field_validator("joint_angle_rad")
    @classmethod
    def _angles(cls, v):
        if len(v) < 2:
            raise ValueError(f"at least two joint angles are needed for a schedule, got {len(v)}")
        if len(v) > MAX_SCHEDULE_ENTRIES:  # export writes one controller per angle: a file certify must read
            raise ValueError(f"at most {MAX_SCHEDULE_ENTRIES} joint angles, got {len(v)} (export writes one "
                             "controller per angle, and the controller file must stay within the size a YAML "
                             "input may have, docs/design-file.md#input-limits-and-accepted-ranges)")
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


class UncertaintyIn(_Strict):
    """Relative uncertainty of each plant parameter (a fraction: 0.1 is ±10 %), the unit of the
    plant-uncertainty margin (docs/method.md#plant-uncertainty-margin); a parameter left out is
    certain (0). Without the section every parameter has weight 1."""

    motor_inertia: Optional[RelativeRange] = None
    motor_damping: Optional[RelativeRange] = None
    sea_stiffness: Optional[RelativeRange] = None
    joint_inertia: Optional[RelativeRange] = None
    cuff_stiffness: Optional[RelativeRange] = None


class RequirementsIn(_Strict):
    """What the design must keep once it runs (docs/design-file.md#requirements): the latency
    margin [s] of its sampled-data loop (0: none; absent: one sample period at the design's rate),
    and where the requirement came from (written by ``exotune optimize``)."""

    latency_margin_s: Optional[Delay] = None
    source: Optional[str] = None


class DesignFileIn(_Strict):
    plant: PlantIn
    design: DesignIn
    implementation: Optional[ImplementationIn] = None
    humans: Optional[list[Any]] = None
    environment: Optional[list[Any]] = None
    transmission: Optional[TransmissionIn] = None
    uncertainty: Optional[UncertaintyIn] = None
    requirements: Optional[RequirementsIn] = None


class HumanMassIn(_Strict):
    kind: Literal["mass"]
    inertia: InertiaRange
    damping: Damping = 0.0


class HumanSpringIn(_Strict):
    kind: Literal["spring"]
    stiffness: StiffnessRange
    damping: Damping = 0.0


class HumanMsdIn(_Strict):
    kind: Literal["msd"]
    inertia: MsdInertia = None
    damping: MsdDamping = None
    stiffness: MsdStiffness = None


class HumanComplexIn(_Strict):
    kind: Literal["complex_stiffness"]
    stiffness: StiffnessRange
    eta: Eta


class EnvLockedIn(_Strict):
    kind: Literal["locked"]


class EnvFreeIn(_Strict):
    kind: Literal["free"]


class EnvSpringIn(_Strict):
    kind: Literal["spring"]
    stiffness: StiffnessRange
    damping: Damping = 0.0


class EnvMassIn(_Strict):
    kind: Literal["mass"]
    inertia: InertiaRange
    damping: Damping = 0.0


HUMAN_MODELS = {"mass": HumanMassIn, "spring": HumanSpringIn, "msd": HumanMsdIn, "complex_stiffness": HumanComplexIn}
ENV_MODELS = {"locked": EnvLockedIn, "free": EnvFreeIn, "spring": EnvSpringIn, "mass": EnvMassIn}


class SeaGainsIn(_Strict):
    K1: SeaGain
    B1: SeaGain
    K2: SeaGain
    B2: SeaGain
    units: str

    @field_validator("units", mode="before")
    @classmethod
    def _units(cls, v):
        if v not in ("deflection", "torque"):
            raise ValueError(
                f"must be 'deflection' (paper eq. (9): K2 [N·m/rad], B2 [N·m·s/rad]) or "
                f"'torque' (K2 [–], B2 [s]), got {fmt_value(v)}"
            )
        return v


class SeaFileIn(_Strict):
    plant: SeaPlantIn
    gains: SeaGainsIn
