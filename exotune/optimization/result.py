"""The typed result of an optimization run (docs/optimize-spec.md).

References
----------
docs/api.md#typed-results; docs/optimize-spec.md.
"""

from __future__ import annotations

from dataclasses import dataclass

from ..record import Record

__all__ = ["OptimizeResult"]


@dataclass(frozen=True)
class OptimizeResult(Record):
    """``exotune optimize``: the best feasible design found (``feasible``), its objective value and
    the written design file (``path``; None when nothing feasible was written). ``to_dict()`` is
    the run's whole report."""

    feasible: bool = False
    objective_value: float | None = None
    path: str | None = None

    @classmethod
    def from_report(cls, rec: dict, path=None) -> "OptimizeResult":
        """The typed view of an optimization report ``rec`` whose design went to ``path``.

        Parameters
        ----------
        rec : dict
            The report (``feasible``, ``objective``, …).
        path : str or os.PathLike, optional
            Where the design was written.

        Returns
        -------
        OptimizeResult
            The view; ``path`` None when no feasible design was written.
        """
        obj = rec.get("objective") or {}
        val = obj.get("value") if isinstance(obj, dict) else obj
        return cls(rec, bool(rec["feasible"]), None if val is None else float(val),
                   None if path is None or not rec["feasible"] else str(path))

    def to_text(self) -> str:
        """The text report of ``exotune optimize``.

        Returns
        -------
        str
            The report.
        """
        from ..text.optimize import format_optimize

        return format_optimize(self.to_dict())

    def plot(self, ax=None):
        """Where the returned design sits in each free parameter's bounds (parameters at a bound in
        red, the binding constraints in the title), or — when the run kept a Pareto front — the
        front with the design marked. Returns the matplotlib ``Figure``.

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Where to draw; None for a new figure.

        Returns
        -------
        matplotlib.figure.Figure
            The figure.
        """
        from ..plots.results import optimum_in_bounds, pareto_front

        r = self.to_dict()
        if r.get("pareto") and self.objective_value is not None:
            front = r["pareto"]
            return pareto_front([p["objective"] for p in front], [p["robust_fraction"] for p in front],
                                (self.objective_value, r.get("robust_fraction", 1.0)),
                                objective_label=f"{r['objective']['name']} [{r['objective'].get('unit') or '–'}]", ax=ax)
        rel = r.get("x_relative") or {}
        names = list(rel)
        title = (f"{r['objective']['name']} = {self.objective_value:.6g} {r['objective'].get('unit') or ''}"
                 if self.feasible else "no feasible design: the least-violating one")
        return optimum_in_bounds(names, [rel[n] for n in names], [b["parameter"] for b in r.get("at_bounds", [])],
                                 ", ".join(r.get("active_constraints") or []), title, ax=ax)
