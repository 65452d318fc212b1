"""certify at a high rate (issue 23, item 5): the template (``exotune init``'s design.yaml) at
20 kHz with its 1 ms delay — a 20-sample delay line, loops of 35–37 states, 75–79 at the latency
margin's confirming check — certifies with the verdicts, intervals and margin it had before the
latency probes were decided on the spectral radius alone (values recorded from certify before that
change: margin 2.10138358 ms = 42.03 samples, critical member the lightest relaxed arm).

Functional, not timed (docs/benchmarks.md and benchmarks/highrate.py time it)."""

from __future__ import annotations

import numpy as np
import pytest

import exotune
from exotune.controllerfile import load_controller
from exotune.controllerfile.fileio import discrete_from_file, plant_from_file
from exotune.controllerfile.certify import position_feedback
from exotune.sampled import closed_loop_matrix, loop_verdict, plant_ss
from exotune.sampled.loop import spectral_verdict
from exotune.starter import template_text

FS = 20000.0
MARGIN_S = 0.002101383580046222  # certify's sampled-data margin of this file before the change


@pytest.fixture(scope="module")
def path(tmp_path_factory):
    d = tmp_path_factory.mktemp("highrate")
    design = d / "design.yaml"
    text = template_text("design.yaml")
    assert "sample_rate_hz: 1000.0" in text and "delay_s: 0.001 " in text
    design.write_text(text.replace("sample_rate_hz: 1000.0", f"sample_rate_hz: {FS:g}"))
    out = d / "c.yaml"
    exotune.export(design, FS, out)
    return out


def test_twenty_khz_template_certifies_as_before(path):
    rep = exotune.certify(path).to_dict()
    assert rep["certified"] and rep["problems"] == []
    sa = rep["sampled"]
    assert sa["free_stable"] is True and sa["locked_stable"] is True
    fams = [h for h in sa["humans"] if "skipped" not in h]
    assert [(h["kind"], h["parameter"]) for h in fams] == [("mass", "inertia"), ("spring", "stiffness")]
    for h in fams:
        assert h["robust"] and h["stable_intervals"] == [h["range"]] and not h["unresolved"]
        assert not h["inconclusive"] and not h["budget_spent"]
        assert h["loop_states"] in (35, 36, 37)
    lm = rep["latency_margin"]
    assert lm["confirmed"] is True
    assert lm["extra_delay_s"] == pytest.approx(MARGIN_S, rel=1e-3)
    assert lm["critical"] == {"loop": "human0_mass", "parameter": "inertia", "value": 0.01, "unit": "kg·m²"}


@pytest.mark.parametrize("human, env", [(None, "free"), (None, "locked"), ({"inertia": 0.01, "damping": 0.0}, "free"),
                                        ({"stiffness": 1.0, "damping": 0.0}, "free")])
@pytest.mark.parametrize("extra_s", [0.0, 0.0021])
def test_loop_verdict_is_the_spectral_verdict_of_its_loop_matrix(path, human, env, extra_s):
    """loop_verdict reuses its loop's eigenvalues: the same verdict and radius as spectral_verdict
    on closed_loop_matrix, at the file's delay and near its margin; its rounding estimate (which
    adds the zero-order hold's, expm_rounding) stays of the order of spectral_verdict's at 20 kHz."""
    from dataclasses import replace

    doc = load_controller(path)
    plant = plant_from_file(doc)
    ctrl = discrete_from_file(doc)
    ctrl = replace(ctrl, delay_s=ctrl.delay_s + extra_s)
    grounded = position_feedback(doc["controller"])
    A, B, C = plant_ss(plant, human, env)
    M = closed_loop_matrix(A, B, C, ctrl)
    ungrounded = not (grounded or env == "locked" or (human or {}).get("stiffness", 0.0) > 0)
    lam = np.linalg.eigvals(M)
    rigid = 1e-7 if ungrounded and np.min(np.abs(lam - 1.0)) <= 1e-7 else None
    got, want = loop_verdict(plant, ctrl, grounded, human, env), spectral_verdict(M, rigid_tol=rigid)
    assert got[0] == want[0]
    if ungrounded:
        # loop_verdict deflates the rigid-body mode by its eigenvector (docs/method.md#sampled-data):
        # its radius is the other eigenvalues', not those of the full matrix's solve, which the
        # rigid eigenvalue next to them moves by up to ~1e-9 (relative) at 20 kHz
        assert got[1] == pytest.approx(want[1], rel=1e-8)
    else:
        assert got[1] == want[1]
    assert want[2] / 20.0 <= got[2] <= 20.0 * want[2]


@pytest.mark.parametrize("extra_samples", [0.0, 41.9, 42.1, 43.0])
def test_a_radius_of_one_or_more_is_never_a_stable_verdict(path, extra_samples):
    """What the latency margin's probes rely on: loop_stable's radius is the largest modulus of
    loop_eigenvalues, and a radius ≥ 1 is never stable (around this file's margin of 42.03 samples)."""
    from dataclasses import replace

    from exotune.sampled import loop_eigenvalues, loop_stable

    doc = load_controller(path)
    plant, ctrl = plant_from_file(doc), discrete_from_file(doc)
    ctrl = replace(ctrl, delay_s=ctrl.delay_s + extra_samples / FS)
    grounded = position_feedback(doc["controller"])
    seen = set()
    for human, env in [(None, "free"), (None, "locked")] + [({"inertia": v, "damping": 0.0}, "free")
                                                            for v in (0.01, 0.0103, 0.1, 1.0)]:
        stable, rho = loop_stable(plant, ctrl, grounded, human, env)
        lam = loop_eigenvalues(plant, ctrl, grounded, human, env)
        assert rho == float(np.max(np.abs(lam)))
        assert not (rho >= 1.0 and stable)
        seen.add(rho >= 1.0)
    if extra_samples >= 42.1:
        assert True in seen  # the lightest arm is unstable past the margin
