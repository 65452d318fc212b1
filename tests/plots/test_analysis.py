"""``exotune analyze --plots``: the analysis figures (exotune.plots.analysis).

The four PNGs are produced for the paper example and are real, non-trivial images; the DOB figure
is skipped without a DOB; a failure while rendering writes nothing (not even the directory); and
the figures draw exactly the arrays of the analysis layer's record
(:class:`exotune.analysis.figure_data.AnalysisFigures`), computing nothing.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from exotune.plots import analysis as plots
from exotune.analysis import analyze_design
from exotune.analysis.figure_data import analysis_figures
from exotune.config import load_design

ROOT = Path(__file__).resolve().parents[2]
PAPER = ROOT / "examples" / "paper.yaml"
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
ALL = {"bode_compliances.png", "nyquist_humans.png", "dob_loop.png", "amplification.png", "latency_boundary.png"}
FIGURE_FUNCS = ("_fig_bode_compliances", "_fig_nyquist_humans", "_fig_dob_loop", "_fig_amplification", "_fig_latency_boundary")


@pytest.fixture(scope="module")
def paper():
    cfg = load_design(PAPER)
    return cfg, analysis_figures(cfg, analyze_design(cfg))


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
    _cfg, figs = paper
    out = tmp_path / "plots" / "nested"
    written = plots.write_analysis_plots(figs, out)
    assert {p.name for p in written} == ALL
    assert {p.name for p in out.iterdir()} == ALL  # no temporary files left behind
    for p in written:
        assert p.parent == out
        _assert_png(p)


def _stub(monkeypatch, keep=()):
    """Replace the (slow) figure renderers not in ``keep`` by a stub returning PNG-like bytes."""
    for name in FIGURE_FUNCS:
        if name not in keep:
            monkeypatch.setattr(plots, name, lambda figs, _n=name: PNG_SIGNATURE + _n.encode() * 1000)


def test_without_dob_the_dob_plot_is_skipped(paper, tmp_path, monkeypatch):
    cfg, _ = paper
    cfg = dataclasses.replace(cfg, implementation=dataclasses.replace(cfg.implementation, dob=None))
    figs = analysis_figures(cfg, analyze_design(cfg))
    assert figs.result["dob"] is None and figs.dob is None
    called = []
    real_dob = plots._fig_dob_loop
    monkeypatch.setattr(plots, "_fig_dob_loop", lambda f: called.append(1) or real_dob(f))
    # the amplification figure depends on the DOB structure: render it for real
    _stub(monkeypatch, keep=("_fig_amplification", "_fig_dob_loop"))
    written = plots.write_analysis_plots(figs, tmp_path / "nodob")
    assert {p.name for p in written} == ALL - {"dob_loop.png"}
    assert not called
    assert not (tmp_path / "nodob" / "dob_loop.png").exists()
    _assert_png(tmp_path / "nodob" / "amplification.png")


@pytest.mark.parametrize("failing", ["_fig_bode_compliances", "_fig_amplification"])
def test_render_failure_writes_nothing(paper, tmp_path, monkeypatch, failing):
    _cfg, figs = paper
    _stub(monkeypatch)

    def boom(figs):
        raise RuntimeError("rendering failed")

    monkeypatch.setattr(plots, failing, boom)
    out = tmp_path / "never"
    with pytest.raises(RuntimeError, match="rendering failed"):
        plots.write_analysis_plots(figs, out)
    assert not out.exists()
    assert list(tmp_path.iterdir()) == []


def test_render_failure_leaves_existing_dir_untouched(paper, tmp_path, monkeypatch):
    _cfg, figs = paper
    out = tmp_path / "existing"
    out.mkdir()
    (out / "bode_compliances.png").write_bytes(b"old")
    _stub(monkeypatch)
    monkeypatch.setattr(plots, "_fig_amplification", lambda f: 1 / 0)
    with pytest.raises(ZeroDivisionError):
        plots.write_analysis_plots(figs, out)
    assert [p.name for p in out.iterdir()] == ["bode_compliances.png"]
    assert (out / "bode_compliances.png").read_bytes() == b"old"


def test_matplotlib_global_backend_untouched(paper, tmp_path, monkeypatch):
    """Rendering uses Figure + the Agg canvas directly: no pyplot figure stays open."""
    import sys

    _cfg, figs = paper
    _stub(monkeypatch, keep=("_fig_dob_loop",))
    plots.write_analysis_plots(figs, tmp_path / "x")
    if "matplotlib.pyplot" in sys.modules:
        assert sys.modules["matplotlib.pyplot"].get_fignums() == []


def _drawn(monkeypatch):
    """Capture the figures a renderer hands to the PNG encoder (nothing is encoded)."""
    figures = []
    monkeypatch.setattr(plots.style, "png", lambda fig: figures.append(fig) or PNG_SIGNATURE)
    return figures


def _line(ax, label):
    (line,) = [ln for ln in ax.lines if ln.get_label() == label]
    return line.get_xdata(), line.get_ydata()


def test_figures_draw_exactly_the_records_arrays(paper, monkeypatch):
    """Each curve is the record's array (in dB, continuous phase or ms), nothing else computed."""
    from exotune.analysis.plot_data import db, phase_deg

    _cfg, figs = paper
    drawn = _drawn(monkeypatch)
    plots.render_analysis_plots(figs)
    bode, nyq, dob, amp, lat = drawn
    c = figs.compliances
    x, y = _line(bode.axes[0], "C7 = θ_h/τ_h (operator side)")
    np.testing.assert_array_equal(x, c.f_hz)
    np.testing.assert_array_equal(y, db(c.C7))
    np.testing.assert_array_equal(_line(bode.axes[2], "∠C6/C5")[1], phase_deg(c.A))
    loop = figs.human_loops[0]
    curve = loop.curves[0]
    (line,) = [ln for ln in nyq.axes[0].lines if str(ln.get_label()).startswith(f"{plots._SYMBOL[loop.parameter]} = {curve.value:.4g}")]
    np.testing.assert_array_equal(line.get_xdata(), curve.L.real)
    np.testing.assert_array_equal(line.get_ydata(), curve.L.imag)
    x, y = _line(dob.axes[0], "L_dob = Q·e^(−jωT)/(1 − Q) (open loop)")
    np.testing.assert_array_equal(x, figs.dob.f_hz)
    np.testing.assert_array_equal(y, db(figs.dob.L))
    np.testing.assert_array_equal(_line(dob.axes[1], "∠L_dob")[1], figs.dob.phase_L_deg)
    for run, line in zip(figs.amplification_at_delays.runs, [ln for ln in amp.axes[1].lines if str(ln.get_label()).startswith("∠C6/C5")]):
        np.testing.assert_array_equal(line.get_xdata(), figs.amplification_at_delays.f_hz)
        np.testing.assert_array_equal(line.get_ydata(), phase_deg(run.A))
    b = figs.latency_boundaries[0]
    line = lat.axes[0].lines[0]
    np.testing.assert_array_equal(line.get_xdata(), b.values)
    np.testing.assert_array_equal(line.get_ydata(), np.where(np.isfinite(b.extra_delay_s), b.extra_delay_s, np.nan) * 1e3)


def test_latency_boundary_figure_draws_into_a_given_ax(paper):
    from matplotlib.figure import Figure

    from exotune.plots.margins import latency_boundary_figure

    _cfg, figs = paper
    fig = Figure()
    ax = fig.add_subplot()
    assert latency_boundary_figure(figs.latency_boundaries, 1e-3, ax=ax) is fig
    b = figs.latency_boundaries[0]
    np.testing.assert_array_equal(ax.lines[0].get_xdata(), b.values)


def test_rendering_computes_nothing(paper, monkeypatch):
    """The figures draw the record: no analysis-layer computation runs while rendering."""
    import importlib

    batch, lm, pdata = (importlib.import_module(f"exotune.analysis.{m}") for m in ("batch", "latency_margin", "plot_data"))

    def refuse(*_a, **_k):
        raise AssertionError("computed while rendering the figures")

    for mod, name in ((batch, "analyze_batch"), (lm, "latency_boundaries"), (pdata, "compliance_responses"),
                      (pdata, "human_loops"), (pdata, "dob_loop"), (pdata, "amplification_at_delays"),
                      (pdata, "freq_grid_hz")):
        monkeypatch.setattr(mod, name, refuse)
    _cfg, figs = paper
    assert set(plots.render_analysis_plots(figs)) == ALL


BOX_HUMANS = "humans:\n  - {kind: msd, inertia: [0.001, 0.5], damping: 0.0, stiffness: [10.0, 1000.0]}\n"


@pytest.fixture(scope="module")
def msd_box(tmp_path_factory):
    """The paper example with one msd box human (inertia × stiffness), not robust on some edges."""
    text = PAPER.read_text(encoding="utf-8")
    head = text[: text.index("humans:")]
    p = tmp_path_factory.mktemp("box") / "box.yaml"
    p.write_text(head + BOX_HUMANS, encoding="utf-8")
    cfg = load_design(p)
    r = analyze_design(cfg)
    return cfg, r.to_dict(), analysis_figures(cfg, r)


def test_msd_box_nyquist_panels_per_edge(msd_box):
    """An msd box is drawn edge by edge: the corner value of the other ranged parameter is kept
    (the stiffness is not dropped) and every member's verdict is the edge's exact one (issue 17)."""
    from exotune.analysis import plot_data

    cfg, result, _figs = msd_box
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

    _cfg, _result, figs = msd_box
    labels, titles = [], []
    real_plot, real_title = Axes.plot, Axes.set_title
    monkeypatch.setattr(Axes, "plot", lambda self, *a, **k: (labels.append(k.get("label")), real_plot(self, *a, **k))[1])
    monkeypatch.setattr(Axes, "set_title", lambda self, t, *a, **k: (titles.append(t), real_title(self, t, *a, **k))[1])
    plots._fig_nyquist_humans(figs)
    curve = [lb for lb in labels if lb and lb.startswith(("m = ", "k = "))]
    assert curve and all(("kg·m²" in lb and "N·m/rad" in lb) for lb in curve), curve
    assert any("(stable)" in lb for lb in curve) and any("(UNSTABLE)" in lb for lb in curve)
    assert len(titles) == 4 and all(f"edge {i + 1} of 4" in t for i, t in enumerate(titles)), titles
    assert all("stable on none" not in t for t in titles)
    assert "stable on [10, 1000] N·m/rad" in titles[3]
