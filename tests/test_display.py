"""Display defects of issue 17 (item 6): every printed interval carries its unit, a dimensionless
unit prints as "–", one sample is "1 sample", an msd box lists every edge, and ``certify`` prints
a controller file exported from a design with an msd box human."""

from __future__ import annotations

from pathlib import Path

import pytest
from click.testing import CliRunner

from exotune.analysis import analyze_design
from exotune.cli import cli
from exotune.config import load_design
from exotune.text.optimize import format_optimize
from exotune.text.analysis import format_report
from exotune.text.margins import format_margins
from exotune.text.numbers import count_text, interval_text, unit_text
from exotune.text.simulate import format_simulation

ROOT = Path(__file__).resolve().parents[1]
PAPER = ROOT / "examples" / "paper.yaml"
BOX_TAIL = """humans:
  - {kind: msd, inertia: [0.001, 0.5], damping: 0.0, stiffness: [10.0, 1000.0]}
environment:
  - {kind: spring, stiffness: [100.0, 10000.0]}
"""


def run(*args):
    return CliRunner().invoke(cli, [str(a) for a in args], catch_exceptions=False)


@pytest.fixture(scope="module")
def box_file(tmp_path_factory) -> Path:
    """The paper example with an msd box human (inertia × stiffness) and a spring environment range."""
    text = PAPER.read_text(encoding="utf-8")
    p = tmp_path_factory.mktemp("box") / "box.yaml"
    p.write_text(text[: text.index("humans:")] + BOX_TAIL, encoding="utf-8")
    return p


@pytest.fixture(scope="module")
def box_text(box_file) -> str:
    return format_report(analyze_design(load_design(box_file)).to_dict())


def test_unit_helpers():
    assert unit_text("1") == "–" and unit_text("1 (N·m/N·m)") == "– (N·m/N·m)"
    assert unit_text("1/s") == "1/s" and unit_text("kg·m²") == "kg·m²"
    assert count_text(1.0, "sample") == "1 sample" and count_text(2, "sample") == "2 samples"
    assert interval_text([[1, 2], [3, 4]], "Hz") == "[1, 2], [3, 4] Hz" and interval_text([], "Hz") == "none"


def test_box_text_lists_every_edge_with_units(box_text):
    lines = box_text.splitlines()
    (head,) = [ln for ln in lines if " box " in ln]
    assert "inertia in [0.001, 0.5] kg·m², stiffness in [10, 1000] N·m/rad" in head and "4 edges" in head
    edges = [ln for ln in lines if ln.startswith("    edge ")]
    assert len(edges) == 4, edges  # "4 edges" and four listed
    assert all(("kg·m²" in ln and "N·m/rad" in ln) for ln in edges), edges
    assert sum("(the whole edge)" in ln for ln in edges) == 1
    assert "    edge stiffness at inertia = 0.5 kg·m²: stable on [10, 1000] N·m/rad (the whole edge)" in lines


def test_environment_interval_has_units(box_text):
    assert ("Environment spring stiffness in [100, 10000] N·m/rad: robust yes, stable on [100, 10000] N·m/rad"
            in box_text.splitlines())


def test_dimensionless_gains_print_a_dash(box_text):
    k2 = [ln for ln in box_text.splitlines() if ln.startswith("  K2      =")]
    assert k2 and k2[0].endswith("[– (N·m/N·m, spring-torque feedback)]"), k2


def test_certify_text_of_a_box_file(box_file, tmp_path):
    """Was: KeyError 'robust' in format_certify (``--json`` worked)."""
    ctrl = tmp_path / "c.yaml"
    assert run("export", box_file, "--sample-rate-hz", 1000, "-o", ctrl, "--allow-uncertified").exit_code == 0
    res = run("certify", ctrl)
    assert res.exit_code == 1, res.output  # a box is not certifiable: NOT CERTIFIED, no traceback
    out = res.stdout.splitlines()
    assert any(ln.startswith("  msd inertia [0.001, 0.5] kg·m² × stiffness [10, 1000] N·m/rad: not certifiable (")
               for ln in out), out
    assert "  spring stiffness [100, 10000] N·m/rad: robust; stable in [100, 10000] N·m/rad" in out
    assert "NOT CERTIFIED:" in out


def test_design_text_dimensionless_units():
    res = run("design", PAPER)
    assert res.exit_code == 0
    assert "– (N·m/N·m, spring-torque feedback)" in res.stdout and "  1 (" not in res.stdout


def test_simulate_text_units_and_one_sample():
    rep = {"scenario": "step", "description": "a step", "sample_rate_hz": 1000.0, "delay_samples": 1.0,
           "summary": {"start": "zero", "verdict": "decaying",
                       "delivered_amplification": {"value": 26.216, "unit": "1", "design_alpha": 8.0},
                       "amplification_error": {"value": 0.1, "unit": "1 (relative)"}}}
    text = format_simulation(rep)
    assert "delay 1 sample," in text
    assert "  delivered amplification: 26.216 –; design alpha 8" in text.splitlines()
    assert "  amplification error: 0.1 – (relative)" in text.splitlines()


def test_simulate_text_gives_the_tolerance_and_rates_their_unit():
    """The verdict's tolerance is in the growth rate's unit and the loop's growth rate in 1/s: the
    text says so (the JSON keeps them inside the quantity whose unit they share, or in the key)."""
    rep = {"scenario": "step", "description": "a step", "sample_rate_hz": 1000.0, "delay_samples": 1.0,
           "summary": {"start": "zero", "verdict": "decaying",
                       "envelope_growth_rate": {"value": -1.5, "unit": "1/s", "signal": "tau_c", "tolerance": 0.05},
                       "loop_spectral_radius": {"value": 0.998, "unit": "1", "growth_rate_per_s": -2.0, "note": "n"}}}
    lines = format_simulation(rep).splitlines()
    assert "  envelope growth rate: -1.5 1/s; measured on tau_c; tolerance 0.05 1/s" in lines
    assert "  loop spectral radius: 0.998 –; growth rate -2 1/s; note n" in lines


def test_margins_text_one_sample():
    lines = format_margins({"latency": {"extra_delay_s": 0.001, "delay_s": 0.001, "extra_delay_samples": 1.0}})
    assert lines[1].endswith("(1 sample)"), lines


def test_optimize_text_units():
    r = {"feasible": True, "evaluated": 12, "x": {"design.amplification": 26.216},
         "objective": {"name": "amplification", "value": 26.216, "unit": "1", "sense": "max"},
         "active_constraints": [], "latency_margin": {"achieved_s": 0.002, "required_s": 0.0,
                                                      "required_from": "none", "achieved_samples": 1.0},
         "metrics": {"dob_phase_margin_deg": {"value": 40.0, "unit": "deg"},
                     "human_stable_intervals": {"human0_mass_stable_intervals": [[0.001, 1.0]],
                                                "human1_spring_stable_intervals": []}}}
    lines = format_optimize(r).splitlines()
    assert lines[0].endswith("amplification = 26.216 – (maximized)"), lines
    assert "  human0_mass_stable_intervals: [0.001, 1] kg·m²" in lines
    assert "  human1_spring_stable_intervals: none" in lines
    assert any(ln.startswith("  latency margin (exact): 2 ms = 1 sample;") for ln in lines), lines
    bad = {"feasible": False, "evaluated": 3, "broken": ["robust"], "x": {"design.amplification": 30.0},
           "violations": [{"constraint": "robust", "family": "human0_mass", "parameter": "inertia", "unit": "kg·m²",
                           "range": [0.001, 1.0], "unstable": [[0.001, 0.05]]}]}
    assert ("  robust: human0_mass not stable over inertia ∈ [0.001, 1] kg·m², unstable for [0.001, 0.05] kg·m²"
            in format_optimize(bad).splitlines())
