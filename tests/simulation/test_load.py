"""What ``exotune simulate`` runs from a design file: exactly the runtime sections of a full export
(controller, gain schedule controllers, plant, delay, DOB, golden vectors), without the sampled-data
predictions a written controller file carries."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from exotune.config import design_from_mapping
from exotune.controllerfile.export import build_export
from exotune.errors import ConfigError
from exotune.simulation import at_joint_angle, load_for_simulation
from exotune.simulation.load import check_human_inertia, check_joint_angle

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
RUNTIME_KEYS = ("schema", "sample_rate_hz", "delay_s", "plant", "design", "gains", "signals", "controller", "dob",
                "transmission", "golden")


def test_in_memory_export_has_the_runtime_sections_of_a_full_export():
    path = EXAMPLES / "scheduled.yaml"
    lite = load_for_simulation(path, 1000.0)
    import yaml

    raw = yaml.safe_load(path.read_text())
    raw["implementation"]["sample_rate_hz"] = 1000.0
    full = build_export(design_from_mapping(raw), 1000.0, source=str(path))
    for k in RUNTIME_KEYS:
        assert lite[k] == full[k], k
    assert lite["predicted"] is None and full["predicted"]["sampled"]["free_stable"] is True
    le, fe = lite["gain_schedule"]["entries"], full["gain_schedule"]["entries"]
    assert len(le) == len(fe) == 5
    for a, b in zip(le, fe):
        assert "predicted_sampled" not in a and "predicted_sampled" in b
        assert a["controller"] == b["controller"] and a["plant"] == b["plant"] and a["gains"] == b["gains"]


@pytest.mark.parametrize("angle, reason", [
    (math.nan, "must be a finite number, got nan"),
    (math.inf, "must be a finite number, got inf"),
    (-math.inf, "must be a finite number, got -inf"),
    (True, "expected a number of radians, got True"),
    ("0.5", "expected a number of radians, got '0.5'"),
])
def test_a_joint_angle_that_is_not_a_finite_number_is_refused(angle, reason):
    with pytest.raises(ConfigError) as ei:
        check_joint_angle(angle)
    assert ei.value.field == "joint_angle" and ei.value.reason == reason
    doc = load_for_simulation(EXAMPLES / "scheduled.yaml", 1000.0)
    with pytest.raises(ConfigError) as ei:  # nan picked a schedule entry
        at_joint_angle(doc, angle)
    assert ei.value.field == "joint_angle"
    assert check_joint_angle(None) is None and check_joint_angle(1) == 1.0


@pytest.mark.parametrize("value, reason", [(True, "expected a number of kg·m², got True"),
                                           ("0.02", "expected a number of kg·m², got '0.02'"),
                                           (math.nan, "must be a finite number"),
                                           (1e-20, "out of the accepted range [1e-9, 1e6] kg·m²")])
def test_a_human_inertia_must_be_a_number_in_range(value, reason):
    with pytest.raises(ConfigError) as ei:
        check_human_inertia(value)
    assert ei.value.field == "human_inertia" and reason in ei.value.reason
    assert check_human_inertia(None) is None and check_human_inertia(2) == 2.0


@pytest.mark.parametrize("value", [1e300, 1.0000001e6, 9.99e-10])
def test_a_human_inertia_has_the_design_files_range(value):
    """``--human-inertia 1e300`` ran ("decaying") although a design file refuses a human inertia
    beyond 1e6 kg·m²: the simulation's human takes the design file's range, both ends included."""
    with pytest.raises(ConfigError) as ei:
        check_human_inertia(value)
    assert ei.value.field == "human_inertia"
    assert ei.value.reason.endswith("kg·m² is out of the accepted range [1e-9, 1e6] kg·m² of an inertia in a design "
                                    "file (docs/design-file.md#input-limits-and-accepted-ranges)")
    assert check_human_inertia(1e6) == 1e6 and check_human_inertia(1e-9) == 1e-9


@pytest.fixture(scope="module")
def scheduled():
    return load_for_simulation(EXAMPLES / "scheduled.yaml", 1000.0)  # entries at 0, 0.5, 1, 1.5, 2 rad


@pytest.mark.parametrize("angle, entry", [(0.0, 0.0), (0.2, 0.0), (0.3, 0.5), (1.7, 1.5), (2.0, 2.0)])
def test_a_joint_angle_within_the_schedule_runs_the_runtimes_entry(scheduled, angle, entry):
    from exotune.controllerfile import Runtime
    from exotune.simulation.load import schedule_entry

    e = schedule_entry(scheduled, angle)
    assert e.joint_angle_rad == entry
    view = at_joint_angle(scheduled, angle)
    assert view.plant == e.plant and view.controller.gains == Runtime(scheduled, joint_angle_rad=angle).gains


@pytest.mark.parametrize("angle, end", [(100.0, "2"), (1e308, "2"), (2.0 + 1e-9, "2"), (-0.5, "0"), (-1e308, "0")])
def test_a_joint_angle_beyond_the_schedule_is_refused_with_its_range(scheduled, angle, end):
    """h8 item 8: ``--joint-angle 100`` (and 1e308) silently ran the 2 rad entry, whose plant is not
    the joint's at 100 rad (the transmission table ends at 2 rad). Refused, naming the range and the
    entry the runtime would run."""
    from exotune.simulation.load import schedule_entry

    for call in (schedule_entry, at_joint_angle):
        with pytest.raises(ConfigError) as ei:
            call(scheduled, angle)
        assert ei.value.field == "joint_angle"
        assert "is outside the gain schedule's joint angles [0, 2] rad" in ei.value.reason
        assert f"the runtime would run the nearest entry ({end} rad)" in ei.value.reason
        assert ei.value.reason.endswith("give an angle in [0, 2] rad")
