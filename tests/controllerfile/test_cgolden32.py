"""exotune.controllerfile.cgolden32: the golden table of the float32 C port. Its controllers are
the file's realizations (nominal then each entry); every row's tolerance is zero; the table is
reproducible from its seed; inputs below the flush threshold give exactly zero; the file's own
golden vectors appear as a run of rows; every input-fault row has a non-finite or out-of-float
input; the program text holds every row's expected output."""

from __future__ import annotations

import math

import numpy as np

from exotune.controllerfile.cgolden import OK
from exotune.controllerfile.cgolden32 import TINY_INPUTS, controllers32, golden_program32, golden_rows32
from exotune.controllerfile.cstep import RETURN_CODES
from exotune.controllerfile.precision import INPUT_LIMIT32

FAULT_INPUT = dict((n, v) for n, v, _ in RETURN_CODES)["EXOTUNE_FAULT_INPUT"]


def test_controllers_are_the_realizations(scheduled_doc32):
    ctrls = controllers32(scheduled_doc32)
    entries = scheduled_doc32["gain_schedule"]["entries"]
    assert [a for _, a, _ in ctrls] == [None] + [float(e["joint_angle_rad"]) for e in entries]
    assert all(r is not None for _, _, r in ctrls)
    assert controllers32(scheduled_doc32.copy() | {"gain_schedule": None})[0][2] == ctrls[0][2]


def test_rows_have_no_tolerance_and_are_reproducible(scheduled_doc32):
    rows = golden_rows32(scheduled_doc32)
    assert len(rows) > 100 and all(r[5] == 0.0 for r in rows)
    assert golden_rows32(scheduled_doc32) == rows
    assert golden_rows32(scheduled_doc32, seed=1) != rows


def test_tiny_inputs_give_zero(scheduled_doc32):
    rows = golden_rows32(scheduled_doc32)
    tiny = [r for r in rows if r[0] == 1 and r[2] and all(abs(x) in {abs(t) for t in TINY_INPUTS} for x in r[2])]
    assert tiny and all(r[3] == OK and r[4] == 0.0 for r in tiny)


def test_the_files_golden_vector_is_a_run_of_rows(scheduled_doc32):
    outs = np.array([r[4] for r in golden_rows32(scheduled_doc32)])
    g = np.asarray(scheduled_doc32["golden"]["tau_cmd"]["values"])
    hits = [i for i in range(len(outs) - len(g) + 1)
            if np.allclose(outs[i:i + len(g)], g, rtol=1e-12, atol=0)]
    assert hits


def test_input_faults_have_bad_inputs(scheduled_doc32):
    faults = [r for r in golden_rows32(scheduled_doc32) if r[0] == 1 and r[3] == FAULT_INPUT]
    assert faults
    for r in faults:
        assert any(not math.isfinite(x) or abs(x) >= INPUT_LIMIT32 for x in r[2])


def test_the_program_holds_every_expected_output(scheduled_doc32):
    rows = golden_rows32(scheduled_doc32)
    text = golden_program32(scheduled_doc32, rows)
    assert text.isascii()
    for r in rows[:200]:
        if r[3] == OK and r[4] != 0.0:
            assert repr(float(np.float32(r[4]))).rstrip("0") in text or repr(r[4]) in text
