"""exotune.controllerfile.runtime: the reference runtime of a controller file. A filter
(:class:`SosFilter`) is ``scipy.signal.sosfilt`` of its sections; the runtime's command is the
closed form of the file (static gains + filters, the DOB's algebraic loop solved) computed here
with ``scipy.signal.lfilter``; a clamp limits the command the DOB sees; non-finite inputs and
overflows are refused with the state unchanged; the gain schedule picks the nearest entry."""

from __future__ import annotations

import copy
import math
import re

import numpy as np
import pytest
import scipy.signal
from hypothesis import given, settings
from hypothesis import strategies as st

from exotune.controllerfile.runtime import Runtime, SosFilter, loop_feedthrough

SIGNALS = ("theta_m", "omega_m", "tau_s", "dtau_s", "tau_c")


def _inputs(n=60, seed=0):
    rng = np.random.default_rng(seed)
    scale = {"theta_m": 0.1, "omega_m": 1.0, "tau_s": 5.0, "dtau_s": 100.0, "tau_c": 2.0}
    return {s: scale[s] * rng.normal(size=n) for s in SIGNALS}


def _reference(doc, ins):
    """τ_cmd without DOB filters (no filter on tau_cmd): Σ gain·y + Σ lfilter(sections)(input)."""
    c = doc["controller"]
    out = np.zeros(len(ins["tau_c"]))
    for s, g in c["gains"].items():
        out += g["gain"] * ins[s]
    for f in c["filters"]:
        x = ins[f["input"]]
        for row in f["sos"]:
            x = scipy.signal.lfilter(row[:3], row[3:], x)
        out += x
    return out


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_sosfilter_is_sosfilt(seed):
    rng = np.random.default_rng(seed)
    sos = np.array([[*rng.normal(size=3), 1.0, -1.2, 0.5], [*rng.normal(size=3), 1.0, 0.3, 0.1]])
    f = SosFilter(sos)
    u = rng.normal(size=40)
    y = [f.step(x) for x in u]
    np.testing.assert_allclose(y, scipy.signal.sosfilt(sos, u), rtol=1e-10, atol=1e-12)
    assert f.feedthrough == pytest.approx(sos[0, 0] * sos[1, 0], rel=1e-15)


def test_peek_does_not_advance_and_save_restore_round_trip():
    f = SosFilter([[0.5, 0.2, 0.1, 1.0, -0.5, 0.06]])
    f.step(1.0)
    z = f.z.copy()
    p = f.peek(2.0)
    np.testing.assert_array_equal(f.z, z)
    saved = f.save()
    assert f.step(2.0) == p
    f.restore(saved)
    np.testing.assert_array_equal(f.z, z)
    f.reset()
    np.testing.assert_array_equal(f.z, np.zeros((1, 2)))
    assert loop_feedthrough([f, SosFilter([[0.25, 0, 0, 1, 0, 0]])]) == pytest.approx(0.75)


def test_runtime_without_dob_is_gains_plus_filters(scheduled_doc):
    doc = copy.deepcopy(scheduled_doc)
    doc["controller"]["filters"] = [f for f in doc["controller"]["filters"] if not f["name"].startswith("dob")]
    doc["gain_schedule"] = None
    ins = _inputs()
    out = Runtime(doc).run(ins)
    np.testing.assert_allclose(out, _reference(doc, ins), rtol=1e-9, atol=1e-9 * np.max(np.abs(out)))


def test_runtime_solves_the_dob_loop(scheduled_doc):
    """With the filter on τ_cmd: u = rest + Q(u) per sample, i.e. (1 − Q) u = rest, solved here by
    filtering ``rest`` through 1/(1 − Q) (lfilter of den/(den − num))."""
    doc = copy.deepcopy(scheduled_doc)
    loop = [f for f in doc["controller"]["filters"] if f["input"] == "tau_cmd"]
    assert len(loop) == 1
    others = copy.deepcopy(doc)
    others["controller"]["filters"] = [f for f in doc["controller"]["filters"] if f["input"] != "tau_cmd"]
    ins = _inputs(80, seed=3)
    rest = _reference(others, ins)
    b, a = np.array([1.0]), np.array([1.0])
    for row in loop[0]["sos"]:
        b, a = np.polymul(b, row[:3]), np.polymul(a, row[3:])
    expected = scipy.signal.lfilter(a, a - b, rest)
    out = Runtime(doc).run(ins)
    np.testing.assert_allclose(out, expected, rtol=1e-7, atol=1e-7 * np.max(np.abs(expected)))


def test_clamp_limits_the_command(scheduled_doc):
    ins = _inputs(60, seed=5)
    free = Runtime(scheduled_doc).run(ins)
    limit = 0.3 * float(np.max(np.abs(free)))
    clamped = Runtime(scheduled_doc, limit_nm=limit).run(ins)
    assert np.max(np.abs(clamped)) <= limit * (1 + 1e-15)
    assert np.any(np.isclose(np.abs(clamped), limit, rtol=1e-12))
    assert not np.allclose(clamped, np.clip(free, -limit, limit))  # the DOB saw the clamped command


@pytest.mark.parametrize("kw, word", [({"limit_nm": 0.0}, "limit_nm"), ({"limit_nm": math.inf}, "limit_nm"),
                                      ({"joint_angle_rad": math.nan}, "joint_angle_rad")])
def test_bad_arguments_are_refused(scheduled_doc, kw, word):
    with pytest.raises(ValueError, match=word):
        Runtime(scheduled_doc, **kw)


@pytest.mark.parametrize("bad", [math.nan, math.inf])
def test_non_finite_input_is_refused_with_state_unchanged(scheduled_doc, bad):
    rt = Runtime(scheduled_doc)
    ins = _inputs(10)
    rt.run(ins)
    before = [f.z.copy() for f in rt._all]
    y = {s: 0.1 for s in SIGNALS}
    y["tau_s"] = bad
    with pytest.raises(ValueError, match="non-finite input tau_s"):
        rt.step(y)
    for f, z in zip(rt._all, before):
        np.testing.assert_array_equal(f.z, z)


def test_overflow_is_refused_with_state_unchanged(scheduled_doc):
    rt = Runtime(scheduled_doc)
    rt.run(_inputs(10))
    before = [f.z.copy() for f in rt._all]
    with pytest.raises(ValueError, match="overflows") as e:
        rt.step({s: 1e307 for s in SIGNALS})
    assert re.search(r"τ_cmd = (−?∞|—) N·m", str(e.value)) and "np." not in str(e.value)  # a number with its unit
    for f, z in zip(rt._all, before):
        np.testing.assert_array_equal(f.z, z)


def test_singular_dob_loop_is_refused(scheduled_doc):
    doc = copy.deepcopy(scheduled_doc)
    for f in doc["controller"]["filters"]:
        if f["input"] == "tau_cmd":
            f["sos"] = [[1.0, 0.0, 0.0, 1.0, 0.0, 0.0]]
    with pytest.raises(ValueError, match="singular"):
        Runtime(doc)


def test_joint_angle_picks_the_nearest_schedule_entry(scheduled_doc):
    entries = scheduled_doc["gain_schedule"]["entries"]
    ins = _inputs(30, seed=9)
    outs = []
    for e in entries:
        got = Runtime(scheduled_doc, joint_angle_rad=float(e["joint_angle_rad"])).run(ins)
        entry_doc = copy.deepcopy(scheduled_doc)
        entry_doc["controller"] = e["controller"]
        entry_doc["gain_schedule"] = None
        np.testing.assert_allclose(got, Runtime(entry_doc).run(ins), rtol=1e-12, atol=1e-12)
        outs.append(got)
    assert not np.allclose(outs[0], outs[-1])  # the entries are different controllers


def test_golden_vectors_are_reproduced(scheduled_doc):
    g = scheduled_doc["golden"]
    ins = {s: np.asarray(v["values"], float) for s, v in g["inputs"].items()}
    np.testing.assert_allclose(Runtime(scheduled_doc).run(ins), g["tau_cmd"]["values"], rtol=1e-12, atol=1e-12)
