"""What certify says when a family's members are all stable by their eigenvalues but some cells are
not proven (an independent ZOH reference found such designs stable everywhere, with a sampled
latency margin of 2.4 ms, while exotune printed "not stable at the file's delay: margin 0", "stable
only in [1, 10000]" for the whole range, and blamed a high sample rate at 500 Hz). The file stays
refused (nothing is proven there); the words now say why."""

from __future__ import annotations

from exotune.controllerfile.certify import sampled_problems
from exotune.text.certify import family_line


def _sa(**family) -> dict:
    h = {"kind": "spring", "parameter": "stiffness", "unit": "N·m/rad", "range": [1.0, 10000.0],
         "robust": False, "stable_intervals": [[1.0, 10000.0]], "unresolved": [[8015.81, 8040.13]],
         "unresolved_cells": 4, "refinement_budget": 75, "loop_states": 20, "budget_spent": True,
         "proofs_spent": True, "inconclusive": []}
    h.update(family)
    return {"free_stable": True, "locked_stable": True, "free_spectral_radius": 0.99,
            "locked_spectral_radius": 0.99, "humans": [h], "environment": []}


def test_unproven_cells_are_said_unproven_not_unstable():
    problems = sampled_problems(_sa())
    assert len(problems) == 1
    assert "not proven stable there, which is not a finding of instability" in problems[0]
    assert "stable only in" not in problems[0] and "high sample rate" not in problems[0]
    assert "NOT PROVEN robust" in family_line(_sa()["humans"][0])


def test_the_refinement_budget_is_still_named_when_it_is_the_cause():
    (p,) = sampled_problems(_sa(proofs_spent=False))
    assert "refinement budget of 75 values" in p


def test_a_family_not_robust_is_never_silent():
    """Not robust over a covered range with no unresolved or inconclusive value (cannot happen
    today): it is still a problem, so the file cannot certify by omission."""
    problems = sampled_problems(_sa(unresolved=[], unresolved_cells=0))
    assert problems and "stable only in [1, 10000]" in problems[0]
    assert "NOT robust" in family_line(_sa(unresolved=[])["humans"][0])
    problems = sampled_problems(_sa(stable_intervals=[[1.0, 5000.0]]))
    assert any("stable only in [1, 5000]" in p for p in problems)


def test_no_instability_up_to_the_probes_meets_only_requirements_within_them():
    """No probe unstable up to 200 samples of total delay (margin None) met any requirement, so a
    requirement of 0.5 s at 1 kHz (200 samples = 0.2 s) passed unchecked. It is now a problem
    beyond the probed delays and met within them."""
    from exotune.controllerfile.latency import requirement_problems

    lm = {"extra_delay_s": None, "extra_delay_samples": None, "checked_up_to_s": 0.199}
    (p,) = requirement_problems({**lm, "required_s": 0.5})
    assert "not verified up to the required 500 ms" in p and "199 ms" in p
    assert requirement_problems({**lm, "required_s": 0.1}) == []
    assert requirement_problems({"extra_delay_s": 0.002, "extra_delay_samples": 2.0, "required_s": 0.003})
    assert requirement_problems({"extra_delay_s": 0.004, "extra_delay_samples": 4.0, "required_s": 0.003}) == []
