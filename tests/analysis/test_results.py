"""The analysis layer's typed results (exotune.analysis.results): built field by field by
analyze_design, their to_dict() is the JSON object, and the fields agree with the batch columns
they come from (an independent path: analyze_batch on the same design)."""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from exotune.analysis import analyze_batch, analyze_design
from exotune.analysis.results import (
    Amplification,
    BoxEdge,
    DesignAnalysis,
    DobMargins,
    EnvironmentResult,
    FamilyResult,
    PassivityResult,
)
from exotune.config import design_from_mapping, load_design, read_yaml
from exotune.jsonio import dumps

ROOT = Path(__file__).resolve().parents[2]
PAPER = ROOT / "examples" / "paper.yaml"


@pytest.fixture(scope="module")
def paper():
    cfg = load_design(PAPER)
    return cfg, analyze_design(cfg)


@pytest.fixture(scope="module")
def box():
    raw = read_yaml(PAPER)
    raw["humans"] = [{"kind": "msd", "inertia": [0.01, 0.5], "stiffness": [10.0, 1000.0], "damping": 1.0}]
    raw["environment"] = [{"kind": "spring", "stiffness": [100.0, 10000.0]}, {"kind": "locked"}, {"kind": "free"}]
    cfg = design_from_mapping(raw)
    return cfg, analyze_design(cfg)


def test_analyze_design_returns_typed_parts(paper):
    _, r = paper
    assert isinstance(r, DesignAnalysis)
    assert all(isinstance(h, FamilyResult) for h in r.humans)
    assert all(isinstance(e, EnvironmentResult) for e in r.environment)
    assert isinstance(r.passivity, PassivityResult) and isinstance(r.dob, DobMargins)
    assert isinstance(r.amplification, Amplification)
    assert r.margins is None and r.latency_margin_s is None  # analyze_with_margins adds them
    from exotune.analysis import KypCertificate

    kyp = r.passivity.kyp
    assert set(kyp) == {"nominal", "delay_free"} and all(isinstance(c, KypCertificate) for c in kyp.values())
    assert r.to_dict()["passivity"]["kyp"] == {k: c.as_dict() for k, c in kyp.items()}


def test_fields_agree_with_the_batch_columns(paper):
    """The typed fields against analyze_batch on the same design (the sweep's path)."""
    cfg, r = paper
    cols = analyze_batch(cfg).to_columns()
    assert r.free_stable is bool(cols["free_stable"][0]) and r.locked_stable is bool(cols["locked_stable"][0])
    for i, (h, fam) in enumerate(zip(r.humans, cfg.humans)):
        key = f"human{i}_{fam.kind}"
        assert h.robust is bool(cols[f"{key}_robust"][0])
        got, ref = np.array(h.stable_intervals, float).reshape(-1, 2), np.array(cols[f"{key}_stable_intervals"][0], float).reshape(-1, 2)
        np.testing.assert_allclose(got, ref, rtol=1e-9)
    assert r.passivity.max_phase_excess_deg == pytest.approx(float(cols["passivity_max_phase_excess_deg"][0]), rel=1e-9)
    assert r.dob.phase_margin_deg == pytest.approx(float(cols["dob_phase_margin_deg"][0]), rel=1e-9)
    assert r.amplification.dc == pytest.approx(cfg.design.amplification, rel=1e-9)
    assert r.gains["K2_hat"] == pytest.approx(float(cols["K2_hat"][0]), rel=1e-12)


def test_to_dict_is_assembled_from_the_fields(paper):
    _, r = paper
    d = r.to_dict()
    assert list(d)[:4] == ["model", "structure", "delay_s", "gain_convention"] and list(d)[-1] == "warnings"
    assert d["free"]["stable"] is r.free_stable and d["free"]["rigid_body_roots"] == r.free_rigid_body_roots
    for h, hd in zip(r.humans, d["humans"]):
        assert hd == h.to_dict()
        assert hd["stable_intervals"] == [list(iv) for iv in h.stable_intervals]
        assert hd["critical"] == [{"value": p, "frequency_hz": f} for p, f in h.critical]
        assert hd["lowest_stable_value_below_range_top"] == h.lowest_stable_value_below_range_top
    assert d["environment"] == [{"kind": "locked", "stable": r.environment[0].robust}]
    assert d["passivity"]["nonpassive_band_hz"] == [list(b) for b in r.passivity.nonpassive_band_hz]
    assert d["dob"] == dataclasses.asdict(r.dob)
    assert d["units"]["K1"] == "N·m/rad" and d["metric_units"] == dict(DesignAnalysis.metric_units)
    json.loads(dumps(d))  # strict JSON


def test_results_are_frozen_and_to_dict_is_a_copy(paper):
    _, r = paper
    with pytest.raises(dataclasses.FrozenInstanceError):
        r.free_stable = False  # type: ignore[misc]
    d = r.to_dict()
    d["humans"][0]["stable_intervals"].clear()
    d["passivity"]["kyp"].clear()
    d["metric_units"].clear()
    again = r.to_dict()
    assert again["humans"][0]["stable_intervals"] and again["passivity"]["kyp"] and again["metric_units"]


def test_box_family_and_ranged_environment(box):
    _, r = box
    (h,) = r.humans
    assert h.stable_intervals is None and h.box is not None and set(h.box) == {"inertia", "stiffness"}
    assert h.edges and all(isinstance(e, BoxEdge) for e in h.edges)
    hd = h.to_dict()
    assert hd["stable_intervals"] is None and "lowest_stable_value_below_range_top" not in hd
    assert list(hd)[-3:] == ["box", "method", "edges"]
    assert hd["edges"] == [e.to_dict() for e in h.edges]
    # the box is robust exactly when every edge is stable over its whole range (Edge Theorem)
    whole = all(len(e.stable_intervals) == 1 and e.stable_intervals[0] == e.range for e in h.edges)
    assert h.robust == (whole and h.conclusive)
    spring, locked, free = r.environment
    assert spring.ranged and not locked.ranged and not free.ranged
    assert set(spring.to_dict()) == {"kind", "parameter", "range", "stable_intervals", "robust"}
    assert locked.to_dict() == {"kind": "locked", "stable": locked.robust}
    assert r.robust == (r.free_stable and h.robust and all(e.robust for e in r.environment))


intervals = st.lists(st.tuples(st.floats(0.0, 1.0), st.floats(0.0, 1.0)).map(sorted), max_size=4).map(
    lambda xs: tuple((a, b) for a, b in sorted(xs)))


@settings(max_examples=60, deadline=None)
@given(ivs=intervals, robust=st.booleans())
def test_family_dict_keys_follow_the_json_contract(ivs, robust):
    """For any intervals: the top-reaching interval gives the lowest stable value (absent when
    none reaches the top, the key only when there are intervals), and the dict round-trips."""
    h = FamilyResult("mass", "inertia", "kg·m²", (0.0, 1.0), {"damping": 0.0}, ivs, robust, True)
    d = h.to_dict()
    assert d["stable_intervals"] == [list(iv) for iv in ivs]
    tops = [a for a, b in ivs if b == 1.0]
    if ivs:
        assert d["lowest_stable_value_below_range_top"] == (tops[0] if tops else None)
    else:
        assert "lowest_stable_value_below_range_top" not in d
    assert json.loads(dumps(d))["stable_intervals"] == [[float(a), float(b)] for a, b in ivs]
    assert all(math.isfinite(x) for iv in d["stable_intervals"] for x in iv)


def test_check_design_takes_the_continuous_intervals(paper):
    """The sampled-data check reads the continuous intervals it is given: handing it the typed
    intervals or the JSON lists gives the same report."""
    from exotune.sampled import check_design

    cfg, r = paper
    cfg = dataclasses.replace(cfg, implementation=dataclasses.replace(cfg.implementation, sample_rate_hz=1000.0),
                              humans=cfg.humans[:1], environment=())
    a = check_design(cfg, [r.humans[0].stable_intervals], [], points=8)
    b = check_design(cfg, [r.to_dict()["humans"][0]["stable_intervals"]], [], points=8)
    assert a == b and a.humans[0].points == 8 and a.to_dict()["humans"][0]["points"] == 8
    # the boundary near the continuous light-mass end: a typed pair, a JSON list
    (bd,) = a.humans[0].boundaries
    assert bd.continuous == pytest.approx(r.humans[0].stable_intervals[0][0], rel=1e-12)
    assert bd.to_dict()["sampled_unstable_where_continuous_stable"] == (None if bd.unsafe is None else list(bd.unsafe))


def test_schedule_entries_are_typed():
    from exotune.analysis.results import ScheduleEntry

    r = analyze_design(load_design(ROOT / "examples" / "scheduled.yaml"))
    assert r.gain_schedule and all(isinstance(e, ScheduleEntry) for e in r.gain_schedule)
    d = r.to_dict()["gain_schedule"]
    assert d == [e.to_dict() for e in r.gain_schedule]
    for e, ed in zip(r.gain_schedule, d):
        assert ed["robust"] is e.robust is (not e.not_robust)
        assert set(ed["gains"]) == set(r.gains) and ed["ratio"] == e.ratio



def test_repr_is_a_readable_summary(paper, box):
    _, r = paper
    text = repr(r)
    assert text.startswith("DesignAnalysis(robust=False, free_stable=True") and len(text) < 800
    lo = r.humans[0].stable_intervals[0][0]
    assert f"mass inertia in [0.001, 1] kg·m²: stable [{lo:.6g}, 1] (not robust)" in text
    assert "DOB phase margin" in text and "1 warning" in text
    assert "box inertia, stiffness, 4 edges" in repr(box[1].humans[0])


def test_plots_draw_the_arrays_the_results_hold(paper):
    """``plot()`` only hands stored arrays to the plots layer: C7 of ``DesignAnalysis.c7_response``
    and the nominal responses of ``DesignSummary.frequency_responses``, computed once (the same
    object on every call) and never part of ``to_dict()``."""
    from matplotlib.figure import Figure

    from exotune.analysis import design_report
    from exotune.analysis.responses import c7_frequency_response

    cfg, r = paper
    f, H = r.c7_response
    assert r.c7_response is r.c7_response  # cached
    np.testing.assert_array_equal(H, c7_frequency_response(cfg)[1])
    fig = Figure()
    ax = fig.add_subplot()
    assert r.plot(ax=ax) is fig
    np.testing.assert_array_equal(ax.lines[0].get_xdata(), f)
    np.testing.assert_array_equal(ax.lines[0].get_ydata(), np.degrees(np.unwrap(np.angle(H))))
    assert r.to_dict() == analyze_design(cfg).to_dict()

    d = design_report(cfg)
    f, responses = d.frequency_responses
    assert d.frequency_responses is d.frequency_responses and set(responses) == set(d.transfer_functions())
    fig = Figure()
    ax = fig.add_subplot()
    assert d.plot(ax=ax) is fig
    for line, (name, Hn) in zip(ax.lines, responses.items(), strict=True):
        np.testing.assert_array_equal(line.get_xdata(), f)
        np.testing.assert_array_equal(line.get_ydata(), 20.0 * np.log10(np.abs(Hn)))
    assert "frequency_responses" not in d.to_dict() and "c7_response" not in r.to_dict()
    json.loads(d.to_json())
