"""exotune.sweeps.summary: the text of summary.md and the per-axis CSV tables, on a hand-made 2 × 2 sweep."""

import csv
import io
import os

import numpy as np
import pytest

from exotune.sweeps.summary import display_path, metric_label, safe_name, summary_md, value_runs


@pytest.mark.parametrize("name, unit, label", [
    ("dob_delay_margin_s", "ms", "dob_delay_margin_ms"),
    ("latency_margin_s", "s", "latency_margin_s"),
    ("amplification_bandwidth_hz", "Hz", "amplification_bandwidth_hz"),
    ("dob_gain_margin_db", "ms", "dob_gain_margin_ms"),
    ("plant_margin_lower", "–", "plant_margin_lower"),
])
def test_metric_label(name, unit, label):
    assert metric_label(name, unit) == label


def test_safe_name_and_value_runs():
    assert safe_name("implementation.gv_filter.cutoff_hz") == "implementation.gv_filter.cutoff_hz"
    assert safe_name("a/b c:d") == "a_b_c_d"
    vals = [1.5, 2.0, 3.0, 4.4, 9.4, 20.0]
    assert value_runs(vals, [True, True, False, False, True, True]) == "1.5 … 2, 9.4 … 20"
    assert value_runs(vals, [False, False, True, False, False, False]) == "3"
    assert value_runs(vals, [False] * 6) == "none"
    assert value_runs([1.23456], [True], digits=2) == "1.2"


def test_display_path(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert display_path(tmp_path / "a" / "b.yaml") == os.path.join("a", "b.yaml")
    outside = os.path.join(os.sep, "very", "private", "machine", "sweep")
    assert display_path(outside) == os.path.join("…", "machine", "sweep")


PATHS = ["design.amplification", "implementation.delay_s"]
VALUES = [np.array([2.0, 8.0]), np.array([0.0, 0.002])]
AXIS_IDX = [np.array([0, 0, 1, 1]), np.array([0, 1, 0, 1])]
ROBUST = np.array([True, True, True, False])
SIMPLE = {"free_stable": np.array([True, True, True, False]), "human0_mass_robust": np.array([True, True, True, True]),
          "free_conclusive": np.array([True, True, False, True])}
METRICS = {"latency_margin_s": (np.array([0.004, 0.002, 0.001, np.nan]),
                                {"unit": "ms", "factor": 1e3})}
MANIFEST = {"spec_hash": "abc123", "exotune_version": "9.9", "status": "complete", "n_points": 4, "grid_points": 4,
            "sampling": {}, "chunks": [], "model": "continuous-time analysis"}


def _md(**kw):
    files = {}
    args = dict(sweep_dir="sweep", m=MANIFEST, n=4, missing=[], paths=PATHS, values=VALUES, scales=["list", "lin"],
                shape=(2, 2), axis_idx=AXIS_IDX, robust=ROBUST, used=["free_stable", "human0_mass_robust"],
                simple=SIMPLE, metrics=METRICS, table_metrics=["latency_margin_s"],
                figures=[("robust.png", "fraction robust")], files=files)
    args.update(kw)
    return summary_md(**args), files


def test_summary_text():
    md, files = _md()
    lines = md.splitlines()
    assert lines[0] == "# exotune sweep report"
    assert "- spec hash: `abc123`; exotune 9.9; status: complete" in lines
    assert "- designs: 4 of 4 (full grid 2 × 2)" in lines
    assert "| `design.amplification` | – | 2 | 2 … 8 | list |" in lines
    assert "| `implementation.delay_s` | s | 2 | 0 … 0.002 | lin |" in lines
    assert "A design is **robust** when all of these hold: `free_stable`, `human0_mass_robust`." in lines
    assert "Robust designs: **3 of 4** (75.0 %)." in lines
    assert "| `free_stable` | 1 | 0.250 |" in lines and "| `human0_mass_robust` | 0 | 0.000 |" in lines
    assert "Inconclusive analyses (any `*_conclusive` false, counted as not robust): 1." in lines
    # the latency margin in ms, its min over robust designs = 1 ms
    assert "| `latency_margin_ms` | ms | 1 | 4 | 1 |" in lines
    assert ("Robust designs exist for design.amplification ∈ {2 … 8}; every design is robust for "
            "design.amplification ∈ {2} (each row aggregates over `implementation.delay_s`).") in lines
    assert "- [robust.png](robust.png): fraction robust" in lines
    # the robust design with the largest α: α = 8, T = 0
    i = lines.index("## Robust design with the largest amplification")
    assert lines[i + 4] == "| 8 | 0 | 1 |"
    assert "partial sweep" not in md


def test_per_axis_csv_by_hand():
    _, files = _md()
    assert sorted(files) == ["axis_design.amplification.csv", "axis_implementation.delay_s.csv"]
    rows = list(csv.reader(io.StringIO(files["axis_design.amplification.csv"].decode())))
    assert rows[0] == ["design.amplification [–]", "designs", "fraction_robust", "latency_margin_ms_min [ms]",
                       "latency_margin_ms_max [ms]"]
    # α = 2: rows 0, 1 (both robust, margins 4 and 2 ms); α = 8: rows 2, 3 (one robust; margins 1 ms and NaN)
    assert [float(x) for x in rows[1]] == pytest.approx([2.0, 2, 1.0, 2.0, 4.0])
    assert [float(x) for x in rows[2]] == pytest.approx([8.0, 2, 0.5, 1.0, 1.0])
    delay = list(csv.reader(io.StringIO(files["axis_implementation.delay_s.csv"].decode())))
    assert [float(x) for x in delay[2]] == pytest.approx([0.002, 2, 0.5, 2.0, 2.0])


def test_partial_sampled_sweep_with_failures():
    m = {**MANIFEST, "status": "partial", "sampling": {"sample": 4, "seed": 5}, "n_points": 4, "grid_points": 4,
         "chunks": [{"status": "done", "failed_designs": [{"row": 0}]}, {"status": "pending"}],
         "base_source": "/somewhere/else/base/paper.yaml"}
    md, _ = _md(m=m, missing=[1], robust=np.array([False, False, False, False]))
    assert "- designs: 4 of 4 — a uniform random sample (seed 5) of a 2 × 2 = 4-point grid" in md
    assert ("- **partial sweep**: 1 chunk(s) missing (chunk 1 of 2); the tables cover the finished chunks only; "
            "rerun `exotune sweep` with the same spec and `-o sweep` to compute it (the finished chunks are kept)") in md
    assert "- **failed designs**: 1 design(s)" in md
    assert "- base design: `…/base/paper.yaml`" in md
    assert "Robust design with the largest amplification" not in md


def test_a_base_with_a_gain_schedule_is_said_not_swept():
    """A base with a ``transmission`` schedule is swept as its nominal controller: every column
    said robust for a design whose schedule entry at 0 rad is unstable (hostile-input round 4).
    The report's header says the schedule is not swept; without a schedule nothing is said."""
    m = dict(MANIFEST, spec={"base": {"transmission": {"joint_angles_rad": [0.0, 1.0], "ratios": [0.001, 1.0]}}})
    md, _ = _md(m=m)
    assert any(line.startswith("- **gain schedule not swept**: the base design has a `transmission` schedule")
               for line in md.splitlines())
    assert "gain schedule not swept" not in _md()[0]
    assert "gain schedule not swept" not in _md(m=dict(MANIFEST, spec={"base": {"transmission": None}}))[0]
