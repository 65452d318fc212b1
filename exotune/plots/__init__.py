"""exotune.plots: every figure (matplotlib, imported when a figure is drawn) and its one style;
figures draw the numbers they are given and never compute.

``analysis``        ``exotune analyze --plots`` (:func:`write_analysis_plots`)
``margins``         the latency-boundary figure
``design``          ``exotune design --plots``
``figures``         the figures of the results' ``plot()``
``results``         sweep maps, the optimum in its bounds, the Pareto front
``simulate``        ``exotune simulate`` runs
``identification``  ``exotune identify --plots``
``sweep``           the sweep report's heatmaps and profiles
``sweep_report``    ``exotune report`` (:func:`make_report`)
``style``           sizes, fonts, colours, unit-aware axes
"""

from ..lazy import attach

__getattr__, __dir__, __all__ = attach(
    __name__,
    {
        "write_analysis_plots": "analysis",
        "make_report": "sweep_report",
    },
)
