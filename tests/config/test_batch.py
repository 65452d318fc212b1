"""exotune.config.batch: batches of designs for sweeps (overrides validated with the design-file
rules, naming the path and index), single rows of a batch, the continuous-time twin."""

from pathlib import Path

import numpy as np
import pytest

from exotune.config import load_design
from exotune.config.batch import OVERRIDABLE, OVERRIDE_LIMITS, batch_config, continuous, design_row
from exotune.config.validate import LIMITS
from exotune.errors import ConfigError

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def paper():
    return load_design(ROOT / "examples" / "paper.yaml")


@pytest.fixture(scope="module")
def scheduled():
    return load_design(ROOT / "examples" / "scheduled.yaml")  # 1 kHz sample rate


def test_overrides_replace_and_the_rest_broadcasts(paper):
    b = batch_config(paper, {"design.amplification": [2.0, 4.0, 8.0], "implementation.dob.cutoff_hz": [10, 20, 30]})
    assert b.design.amplification.tolist() == [2.0, 4.0, 8.0]
    assert b.implementation.dob.cutoff_hz.tolist() == [10.0, 20.0, 30.0]
    assert b.implementation.dob.damping.tolist() == [0.7] * 3
    assert b.plant.sea_stiffness.tolist() == [1180.0] * 3
    assert b.implementation.delay_s.tolist() == [0.001] * 3
    assert b.humans == paper.humans and b.raw == paper.raw  # shared by the batch
    one = batch_config(paper, {})
    assert one.design.amplification.tolist() == [8.0]


def test_design_row_takes_one_design(paper):
    b = batch_config(paper, {"design.amplification": [2.0, 4.0], "plant.cuff_stiffness": [100.0, 200.0]})
    r = design_row(b, 1)
    assert r.design.amplification == 4.0 and r.plant.cuff_stiffness == 200.0 and r.design.zeta == 0.7
    assert isinstance(r.implementation.gv_filter.cutoff_hz, float)


def test_continuous_drops_the_sample_rate_only(paper, scheduled):
    assert continuous(paper) is paper
    c = continuous(scheduled)
    assert c.implementation.sample_rate_hz is None and scheduled.implementation.sample_rate_hz == 1000.0
    assert c.implementation.delay_s == scheduled.implementation.delay_s and c.plant == scheduled.plant
    assert c.humans == scheduled.humans and c.raw == scheduled.raw


@pytest.mark.parametrize("overrides, field, reason", [
    ({"humans[0].inertia": [1.0]}, "humans[0].inertia", "human and environment families are not overridable"),
    ({"implementation.sample_rate_hz": [1e3]}, "implementation.sample_rate_hz", "a batch shares one sample rate"),
    ({"plant.gear": [1.0]}, "plant.gear", "unknown or non-overridable parameter"),
    ({"design.amplification": ["a"]}, "design.amplification", "expected real numbers"),
    ({"design.amplification": [[2.0]]}, "design.amplification", "non-empty 1-D array"),
    ({"design.amplification": []}, "design.amplification", "non-empty 1-D array"),
    ({"design.amplification": [2.0, np.nan]}, "design.amplification", "at index 1 is not a finite number"),
    ({"design.amplification": [2.0, 0.5]}, "design.amplification", "value 0.5 at index 1 is < 1 (must be >= 1)"),
    ({"plant.motor_inertia": [0.0]}, "plant.motor_inertia", "value 0 at index 0 is <= 0 (must be > 0)"),
    ({"plant.motor_inertia": [1e9]}, "plant.motor_inertia", "out of the accepted range"),
    ({"design.amplification": [2.0, 3.0], "design.zeta": [0.7]}, "design.zeta",
     "has 1 values but design.amplification has 2"),
    ({"implementation.velocity_filter.cutoff_hz": [50.0]}, "implementation.velocity_filter.cutoff_hz",
     "implementation.velocity_filter is null in the base design"),
])
def test_bad_overrides_name_the_path(paper, overrides, field, reason):
    with pytest.raises(ConfigError) as ei:
        batch_config(paper, overrides)
    assert ei.value.field == field and reason in ei.value.reason


def test_nyquist_and_delay_rules_with_a_sample_rate(scheduled):
    with pytest.raises(ConfigError) as ei:
        batch_config(scheduled, {"implementation.gv_filter.cutoff_hz": [100.0, 500.0]})
    assert ei.value.field == "implementation.gv_filter.cutoff_hz"
    assert ei.value.reason == "value 500 at index 1 is not below the Nyquist frequency 500 Hz"
    assert batch_config(scheduled, {"implementation.gv_filter.cutoff_hz": [499.0]}).implementation.gv_filter.cutoff_hz[0] == 499.0
    with pytest.raises(ConfigError) as ei:
        batch_config(scheduled, {"implementation.delay_s": [0.001, 0.5, 0.3]})  # 500 samples at 1 kHz
    assert ei.value.field == "implementation.delay_s"
    assert ei.value.reason.startswith("value at index 1: 1000 Hz makes the 500 ms delay 500 samples")


def test_every_overridable_path_has_a_limit():
    assert set(OVERRIDABLE) == set(OVERRIDE_LIMITS)
    assert set(OVERRIDE_LIMITS.values()) <= set(LIMITS)
    assert all(op in (">", ">=") for op, _ in OVERRIDABLE.values())
