"""A-posteriori verification of KYP certificates (exotune.analysis.kyp_verify): the solver's answer
is checked without the solver, and a certificate that is not one fails the check."""

from __future__ import annotations

import numpy as np
import pytest

import exotune.analysis.kyp as kyp
from exotune.analysis import operator_certificates
from exotune.analysis.kyp import admittance_certificate
from exotune.analysis.kyp_verify import lmi_holds, positive_on_axis
from exotune.config import load_design

PAPER = "examples/paper.yaml"


def solver_certificate(num, den):
    """(A, B, C, q0, P, d*) of the SDP for Y = num/den (descending), as admittance_certificate builds it."""
    import scipy.signal

    Y = scipy.signal.TransferFunction(num, den)
    q, r = np.polydiv(Y.num, Y.den)
    q0 = float(q[-1]) if q.size == 1 else 0.0
    A, B, C, _ = scipy.signal.tf2ss(r, Y.den)
    d, P, solver, status = kyp._solve_kyp(A, B, C, q0)
    assert P is not None, solver
    return A, B, C, q0, P, d


def test_the_solvers_certificate_passes_and_a_perturbed_one_fails():
    # Y = 0.5 + (2s + 1)/((s + 1)(s + 2)): Re Y ≥ 0.5 everywhere, a strictly feasible LMI at d = 0
    A, B, C, q0, P, d = solver_certificate([0.5, 3.5, 2.0], [1.0, 3.0, 2.0])
    ok, lam, bound = lmi_holds(A, B, C, q0, P, 0.0)
    assert ok and lam < -bound
    # the same certificate, perturbed: no longer a certificate
    for bad in (-P, P + 10.0 * np.linalg.norm(P) * np.eye(P.shape[0]),
                P + 5.0 * np.linalg.norm(P) * np.array([[0.0, 1.0], [1.0, 0.0]])):
        assert lmi_holds(A, B, C, q0, bad, 0.0)[0] is False
    # and the certificate of a passive model is no certificate of a non-passive one
    assert lmi_holds(A, B, C, -1.0, P, 0.0)[0] is False


def test_a_boundary_certificate_is_not_accepted_by_the_eigenvalue_test():
    # strictly proper PR: the LMI's corner is 0, so it can never be strictly negative definite
    A, B, C, q0, P, d = solver_certificate([2.0, 1.0], [1.0, 3.0, 2.0])
    assert lmi_holds(A, B, C, q0, P, 0.0)[0] is False
    # … but the exact frequency-domain test proves it (ascending coefficients)
    assert positive_on_axis([1.0, 2.0], [2.0, 3.0, 1.0])[0] is True
    c = admittance_certificate([1.0, 2.0], [2.0, 3.0, 1.0])
    assert c.passive is True and c.verified and "exact" in c.verification


@pytest.mark.parametrize("num, den, why", [
    ([1.0, -0.2, 1.0], [0.5, 1.0, 4.0, 1.0, 1.0], "not positive"),   # not PR
    ([1.0, 2.0], [2.0, -3.0, 1.0], "Hurwitz"),                        # unstable denominator
    ([1.0, 0.0, 1.0], [1.0, 2.0, 1.0], "zero crossing"),              # Re Y = (1 − ω²)²/|den|², touches 0 at ω = 1
])
def test_the_exact_test_refuses(num, den, why):
    ok, reason = positive_on_axis(num, den)
    assert ok is False and why in reason


def test_an_unverified_passive_answer_is_undecided(monkeypatch):
    """If neither check goes through, the solver's "passive" is not reported as passive."""
    monkeypatch.setattr(kyp, "lmi_holds", lambda *a, **k: (False, 1.0, 1e-14))
    monkeypatch.setattr(kyp, "positive_on_axis", lambda *a, **k: (False, "refused for the test"))
    c = admittance_certificate([1.0, 2.0], [2.0, 3.0, 1.0])
    assert c.passive is None and not c.verified
    assert "not verified" in c.reason and "refused for the test" in c.verification


def test_paper_nominal_c7_is_verified():
    c = operator_certificates(load_design(PAPER))["nominal"]
    assert c.passive is True and c.verified and c.as_dict()["verified"] is True
