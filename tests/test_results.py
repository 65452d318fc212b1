"""exotune.results: every typed result in one place — the classes of the layers that build them,
each with the views of exotune.record.Result, each named in docs/api.md#typed-results."""

import importlib
import inspect
from pathlib import Path

import exotune.results as results
from exotune.record import Record, Result

ROOT = Path(__file__).resolve().parent.parent
PARTS = {"BoxEdge"}  # a part of a FamilyResult: to_dict only (the JSON of its family)


def test_every_name_is_a_result_class_re_exported_from_its_layer():
    assert set(results.__all__) >= {"Result", "Record", "DesignAnalysis", "ExportedController", "Certificate",
                                    "SweepResult", "SweepReport", "OptimizeResult", "SimulationRun", "PlantEstimate"}
    for name in results.__all__:
        cls = getattr(results, name)
        assert inspect.isclass(cls), name
        home = importlib.import_module(cls.__module__)
        assert getattr(home, name) is cls  # the layer's own class, not a copy
        assert not cls.__module__.startswith("exotune.results")
        assert callable(getattr(cls, "to_dict")), name
        if name not in PARTS:
            assert issubclass(cls, Result), name
    assert results.Result is Result and results.Record is Record


def test_docs_name_every_result():
    doc = (ROOT / "docs" / "api.md").read_text(encoding="utf-8")
    missing = [n for n in results.__all__ if n not in ("Result", "Record") and f"`{n}`" not in doc]
    assert not missing, missing
