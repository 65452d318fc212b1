"""The typed result of a simulation (docs/cli.md#simulate).

References
----------
docs/api.md#typed-results; docs/method.md#simulation.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from ..record import Record

__all__ = ["SimulationRun"]


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
        panels, or the first one only into a given ``ax``. Returns the matplotlib ``Figure``.

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

        return simulation_figure(self.full_report(), ax=ax)
