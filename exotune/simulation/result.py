"""The typed result of a simulation (docs/cli.md#simulate).

References
----------
docs/api.md#typed-results; docs/method.md#simulation.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..record import Record

__all__ = ["SimulationRun", "thinned", "PLOT_POINTS"]

PLOT_POINTS = 20_000  # about the most samples per run a figure draws (a figure is a few thousand pixels wide)


def thinned(series: dict, max_points: int = PLOT_POINTS) -> dict:
    """The time series of a run with at most about ``max_points`` samples, for drawing: the run
    cut into buckets of consecutive samples, each keeping its first sample and, for every
    signal, the samples of its minimum and its maximum (so every peak, envelope and decade a
    figure shows is kept; a run of 6·10⁶ samples drawn whole took 1.5 GB). A shorter run is
    returned as it is.

    Parameters
    ----------
    series : dict
        The run's series (``t`` and the signals, arrays of one length).
    max_points : int, optional
        About the most samples kept.

    Returns
    -------
    dict
        The same keys, each array at the kept samples (in time order).

    Examples
    --------
    >>> import numpy as np
    >>> t = np.arange(100_000) / 1000.0
    >>> s = thinned({"t": t, "x": np.sin(t)}, max_points=1000)
    >>> s["t"].size <= 1000, bool(s["x"].max() == np.sin(t).max())
    (True, True)
    """
    t = series["t"]
    n = t.size
    names = [k for k in series if k != "t"]
    if n <= max_points:
        return series
    buckets = max(1, max_points // (2 * len(names) + 1))
    b = math.ceil(n / buckets)
    starts = np.arange(0, n, b)
    keep = [starts, np.array([n - 1])]
    m = (n // b) * b
    for k in names:
        v = series[k]
        if m:
            r = v[:m].reshape(-1, b)
            keep += [np.argmin(r, axis=1) + starts[: m // b], np.argmax(r, axis=1) + starts[: m // b]]
        if m < n:
            keep += [np.array([m + int(np.argmin(v[m:])), m + int(np.argmax(v[m:]))])]
    idx = np.unique(np.concatenate(keep))
    return {k: v[idx] for k, v in series.items()}


@dataclass(frozen=True)
class SimulationRun(Record):
    """``exotune simulate``: the scenario's summary (``to_dict()``, no time series) and its runs
    (``runs``: the time series of each run, as the plots draw them)."""

    scenario: str = ""
    runs: Any = field(default=None, repr=False, compare=False)

    @classmethod
    def from_report(cls, rep: dict) -> "SimulationRun":
        """The typed view of a scenario report ``rep`` (its ``runs`` kept apart from the summary).

        Parameters
        ----------
        rep : dict
            The scenario's report, with its ``runs``.

        Returns
        -------
        SimulationRun
            The view.
        """
        summary = {k: v for k, v in rep.items() if k != "runs"}
        return cls(summary, str(rep.get("scenario", "")), rep.get("runs"))

    def full_report(self) -> dict:
        """The summary with the time series of every run (``runs``), as the text and plot views read it.

        Returns
        -------
        dict
            The summary and ``runs``.
        """
        return {**self.to_dict(), "runs": self.runs}

    def plot_report(self) -> dict:
        """The summary with every run's series :func:`thinned` for drawing (the figures of a long
        run show the same peaks without drawing millions of samples).

        Returns
        -------
        dict
            The summary and ``runs``, their series thinned.
        """
        runs = {k: {**sim, "series": thinned(sim["series"])} for k, sim in (self.runs or {}).items()}
        return {**self.to_dict(), "runs": runs}

    def to_text(self) -> str:
        """The text report of ``exotune simulate``.

        Returns
        -------
        str
            The report.
        """
        from ..text.simulate import format_simulation

        return format_simulation(self.full_report())

    def plot(self, ax=None):
        """The scenario's time series (:func:`exotune.plots.simulate.simulation_figure`): two
        panels, or the first one only into a given ``ax``, a long run :func:`thinned` to about
        ``PLOT_POINTS`` samples. Returns the matplotlib ``Figure``.

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Where to draw the first panel; None for a new two-panel figure.

        Returns
        -------
        matplotlib.figure.Figure
            The figure.
        """
        from ..plots.simulate import simulation_figure

        return simulation_figure(self.plot_report(), ax=ax)
