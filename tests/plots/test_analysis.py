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

ROOT = Path(__file__).resolve().parents[2]
PAPER = ROOT / "examples" / "paper.yaml"
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
ALL = {"bode_compliances.png", "nyquist_humans.png", "dob_loop.png", "amplification.png", "latency_boundary.png"}
FIGURE_FUNCS = ("_fig_bode_compliances", "_fig_nyquist_humans", "_fig_dob_loop", "_fig_amplification", "_fig_latency_boundary")


@pytest.fixture(scope="module")
def paper():
    cfg = load_design(PAPER)
    return cfg, analyze_design(cfg).to_dict()


def _assert_png(p: Path):
    data = p.read_bytes()
    assert data[:8] == PNG_SIGNATURE, p
    assert data[12:16] == b"IHDR", p
    assert data[-8:-4] == b"IEND", p
    assert len(data) > 10_000, (p, len(data))
    width = int.from_bytes(data[16:20], "big")
    height = int.from_bytes(data[20:24], "big")
    assert width >= 400 and height >= 400, (p, width, height)


def test_paper_example_writes_every_png(paper, tmp_path):
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
    result = analyze_design(cfg).to_dict()
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


BOX_HUMANS = "humans:\n  - {kind: msd, inertia: [0.001, 0.5], damping: 0.0, stiffness: [10.0, 1000.0]}\n"


@pytest.fixture(scope="module")
def msd_box(tmp_path_factory):
    """The paper example with one msd box human (inertia × stiffness), not robust on some edges."""
    text = PAPER.read_text(encoding="utf-8")
    head = text[: text.index("humans:")]
    p = tmp_path_factory.mktemp("box") / "box.yaml"
    p.write_text(head + BOX_HUMANS, encoding="utf-8")
    cfg = load_design(p)
    return cfg, analyze_design(cfg).to_dict()


def test_msd_box_nyquist_panels_per_edge(msd_box):
    """An msd box is drawn edge by edge: the corner value of the other ranged parameter is kept
    (the stiffness is not dropped) and every member's verdict is the edge's exact one (issue 17)."""
    from exotune.analysis import plot_data

    cfg, result = msd_box
    (h,) = result["humans"]
    edges = h["edges"]
    loops = plot_data.human_loops(cfg, result)
    assert len(loops) == len(edges) == 4
    for lp, e in zip(loops, edges):
        assert lp["edge"] == {"index": edges.index(e), "count": 4, "at": e["at"]}
        assert lp["h"]["parameter"] == e["parameter"] and lp["h"]["stable_intervals"] == e["stable_intervals"]
        for q, v in e["at"].items():  # the other ranged parameter at its corner
            assert lp["fixed"][q] == v
        for v, role, state, _L, _x in lp["curves"]:
            inside = any(a * (1 - 1e-12) <= v <= b * (1 + 1e-12) for a, b in e["stable_intervals"])
            assert state == ("stable" if inside else "UNSTABLE"), (e, v, state)
    whole = [lp for lp, e in zip(loops, edges) if e["stable_intervals"] == [e["range"]]]
    assert whole and all(c[2] == "stable" for lp in whole for c in lp["curves"])


def test_msd_box_nyquist_labels_name_both_parameters(msd_box, monkeypatch):
    """Each curve's legend label names the edge parameter and the corner value of the other one,
    with units; each title says which edge and where it is stable, with its unit."""
    from matplotlib.axes import Axes

    cfg, result = msd_box
    labels, titles = [], []
    real_plot, real_title = Axes.plot, Axes.set_title
    monkeypatch.setattr(Axes, "plot", lambda self, *a, **k: (labels.append(k.get("label")), real_plot(self, *a, **k))[1])
    monkeypatch.setattr(Axes, "set_title", lambda self, t, *a, **k: (titles.append(t), real_title(self, t, *a, **k))[1])
    plots._fig_nyquist_humans(cfg, result)
    curve = [lb for lb in labels if lb and lb.startswith(("m = ", "k = "))]
    assert curve and all(("kg·m²" in lb and "N·m/rad" in lb) for lb in curve), curve
    assert any("(stable)" in lb for lb in curve) and any("(UNSTABLE)" in lb for lb in curve)
    assert len(titles) == 4 and all(f"edge {i + 1} of 4" in t for i, t in enumerate(titles)), titles
    assert all("stable on none" not in t for t in titles)
    assert "stable on [10, 1000] N·m/rad" in titles[3]


def test_plots_do_not_analyse_the_design_again(paper, monkeypatch):
    """``analyze --plots`` analyses once: the figures take the family intervals from the result."""
    import exotune.analysis.batch as batch

    def refuse(*_a, **_k):
        raise AssertionError("analyze_batch called while rendering the figures")

    monkeypatch.setattr(batch, "analyze_batch", refuse)
    cfg, result = paper
    figs = plots.render_analysis_plots(cfg, result)
    assert set(figs) == ALL
