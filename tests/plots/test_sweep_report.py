"""`exotune report` (docs/sweep-spec.md): stability maps, per-axis tables and derived metrics of a sweep."""

from __future__ import annotations

import csv
import math
import os
import re
from pathlib import Path

import numpy as np
import pytest
import yaml
from click.testing import CliRunner

from exotune.cli import cli
from exotune.errors import ConfigError
from exotune.plots.sweep_report import make_report
from exotune.sweeps import load_results, run_sweep
from exotune.sweeps.metrics import interval_ends

ROOT = Path(__file__).resolve().parents[2]
PAPER = ROOT / "examples" / "paper.yaml"
PNG = b"\x89PNG\r\n\x1a\n"


def sweep(tmp: Path, axes: dict, name: str, chunk_size=4, base=None) -> Path:
    spec = tmp / f"{name}.yaml"
    spec.write_text(yaml.safe_dump({"base": base or str(PAPER), "axes": axes, "chunk_size": chunk_size}))
    out = tmp / name
    run_sweep(spec, out, workers=1, progress=False)
    return out


@pytest.fixture(scope="module")
def two_axes(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("rep2")
    base = yaml.safe_load(PAPER.read_text())
    base["humans"][0]["inertia"] = [0.05, 1.0]  # a realistic arm: some designs are robust
    bp = tmp / "base.yaml"
    bp.write_text(yaml.safe_dump(base))
    d = sweep(tmp, {"design.amplification": [2.0, 8.0, 20.0], "implementation.delay_s": [0.0, 0.002, 0.004]},
              "s2", base=str(bp))
    return d, make_report(d).directory


def test_two_axis_report_files(two_axes):
    d, out = two_axes
    assert out == d / "report"
    names = set(os.listdir(out))
    pair = "design.amplification__implementation.delay_s"
    for f in (f"robust_{pair}.png", f"metrics_{pair}.png", "summary.md",
              "axis_design.amplification.csv", "axis_implementation.delay_s.csv"):
        assert f in names, f
    for f in names:
        if f.endswith(".png"):
            data = (out / f).read_bytes()
            assert data.startswith(PNG) and len(data) > 5000, f
    assert not [f for f in names if f.startswith(".tmp-")]


def test_summary_mentions_axes_units_and_robust_fraction(two_axes):
    d, out = two_axes
    md = (out / "summary.md").read_text(encoding="utf-8")
    for axis, unit in (("design.amplification", "–"), ("implementation.delay_s", "s")):
        assert f"`{axis}`" in md and f"### `{axis}` [{unit}]" in md
    df = load_results(d)
    robust = (df["free_stable"] & df["human0_mass_robust"] & df["human1_spring_robust"]
              & df["human2_complex_stiffness_robust"] & df["env0_locked_stable"]).to_numpy()
    assert 0 < robust.sum() < len(df)  # the map is informative
    assert f"Robust designs: **{int(robust.sum())} of {len(df)}**" in md
    assert "`free_stable`, `human0_mass_robust`, `human1_spring_robust`" in md
    # per-axis CSV: fraction robust per α value, delay margin in ms
    with open(out / "axis_design.amplification.csv", newline="", encoding="utf-8") as fh:
        rows = list(csv.DictReader(fh))
    assert [float(r["design.amplification [–]"]) for r in rows] == [2.0, 8.0, 20.0]
    for r, a in zip(rows, [2.0, 8.0, 20.0]):
        sel = df["design.amplification"].to_numpy() == a
        assert float(r["fraction_robust"]) == pytest.approx(robust[sel].mean())
        assert float(r["dob_delay_margin_ms_min [ms]"]) == pytest.approx(1e3 * df["dob_delay_margin_s"][sel].min())
        assert float(r["human0_lightest_stable_inertia_max [kg·m²]"]) >= 0.05
        # the latency margin: 0 where not robust, its worst case per value in ms
        assert float(r["latency_margin_ms_min [ms]"]) == pytest.approx(1e3 * df["latency_margin_s"][sel].min())
    lm = df["latency_margin_s"].to_numpy()
    assert np.all(lm[~robust] == 0) and np.all(lm[robust] > 0)
    assert "latency_margin_s" in md


def test_lightest_stable_inertia_from_intervals(two_axes):
    d, _ = two_axes
    df = load_results(d)
    cnt, flo, fhi, llo, lhi = interval_ends(df["human0_mass_stable_intervals"].tolist())
    for row, c, a, b in zip(df["human0_mass_stable_intervals"], cnt, llo, lhi):
        assert c == len(row)
        if row:
            assert [a, b] == row[-1]
        else:
            assert math.isnan(a)
    from exotune.sweeps import derived_metrics
    import pyarrow.parquet as pq

    from exotune.sweeps import load_manifest

    table = pq.read_table(d / "chunks" / "part-000000.parquet")
    vals, info = derived_metrics(table, load_manifest(d))["human0_lightest_stable_inertia"]
    for v, row in zip(vals, table.column("human0_mass_stable_intervals").to_pylist()):
        reach = [iv for iv in row if iv[1] >= 1.0 * (1 - 1e-9)]
        assert v == (reach[0][0] if reach else math.inf)
    assert info["unit"] == "kg·m²" and info["range"] == (0.05, 1.0)


def test_one_axis_profile_and_cli(tmp_path):
    d = sweep(tmp_path, {"plant.cuff_stiffness": {"start": 100.0, "stop": 1000.0, "num": 3, "scale": "log"}}, "s1")
    res = CliRunner().invoke(cli, ["report", str(d), "-o", str(tmp_path / "rep")])
    assert res.exit_code == 0, res.output
    names = set(os.listdir(tmp_path / "rep"))
    assert "profile_plant.cuff_stiffness.png" in names and "summary.md" in names
    assert not any(n.startswith("robust_") for n in names)  # no pair of axes
    md = (tmp_path / "rep" / "summary.md").read_text(encoding="utf-8")
    assert "### `plant.cuff_stiffness` [N·m/rad]" in md
    assert not (d / "report").exists()


def test_three_axes_pairs_and_partial(tmp_path):
    base = yaml.safe_load(PAPER.read_text())
    base["implementation"]["dob"] = None  # no DOB: its metrics are NaN and get no panels
    base["humans"] = base["humans"][:1]
    bp = tmp_path / "base.yaml"
    bp.write_text(yaml.safe_dump(base))
    d = sweep(tmp_path, {"design.amplification": [2.0, 8.0], "design.zeta_hat": [0.5, 0.9],
                         "implementation.delay_s": [0.0, 0.003]}, "s3", chunk_size=3, base=str(bp))
    df = load_results(d)
    assert df["dob_delay_margin_s"].isna().all() and df["dob_phase_margin_deg"].isna().all()
    os.unlink(d / "chunks" / "part-000002.parquet")  # lose the last chunk (rows 6, 7)
    out = make_report(d, tmp_path / "r3").directory
    names = set(os.listdir(out))
    for a, b in (("design.amplification", "design.zeta_hat"), ("design.amplification", "implementation.delay_s"),
                 ("design.zeta_hat", "implementation.delay_s")):
        assert f"robust_{a}__{b}.png" in names and f"metrics_{a}__{b}.png" in names
    md = (out / "summary.md").read_text(encoding="utf-8")
    assert "partial sweep" in md and "designs: 6 of 8" in md
    assert re.search(r"aggregates over `design.zeta_hat`, `implementation.delay_s`", md)
    assert "dob_delay_margin_s" not in md  # undefined without a DOB: not tabulated
    assert "human0_lightest_stable_inertia" in md


def test_report_errors(tmp_path):
    with pytest.raises(ConfigError, match="not a sweep directory"):
        make_report(tmp_path)
    res = CliRunner().invoke(cli, ["report", str(tmp_path)])
    assert res.exit_code == 2 and res.stderr.startswith("exotune: error: ")


def test_report_paths_are_not_machine_paths(tmp_path, monkeypatch):
    """Reports get committed: paths below the working directory are shown relative to it, others
    by their last two components only."""
    from exotune.sweeps.summary import display_path

    monkeypatch.chdir(tmp_path)
    (tmp_path / "studies").mkdir()
    assert display_path(tmp_path / "studies" / "arm.yaml") == "studies/arm.yaml"
    assert display_path("studies/arm.yaml") == "studies/arm.yaml"
    other = tmp_path.parent / "elsewhere" / "data" / "sweep"
    assert display_path(other) == "…/data/sweep"
    assert str(tmp_path.parent) not in display_path(other)


def test_unsorted_axis_is_reported_by_value(tmp_path):
    """An axis listed out of order (found by fuzzing: the summary read "α ∈ {8 … 1.5, 2 … 4}" and
    left a robust value out) gives the same per-axis tables and ranges as the sorted listing."""
    base = yaml.safe_load(PAPER.read_text())
    base["humans"][0]["inertia"] = [0.05, 1.0]
    bp = tmp_path / "base.yaml"
    bp.write_text(yaml.safe_dump(base))
    amp, delay = [8.0, 1.5, 30.0, 2.0, 4.0], [0.002, 0.0, 0.001]
    a = make_report(sweep(tmp_path, {"design.amplification": amp, "implementation.delay_s": delay}, "unsorted",
                          base=str(bp))).directory
    b = make_report(sweep(tmp_path, {"design.amplification": sorted(amp), "implementation.delay_s": sorted(delay)},
                          "sorted", base=str(bp))).directory
    for name in ("axis_design.amplification.csv", "axis_implementation.delay_s.csv"):
        assert (a / name).read_text() == (b / name).read_text(), name
    robust_line = lambda d: [ln for ln in (d / "summary.md").read_text().splitlines() if "Robust designs exist" in ln]  # noqa: E731
    assert robust_line(a) == robust_line(b) and robust_line(a)
    rows = list(csv.reader((a / "axis_design.amplification.csv").open()))
    firsts = [float(r[0]) for r in rows[1:]]
    assert firsts == sorted(firsts)


def test_box_family_has_no_lightest_inertia(tmp_path):
    """The interval column of an msd box is [[lo, hi]] when the box is robust and [] otherwise, so
    no lightest stable inertia can be read from it (it used to be reported as ∞ everywhere)."""
    base = yaml.safe_load(PAPER.read_text())
    base["humans"] = [{"kind": "msd", "inertia": [0.001, 1.0], "stiffness": [1.0, 100.0], "damping": 0.0}]
    bp = tmp_path / "boxbase.yaml"
    bp.write_text(yaml.safe_dump(base))
    out = make_report(sweep(tmp_path, {"design.amplification": [1.5, 8.0]}, "box", base=str(bp))).directory
    assert "human0_lightest_stable_inertia" not in (out / "summary.md").read_text()


def test_report_refuses_a_manifest_without_axes(tmp_path):
    import json

    d = sweep(tmp_path, {"design.amplification": [2.0, 8.0]}, "noaxes")
    m = json.loads((d / "manifest.json").read_text())
    del m["axes"]
    (d / "manifest.json").write_text(json.dumps(m))
    with pytest.raises(ConfigError) as e:
        make_report(d)
    assert "axes" in e.value.field


def test_report_result_lists_what_was_written(two_axes, tmp_path):
    """make_report returns a SweepReport: its files are exactly the directory's, its maps the PNGs
    summary.md links (the line the CLI prints counts them)."""
    from exotune.sweeps import SweepReport

    d, _ = two_axes
    rep = make_report(d, tmp_path / "again")
    assert isinstance(rep, SweepReport) and rep.directory == tmp_path / "again"
    assert set(rep.files) == set(os.listdir(rep.directory))
    md = (rep.directory / "summary.md").read_text(encoding="utf-8")
    linked = [line.split("]")[0][3:] for line in md.splitlines() if line.startswith("- [") and ".png]" in line]
    assert list(rep.maps) == linked and all(m in rep.files for m in rep.maps)
    assert rep.to_text() == f"wrote report to {rep.directory} ({len(linked)} maps, summary.md)"


def test_metrics_maps_are_sliced_at_the_base_value_of_an_axis_that_runs_into_instability(tmp_path):
    """Issue 24 (display): the worst case over a delay axis that runs into instability made every
    panel one colour; the maps hold such an axis at the base design's value and say so, and keep
    the worst case over the other axes."""
    base = yaml.safe_load(PAPER.read_text())
    base["humans"][0]["inertia"] = [0.05, 1.0]  # a realistic arm: some designs are robust
    base["implementation"]["delay_s"] = 0.002
    bp = tmp_path / "base.yaml"
    bp.write_text(yaml.safe_dump(base))
    d = sweep(tmp_path, {"design.amplification": [2.0, 8.0, 16.0], "implementation.delay_s": [0.0, 0.002, 0.008],
                         "design.zeta_hat": [0.5, 1.0]}, "sliced", base=str(bp))
    make_report(d)
    text = (d / "report" / "summary.md").read_text()
    sliced = [ln for ln in text.splitlines() if "metrics_design.amplification__design.zeta_hat.png" in ln and "](" in ln]
    assert sliced and "at implementation.delay_s = 0.002 (the base design's" in sliced[0]
    other = [ln for ln in text.splitlines() if "metrics_design.amplification__implementation.delay_s.png" in ln and "](" in ln]
    assert other and "worst case over design.zeta_hat" in other[0]
