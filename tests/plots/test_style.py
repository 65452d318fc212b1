"""The shared look (exotune.plots.style) and its use by the sweep report's heatmaps: physical names
and units instead of configuration paths, no colour-bar offset text, grey cells explained."""

from __future__ import annotations

import numpy as np
import pytest

from exotune.plots import style
from exotune.plots import sweep as figures


@pytest.mark.parametrize("path, text, scale", [
    ("implementation.delay_s", "total delay T [ms]", 1e3),
    ("implementation.delay_s [s]", "total delay T [ms]", 1e3),
    ("design.amplification", "amplification α [–]", 1.0),
    ("plant.cuff_stiffness", "cuff stiffness K_c [N·m/rad]", 1.0),
    ("implementation.dob.cutoff_hz", "DOB cutoff f_q [Hz]", 1.0),
    ("dob_delay_margin_s [ms]", "DOB delay margin ΔT [ms]", 1e3),
    ("latency_margin_s [ms]", "latency margin ΔT [ms]", 1e3),
    ("plant_margin_lower", "plant-uncertainty margin, lower bound k* [–]", 1.0),
    ("human0_lightest_stable_inertia", "lightest stable inertia, human 0 [kg·m²]", 1.0),
])
def test_label_names_the_physical_quantity(path, text, scale):
    assert style.label(path) == text
    assert style.scale_of(path) == scale
    assert not any(w in style.label(path) for w in ("implementation", "design.", "plant.", "_s "))


def test_label_of_an_unknown_name_is_readable():
    assert style.label("some.odd_name") == "odd name"


def test_unit_axis_scales_the_ticks_not_the_data():
    fig = style.new_figure()
    ax = fig.add_subplot(1, 1, 1)
    ax.plot([0.0, 0.005], [0.0, 1.0])
    style.unit_axis(ax, "x", "implementation.delay_s")
    assert ax.get_xlabel() == "total delay T [ms]"
    assert ax.xaxis.get_major_formatter()(0.002, 0) == "2"
    assert style.log_if_decades(ax, [1e-3, 1.0]) and ax.get_yscale() == "log"


def _captured(monkeypatch):
    figs = []
    real = figures.png
    monkeypatch.setattr(figures, "png", lambda fig, **kw: (figs.append(fig), real(fig, **kw))[1])
    return figs


def test_report_heatmap_has_physical_labels_and_no_offset_text(monkeypatch):
    figs = _captured(monkeypatch)
    grid = 89.99999999 + np.linspace(0, 1e-8, 21 * 25).reshape(21, 25)  # offset text before the fix
    grid[0, 0] = np.nan
    data = figures.heatmap(grid, np.logspace(0.2, 1.3, 25), np.linspace(0.0, 0.005, 21),
                           "design.amplification [–]", "implementation.delay_s [s]",
                           "worst case over design.zeta_hat", "dob_phase_margin_deg [deg]")
    assert data.startswith(b"\x89PNG")
    fig = figs[-1]
    ax, cax = fig.axes[0], fig.axes[1]
    assert ax.get_xlabel() == "amplification α [–]"
    assert ax.get_ylabel() == "total delay T [ms]"
    assert "implementation." not in ax.get_title() and "ζ̂" in ax.get_title()
    assert [t.get_text() for t in ax.get_yticklabels()][-1] == "5"  # ms, not 0.005 s
    fig.canvas.draw()
    assert cax.yaxis.get_offset_text().get_text() == ""
    assert cax.get_ylabel().startswith("DOB phase margin")
    notes = " ".join(t.get_text() for t in fig.texts)
    assert "grey" in notes  # the NaN cell is explained


def test_report_panels_fold_constant_metrics_into_the_title(monkeypatch):
    figs = _captured(monkeypatch)
    x, y = np.array([1.0, 2.0, 3.0]), np.array([0.001, 0.002])
    panels = [{"grid": np.full((2, 3), 3.654), "title": "DOB delay margin", "cbar_label": "dob_delay_margin_s [ms]"},
              {"grid": np.arange(6.0).reshape(2, 3), "title": "bandwidth", "cbar_label": "amplification_bandwidth_hz [Hz]"}]
    figures.heatmap_panels(panels, x, y, "design.amplification [–]", "implementation.delay_s [s]", "key metrics")
    fig = figs[-1]
    visible = [a for a in fig.axes if a.get_visible() and a.get_label() != "<colorbar>"]
    assert len(visible) == 1
    assert "DOB delay margin ΔT: 3.654 ms" in fig.get_suptitle()
