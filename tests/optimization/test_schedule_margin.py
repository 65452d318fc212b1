"""optimize judges a gain-scheduled design's latency margin as analyze does: the smallest over the
controllers the runtime runs (the plant section's and every transmission entry's), so the
optimizer's exact check, analyze's headline and certify (tests/controllerfile/test_schedule_latency.py)
share one model."""

from __future__ import annotations

import copy

import numpy as np
import pytest

from exotune.analysis import analyze_with_margins
from exotune.analysis.latency_margin import latency_margin
from exotune.config import design_from_mapping, read_yaml
from exotune.optimization.diagnose import exact_latency_margin
from exotune.optimization.spec import load_optimize_spec


def test_the_optimizers_exact_margin_is_the_schedules_smallest():
    raw = read_yaml("examples/scheduled.yaml")
    raw["transmission"] = {"joint_angle_rad": [0.0, 1.0], "ratio": [1.0, 1.6]}
    spec = load_optimize_spec({"base": raw, "free": {"design.amplification": [2.0, 12.0]}, "budget": 50})
    alpha = float(raw["design"]["amplification"])
    got = exact_latency_margin(spec, np.array([alpha]))
    cfg = design_from_mapping(copy.deepcopy(raw))
    want = analyze_with_margins(cfg, sampled_check=False).margins[0]
    nominal = latency_margin(design_from_mapping({k: v for k, v in raw.items() if k != "transmission"}))
    assert got.extra_delay_s == pytest.approx(want.extra_delay_s, rel=1e-9)
    assert got.extra_delay_s < nominal.extra_delay_s  # the 1.6 entry, not the plant section
    assert got.gain_schedule_entry == (1.0, 1.6)
