"""exotune.analysis.charfun: the multilinear characteristic terms Δ00, Δ10, Δ01, Δ11 and the
amplification quasi-polynomials, checked against the paper's system algebra (Table II,
exotune.model.plant.seven_systems composed from the implemented controller blocks) and against
identities of the plant model (a locked joint leaves the human only the cuff spring)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import exotune
from exotune.analysis.charfun import amplification_qps, char_terms, design_column, strip_qps, trim_poly
from exotune.model.controller import build_controller
from exotune.numerics.quasipoly import QP
from tests.paper_design import paper_design
from tests.system_algebra import implemented_systems

W = np.geomspace(0.1, 2e4, 300)


def _cfg(dob=False, **design):
    cfg = paper_design() if dob else paper_design(dob=None)
    return dataclasses.replace(cfg, design=dataclasses.replace(cfg.design, **design)) if design else cfg


def _at(qp: QP, w=W, row=0):
    v, _ = qp.eval(np.full(w.size, row), w, deriv=False)
    return v


def _systems(cfg):
    cs, _ = build_controller(cfg.plant, cfg.design, cfg.implementation)
    return cs, implemented_systems(cfg)


@pytest.mark.parametrize("design", [{}, {"amplification": 3.0, "zeta_hat": 0.5}, {"felt_inertia": 0.1}])
def test_operator_compliance_and_amplification_equal_the_papers_system_algebra(design):
    cfg = _cfg(**design)
    cs, S = _systems(cfg)
    ct = char_terms(cfg.plant, cs, 1)
    c7 = _at(ct.qp("10")) / _at(ct.qp("00"))
    np.testing.assert_allclose(c7, np.ravel(S["S7"].C(1j * W)), rtol=1e-8)
    num, den = amplification_qps(cfg.plant, cs, 1)
    ref = np.ravel(S["S6"].C(1j * W)) / np.ravel(S["S5"].C(1j * W))
    np.testing.assert_allclose(_at(num) / _at(den), ref, rtol=1e-8)


@pytest.mark.parametrize("dob", [False, True])
def test_locked_joint_terms_are_the_cuff_spring_and_the_locked_loop(dob):
    """Δ01 = K_c Δ11 (a locked joint leaves the human the cuff spring 1/K_c) and Δ01 = K_c × the
    amplification denominator (both are the output-locked loop)."""
    cfg = _cfg(dob=dob)
    cs, _ = build_controller(cfg.plant, cfg.design, cfg.implementation)
    ct = char_terms(cfg.plant, cs, 1)
    Kc = float(cfg.plant.K_c)
    d01, d11 = _at(ct.qp("01")), _at(ct.qp("11"))
    np.testing.assert_allclose(d01, Kc * d11, rtol=1e-10)
    _, den = amplification_qps(cfg.plant, cs, 1)
    np.testing.assert_allclose(d01, Kc * _at(den), rtol=1e-10)


def test_a_dob_model_equal_to_the_plant_is_the_default_path():
    cfg = _cfg(dob=True)
    assert cfg.implementation.dob is not None
    cs, _ = build_controller(cfg.plant, cfg.design, cfg.implementation)
    a = char_terms(cfg.plant, cs, 1)
    b = char_terms(cfg.plant, cs, 1, dob_model=(float(cfg.plant.J_m), float(cfg.plant.B_m)))
    for k in ("00", "10", "01", "11"):
        np.testing.assert_allclose(_at(b.qp(k)), _at(a.qp(k)), rtol=1e-9)
    c = char_terms(cfg.plant, cs, 1, dob_model=(2.0 * float(cfg.plant.J_m), float(cfg.plant.B_m)))
    assert not np.allclose(_at(c.qp("00")), _at(a.qp("00")), rtol=1e-6)
    np.testing.assert_allclose(c.qp("00").p0, a.qp("00").p0, rtol=1e-12)  # P0 does not hold the DOB model


def test_batched_terms_equal_the_single_design_terms():
    cfg = _cfg()
    cs, _ = build_controller(cfg.plant, cfg.design, cfg.implementation)
    Ks = float(cfg.plant.K_s) * np.array([0.5, 1.0, 2.0])
    plants = [dataclasses.replace(cfg.plant, sea_stiffness=k) for k in Ks]
    batch = char_terms(dataclasses.replace(cfg.plant, sea_stiffness=Ks), cs, 3)
    for i, p in enumerate(plants):
        one = char_terms(p, cs, 1)
        for k in ("00", "10"):
            np.testing.assert_allclose(_at(batch.qp(k), row=i), _at(one.qp(k)), rtol=1e-10)


def test_stacked_terms_are_the_parts_rows_in_order_with_their_polynomials_unchanged():
    from exotune.analysis.charfun import CharTerms

    cfg = _cfg()
    parts = []
    for dob, k in ((False, 1.0), (True, 2.0), (False, 0.5)):  # with and without the DOB: other widths
        c = _cfg(dob=dob)
        cs, _ = build_controller(c.plant, c.design, c.implementation)
        parts.append(char_terms(dataclasses.replace(c.plant, sea_stiffness=float(cfg.plant.K_s) * k), cs, 1))
    widths = {p.qp("00").p0.shape[1] for p in parts}
    assert len(widths) > 1  # the padding is exercised
    st_ = CharTerms.stack(parts)
    assert st_.T.shape == (3,)
    for i, one in enumerate(parts):
        assert st_.T[i] == one.T[0]
        for k in one.terms:
            np.testing.assert_array_equal(st_.qp(k).T[i], one.qp(k).T[0])
            np.testing.assert_array_equal(_at(st_.qp(k), row=i), _at(one.qp(k)))  # zeros appended: same values


def test_the_combined_term_is_the_affine_sum():
    cfg = _cfg()
    cs, _ = build_controller(cfg.plant, cfg.design, cfg.implementation)
    ct = char_terms(cfg.plant, cs, 1)
    z = np.array([[30.0, 2.0, 0.05]])  # k + b s + m s²
    q, B = ct.combine("00", "10", z)
    zs = 30.0 + 2.0 * (1j * W) + 0.05 * (1j * W) ** 2
    np.testing.assert_allclose(_at(q), _at(ct.qp("00")) + zs * _at(ct.qp("10")), rtol=1e-10)
    assert B is ct.qp("10")


def test_trim_poly_and_design_column():
    c = np.array([[1.0, 2.0, 0.0, 0.0], [3.0, 0.0, 0.0, 0.0]])
    np.testing.assert_array_equal(trim_poly(c), c[:, :2])
    assert trim_poly(np.zeros((2, 3))).shape == (2, 1)
    col = design_column(2.5, 3)
    np.testing.assert_array_equal(col, [2.5, 2.5, 2.5])
    x = np.array([1.0, 2.0])
    y = design_column(x, 2)
    y[0] = 9.0
    assert x[0] == 1.0  # a copy


@settings(max_examples=30, deadline=None)
@given(r=st.integers(0, 3), a=st.floats(0.1, 10.0), b=st.floats(-5.0, 5.0), T=st.floats(0.0, 0.01))
def test_strip_qps_divides_out_exactly_the_common_zero_roots(r, a, b, T):
    p0 = np.concatenate([np.zeros(r), [a, 1.0]])[None, :]
    p1 = np.concatenate([np.zeros(r + 1), [b]])[None, :]
    n, (q,) = strip_qps(QP(p0, p1, T))
    assert int(n[0]) == r
    np.testing.assert_array_equal(q.p0, [[a, 1.0]])
    s = 1j * np.array([0.3, 2.0, 7.0])
    full = _at(QP(p0, p1, T), w=s.imag)
    np.testing.assert_allclose(_at(q, w=s.imag) * s**r, full, rtol=1e-12)


@pytest.mark.parametrize("dob_model", [False, True])
def test_a_subset_of_keys_and_precomputed_controller_polynomials_change_nothing(dob_model):
    """``keys`` builds only the terms asked for and ``controller`` reuses controller_polys: the
    coefficients are bit for bit those of the full call (the plant-uncertainty margin relies on it)."""
    from exotune.analysis.charfun import KEYS, controller_polys
    from exotune.model.plant import Plant

    cfg = exotune.load_design("examples/scheduled.yaml")
    cs = build_controller(cfg.plant, cfg.design, cfg.implementation)[0]
    plants = Plant(np.array([0.44, 0.3, 0.6]), np.array([17.9, 10.0, 25.0]), np.array([1180.0, 900.0, 1500.0]),
                   np.array([0.29, 0.2, 0.4]), np.array([300.0, 200.0, 400.0]))
    kw = {"dob_model": (0.4, 15.0)} if dob_model else {}
    full = char_terms(plants, cs, 3, **kw)
    assert KEYS == ("00", "10", "01", "11")
    for keys in (("00",), ("00", "10"), ("01",), ("11", "01")):
        part = char_terms(plants, cs, 3, keys=keys, controller=controller_polys(cs, 3), **kw)
        assert set(part.terms) == set(keys)
        for key in keys:
            assert np.array_equal(part.qp(key).p0, full.qp(key).p0)
            assert np.array_equal(part.qp(key).p1, full.qp(key).p1)
