"""A design file's transmission ratios must keep the plant they reflect (J_m, B_m, K_s × ratio²)
within the accepted ranges (docs/design-file.md#input-limits-and-accepted-ranges), and the error
names the ratio that breaks them, not the plant field the analysis refuses later."""

from __future__ import annotations

import copy
from pathlib import Path

import pytest
from click.testing import CliRunner

from exotune.cli import cli
from exotune.config import design_from_mapping, load_design
from exotune.errors import ConfigError

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture()
def base() -> dict:
    raw = copy.deepcopy(load_design(ROOT / "examples" / "paper.yaml").raw)
    raw.pop("transmission", None)
    return raw


def _with_ratios(base, ratios):
    return {**base, "transmission": {"joint_angle_rad": [float(i) for i in range(len(ratios))], "ratio": ratios}}


def test_a_ratio_reflecting_the_motor_damping_out_of_range_is_named(base):
    """``ratio: [1.0, 1000.0]`` with B_m = 17.9 N·m·s/rad was refused as "plant.motor_damping:
    value 1.79e+07 at index 1 …", a field the file does not hold at that value."""
    base["plant"]["motor_damping"] = 17.9
    with pytest.raises(ConfigError) as e:
        design_from_mapping(_with_ratios(base, [1.0, 1000.0]))
    assert e.value.field == "transmission.ratio[1]"
    assert e.value.reason == (
        "the motor damping at ratio 1000, plant.motor_damping × ratio² = 17.9 N·m·s/rad × 1000² = 1.79e+07 N·m·s/rad, "
        "is out of the accepted range [0, 1e7] N·m·s/rad (the motor inertia, motor damping and SEA stiffness scale "
        "with ratio²; with this plant the ratios must lie in [0.001, 747.4] (–); "
        "docs/design-file.md#input-limits-and-accepted-ranges)")


def test_every_bad_ratio_is_listed_and_the_window_printed_is_accepted(base):
    base["plant"]["motor_damping"] = 17.9
    with pytest.raises(ConfigError) as e:
        design_from_mapping(_with_ratios(base, [900.0, 1.0, 1000.0]))
    assert e.value.field == "transmission.ratio[0]" and e.value.more[0].startswith("transmission.ratio[2]: ")
    cfg = design_from_mapping(_with_ratios(base, [747.4, 1.0]))  # the printed upper end itself
    assert cfg.raw["transmission"]["ratio"] == [747.4, 1.0]
    with pytest.raises(ConfigError) as e:
        design_from_mapping(_with_ratios(base, [747.5, 1.0]))
    assert e.value.field == "transmission.ratio[0]"


def test_a_small_ratio_reflecting_the_motor_inertia_below_range_is_named(base):
    base["plant"]["motor_inertia"] = 1e-4
    with pytest.raises(ConfigError) as e:
        design_from_mapping(_with_ratios(base, [1.0, 0.001]))
    assert e.value.field == "transmission.ratio[1]"
    assert "the motor inertia at ratio 0.001" in e.value.reason and "[1e-9, 1e6] kg·m²" in e.value.reason


def test_the_command_line_names_the_ratio(tmp_path, base):
    import yaml

    base["plant"]["motor_damping"] = 17.9
    p = tmp_path / "d.yaml"
    p.write_text(yaml.safe_dump(_with_ratios(base, [1.0, 1000.0])))
    res = CliRunner().invoke(cli, ["analyze", str(p)])
    assert res.exit_code == 2
    assert res.output.startswith("exotune: error: transmission.ratio[1]: the motor damping at ratio 1000"), res.output
