"""exotune.controllerfile.build: the controller a design builds as the file writes it. Each
filter's ``sos`` has the frequency response of its continuous block at the prewarp frequency (the
prewarped bilinear transform is exact there) and the block's DC gain; the section is the one
written into an export; the reflected mapping scales J_m, B_m, K_s by the ratio squared; an edited
filter, gain or delay is named by :func:`implementation_mismatches`."""

from __future__ import annotations

import copy
import math
from pathlib import Path

import numpy as np
import pytest
import scipy.signal
from hypothesis import given, settings
from hypothesis import strategies as st

from exotune.config import design_from_mapping, read_yaml
from exotune.controllerfile.build import close, controller_section, implementation_mismatches, quantity, reflected_mapping
from exotune.controllerfile.export import design_at_rate

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def section():
    raw = read_yaml(ROOT / "examples" / "scheduled.yaml")
    cfg = design_at_rate(raw, 1000.0)
    return controller_section(cfg, 1000.0)


def _cont(f, w):
    s = 1j * w
    return (np.polyval(f["continuous"]["num"][::-1], s) / np.polyval(f["continuous"]["den"][::-1], s))


def test_each_filter_matches_its_block_at_the_prewarp_frequency(section):
    _gains, filters, _six = section
    assert filters
    for f in filters:
        assert f["discretization"] == "tustin" and f["prewarp_hz"] is not None
        w = 2 * math.pi * f["prewarp_hz"]
        _, h = scipy.signal.sosfreqz(np.array(f["sos"]), worN=[f["prewarp_hz"]], fs=1000.0)
        assert h[0] == pytest.approx(_cont(f, w), rel=1e-8), f["name"]


def test_each_filter_keeps_its_dc_gain(section):
    for f in section[1]:
        num, den = f["continuous"]["num"], f["continuous"]["den"]
        sos = np.array(f["sos"])
        dc = np.prod(sos[:, :3].sum(1)) / np.prod(sos[:, 3:].sum(1))
        assert dc == pytest.approx(num[0] / den[0], rel=1e-6, abs=1e-9 * max(abs(c) for c in num)), f["name"]


def test_six_gains_and_static_gains_carry_units(section):
    gains, _filters, six = section
    assert set(six) == {"K1", "B1", "K2", "B2", "K2_hat", "B2_hat"}
    assert all(set(q) == {"value", "unit"} for q in six.values())
    assert all(g["gain"] != 0 and g["unit"] for g in gains.values())


def test_the_export_writes_this_section(section, scheduled_doc):
    gains, filters, _six = section
    assert scheduled_doc["controller"]["gains"] == gains
    assert [f["sos"] for f in scheduled_doc["controller"]["filters"]] == [f["sos"] for f in filters]


@settings(max_examples=20, deadline=None)
@given(st.floats(0.1, 10.0))
def test_reflected_mapping_scales_by_the_ratio_squared(ratio):
    raw = read_yaml(ROOT / "examples" / "scheduled.yaml")
    r = reflected_mapping(raw, ratio)
    assert "transmission" not in r
    for k in ("motor_inertia", "motor_damping", "sea_stiffness"):
        assert r["plant"][k] == pytest.approx(float(raw["plant"][k]) * ratio ** 2, rel=1e-12)
    assert r["plant"]["joint_inertia"] == raw["plant"]["joint_inertia"]
    assert raw == read_yaml(ROOT / "examples" / "scheduled.yaml")  # the input is not changed


def test_quantity_and_close():
    assert quantity(3, "s") == {"value": 3.0, "unit": "s"}
    assert close(1.0, 1.0 + 1e-10, 1e-9) and not close(1.0, 1.0 + 1e-8, 1e-9)
    assert close(0.0, 0.0, 1e-9) and not close(0.0, 1e-300, 1e-9)


def test_a_fresh_export_has_no_mismatch(scheduled_doc):
    assert implementation_mismatches(copy.deepcopy(scheduled_doc)) == []


def test_an_edited_filter_is_named(scheduled_doc):
    doc = copy.deepcopy(scheduled_doc)
    doc["controller"]["filters"][1]["sos"][0][0] *= 1 + 1e-6
    name = doc["controller"]["filters"][1]["name"]
    assert implementation_mismatches(doc) == [f"controller.filters[{name}] is not the filter the implementation "
                                              "section builds"]


def test_an_edited_entry_gain_is_named(scheduled_doc):
    doc = copy.deepcopy(scheduled_doc)
    doc["gain_schedule"]["entries"][2]["controller"]["gains"]["omega_m"]["gain"] *= 1.001
    out = implementation_mismatches(doc)
    assert out == ["gain_schedule.entries[2].controller.gains.omega_m is not the gain the implementation section builds"]


def test_a_changed_delay_is_named(scheduled_doc):
    doc = copy.deepcopy(scheduled_doc)
    doc["delay_s"]["value"] *= 2
    out = implementation_mismatches(doc)
    assert len(out) == 1 and out[0].startswith("implementation.delay_s")
