"""exotune.plots.results: the sweep map, the optimum within its bounds and the Pareto front draw
the data they are given into the given ax and return the Figure."""

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

from exotune.plots.results import optimum_in_bounds, pareto_front, sweep_map  # noqa: E402


def test_sweep_map():
    grid = np.array([[0.0, 0.5], [1.0, np.nan]])
    fig, ax = plt.subplots()
    assert sweep_map(grid, [2.0, 8.0], [0.0, 0.002], "design.amplification", "implementation.delay_s", "robust",
                     "fraction robust [–]", ax=ax) is fig
    data = ax.get_images()[0].get_array()
    assert data.mask.tolist() == [[False, False], [False, True]]
    assert data[0].tolist() == [0.0, 0.5] and data[1, 0] == 1.0
    assert ax.get_ylabel() == "total delay T [ms]"
    plt.close(fig)
    assert isinstance(sweep_map(grid, [2.0, 8.0], [0.0, 0.002], "design.amplification", "implementation.delay_s",
                                "t", "c [–]"), Figure)


def test_optimum_in_bounds():
    fig, ax = plt.subplots()
    names = ["design.amplification", "implementation.dob.cutoff_hz"]
    assert optimum_in_bounds(names, [1.0, 0.25], at_bounds=["design.amplification"], binding_text="robust",
                             title="optimum", ax=ax) is fig
    pts = ax.collections[-1]
    assert np.allclose(pts.get_offsets(), [[1.0, 0.0], [0.25, 1.0]])
    red, blue = pts.get_facecolors()[:2]
    assert red[0] > 0.7 and red[2] < 0.3 and blue[2] > 0.5  # the parameter at its bound in red
    assert [t.get_text() for t in ax.get_yticklabels()] == ["amplification", "dob.cutoff_hz"]
    assert ax.get_title() == "optimum\nbinding: robust"
    plt.close(fig)


def test_pareto_front():
    fig, ax = plt.subplots()
    assert pareto_front([1.0, 2.0, 3.0], [1.0, 0.8, 0.5], optimum=(2.0, 0.8), objective_label="α [–]", ax=ax) is fig
    front, star = ax.get_lines()
    assert np.allclose(front.get_xdata(), [1, 2, 3]) and np.allclose(front.get_ydata(), [1.0, 0.8, 0.5])
    assert star.get_xdata().tolist() == [2.0] and star.get_label() == "returned design"
    assert ax.get_xlabel() == "α [–]" and ax.get_ylabel() == "robust fraction [–]"
    plt.close(fig)
    assert len(pareto_front([1.0], [1.0]).axes[0].get_lines()) == 1
