"""exotune.controllerfile.cellbound on stiff members (docs/method.md#guarantees): a damped human
spring whose pole −(K_c + k)/b lies far beyond 1/T_s (b = 1 N·m·s/rad, k up to 1e4 N·m/rad at
265–545 Hz). Such cells were refused although every member is stable (the remainder bound and an
ill-conditioned eigenvector basis); they are proven now, and a proof still never accepts an
unstable member: every proven cell's members, sampled densely, have their spectral radius (of a
sampled-data loop assembled here from scratch with scipy.linalg.expm) below 1 − the margin."""

from __future__ import annotations

import dataclasses
import functools
import math
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg
from hypothesis import given, settings
from hypothesis import strategies as st

from exotune.config import read_yaml
from exotune.controllerfile import build_export, design_at_rate
from exotune.controllerfile.cellbound import disc_test, loop_cell
from exotune.controllerfile.fileio import discrete_from_file, plant_from_file
from exotune.sampled import closed_loop_matrix, plant_ss

ROOT = Path(__file__).resolve().parents[2]

# a stiff-damped-spring design (an independent campaign's case s4_17: near 2905 N·m/rad the stiff
# pole e^{−(K_c + k)T_s/b} crosses a controller pole near z = 0)
S4_17 = {
    "plant": {"motor_inertia": 0.580549, "motor_damping": 13.474346, "sea_stiffness": 1169.085575,
              "joint_inertia": 0.307743, "cuff_stiffness": 296.362315},
    "design": {"amplification": 2.7256, "felt_inertia": 0.25679, "felt_damping": 0.59867, "zeta": 0.4352,
               "zeta_hat": 1.1253},
    "implementation": {"delay_s": 0.00011216927334275958, "sample_rate_hz": 545.323,
                       "gv_filter": {"cutoff_hz": 108.5639, "damping": 0.872},
                       "derivative_filter": {"cutoff_hz": 168.8226},
                       "dob": {"cutoff_hz": 54.9702, "damping": 0.868}},
    "humans": [{"kind": "spring", "stiffness": [1.0, 10000.0], "damping": 1.0}],
    "environment": [{"kind": "locked"}],
}


@functools.lru_cache(maxsize=None)
def _loop(design: str, rate_hz: float):
    """(plant, controller) of examples/scheduled.yaml or S4_17 at ``rate_hz``, no predictions."""
    raw = read_yaml(ROOT / "examples" / "scheduled.yaml") if design == "scheduled" else dict(S4_17)
    doc = build_export(design_at_rate(raw, rate_hz), rate_hz, analyses=False)
    return plant_from_file(doc), discrete_from_file(doc)


def _member(damping: float):
    return lambda v: ({"stiffness": v, "damping": damping}, "free")


def _reference_radius(plant, ctrl, human: dict) -> float:
    """Spectral radius of the sampled-data loop built here: the plant held by a zero-order hold,
    the command τ[k] = C_c z[k] + D_c y[k] applied (d + f)·T_s after the sample — over a sample
    τ[k−d−1] acts for f·T_s, then τ[k−d] — on the state [x; z; τ[k−1] … τ[k−d−1]]."""
    A, B, C = plant_ss(plant, human, "free")
    Ts = 1.0 / ctrl.sample_rate_hz
    q = ctrl.delay_s / Ts
    d = int(math.floor(q + 1e-9))
    f = q - d if q - d >= 1e-9 else 0.0
    n, nz = A.shape[0], ctrl.Ac.shape[0]
    aug = np.zeros((n + 1, n + 1))
    aug[:n, :n], aug[:n, n] = A, B[:, 0]
    Eo, En = scipy.linalg.expm(aug * f * Ts), scipy.linalg.expm(aug * (1.0 - f) * Ts)
    Phi, G_old, G_new = En[:n, :n] @ Eo[:n, :n], En[:n, :n] @ Eo[:n, n], En[:n, n]
    N = n + nz + d + 1
    s0 = n + nz
    u = np.zeros(N)  # τ[k] as a row over the state
    u[:n], u[n:s0] = (ctrl.Dc @ C).ravel(), ctrl.Cc.ravel()
    new = u if d == 0 else np.eye(N)[s0 + d - 1]
    M = np.zeros((N, N))
    M[:n, :n] = Phi
    M[:n] += np.outer(G_new, new) + np.outer(G_old, np.eye(N)[s0 + d])
    M[n:s0, :n], M[n:s0, n:s0] = ctrl.Bc @ C, ctrl.Ac
    M[s0] = u
    for j in range(1, d + 1):
        M[s0 + j, s0 + j - 1] = 1.0
    return float(np.max(np.abs(np.linalg.eigvals(M))))


def test_the_reference_loop_is_exotunes():
    plant, ctrl = _loop("scheduled", 500.0)
    for c in (ctrl, dataclasses.replace(ctrl, delay_s=0.0035)):
        for k in (10.0, 3000.0, 9000.0):
            h = {"stiffness": k, "damping": 1.0}
            ours = max(abs(np.linalg.eigvals(closed_loop_matrix(*plant_ss(plant, h, "free"), c))))
            assert _reference_radius(plant, c, h) == pytest.approx(ours, rel=1e-9)


@pytest.mark.parametrize("design, rate, cell", [
    ("scheduled", 500.0, (8015.81, 8040.13)),  # refused before (margin −0.30): the remainder bound
    ("scheduled", 500.0, (7000.0, 7400.0)),
    ("S4_17", 545.323, (2905.08, 2905.15)),  # refused before (margin −0.35): two eigenvalues near z = 0
    ("S4_17", 545.323, (5000.0, 5001.0)),  # refused before (margin −8)
])
def test_stiff_damped_spring_cells_are_proven(design, rate, cell):
    plant, ctrl = _loop(design, rate)
    a, b = cell
    ok, margin = loop_cell(plant, ctrl, False, _member(1.0), a, b, math.sqrt(a * b))
    radii = [_reference_radius(plant, ctrl, {"stiffness": v, "damping": 1.0}) for v in np.linspace(a, b, 9)]
    assert ok and 0 < margin
    assert max(radii) <= (1.0 - margin) * (1 + 1e-9)  # the discs hold every member's eigenvalues


def test_a_cell_with_unstable_members_is_refused():
    """At 3.5 ms of delay the stiff end of the family is unstable (radius ≈ 1.0008 at 1e4)."""
    plant, ctrl = _loop("scheduled", 500.0)
    ctrl = dataclasses.replace(ctrl, delay_s=0.0035)
    assert _reference_radius(plant, ctrl, {"stiffness": 1e4, "damping": 1.0}) > 1.0
    assert not loop_cell(plant, ctrl, False, _member(1.0), 9000.0, 1e4, math.sqrt(9e7))[0]


@settings(max_examples=30, deadline=None)
@given(rate=st.sampled_from([500.0, 265.0]), delay=st.sampled_from([None, 0.0034, 0.0035]),
       damping=st.floats(0.2, 3.0), log_k=st.floats(2.0, 4.0), log_w=st.floats(-5.0, -0.7))
def test_a_proven_stiff_cell_has_only_stable_members(rate, delay, damping, log_k, log_w):
    plant, ctrl = _loop("scheduled", rate)
    if delay is not None:
        ctrl = dataclasses.replace(ctrl, delay_s=delay)
    a = 10.0 ** log_k
    b = a * (1.0 + 10.0 ** log_w)
    ok, margin = loop_cell(plant, ctrl, False, _member(damping), a, b, math.sqrt(a * b))
    if ok:
        radii = [_reference_radius(plant, ctrl, {"stiffness": v, "damping": damping}) for v in np.linspace(a, b, 9)]
        assert margin > 0 and max(radii) <= (1.0 - margin) * (1 + 1e-9)
    else:
        assert margin <= 0


def _close_pair(rng, sep: float, coupling: float) -> np.ndarray:
    """A 5×5 matrix with two eigenvalues 0.3 and 0.3 + sep whose eigenvectors are nearly parallel
    (a Jordan-like block [[0.3, coupling], [0, 0.3 + sep]]), three more at 0.85, −0.5 and 0.1, in a
    random well-conditioned basis."""
    T = np.diag([0.3, 0.3 + sep, 0.85, -0.5, 0.1])
    T[0, 1] = coupling
    S = np.linalg.qr(rng.normal(size=(5, 5)))[0] @ np.diag(rng.uniform(0.5, 2.0, 5))
    return S @ T @ np.linalg.inv(S)


def test_nearly_parallel_eigenvectors_do_not_defeat_the_remainder():
    """Eigenvector coordinates blow the remainder β up by the pair's condition number (~1e8); the
    pair's own orthonormal block keeps it at ~√β."""
    M0 = _close_pair(np.random.default_rng(3), 1e-8, 1.0)
    ok, margin = disc_test([M0], np.eye(5), np.eye(5), beta=1e-8)
    assert ok and 0 < margin <= 1 - 0.85
    assert not disc_test([M0], np.eye(5), np.eye(5), beta=0.2)[0]  # 0.85 + 0.2 > 1 for Δ = 0.2 I


@settings(max_examples=40, deadline=None)
@given(sep=st.sampled_from([0.0, 1e-10, 1e-8, 1e-6, 1e-4, 1e-2]), coupling=st.floats(0.0, 3.0),
       beta=st.floats(0.0, 0.1), spread=st.floats(0.0, 0.2), seed=st.integers(0, 2**32 - 1))
def test_a_proof_with_close_eigenvalues_bounds_every_member(sep, coupling, beta, spread, seed):
    """Whenever the disc test proves such a family, every member — δ on a grid, Δ with ‖Δ‖₂ = β of
    rank one (the worst directions) and ±β·I — has its spectral radius below 1 − margin."""
    rng = np.random.default_rng(seed)
    M0 = _close_pair(rng, sep, coupling)
    M1 = spread * rng.normal(size=(5, 5)) / 5
    ok, margin = disc_test([M0, M1], np.eye(5), np.eye(5), beta=beta)
    if not ok:
        assert margin <= 0
        return
    deltas = [beta * np.eye(5), -beta * np.eye(5)]
    for _ in range(6):
        x, y = rng.normal(size=5), rng.normal(size=5)
        deltas.append(beta * np.outer(x, y) / (np.linalg.norm(x) * np.linalg.norm(y)))
    for d in np.linspace(-0.5, 0.5, 11):
        for D in deltas:
            assert max(abs(np.linalg.eigvals(M0 + d * M1 + D))) <= 1.0 - margin + 1e-12
