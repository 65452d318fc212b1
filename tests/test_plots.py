"""``exotune analyze --plots``: the analysis figures (exotune.plots.analysis).

The four PNGs are produced for the paper example and are real, non-trivial images; the DOB figure
is skipped without a DOB; and a failure while rendering writes nothing (not even the directory).
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

from exotune.plots import analysis as plots
from exotune.analysis import analyze_design
from exotune.config import load_design

ROOT = Path(__file__).resolve().parents[1]
PAPER = ROOT / "examples" / "paper.yaml"
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
ALL = {"bode_compliances.png", "nyquist_humans.png", "dob_loop.png", "amplification.png"}
FIGURE_FUNCS = ("_fig_bode_compliances", "_fig_nyquist_humans", "_fig_dob_loop", "_fig_amplification")


@pytest.fixture(scope="module")
def paper():
    cfg = load_design(PAPER)
    return cfg, analyze_design(cfg)


def _assert_png(p: Path):
    data = p.read_bytes()
    assert data[:8] == PNG_SIGNATURE, p
    assert data[12:16] == b"IHDR", p
    assert data[-8:-4] == b"IEND", p
    assert len(data) > 10_000, (p, len(data))
    width = int.from_bytes(data[16:20], "big")
    height = int.from_bytes(data[20:24], "big")
    assert width >= 400 and height >= 400, (p, width, height)


def test_paper_example_writes_the_four_pngs(paper, tmp_path):
    cfg, result = paper
    out = tmp_path / "plots" / "nested"
    written = plots.write_analysis_plots(cfg, result, out)
    assert {p.name for p in written} == ALL
    assert {p.name for p in out.iterdir()} == ALL  # no temporary files left behind
    for p in written:
        assert p.parent == out
        _assert_png(p)


def _stub(monkeypatch, keep=()):
    """Replace the (slow) figure renderers not in ``keep`` by a stub returning PNG-like bytes."""
    for name in FIGURE_FUNCS:
        if name not in keep:
            monkeypatch.setattr(plots, name, lambda cfg, result, _n=name: PNG_SIGNATURE + _n.encode() * 1000)


def test_without_dob_the_dob_plot_is_skipped(paper, tmp_path, monkeypatch):
    cfg, _ = paper
    cfg = dataclasses.replace(cfg, implementation=dataclasses.replace(cfg.implementation, dob=None))
    result = analyze_design(cfg)
    assert result["dob"] is None
    called = []
    real_dob = plots._fig_dob_loop
    monkeypatch.setattr(plots, "_fig_dob_loop", lambda c, r: called.append(1) or real_dob(c, r))
    # the amplification figure depends on the DOB structure: render it for real
    _stub(monkeypatch, keep=("_fig_amplification", "_fig_dob_loop"))
    written = plots.write_analysis_plots(cfg, result, tmp_path / "nodob")
    assert {p.name for p in written} == ALL - {"dob_loop.png"}
    assert not called
    assert not (tmp_path / "nodob" / "dob_loop.png").exists()
    _assert_png(tmp_path / "nodob" / "amplification.png")


@pytest.mark.parametrize("failing", ["_fig_bode_compliances", "_fig_amplification"])
def test_render_failure_writes_nothing(paper, tmp_path, monkeypatch, failing):
    cfg, result = paper
    _stub(monkeypatch)

    def boom(cfg, result):
        raise RuntimeError("rendering failed")

    monkeypatch.setattr(plots, failing, boom)
    out = tmp_path / "never"
    with pytest.raises(RuntimeError, match="rendering failed"):
        plots.write_analysis_plots(cfg, result, out)
    assert not out.exists()
    assert list(tmp_path.iterdir()) == []


def test_render_failure_leaves_existing_dir_untouched(paper, tmp_path, monkeypatch):
    cfg, result = paper
    out = tmp_path / "existing"
    out.mkdir()
    (out / "bode_compliances.png").write_bytes(b"old")
    _stub(monkeypatch)
    monkeypatch.setattr(plots, "_fig_amplification", lambda c, r: 1 / 0)
    with pytest.raises(ZeroDivisionError):
        plots.write_analysis_plots(cfg, result, out)
    assert [p.name for p in out.iterdir()] == ["bode_compliances.png"]
    assert (out / "bode_compliances.png").read_bytes() == b"old"


def test_matplotlib_global_backend_untouched(paper, tmp_path, monkeypatch):
    """Rendering uses Figure + the Agg canvas directly: no pyplot figure stays open."""
    import sys

    cfg, result = paper
    _stub(monkeypatch, keep=("_fig_dob_loop",))
    plots.write_analysis_plots(cfg, result, tmp_path / "x")
    if "matplotlib.pyplot" in sys.modules:
        assert sys.modules["matplotlib.pyplot"].get_fignums() == []


def test_plot_numbers_come_from_the_analysis_layer(paper):
    """The figures only draw: the responses come from exotune.analysis.plot_data."""
    import numpy as np

    from exotune.analysis import plot_data

    cfg, result = paper
    r = plot_data.compliance_responses(cfg, result)
    assert r["f"].shape == r["C5"].shape == r["C7"].shape == r["A"].shape
    assert np.all(np.diff(r["f"]) > 0) and r["f"][0] == pytest.approx(plot_data.F_MIN_HZ)
    loops = plot_data.human_loops(cfg, result)
    assert [lp["h"]["kind"] for lp in loops] == [h["kind"] for h in result["humans"]]
    for lp in loops:
        assert 3 <= len(lp["curves"]) <= 5
        assert {c[2] for c in lp["curves"]} <= {"critical", "stable", "UNSTABLE"}
        for c, Lc in lp["critical"]:  # L = −1 at a critical value and frequency
            assert abs(Lc + 1.0) < 1e-3, (lp["h"]["kind"], c, Lc)
    d = plot_data.dob_loop(cfg, result)
    if d["crossover"] is not None:
        assert abs(abs(d["crossover"][1]) - 1.0) < 1e-6  # |L_dob| = 1 at the gain crossover
    f, runs = plot_data.amplification_at_delays(cfg, result)
    assert [run["configured"] for run in runs] == [True, False]
    assert runs[1]["T"] == plot_data.second_delay(runs[0]["T"])
