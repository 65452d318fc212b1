"""exotune.identification.result: the plant estimate's views — standard errors, the covariance
assembled per equation, the uncertainty section (3 SE or the model error), the design-file sections."""

import json
import math

import pytest

from exotune.identification.result import UNCERTAINTY_SIGMAS, EquationFit, ParameterEstimate, PlantEstimate
from exotune.identification.validresult import ModelError

P = (ParameterEstimate("motor_inertia", "J_m", 0.44, 0.0044, "kg·m²"),
     ParameterEstimate("motor_damping", "B_m", 17.9, 0.179, "N·m·s/rad"),
     ParameterEstimate("sea_stiffness", "K_s", 1180.0, 1.18, "N·m/rad"),
     ParameterEstimate("coulomb_friction", "F_c", 0.1, 0.05, "N·m"))
FITS = (EquationFit("motor", ("motor_inertia", "motor_damping", "coulomb_friction"), 0.01, "N·m", 0.999, 0.02, "N·m",
                    ((1.0, 0.1, 0.0), (0.1, 2.0, 0.0), (0.0, 0.0, 3.0))),
        EquationFit("SEA", ("sea_stiffness",), 0.0, "N·m", 0.9999, 0.01, "N·m", ((4.0,),)))


def _est(**kw):
    args = dict(parameters=P, fits=FITS, sample_rate_hz=1000.0, samples=5000, filter_hz=20.0, correlation_s=0.05,
                source="log.csv")
    args.update(kw)
    return PlantEstimate(**args)


def test_parameter_estimate():
    p = ParameterEstimate("motor_inertia", "J_m", -0.5, 0.05, "kg·m²")
    assert p.relative_std_error == pytest.approx(0.1)
    assert ParameterEstimate("x", "x", 0.0, 1.0, "1").relative_std_error == math.inf
    assert P[0].to_dict() == {"value": 0.44, "std_error": 0.0044, "unit": "kg·m²", "relative_std_error": pytest.approx(0.01),
                              "fixed": False}


def test_lookup_and_block_diagonal_covariance():
    e = _est()
    assert e["sea_stiffness"].value == 1180.0
    with pytest.raises(KeyError):
        e["joint_inertia"]
    keys, C = e.covariance()
    assert keys == ["motor_inertia", "motor_damping", "sea_stiffness", "coulomb_friction"]
    assert C.tolist() == [[1.0, 0.1, 0.0, 0.0], [0.1, 2.0, 0.0, 0.0], [0.0, 0.0, 4.0, 0.0], [0.0, 0.0, 0.0, 3.0]]


def test_uncertainty_is_three_standard_errors_or_the_larger_model_error():
    e = _est(model_errors=(ModelError("motor_damping", 0.2, "errors in variables"), ModelError("motor_inertia", 0.001, "x")))
    unc = e.uncertainty()
    assert "coulomb_friction" not in unc  # not a design-file parameter
    assert unc["motor_inertia"] == (pytest.approx(UNCERTAINTY_SIGMAS * 0.01), "3 SE")  # 3 SE > 0.1 % model error
    assert unc["motor_damping"] == (0.2, "errors in variables")
    big = _est(parameters=(ParameterEstimate("sea_stiffness", "K_s", 1.0, 5.0, "N·m/rad"),), fits=())
    assert big.uncertainty()["sea_stiffness"][0] == 0.99  # capped below 1
    sections = e.design_sections()
    assert sections["plant"] == {"motor_inertia": 0.44, "motor_damping": 17.9, "sea_stiffness": 1180.0}
    assert sections["uncertainty"]["motor_damping"] == 0.2


def test_physical_and_complete():
    assert _est().physical and _est().complete
    neg = _est(parameters=P[:3] + (ParameterEstimate("coulomb_friction", "F_c", -0.1, 0.05, "N·m"),))
    assert neg.physical  # friction within 3 SE of zero
    assert not _est(parameters=P[:3] + (ParameterEstimate("coulomb_friction", "F_c", -0.2, 0.05, "N·m"),)).physical
    bad = _est(parameters=(ParameterEstimate("motor_inertia", "J_m", -0.44, 0.01, "kg·m²"),) + P[1:])
    assert not bad.physical and not bad.complete
    assert "NOT A PLANT: motor_inertia ≤ 0" in bad.to_text()
    assert not _est(not_identified=(("joint_inertia", "no excitation"),)).complete


def test_text_and_json():
    e = _est(missing=(("cuff_stiffness", "needs theta_h, tau_c"),), warnings=("a warning",))
    lines = e.to_text().splitlines()
    assert lines[0] == ("exotune identify — log.csv: 5000 samples at 1000 Hz, filter 20 Hz, standard errors for "
                        "residuals correlated over 0.05 s")
    assert "  motor_inertia (J_m): 0.44 ± 0.0044 kg·m² (1 %)" in lines
    assert "  cuff_stiffness: not identified (needs theta_h, tau_c)" in lines
    assert "  warning: a warning" in lines
    assert "  uncertainty sea_stiffness: ±0.3 % (3 SE)" in lines
    d = json.loads(e.to_json())
    assert d["parameters"]["motor_inertia"]["value"] == 0.44
