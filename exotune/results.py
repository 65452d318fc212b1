"""Typed results of exotune's commands, in one place (docs/api.md#typed-results).

Each result is built by the layer that computes it and is re-exported here: a frozen dataclass
with a readable ``repr``, ``to_dict()`` (exactly the command's ``--json`` object), ``to_json()``,
``to_text()`` (the text report) and — where the command draws figures — ``plot(ax=None)``
returning a matplotlib ``Figure``. Text and figures are views: they are imported only when asked
for.
"""

from __future__ import annotations

from .analysis.results import (
    Amplification,
    BoxEdge,
    DesignAnalysis,
    DesignSummary,
    DobMargins,
    EnvironmentResult,
    FamilyResult,
    PassivityResult,
    SeaReport,
)
from .controllerfile.results import Certificate, ExportedController, GeneratedC
from .identification.result import PlantEstimate
from .optimization.result import OptimizeResult
from .record import Record, Result
from .simulation.result import SimulationRun
from .sweeps.result import SweepReport, SweepResult

__all__ = [
    "Result",
    "Record",
    "DesignSummary",
    "SeaReport",
    "FamilyResult",
    "BoxEdge",
    "EnvironmentResult",
    "PassivityResult",
    "DobMargins",
    "Amplification",
    "DesignAnalysis",
    "ExportedController",
    "Certificate",
    "GeneratedC",
    "SweepResult",
    "SweepReport",
    "OptimizeResult",
    "SimulationRun",
    "PlantEstimate",
]
