"""exotune.config.schema: the strict pydantic models of design and SEA files (unknown keys
refused, every number validated, the errors located)."""

import pytest
from pydantic import ValidationError

from exotune.config.schema import (ENV_KINDS, ENV_MODELS, HUMAN_KINDS, HUMAN_MODELS, DesignFileIn, ImplementationIn,
                                   SeaFileIn, SeaPlantIn, TransmissionIn)
from exotune.model.controller import STRUCTURES

PLANT = {"motor_inertia": 0.44, "motor_damping": 17.9, "sea_stiffness": 1180.0, "joint_inertia": 0.29,
         "cuff_stiffness": 300.0}
DESIGN = {"amplification": 8.0, "felt_inertia": 0.25, "felt_damping": 1.0, "zeta": 0.7, "zeta_hat": 0.7}


def _locs(e: ValidationError):
    return [tuple(err["loc"]) for err in e.errors()]


def test_a_valid_design_file():
    d = DesignFileIn(plant=PLANT, design=DESIGN, implementation={"delay_s": 0.001, "dob": {"cutoff_hz": 60.0,
                                                                                           "damping": 0.7}})
    assert d.plant.sea_stiffness == 1180.0 and d.implementation.dob.cutoff_hz == 60.0
    assert d.implementation.structure == "default" and d.implementation.gv_filter is None
    assert d.humans is None and d.requirements is None
    with pytest.raises(ValidationError):
        d.plant = None  # frozen


def test_unknown_keys_are_refused_where_they_are():
    with pytest.raises(ValidationError) as ei:
        DesignFileIn(plant={**PLANT, "gear_ratio": 3}, design=DESIGN)
    assert _locs(ei.value) == [("plant", "gear_ratio")]
    with pytest.raises(ValidationError) as ei:
        DesignFileIn(plant=PLANT, design=DESIGN, extra={})
    assert _locs(ei.value) == [("extra",)]


@pytest.mark.parametrize("section, key, value", [
    ("plant", "motor_inertia", -1.0),
    ("plant", "sea_stiffness", 0.0),
    ("design", "amplification", 0.5),
    ("design", "zeta", "high"),
])
def test_bad_numbers_are_located(section, key, value):
    args = {"plant": dict(PLANT), "design": dict(DESIGN)}
    args[section][key] = value
    with pytest.raises(ValidationError) as ei:
        DesignFileIn(**args)
    assert (section, key) in _locs(ei.value)


def test_implementation_structure_and_precision():
    assert set(STRUCTURES) == {"default", "full_filter"}
    assert ImplementationIn(structure="full_filter").structure == "full_filter"
    with pytest.raises(ValidationError, match="must be one of default, full_filter"):
        ImplementationIn(structure="other")
    assert ImplementationIn(precision="float32").precision == "float32"
    with pytest.raises(ValidationError, match="must be float64 or float32"):
        ImplementationIn(precision="float16")


def test_transmission_schedule_rules():
    t = TransmissionIn(joint_angle_rad=[-0.5, 0.0, 0.5], ratio=[0.9, 1.0, 1.1])
    assert t.ratio == [0.9, 1.0, 1.1]
    with pytest.raises(ValidationError, match="at least two joint angles"):
        TransmissionIn(joint_angle_rad=[0.0], ratio=[1.0])
    with pytest.raises(ValidationError, match="strictly increasing"):
        TransmissionIn(joint_angle_rad=[0.0, 0.0], ratio=[1.0, 1.0])
    with pytest.raises(ValidationError, match=r"one ratio per joint angle: 2 angle\(s\), 3 ratio\(s\)"):
        TransmissionIn(joint_angle_rad=[0.0, 1.0], ratio=[1.0, 1.0, 1.0])


def test_every_kind_has_a_model():
    assert set(HUMAN_MODELS) == set(HUMAN_KINDS) and set(ENV_MODELS) == set(ENV_KINDS)
    m = HUMAN_MODELS["mass"](kind="mass", inertia=[0.001, 1.0])
    assert m.damping == 0.0
    with pytest.raises(ValidationError):
        HUMAN_MODELS["mass"](kind="spring", inertia=[0.001, 1.0])  # the kind must match the model
    with pytest.raises(ValidationError):
        HUMAN_MODELS["spring"](kind="spring", stiffness=[10.0, 1.0])  # a range must be ordered
    assert ENV_MODELS["locked"](kind="locked").kind == "locked"
    with pytest.raises(ValidationError):
        ENV_MODELS["locked"](kind="locked", stiffness=1.0)


def test_sea_file():
    gains = {"K1": 100.0, "B1": 2.0, "K2": -4.0, "B2": 0.1, "units": "torque"}
    s = SeaFileIn(plant={k: v for k, v in PLANT.items() if k != "cuff_stiffness"}, gains=gains)
    assert s.plant.cuff_stiffness == 300.0 and s.gains.K2 == -4.0  # gains may be negative
    assert SeaPlantIn(**PLANT).cuff_stiffness == 300.0
    with pytest.raises(ValidationError, match="must be 'deflection'"):
        SeaFileIn(plant=PLANT, gains={**gains, "units": "newton"})
