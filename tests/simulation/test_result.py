"""exotune.simulation.result: SimulationRun keeps the summary as its record and the time series apart."""

import json

import numpy as np

from exotune.simulation.result import SimulationRun

REPORT = {"scenario": "light-mass", "summary": {"verdict": "decaying"}, "runs": [{"t": np.arange(3.0)}]}


def test_from_report_separates_the_runs():
    r = SimulationRun.from_report(REPORT)
    assert r.scenario == "light-mass"
    assert r.to_dict() == {"scenario": "light-mass", "summary": {"verdict": "decaying"}}
    assert json.loads(r.to_json()) == r.to_dict()  # no time series in the JSON
    full = r.full_report()
    assert full["runs"] is REPORT["runs"] and full["summary"] == {"verdict": "decaying"}
    assert "runs" in REPORT  # the caller's report is untouched


def test_runs_do_not_take_part_in_equality():
    a = SimulationRun.from_report(REPORT)
    b = SimulationRun.from_report({**REPORT, "runs": None})
    assert a == b and "runs" not in repr(a)
    assert SimulationRun.from_report({"summary": {}}).scenario == ""
