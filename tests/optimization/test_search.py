"""exotune.optimization.search: ``optimize`` on one-parameter problems (the amplification α of
examples/paper.yaml) whose optimum is known from a dense batch scan of the same design (the largest
α robust with an amplification bandwidth of at least 3 Hz, recomputed from the sweep columns), its reports (binding
constraint, bounds, exact latency margin) and determinism; a tiny budget."""

from __future__ import annotations

import copy
from pathlib import Path

import numpy as np
import pytest

from exotune.analysis import analyze_batch
from exotune.analysis.latency_margin import latency_margin
from exotune.config import batch_config, design_from_mapping, load_design
from exotune.optimization import load_optimize_spec, optimize, optimized_design_mapping

ROOT = Path(__file__).resolve().parents[2]
LO, HI = 1.5, 60.0
BW = 3.0  # Hz: the bandwidth falls from 443 Hz (α = 1.5) to 1.5 Hz (α = 60), 3 Hz near α ≈ 18


def _base():
    raw = copy.deepcopy(load_design(ROOT / "examples" / "paper.yaml").raw)
    raw["implementation"]["delay_s"] = 0.002
    raw["humans"] = [{"kind": "mass", "inertia": [0.01, 1.0], "damping": 0.0},
                     {"kind": "spring", "stiffness": [1.0, 10000.0], "damping": 0.0}]
    return raw


def _spec(**kw):
    s = {"base": _base(), "objective": "amplification", "free": {"design.amplification": [LO, HI]},
         "constraints": {"amplification_bandwidth_hz": BW, "latency_margin_s": 0.0}, "budget": 60}
    s.update(kw)
    return load_optimize_spec(s)


@pytest.fixture(scope="module")
def solved():
    spec = _spec()
    return spec, optimize(spec)


def test_optimum_is_the_last_robust_alpha_of_a_dense_scan(solved):
    spec, r = solved
    a = np.geomspace(LO, HI, 400)
    res = analyze_batch(batch_config(spec.cfg, {"design.amplification": a}))
    ok = (res.free.stable & res.locked.stable & res.humans[0].robust & res.humans[1].robust
          & (res.amplification.bandwidth_hz >= BW))
    assert ok[0] and not ok.all()
    first_bad = int(np.argmin(ok))
    assert ok[:first_bad].all()
    got = r["x"]["design.amplification"]
    assert r["feasible"] and r["objective"]["value"] == pytest.approx(got, rel=1e-12)
    assert a[first_bad - 1] <= got * (1 + 1e-9) and got <= a[first_bad] * (1 + 1e-9)
    assert r["active_constraints"] == ["amplification_bandwidth_hz"] and r["at_bounds"] == []


def test_reported_latency_margin_is_exact(solved):
    spec, r = solved
    cfg = design_from_mapping(optimized_design_mapping(spec, r))
    assert float(cfg.design.amplification) == pytest.approx(r["x"]["design.amplification"], rel=1e-12)
    lm = latency_margin(cfg).extra_delay_s
    ach = r["latency_margin"]["achieved_s"]
    assert (ach is None and not np.isfinite(lm)) or ach == pytest.approx(lm, rel=1e-9)


def test_an_upper_bound_below_the_boundary_is_reported_at_bounds(solved):
    _, r = solved
    hi = 0.5 * r["x"]["design.amplification"]
    r2 = optimize(_spec(free={"design.amplification": [LO, hi]}))
    assert r2["feasible"] and r2["x"]["design.amplification"] == pytest.approx(hi, rel=1e-9)
    assert r2["at_bounds"] == [{"parameter": "design.amplification", "bound": "upper",
                                "value": pytest.approx(hi, rel=1e-9)}]


def test_deterministic_for_a_seed(solved):
    spec, r = solved
    assert optimize(_spec())["x"] == r["x"]


def test_an_objective_undefined_wherever_the_constraints_hold_is_named_as_what_breaks(monkeypatch):
    """A problem whose designs meet every constraint but whose objective is undefined (NaN) at all
    of them returned no design with an empty ``broken``: the text said "the best one breaks: "
    with nothing after. It names the objective and why."""
    import exotune.optimization.space as space
    from exotune.text.optimize import format_optimize

    real = space.evaluate

    def nan_objective(spec, X):
        ev = real(spec, X)
        ev["objective"] = np.full(np.asarray(ev["X"]).shape[0], np.nan)
        return ev

    monkeypatch.setattr(space, "evaluate", nan_objective)
    spec = _spec(objective="amplification_bandwidth_hz", free={"design.zeta_hat": [0.5, 1.0]},
                 constraints={"latency_margin_s": 0.0}, budget=50)
    r = optimize(spec)
    assert not r["feasible"] and r["violations"] == []
    assert r["broken"] == ["objective: amplification_bandwidth_hz is undefined (NaN) at every design evaluated "
                           "that meets the constraints"]
    head = format_optimize(r).splitlines()[0]
    assert head.endswith("the best one breaks: " + r["broken"][0])
