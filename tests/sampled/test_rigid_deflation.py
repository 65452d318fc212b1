"""The rigid-body eigenvalue z = 1 of an ungrounded sampled-data loop, deflated exactly by its
structural eigenvector (exotune.sampled.rigid), checked against independent eigen-solves:

* random ungrounded loops (cuff free, mass, damper-only and mass-damper humans, an environment
  mass; whole and fractional delays; with and without a DOB, whose 1/(1 − Q) puts a controller
  pole at z = 1): the deflated spectrum is the full spectrum of the loop matrix (LAPACK's balanced
  ``geev`` through scipy, each eigenvalue within its own condition number's rounding) with one
  eigenvalue at 1 removed;
* the committed conservative case (benchmarks/cases/rigid_body_conservative.yaml): a slow mode
  within 5e-6 of z = 1 next to the rigid one, where the eigen-solver put the rigid eigenvalue
  3.5e-7 from 1 and certify proved only slivers of the mass range: the deflated spectral radius
  equals the 25-digit one (mpmath) and certify's sampled verdicts now prove the whole range;
* grounded loops (locked joint, a human spring, position feedback) keep their full spectra.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import mpmath as mp
import numpy as np
import pytest
import scipy.linalg
from scipy.optimize import linear_sum_assignment

from exotune.config import load_design
from exotune.controllerfile import build_export
from exotune.controllerfile.cellbound import loop_cell
from exotune.controllerfile.certify import sampled_analysis
from exotune.controllerfile.fileio import discrete_from_file, plant_from_file
from exotune.model.controller import build_controller
from exotune.sampled.batch import BatchLoops, Loop
from exotune.sampled.loop import (closed_loop_matrix, default_prewarp, discretize, loop_eigenvalues, loop_spectra,
                                  loop_verdict, plant_ss)
from exotune.sampled.rigid import rigid_vectors
from paper_design import paper_design

ROOT = Path(__file__).resolve().parents[2]
CASE = ROOT / "benchmarks" / "cases" / "rigid_body_conservative.yaml"
EPS = np.finfo(float).eps


def _paper_loop(fs: float, delay_samples: float, amplification: float, dob: bool):
    """(plant, discrete controller) of examples/paper.yaml (no position feedback: K1 = 0)."""
    cfg = paper_design(sample_rate_hz=fs, delay_s=delay_samples / fs, **({} if dob else {"dob": None}))
    cfg = dataclasses.replace(cfg, design=dataclasses.replace(cfg.design, amplification=amplification))
    cs, _ = build_controller(cfg.plant, cfg.design, cfg.implementation)
    assert float(np.ravel(cs.motor_position.num)[0]) == 0.0  # ungrounded when nothing else grounds it
    return cfg.plant, discretize(cs, cfg.plant, fs, default_prewarp(cfg.implementation))


def _reference(M: np.ndarray):
    """Eigenvalues of M by scipy's balanced LAPACK solve, with a rounding scale per eigenvalue:
    1e3·κ_i·ε·‖M_b‖_F (κ_i = 1/|y_iᴴx_i| of unit left and right eigenvectors of the balanced M_b)."""
    Mb = scipy.linalg.matrix_balance(M, permute=False)[0]
    w, vl, vr = scipy.linalg.eig(Mb, left=True, right=True)
    kappa = 1.0 / np.maximum(np.abs(np.sum(vl.conj() * vr, axis=0)), 1e-300)
    return w, 1e3 * kappa * EPS * np.linalg.norm(Mb) + 1e-13


def _without_one(w: np.ndarray, tol: np.ndarray):
    """``w`` and ``tol`` less the eigenvalue nearest 1 (asserted to be 1 within its rounding)."""
    i = int(np.argmin(np.abs(w - 1.0)))
    assert abs(w[i] - 1.0) <= max(tol[i], 1e-6)
    return np.delete(w, i), np.delete(tol, i)


def _matched(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """|a_i − b_σ(i)| for the assignment σ of least total distance."""
    r, c = linear_sum_assignment(np.abs(a[:, None] - b[None, :]))
    assert r.size == a.size == b.size
    return np.abs(a[r] - b[c]), r


def _mp_spectrum(M: np.ndarray, dps: int = 25) -> np.ndarray:
    with mp.workdps(dps):
        return np.array([complex(e) for e in mp.eig(mp.matrix(M.tolist()), left=False, right=False)])


@pytest.mark.parametrize("fs, delay, amp, dob, human, env", [
    (1000.0, 0.0, 8.0, True, None, "free"),
    (1000.0, 1.37, 4.0, True, {"inertia": 0.02, "damping": 0.0}, "free"),
    (4000.0, 2.5, 12.0, False, {"damping": 3.0}, "free"),
    (10000.0, 0.6, 8.0, True, {"inertia": 0.5, "damping": 1.0}, "free"),
    (2000.0, 1.0, 6.0, False, None, {"inertia": 0.3, "damping": 2.0}),
    (500.0, 3.2, 2.0, True, {"inertia": 2.0}, "free"),
])
def test_deflated_spectrum_is_the_full_one_less_one_eigenvalue_at_1(fs, delay, amp, dob, human, env):
    plant, ctrl = _paper_loop(fs, delay, amp, dob)
    A, B, C = plant_ss(plant, human, env)
    M = closed_loop_matrix(A, B, C, ctrl)
    ref, tol = _without_one(*_reference(M))
    got = loop_eigenvalues(plant, ctrl, False, human, env)
    assert got.size == M.shape[0] - 1
    err, r = _matched(ref, got)
    assert np.all(err <= tol[r]), (err / tol[r]).max()
    rho, rho_ref = float(np.max(np.abs(got))), float(np.max(np.abs(ref)))
    i = int(np.argmax(np.abs(ref)))
    assert abs(rho - rho_ref) <= tol[i]
    # the structural eigenvector: positions 1, velocities 0, and M v = v to rounding of the balanced M
    v, ok = rigid_vectors(M[None], np.array([1.0 if s else 0.0 for s in _positions(A.shape[0])]))
    assert ok[0]
    Mb, (sc, _) = scipy.linalg.matrix_balance(M, permute=False, separate=True)
    vb = v[0] / sc
    assert np.linalg.norm(Mb @ vb - vb) <= 1e3 * M.shape[0] * EPS * np.linalg.norm(Mb) * np.linalg.norm(vb)


def _positions(n: int) -> list[bool]:
    """Position states of the plant layouts used here: θ_m, ω_m, θ_j, ω_j[, θ_h[, ω_h]]."""
    return [True, False, True, False, True, False][:n]


def test_a_damper_human_has_one_position_state():
    """A massless damped human adds θ_h alone (a position: 1 in the rigid vector)."""
    plant, ctrl = _paper_loop(2000.0, 1.5, 8.0, True)
    A, B, C = plant_ss(plant, {"damping": 5.0})
    M = closed_loop_matrix(A, B, C, ctrl)
    v, ok = rigid_vectors(M[None], np.array([1.0, 0.0, 1.0, 0.0, 1.0]))
    assert ok[0] and A.shape[0] == 5
    assert np.linalg.norm(M @ v[0] - v[0]) <= 1e-9 * np.linalg.norm(v[0])
    assert not rigid_vectors(M[None], np.array([1.0, 0.0, 1.0, 0.0, 0.0]))[1][0]  # θ_h left behind: no eigenvector


@pytest.fixture(scope="module")
def conservative():
    """The committed conservative case: its controller file (no predictions) and its loop."""
    cfg = load_design(CASE)
    doc = build_export(cfg, 4000.0, analyses=False)
    return doc, plant_from_file(doc), discrete_from_file(doc)


@pytest.mark.parametrize("mass", [1.0, 2.2])
def test_conservative_case_radius_against_25_digits(conservative, mass):
    """The members the eigen-solver left inconclusive: the deflated spectral radius is the exact
    (25-digit) one of the loop matrix less its eigenvalue at 1, and the verdict is stable."""
    _doc, plant, ctrl = conservative
    human = {"inertia": mass, "damping": 0.0}
    M = closed_loop_matrix(*plant_ss(plant, human), ctrl)
    exact = _mp_spectrum(M)
    i = int(np.argmin(np.abs(exact - 1.0)))
    assert abs(exact[i] - 1.0) < 1e-10  # the rigid eigenvalue of the rounded matrix
    others = np.delete(exact, i)
    rho_exact = float(np.max(np.abs(others)))
    assert 1.0 - 1e-5 < rho_exact < 1.0 - 1e-6  # stable, within 1e-5 of the circle
    stable, rho, rounding = loop_verdict(plant, ctrl, False, human)
    assert stable is True
    assert abs(rho - rho_exact) <= 1e-9 and rounding < 1.0 - rho
    err, _ = _matched(others, loop_eigenvalues(plant, ctrl, False, human))
    assert err.max() <= 1e-9
    # the batch engine (the latency margin's) agrees
    bl = BatchLoops.of_controller(plant, ctrl, False)
    rb, _eig, st = bl.spectra(np.array([0]), Loop("h", human={"damping": 0.0}, param="inertia"), np.array([mass]))
    assert st[0] and abs(rb[0] - rho_exact) <= 1e-9


def test_conservative_case_is_certified_over_the_whole_mass_range(conservative):
    """certify's sampled verdicts (free, locked, the mass family with every cell proven) on the
    file: robust over [1, 2.2] kg·m², nothing inconclusive or unresolved — and the exact radii at
    points of the range (25 digits) are below 1."""
    doc, plant, ctrl = conservative
    sa = sampled_analysis(doc)
    assert sa["free_stable"] is True and sa["locked_stable"] is True
    (fam,) = sa["humans"]
    assert fam["parameter"] == "inertia"
    assert fam["stable_intervals"] == [[1.0, 2.2]] and fam["robust"]
    assert not fam["inconclusive"] and not fam["unresolved"]
    for mass in (1.3, 1.7):
        M = closed_loop_matrix(*plant_ss(plant, {"inertia": mass, "damping": 0.0}), ctrl)
        exact = _mp_spectrum(M, 20)
        assert float(np.max(np.abs(np.delete(exact, np.argmin(np.abs(exact - 1.0)))))) < 1.0


def test_conservative_cell_is_proven(conservative):
    """The cell proof deflates the structural eigenvector: a cell of the range is proven stable."""
    _doc, plant, ctrl = conservative
    proven, margin = loop_cell(plant, ctrl, False, lambda v: ({"inertia": v, "damping": 0.0}, "free"),
                               1.0, 1.008, (1.0 * 1.008) ** 0.5)
    assert proven and margin > 0.0


@pytest.mark.parametrize("human, env, position_feedback", [
    (None, "locked", False),
    ({"inertia": 0.05, "stiffness": 300.0}, "free", False),
    (None, {"stiffness": 800.0, "damping": 1.0}, False),
    ({"inertia": 0.05}, "free", True),
    (None, "free", True),
])
def test_grounded_loops_keep_their_full_spectrum(human, env, position_feedback):
    """Nothing is deflated or dropped: the eigenvalues are the loop matrix's (numpy's solve), and
    the radius. Position feedback: a θ_m gain added to the command (no DOB here: a DOB that does
    not see the gain rejects its torque at DC, and the loop keeps a mode at z = 1)."""
    plant, ctrl = _paper_loop(1000.0, 1.3, 8.0, not position_feedback)
    if position_feedback:
        Dc = ctrl.Dc.copy()
        Dc[0, 0] -= 50.0
        ctrl = dataclasses.replace(ctrl, Dc=Dc)
    M = closed_loop_matrix(*plant_ss(plant, human, env), ctrl)
    want = np.linalg.eigvals(M)
    got = loop_eigenvalues(plant, ctrl, position_feedback, human, env)
    err, _ = _matched(want, got)
    assert err.max() <= 1e-12 * max(1.0, float(np.max(np.abs(want))))
    (got_s,) = loop_spectra(plant, ctrl, position_feedback, [human], env)
    assert got_s.size == want.size
    _stable, rho, _ = loop_verdict(plant, ctrl, position_feedback, human, env)
    assert rho == pytest.approx(float(np.max(np.abs(want))), rel=1e-12)


@pytest.mark.parametrize("loop, v", [
    (Loop("locked", env="locked"), None),
    (Loop("h", human={"inertia": 0.05}, param="stiffness"), 300.0),
    (Loop("e", env_param="stiffness", env_damping=1.0), 800.0),
])
def test_batch_grounded_loops_keep_their_full_spectrum(loop, v):
    plant, ctrl = _paper_loop(1000.0, 1.3, 8.0, True)
    bl = BatchLoops.of_controller(plant, ctrl, False)
    vv = None if v is None else np.array([v])
    rho, eig, _st = bl.spectra(np.array([0]), loop, vv, rounding=False)
    ((_pos, M),) = bl.matrices(np.array([0]), loop, np.zeros(1) if vv is None else vv, bl.delay[:1])
    want = np.linalg.eigvals(M[0])
    assert rho[0] == pytest.approx(float(np.max(np.abs(want))), rel=1e-12)
    err, _ = _matched(want, eig[0, :want.size])
    assert err.max() <= 1e-9


def test_a_loop_with_position_feedback_declared_free_falls_back():
    """The structural vector is no eigenvector when the controller does feed back θ_m (a gain
    added to the command, no DOB to reject it): nothing is deflated, and no eigenvalue lies near 1
    to drop (the fallback of the eigenvalue within 1e-7)."""
    plant, ctrl = _paper_loop(1000.0, 1.3, 8.0, False)
    Dc = ctrl.Dc.copy()
    Dc[0, 0] -= 50.0
    ctrl = dataclasses.replace(ctrl, Dc=Dc)
    A, B, C = plant_ss(plant, {"inertia": 0.05})
    M = closed_loop_matrix(A, B, C, ctrl)
    assert not rigid_vectors(M[None], np.array([1.0, 0.0, 1.0, 0.0, 1.0, 0.0]))[1][0]
    got = loop_eigenvalues(plant, ctrl, False, {"inertia": 0.05})
    want = np.linalg.eigvals(M)
    assert got.size == want.size and np.min(np.abs(want - 1.0)) > 1e-3
