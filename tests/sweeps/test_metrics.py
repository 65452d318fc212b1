"""exotune.sweeps.metrics: interval ends, the derived family metrics, the robust mask and the
per-cell aggregation, against hand-made columns."""

import numpy as np
import pyarrow as pa
import pytest

from exotune.sweeps.metrics import AXIS_UNITS, METRICS, TABLE_METRICS, aggregate, derived_metrics, interval_ends, robust_mask

LL = pa.list_(pa.list_(pa.float64()))


def test_interval_ends_per_row():
    rows = [[[0.0, 1.0], [2.0, 3.0]], [], [[5.0, 6.0]]]
    cnt, flo, fhi, llo, lhi = interval_ends(rows)
    assert cnt.tolist() == [2, 0, 1]
    assert flo[[0, 2]].tolist() == [0.0, 5.0] and fhi[[0, 2]].tolist() == [1.0, 6.0]
    assert llo[[0, 2]].tolist() == [2.0, 5.0] and lhi[[0, 2]].tolist() == [3.0, 6.0]
    assert all(np.isnan(a[1]) for a in (flo, fhi, llo, lhi))
    chunked = pa.chunked_array([pa.array(rows[:2], type=LL), pa.array(rows[2:], type=LL)])
    for a, b in zip(interval_ends(chunked), (cnt, flo, fhi, llo, lhi)):
        assert np.array_equal(a, b, equal_nan=True)
    empty = interval_ends(pa.chunked_array([], type=LL))
    assert all(e.size == 0 for e in empty)


def test_interval_ends_refuses_non_pairs():
    with pytest.raises(ValueError, match=r"not \[lo, hi\] pairs"):
        interval_ends([[[0.0, 1.0, 2.0]]])


MANIFEST = {"spec": {"base": {"humans": [{"kind": "mass", "inertia": [0.001, 1.0]},
                                         {"kind": "spring", "stiffness": [1.0, 1e4]},
                                         {"kind": "msd", "inertia": [0.1, 0.2], "stiffness": [10.0, 20.0]}],
                              "environment": [{"kind": "locked"}]}}}


def test_derived_metrics_by_definition():
    table = pa.table({
        # stable intervals of a mass family [0.001, 1]: lightest stable inertia = lower end of the
        # interval containing hi; ∞ when hi is unstable
        "human0_mass_stable_intervals": pa.array([[[0.2, 1.0]], [[0.001, 0.5]], [[0.001, 0.1], [0.3, 1.0]]], type=LL),
        # spring family [1, 1e4]: stiffest stable spring = upper end of the interval containing lo; 0 when lo unstable
        "human1_spring_stable_intervals": pa.array([[[1.0, 300.0]], [[5.0, 1e4]], []], type=LL),
        "human2_msd_stable_intervals": pa.array([[], [], []], type=LL),  # a box: no derived metric
    })
    out = derived_metrics(table, MANIFEST)
    assert sorted(out) == ["human0_lightest_stable_inertia", "human1_stiffest_stable_stiffness"]
    v, info = out["human0_lightest_stable_inertia"]
    assert v.tolist() == [0.2, np.inf, 0.3]
    assert info["unit"] == "kg·m²" and info["worst"] == "max" and info["range"] == (0.001, 1.0)
    assert "lightest stable inertia, human 0 (mass, range [0.001, 1] kg·m²)" == info["title"]
    v, info = out["human1_stiffest_stable_stiffness"]
    assert v.tolist() == [300.0, 0.0, 0.0]
    assert info["unit"] == "N·m/rad" and info["worst"] == "min"


def test_derived_metrics_of_sampled_families_leave_out_unresolved_cells():
    """A sampled-data family lists the cells step control left unresolved; the lightest stable
    inertia and the stiffest stable spring use only checked members."""
    table = pa.table({
        "sampled_human0_mass_stable_intervals": pa.array([[[0.2, 1.0]], [[0.2, 1.0]], [[0.001, 1.0]]], type=LL),
        "sampled_human0_mass_unresolved_cells": pa.array([[], [[0.3, 0.4]], [[0.5, 1.0]]], type=LL),
        "sampled_human1_spring_stable_intervals": pa.array([[[1.0, 300.0]], [[1.0, 300.0]], [[1.0, 1e4]]], type=LL),
        "sampled_human1_spring_unresolved_cells": pa.array([[[1.0, 2.0]], [[50.0, 60.0]], []], type=LL),
    })
    out = derived_metrics(table, MANIFEST)
    assert out["sampled_human0_lightest_stable_inertia"][0].tolist() == [0.2, 0.4, np.inf]
    assert out["sampled_human1_stiffest_stable_stiffness"][0].tolist() == [0.0, 50.0, 1e4]
    assert "sampled-data lightest stable inertia" in out["sampled_human0_lightest_stable_inertia"][1]["title"]


def test_robust_mask_combines_the_verdicts():
    cols = {"free_stable": [True, True, True, False], "human0_mass_robust": [True, False, True, True],
            "env0_locked_stable": [True, True, False, True], "human0_mass_conclusive": [False] * 4,
            "latency_margin_s": [1.0] * 4}
    mask, used = robust_mask(cols)
    assert mask.tolist() == [True, False, False, False]
    assert used == ["free_stable", "human0_mass_robust", "env0_locked_stable"]
    mask, used = robust_mask({**cols, "sampled_free_stable": [False, True, True, True],
                              "sampled_human0_mass_robust": [True] * 4})
    assert mask.tolist() == [False, False, False, False]
    assert "sampled_free_stable" in used and "sampled_human0_mass_robust" in used
    assert robust_mask({})[0].size == 0


def test_aggregate_ignores_nan_and_leaves_empty_cells_nan():
    cells = np.array([0, 0, 1, 1, 3])
    vals = np.array([1.0, 3.0, np.nan, 5.0, np.inf])
    assert np.array_equal(aggregate(cells, 4, vals, "mean"), [2.0, 5.0, np.nan, np.inf], equal_nan=True)
    assert np.array_equal(aggregate(cells, 4, vals, "min"), [1.0, 5.0, np.nan, np.inf], equal_nan=True)
    assert np.array_equal(aggregate(cells, 4, vals, "max"), [3.0, 5.0, np.nan, np.inf], equal_nan=True)


def test_tables_are_consistent():
    assert set(TABLE_METRICS) <= set(METRICS)
    assert AXIS_UNITS["implementation.delay_s"] == "s" and AXIS_UNITS["design.amplification"] == "–"
    for title, unit, factor, worst, cmap in METRICS.values():
        assert worst in ("min", "max") and factor > 0 and unit
    assert METRICS["latency_margin_s"][1:3] == ("ms", 1e3)  # s shown in ms
