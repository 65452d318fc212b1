"""The latency margin of a design with a gain schedule is the smallest over the controllers the
runtime runs (the main one and every entry's), in certify, export and analyze alike — checked
against the margin of the same entry exported (or analysed) as a design of its own, with its plant
reflected by hand (J_m, B_m, K_s × ratio², paper §IV gain scheduling)."""

from __future__ import annotations

import copy
from pathlib import Path

import pytest
import yaml

from exotune import api
from exotune.analysis import analyze_with_margins
from exotune.analysis.latency_margin import latency_margin
from exotune.config import design_from_mapping, read_yaml
from exotune.controllerfile.certify import certify
from exotune.errors import ExotuneError

ROOT = Path(__file__).resolve().parents[2]
RATIO = 1.6


def _raw(schedule: bool = True) -> dict:
    raw = read_yaml(ROOT / "examples" / "scheduled.yaml")
    if schedule:
        raw["transmission"] = {"joint_angle_rad": [0.0, 1.0], "ratio": [1.0, RATIO]}
    else:
        raw.pop("transmission", None)
        for k in ("motor_inertia", "motor_damping", "sea_stiffness"):
            raw["plant"][k] = float(raw["plant"][k]) * RATIO**2
    return raw


def _write(tmp_path, raw, name) -> Path:
    p = tmp_path / name
    p.write_text(yaml.safe_dump(raw, sort_keys=False))
    return p


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("sched")
    sched = api.export(_write(d, _raw(), "s.yaml"), 1000.0, d / "s_c.yaml", allow_uncertified=True)
    alone = api.export(_write(d, _raw(False), "r.yaml"), 1000.0, d / "r_c.yaml", allow_uncertified=True)
    return d, sched, alone


def test_certify_takes_the_smallest_margin_over_the_entries(files):
    d, _, _ = files
    rep = certify(yaml.safe_load((d / "s_c.yaml").read_text())).to_dict()
    alone = certify(yaml.safe_load((d / "r_c.yaml").read_text())).to_dict()
    entries = rep["gain_schedule"]
    lm = rep["latency_margin"]
    m_entry = entries[1]["latency_margin"]["extra_delay_s"]
    # the 1.6 entry tolerates less than the main controller (ratio 1), and exactly what the same
    # controller tolerates exported as a design of its own
    assert m_entry < entries[0]["latency_margin"]["extra_delay_s"]
    assert m_entry == pytest.approx(alone["latency_margin"]["extra_delay_s"], rel=1e-5)
    assert lm["extra_delay_s"] == m_entry
    assert lm["gain_schedule_entry"] == {"joint_angle_rad": 1.0, "ratio": RATIO}
    assert lm["main_controller_s"] == pytest.approx(entries[0]["latency_margin"]["extra_delay_s"], rel=1e-5)


def test_a_requirement_only_the_main_controller_meets_is_refused(files, tmp_path):
    d, _, _ = files
    rep = certify(yaml.safe_load((d / "s_c.yaml").read_text())).to_dict()
    m_main = rep["latency_margin"]["main_controller_s"]
    m_entry = rep["latency_margin"]["extra_delay_s"]
    req = 0.5 * (m_main + m_entry)  # met by the main controller, not by the 1.6 entry
    raw = _raw()
    raw["requirements"] = {"latency_margin_s": req}
    src = _write(tmp_path, raw, "req.yaml")
    with pytest.raises(ExotuneError, match="gain schedule at joint angle 1 rad: latency margin"):
        api.export(src, 1000.0, tmp_path / "c.yaml")
    assert not (tmp_path / "c.yaml").exists()
    api.export(src, 1000.0, tmp_path / "u.yaml", allow_uncertified=True)
    rep = certify(yaml.safe_load((tmp_path / "u.yaml").read_text())).to_dict()
    assert not rep["certified"]
    assert any("gain schedule at joint angle 1 rad: latency margin" in p for p in rep["problems"])
    raw["requirements"] = {"latency_margin_s": 0.9 * m_entry}
    api.export(_write(tmp_path, raw, "ok.yaml"), 1000.0, tmp_path / "ok_c.yaml")  # met by every entry


def test_analyze_reports_the_smallest_continuous_margin_over_the_entries():
    r = analyze_with_margins(design_from_mapping(copy.deepcopy(_raw())), sampled_check=False)
    lm = r.margins[0]
    alone = latency_margin(design_from_mapping(_raw(False)))
    main = latency_margin(design_from_mapping({k: v for k, v in _raw().items() if k != "transmission"}))
    assert alone.extra_delay_s < main.extra_delay_s
    assert lm.extra_delay_s == pytest.approx(alone.extra_delay_s, rel=1e-9)
    assert lm.gain_schedule_entry == (1.0, RATIO)
    assert lm.main_controller_s == pytest.approx(main.extra_delay_s, rel=1e-9)
    assert [e.latency_margin_s for e in r.gain_schedule] == pytest.approx([main.extra_delay_s, alone.extra_delay_s],
                                                                          rel=1e-9)
    d = r.to_dict()["margins"]["latency"]
    assert d["gain_schedule_entry"] == {"joint_angle_rad": 1.0, "ratio": RATIO}
