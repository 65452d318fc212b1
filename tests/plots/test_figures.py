"""exotune.plots.figures: the figures draw the data they are given into the given ax, compute
nothing, and return the Figure."""

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

from exotune.plots.figures import bode_magnitude, compliance_phase  # noqa: E402

F = np.geomspace(0.1, 100.0, 50)
H1 = 1.0 / (1.0 + 1j * F / 5.0)
H2 = np.full(F.size, 10.0 + 0j)


def test_bode_magnitude_draws_each_curve_in_db_into_the_given_ax():
    fig, ax = plt.subplots()
    out = bode_magnitude([("C_5", F, H1), ("C7", F, H2)], ax=ax, title="compliances")
    assert out is fig
    lines = ax.get_lines()
    assert [ln.get_label() for ln in lines] == ["C 5", "C7"]  # underscores shown as spaces
    assert np.allclose(lines[0].get_xdata(), F) and np.allclose(lines[0].get_ydata(), 20 * np.log10(np.abs(H1)))
    assert np.allclose(lines[1].get_ydata(), 20.0)  # |10| = 20 dB
    assert ax.get_xscale() == "log" and ax.get_title() == "compliances"
    assert "[Hz]" in ax.get_xlabel() and "[dB]" in ax.get_ylabel()
    assert [t.get_text() for t in ax.get_legend().get_texts()] == ["C 5", "C7"]
    plt.close(fig)


def test_bode_magnitude_without_ax_makes_a_figure():
    fig = bode_magnitude([("a", F, H1)])
    assert isinstance(fig, Figure) and len(fig.axes) == 1 and fig.axes[0].get_title() == ""
    plt.close(fig)


def test_compliance_phase_draws_phase_limits_and_bands():
    fig, ax = plt.subplots()
    H = np.exp(-1j * np.linspace(0.1, 4.0, F.size))  # winds past −180°: unwrapped, not wrapped
    out = compliance_phase(F, H, bands=[(1.0, 2.0), (10.0, 20.0)], ax=ax, title="C7")
    assert out is fig
    line = ax.get_lines()[0]
    assert np.allclose(line.get_xdata(), F)
    assert np.allclose(line.get_ydata(), -np.degrees(np.linspace(0.1, 4.0, F.size)))
    horizontal = sorted(ln.get_ydata()[0] for ln in ax.get_lines()[1:])
    assert horizontal == [-180.0, 0.0]
    spans = [p for p in ax.patches]
    assert len(spans) == 2
    xs = sorted((round(p.get_x(), 9), round(p.get_x() + p.get_width(), 9)) for p in spans)
    assert xs == [(1.0, 2.0), (10.0, 20.0)]
    legend = [t.get_text() for t in ax.get_legend().get_texts()]
    assert legend.count("non-passive band") == 1 and "phase of C7" in legend
    assert ax.get_title() == "C7"
    plt.close(fig)
