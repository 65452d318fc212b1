"""exotune.optimization.runner: ``exotune optimize`` writes a design file that loads and holds the
optimum (with a header naming objective, constraints and seed), the Pareto front as CSV, and
nothing when no design is feasible."""

from __future__ import annotations

import copy
import os
from pathlib import Path

import numpy as np
import pytest

from exotune.config import load_design
from exotune.optimization.runner import run_optimize

from disk_faults import full_disk_after

BASE = copy.deepcopy(load_design(Path(__file__).resolve().parents[2] / "examples" / "paper.yaml").raw)
BASE["humans"] = [{"kind": "mass", "inertia": [0.01, 1.0], "damping": 0.0},
                  {"kind": "spring", "stiffness": [1.0, 10000.0], "damping": 0.0}]


def _spec(**constraints):
    return {"base": copy.deepcopy(BASE), "objective": "amplification", "budget": 50, "seed": 1,
            "free": {"design.amplification": [1.5, 60.0]},
            "constraints": {"latency_margin_s": 0.0, **constraints}}


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    d = tmp_path_factory.mktemp("opt")
    out, csv = d / "best.yaml", d / "front.csv"
    return run_optimize(_spec(max_phase_excess_deg=20.0), out, pareto_csv=csv), out, csv


def test_the_written_design_loads_and_holds_the_optimum(run):
    res, out, _ = run
    assert res.feasible and res.path == str(out)
    cfg = load_design(out)
    assert float(cfg.design.amplification) == pytest.approx(res.objective_value, rel=1e-12)
    assert 1.5 <= res.objective_value <= 60.0
    head = out.read_text().splitlines()[0]
    assert head.startswith("# exotune optimize: amplification = ")
    assert "maximized" in head and "seed 1" in head and "latency margin" in head


def test_the_pareto_front_is_written_as_csv(run):
    res, _, csv = run
    lines = csv.read_text().splitlines()
    assert lines[0] == "amplification [1],robust_fraction [1],design.amplification [1]"
    rows = np.array([[float(x) for x in ln.split(",")] for ln in lines[1:]])
    assert len(rows) == len(res.to_dict()["pareto"]) >= 1
    np.testing.assert_array_equal(rows[:, 0], rows[:, 2])  # the objective is α
    assert np.all((rows[:, 1] >= 0) & (rows[:, 1] <= 1))


def test_every_pareto_column_carries_its_unit(tmp_path):
    """The ``--pareto`` header was ``objective,robust_fraction,…`` without units: each column is
    now ``name [unit]`` (the objective under its name), the unit of the free parameter's path."""
    import csv

    spec = {**_spec(), "objective": "felt_inertia",
            "free": {"design.felt_inertia": [0.05, 0.5], "implementation.dob.cutoff_hz": [20.0, 80.0]}}
    run_optimize(spec, tmp_path / "a.yaml", pareto_csv=tmp_path / "front.csv")
    with open(tmp_path / "front.csv", newline="", encoding="utf-8") as fh:
        rows = list(csv.reader(fh))
    assert rows[0] == ["felt_inertia [kg·m²]", "robust_fraction [1]", "design.felt_inertia [kg·m²]",
                       "implementation.dob.cutoff_hz [Hz]"]
    assert len(rows) >= 2 and all(len(r) == 4 for r in rows[1:])
    assert [float(x) for x in rows[1]]  # the rows stay numbers


def test_the_seed_argument_overrides_the_spec(tmp_path):
    res = run_optimize(_spec(max_phase_excess_deg=20.0), tmp_path / "a.yaml", seed=5)
    assert "seed 5" in (tmp_path / "a.yaml").read_text().splitlines()[0]
    assert res.to_dict()["feasible"]


def test_an_infeasible_problem_writes_nothing(tmp_path):
    out = tmp_path / "none.yaml"
    res = run_optimize(_spec(amplification_bandwidth_hz=1e6), out)
    assert not res.feasible and res.path is None
    assert not out.exists()


@pytest.mark.parametrize("existing", [False, True])
def test_a_full_disk_on_the_pareto_front_leaves_the_design_as_it_was(tmp_path, monkeypatch, existing):
    """``-o O --pareto F`` wrote O, then failed on F (exit 2) and left O behind: the two are now
    written both or neither, and an O that was there keeps its content."""
    from exotune.errors import ConfigError

    out, csv = tmp_path / "sub" / "best.yaml", tmp_path / "sub" / "front.csv"
    if existing:
        out.parent.mkdir()
        out.write_text("old design\n")
    before = sorted(p.name for p in tmp_path.rglob("*"))
    calls = full_disk_after(monkeypatch, 1)
    with pytest.raises(ConfigError) as e:
        run_optimize(_spec(max_phase_excess_deg=20.0), out, pareto_csv=csv)
    assert (e.value.field, e.value.reason) == (str(csv), "cannot write output: No space left on device")
    assert len(calls) == 2  # both staged: the design first, then the front
    assert sorted(p.name for p in tmp_path.rglob("*")) == before  # no staging directory, no created parent
    assert not existing or out.read_text() == "old design\n"


@pytest.mark.skipif(not os.path.isdir("/proc/self"), reason="needs Linux /proc (a directory that refuses new files)")
def test_an_output_that_cannot_be_created_is_refused_before_the_search(tmp_path, monkeypatch):
    """``--pareto /proc/x.csv`` passes the permission bits (as root) but no file can be created
    there: it was found only after the search, once the design had been written. It is refused
    before the search now, nothing written."""
    from exotune.errors import ConfigError
    from exotune.optimization import runner

    def no_search(*a, **k):
        raise AssertionError("the search ran")

    monkeypatch.setattr(runner, "optimize", no_search)
    with pytest.raises(ConfigError) as e:
        run_optimize(_spec(), tmp_path / "best.yaml", pareto_csv="/proc/exotune-front.csv")
    assert e.value.field == "/proc/exotune-front.csv" and e.value.reason.startswith("cannot write output (`pareto_csv`): ")
    assert os.listdir(tmp_path) == []
