"""The golden test of the float32 C port (``exotune_golden_test.c`` of a float32 file): scenarios
run by the float32 reference (:class:`~exotune.controllerfile.precision.Float32Runtime`), every
output compared **exactly**.

Every controller of the file (nominal, then each gain-schedule entry) runs:

* no clamp: inputs below the flush threshold on every signal from the zero state (1e-31, float
  and double subnormals: the command must stay exactly 0, which it would not if an input were not
  flushed), the file's golden inputs (the vectors ``certify`` checks), every input fault from that
  non-zero state (NaN, +-infinity, 3.5e38 and -1e300, which are infinite in float, and
  ``EXOTUNE_INPUT_LIMIT`` itself: ``EXOTUNE_FAULT_INPUT``, state unchanged), random inputs of the
  golden inputs' sizes with values at the flush threshold among them, then on each signal the
  largest double below ``EXOTUNE_INPUT_LIMIT`` (FLT_MAX in float) and 3e38 (an overflow fault, or
  accepted where the controller does not amplify that signal);
* a clamp of half the largest unclamped command (a float32 value): random inputs, the input faults,
  more random inputs, the clamp engaging from a non-zero state;
* a switch to the next controller (``EXOTUNE_SWITCH_RESET``: its zero state, the same clamp),
  random inputs, a request of ``EXOTUNE_SWITCH_BUMPLESS`` (``EXOTUNE_ERR_ARGUMENT``, nothing
  changed: the next outputs continue), random inputs.

Then the schedule look-up and the argument checks of the float64 port, and limits outside float
(``EXOTUNE_ERR_ARGUMENT``).

**Tolerance: none.** The port performs the reference's float32 operations in its order; with
float arithmetic evaluated in float (``FLT_EVAL_METHOD`` 0), no contraction and rounding to
nearest (the port refuses to compile or to initialize otherwise) each operation is one correctly
rounded IEEE single operation on the same operands, so every state and output is the same float
(docs/deploying.md#precision). A coefficient changed by one float32 ulp makes the golden test fail
(tests/controllerfile/test_ccode32.py checks every coefficient).

References
----------
docs/deploying.md#golden-test; docs/controller-file.md#precision.
"""

from __future__ import annotations

import math

import numpy as np

from .cgolden import (OP_INIT, OP_STEP, OP_SWITCH, GoldenRow, fault_inputs, golden_program, lookup_rows)
from .cstep import SIGNALS
from .model import ControllerFile, Realization, as_controller_file
from .precision import INPUT_LIMIT32, Float32Runtime

__all__ = ["golden_rows32", "golden_program32", "controllers32", "TINY_INPUTS", "BIG_INPUTS"]

OK, FAULT_INPUT, FAULT_OVERFLOW, ERR_ARGUMENT = 0, 1, 2, 4
SWITCH_RESET, SWITCH_BUMPLESS = 0, 1
FLT_MAX = float(np.finfo(np.float32).max)
FLT_MIN = float(np.finfo(np.float32).tiny)
FLUSH_F = float(np.float32(1e-30))
# below the flush threshold once in float (a row per value, on every signal): the command stays 0
TINY_INPUTS = (1e-31, -9.9e-31, 1e-40, -1.4e-45, 1e-310, -5e-324)
# at the threshold (kept), the float just below it (flushed), just above
EDGE_INPUTS = (FLUSH_F, -FLUSH_F, float(np.nextafter(np.float32(FLUSH_F), np.float32(0))), 2e-30, -1e-29)
# infinite in float: an input fault (with NaN and +-infinity)
BEYOND_FLOAT = (3.5e38, -1e300, INPUT_LIMIT32)
# finite in float (the first: FLT_MAX once converted): accepted or an overflow fault
BIG_INPUTS = (float(np.nextafter(INPUT_LIMIT32, 0.0)), 3e38)

ABOUT32 = (" * Every controller of the float32 controller file through the float32 C port, against the float32",
           " * reference: inputs below the flush threshold, the file's golden inputs, every input fault from a",
           " * non-zero state, random inputs, inputs at the limits of float, a clamp that engages, a schedule",
           " * switch, the schedule look-up and the argument checks; every output EXACTLY the reference's",
           " * (tolerance 0). Exit 0 and 'OK': the build computes the certified float32 controller bit for bit.")


def controllers32(doc: ControllerFile | dict) -> list[tuple[str, float | None, Realization]]:
    """(label, joint angle [rad] or None, float32 realization): the nominal controller, then every
    gain-schedule entry (the C port's controller indices 0, 1, ...).

    Parameters
    ----------
    doc : dict
        The validated float32 controller file's mapping.

    Returns
    -------
    list of tuple
        ``(label, joint angle [rad] or None, realization)`` per controller.
    """
    cf = as_controller_file(doc)
    out = [("nominal", None, cf.controller.realization)]
    for e in cf.schedule_entries:
        out.append((f"joint angle {e.joint_angle_rad!r} rad", float(e.joint_angle_rad), e.controller.realization))
    return out


def _run32(rt: Float32Runtime, X) -> list[GoldenRow]:
    rows = []
    for x in X:
        vals = dict(zip(SIGNALS, (float(v) for v in x)))
        bad = not all(abs(v) < INPUT_LIMIT32 for v in vals.values())
        try:
            u = rt.step(vals)
        except ValueError:
            rows.append(GoldenRow(OP_STEP, 0, x, FAULT_INPUT if bad else FAULT_OVERFLOW))
            continue
        rows.append(GoldenRow(OP_STEP, 0, x, OK, u, 0.0))
    return rows


def _on_each(values) -> list[list[float]]:
    """Each value on each signal in turn (the others 0)."""
    return [[v if j == i else 0.0 for j in range(5)] for v in values for i in range(5)]


def _controller_rows(doc: ControllerFile, c: int, angles: list, G, rng, scale) -> list[GoldenRow]:
    """The three scenarios of controller ``c`` (the module docstring)."""
    n = len(angles)
    R1, R2, R3, R4, R5 = (rng.standard_normal((m, 5)) * scale for m in (40, 50, 30, 20, 20))
    R1[10:10 + len(EDGE_INPUTS)] = np.array(EDGE_INPUTS)[:, None] * np.ones(5)
    tiny = [[v] * 5 for v in TINY_INPUTS]
    faults = fault_inputs() + _on_each(BEYOND_FLOAT)
    rt = Float32Runtime(doc, joint_angle_rad=angles[c])
    rows = [GoldenRow(OP_INIT, c, [0.0] * 5, OK)]
    run = _run32(rt, [*tiny, *G, *faults, *R1, *_on_each(BIG_INPUTS)])
    rows += run
    limit = float(np.float32(0.5 * max(abs(r[4]) for r in run[:-10] if r[3] == OK)))
    rt = Float32Runtime(doc, limit_nm=limit, joint_angle_rad=angles[c])
    rows.append(GoldenRow(OP_INIT, c, [limit] + [0.0] * 4, OK))
    rows += _run32(rt, [*R2, *faults, *R3])
    c2 = (c + 1) % n
    rt = Float32Runtime(doc, limit_nm=limit, joint_angle_rad=angles[c2])
    rows.append(GoldenRow(OP_SWITCH, c2, [SWITCH_RESET] + [0.0] * 4, OK))
    rows += _run32(rt, R4)
    rows.append(GoldenRow(OP_SWITCH, c, [SWITCH_BUMPLESS] + [0.0] * 4, ERR_ARGUMENT))
    return rows + _run32(rt, R5)


def golden_rows32(doc: ControllerFile | dict, seed: int = 20250) -> list[GoldenRow]:
    """The golden table of a float32 controller file (the module docstring), rows as
    :func:`~exotune.controllerfile.cgolden.golden_rows`' with tolerance 0 (op 3: a switch).

    Parameters
    ----------
    doc : dict
        The validated float32 controller file's mapping.
    seed : int, optional
        Seed of the random inputs.

    Returns
    -------
    list of GoldenRow
        The table.
    """
    doc = as_controller_file(doc)
    ins = doc.golden.inputs
    G = np.array([ins[s] for s in SIGNALS], dtype=float).T
    scale = np.array([max(float(np.max(np.abs(G[:, i]))), 1e-3) for i in range(5)])
    rng = np.random.default_rng(seed)
    angles = [a for _l, a, _r in controllers32(doc)]
    rows: list[GoldenRow] = []
    for c in range(len(angles)):
        rows += _controller_rows(doc, c, angles, G, rng, scale)
    rows += lookup_rows(angles[1:])
    rows += [GoldenRow(OP_INIT, 0, [lim] + [0.0] * 4, ERR_ARGUMENT)
             for lim in (FLT_MAX * (1 + 2.0 ** -20), 1e300, FLT_MIN / 2, -FLT_MIN, math.nan)]
    return rows


def golden_program32(doc: ControllerFile | dict, rows: list[GoldenRow]) -> str:
    """``exotune_golden_test.c`` of the float32 port: the float64 port's program
    (:func:`~exotune.controllerfile.cgolden.golden_program`) on the float32 table, every tolerance 0.

    Parameters
    ----------
    doc : dict
        The controller file's mapping.
    rows : list of GoldenRow
        The float32 golden table (:func:`golden_rows32`).

    Returns
    -------
    str
        The C source.
    """
    return golden_program(doc, rows, ABOUT32)
