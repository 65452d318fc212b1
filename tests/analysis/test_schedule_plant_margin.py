"""The plant-uncertainty margin of a gain-scheduled design (docs/method.md#plant-uncertainty-margin):
the smallest over the main controller and every entry, each entry being the design on its plant
section reflected by ratio² (paper §IV gain scheduling) — checked against design files reflected
by hand."""

from __future__ import annotations

import copy

import pytest

from exotune.analysis import analyze_with_margins
from exotune.analysis.plant_margin import plant_uncertainty_margin, schedule_plant_margin
from exotune.config import design_from_mapping, read_yaml
from reflected_design import by_hand

RATIOS = (0.85, 1.25)


def _raw():
    raw = read_yaml("examples/scheduled.yaml")
    raw["implementation"]["sample_rate_hz"] = None
    raw["transmission"] = {"joint_angle_rad": [0.0, 2.0], "ratio": list(RATIOS)}
    return raw


@pytest.fixture(scope="module")
def margins():
    raw = _raw()
    cfg = design_from_mapping(copy.deepcopy(raw))
    main = plant_uncertainty_margin(cfg, loop_detail=False)
    refs = {r: plant_uncertainty_margin(by_hand(raw, r), loop_detail=False) for r in RATIOS}
    return cfg, main, refs, schedule_plant_margin(cfg, main, loop_detail=False)


def test_the_smallest_over_the_entries(margins):
    _, main, refs, got = margins
    allm = [main, *refs.values()]
    assert got.lower == pytest.approx(min(m.lower for m in allm), rel=1e-12)
    assert got.upper == pytest.approx(min(m.upper for m in allm), rel=1e-12)
    assert got.main_controller == (main.lower, main.upper)
    # the ratio-1.25 entry (heavier reflected motor) is the weakest, below the main controller
    assert got.gain_schedule_entry == (2.0, 1.25)
    assert got.lower < main.lower and got.upper < main.upper
    assert got.lower <= got.upper
    assert "not applied" in main.note and "not applied" not in got.note


def test_the_witness_is_the_entrys_unstable_plant(margins):
    _, _, refs, got = margins
    w = got.witness
    assert w is not None and w.confirmed and w.k == pytest.approx(got.upper, rel=1e-12)
    ref = refs[1.25].witness
    assert w.plant == pytest.approx(ref.plant, rel=1e-12)  # the reflected plant, deviated by k


def test_analyze_reports_the_schedules_margin(margins):
    cfg, main, _, got = margins
    d = analyze_with_margins(cfg, sampled_check=False).to_dict()["margins"]["plant_uncertainty"]
    assert d["lower"] == pytest.approx(got.lower, rel=1e-12) and d["upper"] == pytest.approx(got.upper, rel=1e-12)
    assert d["gain_schedule_entry"] == {"joint_angle_rad": 2.0, "ratio": 1.25}
    assert d["main_controller"] == {"lower": pytest.approx(main.lower, rel=1e-12),
                                    "upper": pytest.approx(main.upper, rel=1e-12)}


def test_without_a_schedule_nothing_changes():
    raw = _raw()
    del raw["transmission"]
    cfg = design_from_mapping(raw)
    pm = plant_uncertainty_margin(cfg, loop_detail=False)
    assert schedule_plant_margin(cfg, pm) is pm
