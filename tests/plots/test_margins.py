"""exotune.plots.margins: the latency-boundary figure draws the boundaries it is given (ms, stable
below), marks members unstable at the nominal delay, draws the margin, computes nothing."""

from types import SimpleNamespace

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

from exotune.plots.margins import latency_boundary_figure  # noqa: E402


def _b(values, extra, loop="human0_mass"):
    return SimpleNamespace(values=np.asarray(values, float), extra_delay_s=np.asarray(extra, float), loop=loop,
                           parameter="inertia", unit="kg·m²", delay_s=0.001)


def test_draws_each_boundary_in_ms_into_the_given_ax():
    b = _b([0.01, 0.1, 1.0], [np.nan, 0.002, 0.005])
    fig, ax = plt.subplots()
    assert latency_boundary_figure([b], margin_s=0.0015, ax=ax) is fig
    curve, marks, margin = ax.get_lines()
    assert np.allclose(curve.get_xdata(), [0.01, 0.1, 1.0])
    assert np.isnan(curve.get_ydata()[0]) and np.allclose(curve.get_ydata()[1:], [2.0, 5.0])
    assert np.allclose(marks.get_xdata(), [0.01]) and np.allclose(marks.get_ydata(), [0.0])
    assert marks.get_label() == "human0 mass: unstable at the nominal delay"
    assert np.allclose(margin.get_ydata(), 1.5) and margin.get_label() == "design latency margin 1.5 ms"
    assert curve.get_label() == "human0 mass: inertia [kg·m²]"
    assert ax.get_xscale() == "log" and ax.get_xlabel() == "human parameter: inertia [kg·m²]"
    assert ax.get_title() == "latency boundary of the human families (T = 1 ms)"
    plt.close(fig)


def test_no_margin_line_and_a_new_figure():
    fig = latency_boundary_figure([_b([0.1, 1.0], [0.002, 0.003])], margin_s=float("inf"))
    assert isinstance(fig, Figure)
    (ax,) = fig.axes
    assert len(ax.get_lines()) == 1  # all stable at the nominal delay, no finite margin: the curve alone
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")  # nothing to draw: no empty-legend warning either
        empty = latency_boundary_figure([], margin_s=None)
    assert empty.axes[0].get_title() == "" and empty.axes[0].get_legend() is None
