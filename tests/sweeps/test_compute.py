"""The opt-in sweep columns ``plant_margin_lower`` / ``plant_margin_upper`` (spec key
``plant_margin``): equal to the single-design plant-uncertainty margin of each row, 0 where a design
is not robust at the nominal plant, mapped by ``report``; and the spec key's validation. The sweeps
and their single-design references use a certification budget of 5000 evaluations (``BUDGET``,
not 20000): the comparison is at the same budget either way, and every robust row still has a
positive certified lower bound."""

from __future__ import annotations

import copy
from pathlib import Path

import numpy as np
import pytest
import yaml

from exotune.analysis.plant_margin import plant_uncertainty_margin
from exotune.config import design_from_mapping, read_yaml
from exotune.errors import ConfigError
from exotune.plots.sweep_report import make_report
from exotune.sweeps import load_results, load_spec, run_sweep

ROOT = Path(__file__).resolve().parents[2]
# interval evaluations per loop and certification attempt: enough for a positive certified lower
# bound on every robust row here (the check is sweep column == single-design margin at the same
# budget); 20000 spent ~8 s on the 0.5 ms design alone for the same checks
BUDGET = 5000


def _base(tmp: Path) -> Path:
    m = read_yaml(ROOT / "examples" / "scheduled.yaml")
    m.pop("transmission", None)
    m["humans"] = [{"kind": "mass", "inertia": [0.01, 1.0], "damping": 0.0}]
    m["uncertainty"] = {"cuff_stiffness": 0.2, "sea_stiffness": 0.1}
    p = tmp / "base.yaml"
    p.write_text(yaml.safe_dump(m, sort_keys=False), encoding="utf-8")
    return p


@pytest.fixture(scope="module")
def swept(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("pm")
    base = _base(tmp)
    spec = tmp / "spec.yaml"
    spec.write_text(yaml.safe_dump({"base": str(base), "axes": {"implementation.delay_s": [0.0005, 0.002, 0.012]},
                                    "chunk_size": 2, "plant_margin": {"budget": BUDGET}}), encoding="utf-8")
    run_sweep(spec, tmp / "out", workers=1, progress=False)
    return base, tmp / "out", load_results(tmp / "out")


def test_columns_equal_the_single_design_margin(swept):
    base, _out, df = swept
    assert {"plant_margin_lower", "plant_margin_upper", "latency_margin_s"} <= set(df.columns)
    mapping = read_yaml(base)
    for t, lo, up in zip(df["implementation.delay_s"], df["plant_margin_lower"], df["plant_margin_upper"]):
        m = copy.deepcopy(mapping)
        m["implementation"]["delay_s"] = float(t)
        cfg = design_from_mapping(m)
        pm = plant_uncertainty_margin(cfg, cfg.uncertainty, budget=BUDGET, loop_detail=False)
        assert lo == pytest.approx(pm.lower, rel=1e-12) and up == pytest.approx(pm.upper, rel=1e-12)
        assert 0 <= lo <= up


def test_not_robust_rows_have_zero_margins(swept):
    _base_, _out, df = swept
    robust = (df["free_stable"] & df["human0_mass_robust"] & df["env0_locked_stable"]).to_numpy()
    assert robust.any() and not robust.all()  # 12 ms of delay is not robust over the masses
    assert np.all(df["plant_margin_lower"].to_numpy()[~robust] == 0)
    assert np.all(df["plant_margin_lower"].to_numpy()[robust] > 0)


def test_report_maps_and_tables_the_lower_bound(swept):
    _base_, out, df = swept
    rep = make_report(out).directory
    md = (rep / "summary.md").read_text(encoding="utf-8")
    assert "plant_margin_lower" in md
    csv_text = (rep / "axis_implementation.delay_s.csv").read_text(encoding="utf-8")
    assert "plant_margin_lower_min" in csv_text.splitlines()[0]


@pytest.mark.parametrize("value, field", [("yes", "plant_margin"), ({"budget": 10}, "plant_margin.budget"),
                                          ({"bugdet": 5000}, "plant_margin.bugdet"), (3, "plant_margin")])
def test_spec_key_is_validated(tmp_path, value, field):
    spec = {"base": str(_base(tmp_path)), "axes": {"design.amplification": [3.0]}, "plant_margin": value}
    with pytest.raises(ConfigError) as e:
        load_spec(spec)
    assert e.value.field == field


def test_spec_without_the_key_keeps_its_hash(tmp_path):
    spec = {"base": str(_base(tmp_path)), "axes": {"design.amplification": [3.0]}}
    h = load_spec(spec).hash
    assert load_spec({**spec, "plant_margin": False}).hash == h
    assert load_spec({**spec, "plant_margin": True}).hash != h
    assert load_spec({**spec, "plant_margin": True}).spec["plant_margin"] == {"budget": 150000}


def test_sweep_rows_compute_their_margins_without_child_processes(tmp_path, monkeypatch):
    """A sweep's workers already use every core: the plant margin of a row (and its witness
    confirmation) never forks a child process there (exotune.numerics.beside.serial)."""
    import exotune.numerics.beside as B

    seen = []
    orig = B.Beside.__init__

    def record(self, key, fn, args, kwargs):
        orig(self, key, fn, args, kwargs)
        seen.append((key, self.forked, B.can_fork()))

    monkeypatch.setattr(B.Beside, "__init__", record)
    base = _base(tmp_path)
    spec = tmp_path / "spec.yaml"
    spec.write_text(yaml.safe_dump({"base": str(base), "axes": {"implementation.delay_s": [0.0005, 0.001]},
                                    "chunk_size": 2, "plant_margin": {"budget": BUDGET}}), encoding="utf-8")
    run_sweep(spec, tmp_path / "out", workers=1, progress=False)
    assert len(seen) == 2 and all(k == "plant_margin_witnesses" and not f and not c for k, f, c in seen)
