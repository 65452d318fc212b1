"""Plant-uncertainty margin (exotune.analysis.plant_margin): the DOB-model extension of char_terms,
the certified lower bound against dense sampling of the plant box by exact counts, and the witness
of the upper bound against independent root finders (Newton on the exact Δ, python-control
eigenvalues of a Padé model)."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

import exotune
from reference_model import free_loop_eigs_mismatched_dob
from exotune.analysis.charfun import char_terms
from exotune.analysis.crosscheck import exact_rhp_roots, pade_stable
from exotune.analysis.plant_margin import loop_counts_at, plant_loops, plant_uncertainty_margin
from exotune.analysis.plant_margin_box import LoopModel, hull_distance, strip_rows
from exotune.model.controller import build_controller
from exotune.model.plant import Plant

SCHEDULED = "examples/scheduled.yaml"


@pytest.fixture(scope="module")
def sched():
    cfg = exotune.load_design(SCHEDULED)
    return cfg, plant_uncertainty_margin(cfg)


def _cs(cfg):
    return build_controller(cfg.plant, cfg.design, cfg.implementation)[0]


# ---------------------------------------------------------------------------------------------
# char_terms(dob_model=…)
# ---------------------------------------------------------------------------------------------
def test_char_terms_dob_model_nominal_equals_default():
    cfg = exotune.load_design(SCHEDULED)
    cs = _cs(cfg)
    p = cfg.plant
    plants = Plant(np.array([0.44, 0.3, 0.6]), np.array([17.9, 10.0, 25.0]), np.array([1180.0, 900.0, 1500.0]),
                   np.array([0.29, 0.2, 0.4]), np.array([300.0, 200.0, 400.0]))
    for plant, N in ((p, 1), (plants, 3)):
        a = char_terms(plant, cs, N)
        b = char_terms(plant, cs, N, dob_model=(plant.J_m, plant.B_m))
        again = char_terms(plant, cs, N)
        for key in ("00", "10", "01", "11"):
            qa, qb, qc = a.qp(key), b.qp(key), again.qp(key)
            assert np.array_equal(qa.p0, qc.p0) and np.array_equal(qa.p1, qc.p1)  # default path deterministic
            assert np.array_equal(qa.p0, qb.p0)  # P0 does not involve the DOB model
            assert qa.p1.shape == qb.p1.shape
            scale = np.max(np.abs(qa.p1), axis=1, keepdims=True)
            assert np.max(np.abs(qa.p1 - qb.p1) / scale) < 1e-13, key


def test_det_identity_symbolic():
    """det = M·N_θm − N_τs for every key of the multilinear expansion (the formulas of char_terms)."""
    sp = pytest.importorskip("sympy")
    s, Jm, Bm, Ks, Jj, Kc = sp.symbols("s J_m B_m K_s J_j K_c")
    A = Jm * s**2 + Bm * s + Ks
    M = Jm * s**2 + Bm * s
    X0 = M * (Jj * s**2 + Ks) + Ks * Jj * s**2
    det = {"00": Kc * X0, "10": X0 + Kc * A, "01": Kc * A, "11": A}
    Nth = {"00": Kc * (Jj * s**2 + Ks), "10": Jj * s**2 + Ks + Kc, "01": Kc, "11": sp.Integer(1)}
    Nts = {"00": -Ks * Kc * Jj * s**2, "10": -Ks * (Jj * s**2 + Kc), "01": -Ks * Kc, "11": -Ks}
    for key in det:
        assert sp.expand(det[key] - (M * Nth[key] - Nts[key])) == 0, key
    # and the plant itself: θ_m, τ_s responses to τ_m of the grounded plant with cuff and human z
    z, ze = sp.symbols("z z_e")
    th_m, th_j, th_h = sp.symbols("theta_m theta_j theta_h")
    tau = sp.Symbol("tau_m")
    tau_s = Ks * (th_j - th_m)
    tau_c = Kc * (th_h - th_j)
    eqs = [M * th_m - tau_s - tau, Jj * s**2 * th_j + ze * th_j - tau_c + tau_s, z * th_h + tau_c]
    sol = sp.solve(eqs, [th_m, th_j, th_h], dict=True)[0]
    full_det = sum(det[k] * {"00": 1, "10": z, "01": ze, "11": z * ze}[k] for k in det)
    full_nth = sum(Nth[k] * {"00": 1, "10": z, "01": ze, "11": z * ze}[k] for k in det)
    assert sp.simplify(sol[th_m] / tau - full_nth / full_det) == 0


def _free_loop_eigs(q, cs, dob_model, order=10):
    """Closed-loop eigenvalues of the free exoskeleton (tests/reference_model.py,
    :func:`free_loop_eigs_mismatched_dob`) without the rigid-body root."""
    ev = free_loop_eigs_mismatched_dob(q, cs, dob_model, order)
    return ev[np.abs(ev) > 1e-6]  # the rigid-body root of the free exoskeleton


def test_dob_mismatch_against_python_control():
    """The DOB-mismatch characteristic function gives the verdicts and roots of an independent
    block-diagram model of the DOB (python-control, Padé delay)."""
    pytest.importorskip("control")
    cfg = exotune.load_design(SCHEDULED)
    cs = _cs(cfg)
    model = LoopModel(cs, cfg.plant, None, "00", None)
    rng = np.random.default_rng(3)
    deltas = np.r_[rng.uniform(-0.7, 0.7, (6, 5)), -0.8 * np.ones((1, 5)), [[0.6, -0.5, 0.3, -0.7, 0.2]]]
    for d in deltas:
        q = model.q0 * (1.0 + d)
        ev = _free_loop_eigs(q, cs, (model.q0[0], model.q0[1]))
        N, r, ok = model.counts(q[None, :], None)
        assert ok[0] and r[0] == 1
        assert (N[0] == 0) == (np.max(ev.real) < 0), d
        # the rightmost root of the exact Δ (Newton) matches an eigenvalue of the Padé model
        P0, P1 = model.coeffs(q[None, :], None)
        _, P0s, P1s = strip_rows(P0, P1)
        if N[0] > 0:
            z = exact_rhp_roots(P0s[0], P1s[0], model.T)[0]
            assert np.min(np.abs(ev - z)) < 1e-3 * abs(z)


def test_hull_distance_is_a_lower_bound():
    rng = np.random.default_rng(1)
    V = (rng.normal(size=(150, 32)) + 1j * rng.normal(size=(150, 32))) * 0.3
    V += rng.normal(size=(150, 1)) + 1j * rng.normal(size=(150, 1))
    th = np.linspace(0, 2 * np.pi, 4001)
    ref = np.array([np.max(np.min(np.real(V[i][:, None] * np.exp(-1j * th)[None, :]), axis=0)) for i in range(150)])
    _, d = hull_distance(V)
    assert np.all(d <= ref + 1e-3)  # the grid reference is itself slightly below the true distance
    assert np.all((d > 0) == (ref > 0))


# ---------------------------------------------------------------------------------------------
# the margin of the shipped example
# ---------------------------------------------------------------------------------------------
def test_scheduled_bounds_and_gap(sched):
    cfg, m = sched
    assert 0 < m.lower <= m.upper
    assert m.ratio <= 1.02
    assert "transmission" in m.note
    assert [lp.loop for lp in m.loops] == [n for n, *_ in plant_loops(cfg)]
    d = m.to_dict()
    assert d["witness"]["plant"]["motor_inertia"]["unit"] == "kg·m²"
    assert d["units"]["lower"].startswith("1")
    assert "≤ k* ≤" in repr(m)


def test_witness_is_unstable_by_independent_root_finders(sched):
    cfg, m = sched
    w = m.witness
    assert w is not None and w.confirmed and w.k == m.upper
    assert all(abs(v) <= w.k * (1 + 1e-12) for v in w.deviations.values())
    loop = {n: (f, k0, k1) for n, f, k0, k1 in plant_loops(cfg)}[w.loop]
    model = LoopModel(_cs(cfg), cfg.plant, *loop)
    q = np.array([w.plant[f] for f in ("motor_inertia", "motor_damping", "sea_stiffness", "joint_inertia",
                                       "cuff_stiffness")])
    P0, P1 = model.coeffs(q[None, :], None if w.value is None else np.array([w.value]))
    _, P0s, P1s = strip_rows(P0, P1)
    roots = exact_rhp_roots(P0s[0], P1s[0], model.T)
    if model.complex:
        roots = roots[roots.imag > 0]
    assert roots.size and roots[0].real > 0
    assert abs(roots[0] - w.rightmost_root) <= 1e-6 * abs(roots[0])
    if not model.complex:
        stable, right = pade_stable(P0s[0], P1s[0], model.T, 16, allowed_rigid=0)
        assert not stable and right.real > 0


def test_lower_bound_never_above_sampling(sched):
    """Every plant of the box at k_lo(1 − ε) — its vertices and a dense random sample — is robust
    for every loop (exact argument-principle counts over each family's member grid)."""
    cfg, m = sched
    k = m.lower * (1 - 1e-6)
    cs = _cs(cfg)
    rng = np.random.default_rng(7)
    verts = np.array(list(itertools.product((-k, k), repeat=5)))
    rand = rng.uniform(-k, k, (300, 5))
    for name, fam, k0, k1 in plant_loops(cfg):
        model = LoopModel(cs, cfg.plant, fam, k0, k1)
        members = None
        if fam is not None:
            members = np.unique(np.r_[fam.lo, fam.hi, np.geomspace(fam.lo, fam.hi, 24), rng.uniform(fam.lo, fam.hi, 8)])
        _, r, _ = model.counts(model.q0[None, :], None if fam is None else np.array([fam.lo, fam.hi]))
        bad = loop_counts_at(model, np.r_[verts, rand], members, int(np.min(r)))
        assert not bad.any(), name


def test_not_robust_at_nominal_gives_zero():
    cfg = exotune.load_design("examples/paper.yaml")
    m = plant_uncertainty_margin(cfg, families=["free", "human0_mass"])
    assert m.lower == 0.0 and m.upper == 0.0
    assert "not robust at the nominal plant" in m.note
    assert m.witness is not None and m.witness.loop == "human0_mass" and m.witness.confirmed
    free = m.loops[0]
    assert free.loop == "free" and 0 < free.lower <= free.upper <= 1.02 * free.lower


def test_parameters_that_cannot_matter():
    """The free and locked loops are proportional to K_c (the cuff spring carries no torque when
    the cuff is free; it is a common factor of every term when the joint is locked): with only K_c
    uncertain the margin is the admissible limit, certified, with no witness."""
    cfg = exotune.load_design(SCHEDULED)
    m = plant_uncertainty_margin(cfg, {"K_c": 1.0, "J_m": 0.0, "B_m": 0.0, "K_s": 0.0, "J_j": 0.0},
                                 families=["free", "env0_locked"])
    assert m.upper == math.inf and m.witness is None
    assert m.lower == pytest.approx(0.999)


def test_single_parameter_against_a_one_dimensional_scan():
    """Only J_m uncertain, free loop: the bounds enclose the boundary found by a dense 1-D scan
    of exact counts."""
    cfg = exotune.load_design(SCHEDULED)
    m = plant_uncertainty_margin(cfg, {"J_m": 1.0, "B_m": 0.0, "K_s": 0.0, "J_j": 0.0, "K_c": 0.0},
                                 families=["free"])
    model = LoopModel(_cs(cfg), cfg.plant, None, "00", None)
    delta = np.linspace(-0.999, 0.999, 1999)
    D = np.zeros((delta.size, 5))
    D[:, 0] = delta
    bad = loop_counts_at(model, D, None, 1)
    if bad.any():
        k_scan = float(np.min(np.abs(delta[bad])))
        assert m.lower <= k_scan <= m.upper + 1e-3
        assert m.upper / m.lower <= 1.02
    else:
        assert m.upper == math.inf


def test_hysteretic_witness_has_an_upper_half_plane_root():
    """For the complex-stiffness family the factor 1 + jη holds for Im s > 0: its witness is
    confirmed by a root there, and the exact count flips across the bound."""
    cfg = exotune.load_design(SCHEDULED)
    m = plant_uncertainty_margin(cfg, families=["human2_complex_stiffness"])
    w = m.witness
    assert m.ratio <= 1.02 and w.confirmed
    assert w.rightmost_root.real > 0 and w.rightmost_root.imag > 0
    fam, k0, k1 = {n: (f, a, b) for n, f, a, b in plant_loops(cfg)}[w.loop]
    model = LoopModel(_cs(cfg), cfg.plant, fam, k0, k1)
    d = np.array(list(w.deviations.values()))
    assert loop_counts_at(model, d[None, :], np.array([w.value]), 0).all()
    assert not loop_counts_at(model, (d * m.lower / w.k * (1 - 1e-6))[None, :], np.array([w.value]), 0).any()


def _random_design(seed):
    import copy

    from exotune.analysis.batch import analyze_batch
    from exotune.config import design_from_mapping

    base = exotune.load_design(SCHEDULED).raw
    rng = np.random.default_rng(seed)
    while True:
        m = copy.deepcopy(base)
        m.pop("transmission", None)
        m["design"].update(amplification=float(rng.uniform(2, 10)), felt_inertia=float(rng.uniform(0.1, 0.5)),
                           felt_damping=float(rng.uniform(0.5, 3)))
        m["implementation"]["delay_s"] = float(rng.uniform(2e-4, 1.5e-3))
        m["implementation"]["dob"] = {"cutoff_hz": float(rng.uniform(20, 80)), "damping": 0.7}
        m["humans"] = m["humans"][:2]
        m["environment"] = [{"kind": "locked"}, {"kind": "spring", "stiffness": [10.0, 5000.0], "damping": 1.0}]
        cfg = design_from_mapping(m)
        cols = analyze_batch(cfg).to_columns()
        keys = [k for k in cols if k == "free_stable"
                or (k.startswith(("human", "env")) and k.endswith(("_robust", "_stable")))]
        if all(bool(cols[k][0]) for k in keys):
            return cfg


@pytest.mark.parametrize("seed", [11])
def test_random_design_bounds_against_sampling(seed):
    cfg = _random_design(seed)
    weights = {"J_m": 0.5, "B_m": 1.0, "K_s": 0.3, "J_j": 1.0, "K_c": 0.8}
    m = plant_uncertainty_margin(cfg, weights)
    assert 0 < m.lower <= m.upper and m.ratio <= 1.10
    assert m.witness is not None and m.witness.confirmed
    k = m.lower * (1 - 1e-6)
    w = np.array([0.5, 1.0, 0.3, 1.0, 0.8])
    rng = np.random.default_rng(seed)
    pts = np.r_[np.array(list(itertools.product((-1.0, 1.0), repeat=5))), rng.uniform(-1, 1, (200, 5))] * (k * w)
    cs = _cs(cfg)
    for name, fam, k0, k1 in plant_loops(cfg):
        model = LoopModel(cs, cfg.plant, fam, k0, k1)
        members = None if fam is None else np.geomspace(fam.lo, fam.hi, 20)
        _, r, _ = model.counts(model.q0[None, :], None if fam is None else np.array([fam.lo, fam.hi]))
        assert not loop_counts_at(model, pts, members, int(np.min(r))).any(), name



@pytest.mark.parametrize("path,weights", [(SCHEDULED, None), (SCHEDULED, {"K_c": 3.0, "J_m": 0.5}),
                                          ("examples/paper.yaml", None)])
def test_upper_bisection_shortcut_equals_the_full_search(path, weights):
    """The upper-bound bisection re-counts only the last unstable vertex point at each level; its
    levels and witnesses (the first unstable point of the full search) are exactly those of the full
    vertex × member search at every level."""
    from exotune.analysis.plant_margin import vertex_upper_bounds

    cfg = exotune.load_design(path)
    fast = vertex_upper_bounds(cfg, weights)
    plain = vertex_upper_bounds(cfg, weights, shortcut=False)
    assert fast.keys() == plain.keys() and fast
    for name in plain:
        a, b = fast[name], plain[name]
        assert (a is None) == (b is None), name
        if a is not None:
            assert a[0] == b[0] and np.array_equal(a[1], b[1]) and a[2] == b[2], name
            # the witness is unstable: an independent check of the level's meaning
            p = None if a[2] is None else np.array([a[2]])
            name_, fam, k0, k1 = next(x for x in plant_loops(cfg) if x[0] == name)
            model = LoopModel(_cs(cfg), cfg.plant, fam, k0, k1)
            r0 = int(np.min(model.counts(model.q0[None, :], None if fam is None else np.array([fam.lo, fam.hi]))[1]))
            assert loop_counts_at(model, a[1][None, :], p, r0).all(), name


def test_plant_margin_upper_is_at_most_the_vertex_bound(sched):
    """plant_uncertainty_margin's upper bound is the vertex bisection's (or lower, when a stalled
    certification found an unstable point below it)."""
    from exotune.analysis.plant_margin import vertex_upper_bounds

    cfg, pm = sched
    ups = [v[0] for v in vertex_upper_bounds(cfg).values() if v is not None]
    assert ups and pm.upper <= min(ups)
