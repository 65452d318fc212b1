"""exotune.plots.sweep: the sweep report's heatmaps and profiles draw the grid they are given
(SI axis values shown in display units, +inf and NaN cells explained), computing nothing."""

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

from exotune.plots import sweep  # noqa: E402
from exotune.plots.style import BAD_MEANING  # noqa: E402

PNG = b"\x89PNG\r\n\x1a\n"
X = np.array([0.001, 0.002, 0.003])  # delay [s]
Y = np.array([2.0, 4.0])  # amplification [–]
GRID = np.array([[0.1, 0.5, np.nan], [0.9, np.inf, 0.3]])


@pytest.fixture
def figures(monkeypatch):
    """The figures the PNG functions would render (png() returns the figure instead of bytes)."""
    monkeypatch.setattr(sweep, "png", lambda fig: fig)
    yield
    plt.close("all")


def test_draw_heatmap_draws_the_grid_into_the_given_ax():
    fig, ax = plt.subplots()
    flags = sweep.draw_heatmap(ax, GRID, X, Y, "implementation.delay_s [s]", "design.amplification [1]",
                               "robust over design.amplification", "fraction robust [–]", vmin=0.0, vmax=1.0)
    assert flags == {"nan": True, "inf": True, "zero": False}
    (im,) = ax.get_images()
    data = im.get_array()
    assert data.shape == GRID.shape
    assert data.mask.tolist() == np.isnan(GRID).tolist()  # NaN: masked (the grey "bad" colour)
    fin = np.isfinite(GRID)
    assert np.allclose(data[fin], GRID[fin])
    assert data[1, 1] > 1.0  # +inf: above vmax, the colour bar's "over" arrow
    assert im.norm.vmin == 0.0 and im.norm.vmax == 1.0
    assert ax.get_xlabel() == "total delay T [ms]" and ax.get_ylabel() == "amplification α [–]"
    assert [t.get_text() for t in ax.get_xticklabels()] == ["1", "2", "3"]  # s shown in ms
    assert ax.get_title() == "robust over amplification α"  # paths replaced by physical names
    assert len(fig.axes) == 2  # the colour bar
    plt.close(fig)


def test_log_scale_marks_non_positive_cells():
    fig, ax = plt.subplots()
    g = np.array([[0.0, 1.0, 100.0], [10.0, 1000.0, 5.0]])
    flags = sweep.draw_heatmap(ax, g, X, Y, "implementation.delay_s [s]", "design.amplification [1]", "t", "c [–]",
                               log=True)
    assert flags == {"nan": False, "inf": False, "zero": True}
    im = ax.get_images()[0]
    assert type(im.norm).__name__ == "LogNorm" and im.norm.vmin == 1.0 and im.norm.vmax == 1000.0
    assert im.get_array()[0, 0] < im.norm.vmin  # the "under" colour
    plt.close(fig)


def test_heatmap_notes_the_cells_off_the_colour_bar(figures):
    fig = sweep.heatmap(GRID, X, Y, "implementation.delay_s [s]", "design.amplification [1]", "t", "fraction robust [–]")
    notes = " ".join(t.get_text() for t in fig.texts)
    assert BAD_MEANING in notes and "∞" in notes
    ax = fig.axes[0]
    cells = {t.get_text() for t in ax.texts}  # 6 cells ≤ 144: annotated, NaN left blank
    assert cells == {"0.10", "0.50", "0.90", "∞", "0.30"}


def test_heatmap_bytes_are_a_png():
    data = sweep.heatmap(np.ones((2, 3)), X, Y, "implementation.delay_s [s]", "design.amplification [1]", "t", "c [–]")
    assert data.startswith(PNG)


def test_heatmap_panels_skip_constant_metrics(figures):
    panels = [{"grid": GRID, "title": "a", "cbar_label": "phase margin [deg]"},
              {"grid": np.full((2, 3), 7.0), "title": "b", "cbar_label": "gain margin [dB]"},
              {"grid": np.arange(6.0).reshape(2, 3), "title": "c", "cbar_label": "bandwidth [Hz]"}]
    fig = sweep.heatmap_panels(panels, X, Y, "implementation.delay_s", "design.amplification", "metrics")
    visible = [ax for ax in fig.axes if ax.get_visible() and ax.get_images()]
    assert [ax.get_title() for ax in visible] == ["a", "c"]
    assert np.allclose(visible[1].get_images()[0].get_array(), np.arange(6.0).reshape(2, 3))
    title = fig._suptitle.get_text()
    assert title.startswith("metrics\nthe same in every cell: gain margin: 7 dB")


def test_profile_figure_plots_each_series_with_inf_markers(figures):
    y_inf = np.array([1.0, np.inf, 3.0])
    fig = sweep.profile_figure(X, [("fraction robust", [0.0, 0.5, 1.0]), ("margin [ms]", y_inf)],
                               "implementation.delay_s", True, "profile over implementation.delay_s")
    a0, a1 = [ax for ax in fig.axes]
    (line,) = a0.get_lines()
    assert np.allclose(line.get_xdata(), X * 1e3) and np.allclose(line.get_ydata(), [0.0, 0.5, 1.0])
    finite, marker = a1.get_lines()
    assert np.allclose(finite.get_ydata(), [1.0, 3.0])
    assert marker.get_label() == "∞" and np.allclose(marker.get_xdata(), [2.0]) and np.allclose(marker.get_ydata(), 3.0)
    assert a1.get_xscale() == "log" and a1.get_xlabel() == "total delay T [ms]"
    assert a0.get_title() == "profile over total delay T"
