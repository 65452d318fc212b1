"""exotune.controllerfile.cstep: the pieces of the C step the generators share. C literals
round-trip to the same double; comment text is ASCII and cannot end a comment or string; the
controllers are the file's (nominal then each entry, each reproducing its golden vector); layouts
group controllers of the same structure; a section's state map (M, W) takes its direct-form-II
signal to its transposed state (checked against a simulation of the section)."""

from __future__ import annotations

import copy
import math

import numpy as np
import pytest
import scipy.signal
from hypothesis import given, settings
from hypothesis import strategies as st

from exotune.controllerfile.cstep import (FLUSH_BELOW, RETURN_CODES, SIGNALS, ascii_text, c_double, controllers_of,
                                          layouts_of, state_maps)
from exotune.controllerfile.runtime import SosFilter


@given(st.floats(allow_nan=False, allow_infinity=False))
def test_c_double_round_trips(x):
    s = c_double(x)
    assert float(s) == x and math.copysign(1.0, float(s)) == math.copysign(1.0, x)
    assert any(c in s for c in ".en")  # a double literal, never an int


@pytest.mark.parametrize("x", [math.nan, math.inf, -math.inf])
def test_c_double_refuses_non_finite(x):
    with pytest.raises(ValueError, match="not finite"):
        c_double(x)


@given(st.text())
def test_ascii_text_is_safe_in_c_comments_and_strings(s):
    """Whatever the text: printable ASCII only, and nothing that ends or opens a comment, ends a
    string, continues a line or forms a trigraph."""
    out = ascii_text(s)
    assert all(" " <= c <= "~" for c in out), out
    for bad in ("*/", "/*", "??", '"', "\\"):
        assert bad not in out


@given(st.text(alphabet="*/\\?\r\n\t\x00\x0b\x0c\u2028\"ab\u00df\u00b7\u00b2", max_size=40))
def test_ascii_text_is_safe_on_hostile_alphabets(s):
    out = ascii_text(s)
    assert all(" " <= c <= "~" for c in out)
    assert "*/" not in out and "/*" not in out and "??" not in out


@pytest.mark.parametrize("s", [
    "sched*\\\r#define EXOTUNE_BUMPLESS_DECAY 1.01\r/*.yaml",  # the review's injection: *\ became */
    "a*\\\n#define X 1\n/*", "x *\\/ y", "*/*/*/", "??/\nnext line", "a\x00b\x0bc\x0cd\te",
    "arm*\u00df.yaml", "\u2028#define X 1\u2029"])
def test_ascii_text_defeats_the_injections(s):
    out = ascii_text(s)
    assert all(" " <= c <= "~" for c in out)
    assert "*/" not in out and "/*" not in out and "??" not in out and "\\" not in out


def test_ascii_text_keeps_ascii_and_spells_out_units():
    assert ascii_text("tau_s [N m]") == "tau_s [N m]"
    assert ascii_text("N·m") == "N.m"
    assert ascii_text("kg·m²") == "kg.m^2"
    assert ascii_text("m³ −3 °C θ_m Ω ✓") == "m^3 -3 degC theta_m Omega ?"
    assert ascii_text('say "x"') == "say 'x'"


def test_return_codes_are_distinct_and_documented():
    names = [n for n, _, _ in RETURN_CODES]
    values = [v for _, v, _ in RETURN_CODES]
    assert names[0] == "EXOTUNE_OK" and values[0] == 0
    assert len(set(names)) == len(names) and values == list(range(len(values)))
    assert all(what for _, _, what in RETURN_CODES)
    assert SIGNALS == ("theta_m", "omega_m", "tau_s", "dtau_s", "tau_c") and FLUSH_BELOW == 1e-100


def test_controllers_are_the_nominal_then_the_entries(scheduled_doc):
    ctrls = controllers_of(scheduled_doc)
    entries = scheduled_doc["gain_schedule"]["entries"]
    assert len(ctrls) == 1 + len(entries)
    assert ctrls[0][:2] == ("nominal", None)
    assert [a for _, a, _ in ctrls[1:]] == [float(e["joint_angle_rad"]) for e in entries]
    ins = {s: np.asarray(v["values"], float) for s, v in scheduled_doc["golden"]["inputs"].items()}
    refs = [scheduled_doc["golden"]["tau_cmd"]["values"]] + [e["golden_tau_cmd"]["values"] for e in entries]
    for (_label, _a, rt), ref in zip(ctrls, refs):
        np.testing.assert_allclose(rt.run(ins), ref, rtol=1e-12, atol=0)


def test_layouts_group_controllers_of_the_same_structure(scheduled_doc):
    ctrls = controllers_of(scheduled_doc)
    assert layouts_of(ctrls) == [0] * len(ctrls)  # the entries only change numbers
    doc = copy.deepcopy(scheduled_doc)
    e = doc["gain_schedule"]["entries"][1]["controller"]
    e["filters"][0]["sos"] = e["filters"][0]["sos"][:1]  # one section fewer
    assert layouts_of(controllers_of(doc)) == [0, 0, 1] + [0] * (len(ctrls) - 3)


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_state_map_takes_the_df2_signal_to_the_state(seed):
    rng = np.random.default_rng(seed)
    r, th = rng.uniform(0.2, 0.95), rng.uniform(0.1, 3.0)
    b0, b1, b2 = rng.normal(size=3)
    a1, a2 = -2 * r * math.cos(th), r * r
    m = state_maps((b0, b1, b2, a1, a2))
    M, W = np.reshape(m[:4], (2, 2)), np.reshape(m[4:], (2, 2))
    np.testing.assert_allclose(W @ M, np.eye(2), atol=1e-8)
    x = rng.normal(size=20)
    w = scipy.signal.lfilter([1.0], [1.0, a1, a2], x)  # the signal the denominator filters
    f = SosFilter([[b0, b1, b2, 1.0, a1, a2]])
    for k in range(len(x)):
        f.step(x[k])
        if k >= 1:
            np.testing.assert_allclose(f.z[0], M @ [w[k], w[k - 1]], rtol=1e-9, atol=1e-9 * np.max(np.abs(w)))


def test_state_map_of_a_cancelling_section_is_zero():
    m = state_maps((1.0, -0.5, 0.0, -0.5, 0.0))  # numerator root = denominator root
    assert m[4:] == (0.0, 0.0, 0.0, 0.0)
