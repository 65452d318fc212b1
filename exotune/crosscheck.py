"""Second opinion on the exact-delay verdicts: closed-loop roots of a rational Padé model (SPEC §5).

SPEC §5: "count encirclements with the Nyquist criterion on an indented contour ... and
cross-check with closed-loop eigenvalues of a rational (Padé or sampled-data) model". For one
design, :func:`pade_crosscheck` replaces e^{−sT} in every characteristic quasi-polynomial
Δ = P0 + P1 e^{−sT} of :mod:`exotune.analysis` by Padé approximants N_n/D_n of two orders
(``control.pade``), takes the roots of P0·D_n + P1·N_n (frequency-scaled companion eigenvalues) and
compares "all roots in the open left half plane" (the exact s = 0 rigid-body roots removed first)
with exotune's exact verdicts: free cuff, output locked, and every human family at the ends and at
one interior point of each sub-interval between its critical values.

A Padé model is only trustworthy where the two orders agree; points where they disagree with each
other are reported as ``pade_unresolved`` rather than as a disagreement with exotune. This is a
diagnostic: exotune's verdicts come from the exact argument principle, never from this model.
"""

from __future__ import annotations

import numpy as np

from .analysis import _strip, _trim, analyze_batch, char_terms
from .controller import build_controller
from .humans import family_split
from .poly import padd, pmul
from .quasipoly import QP

__all__ = ["pade_crosscheck", "pade_stable"]


def _pade(T: float, n: int):
    import control

    num, den = control.pade(T, n)
    return np.asarray(num, float)[::-1], np.asarray(den, float)[::-1]  # ascending


def _roots_scaled(c: np.ndarray) -> np.ndarray:
    """Roots of an ascending-coefficient polynomial, computed in a scaled variable s = σ x."""
    c = np.trim_zeros(np.asarray(c, dtype=complex), "b")
    n = len(c) - 1
    if n < 1:
        return np.zeros(0, complex)
    mags = np.abs(c)
    nz = mags > 0
    k = np.nonzero(nz)[0]
    sigma = (mags[k[0]] / mags[-1]) ** (1.0 / max(n - k[0], 1)) if k.size else 1.0
    sigma = sigma if np.isfinite(sigma) and sigma > 0 else 1.0
    cs = c * sigma ** np.arange(n + 1)
    return np.roots(cs[::-1]) * sigma


def pade_stable(p0: np.ndarray, p1: np.ndarray, T: float, order: int, allowed_rigid: int = 1):
    """(stable, rightmost root) of P0 + P1·Padé_n(e^{−sT}) for one real quasi-polynomial."""
    q = QP(np.atleast_2d(p0), np.atleast_2d(p1), np.array([T]))
    r, (qs,) = _strip(q)
    if T > 0:
        num, den = _pade(T, order)
        poly = padd(pmul(qs.p0[0], den), pmul(qs.p1[0], num))
    else:
        poly = padd(qs.p0[0], qs.p1[0])
    roots = _roots_scaled(poly)
    right = roots[np.argmax(roots.real)] if roots.size else complex(-np.inf)
    return bool((right.real < 0) and (r[0] <= allowed_rigid)), right


def pade_crosscheck(cfg, orders=(10, 16)) -> dict:
    """Compare exotune's exact verdicts for one design with two Padé models (module docstring)."""
    cols = analyze_batch(cfg)
    cs, _ = build_controller(cfg.plant, cfg.design, cfg.implementation)
    ct = char_terms(cfg.plant, cs, 1)
    T = float(np.asarray(cfg.implementation.delay_s))
    cases = []  # (label, p0, p1, allowed_rigid, exotune verdict)
    q00, q01 = ct.qp("00"), ct.qp("01")
    cases.append(("free cuff", q00.p0[0], q00.p1[0], 1, bool(cols["free_stable"][0])))
    cases.append(("output locked", q01.p0[0], q01.p1[0], 0, bool(cols["locked_stable"][0])))
    for i, fam in enumerate(cfg.humans):
        if fam.kind == "complex_stiffness":
            continue  # not rational: no eigenvalue model exists
        ivs = cols[f"human{i}_{fam.kind}_stable_intervals"][0]
        crit = sorted(p for p, _ in cols[f"human{i}_{fam.kind}_critical"][0])
        edges = [fam.lo] + [p for p in crit if fam.lo < p < fam.hi] + [fam.hi]
        pts = set([fam.lo, fam.hi])
        for a, b in zip(edges[:-1], edges[1:]):
            pts.add(float(np.sqrt(a * b)) if a > 0 else 0.5 * (a + b))
        z0, phi, _ = family_split(fam.kind, fam.param, fam.fixed(), fam.eta)
        D0, D1 = ct.combine("00", "10", z0)
        for p in sorted(pts):
            if any(abs(p - e) <= 1e-9 * max(abs(e), 1e-300) for e in crit):
                continue
            p0 = padd(D0.p0[0], p * pmul(D1.p0[0], phi))
            p1 = padd(D0.p1[0], p * pmul(D1.p1[0], phi))
            verdict = any(a <= p <= b for a, b in ivs)
            cases.append((f"human{i} {fam.kind} {fam.param} = {p:.6g} {fam.unit}", _trim(p0[None])[0], _trim(p1[None])[0], 1, verdict))
    out = {"pade_orders": list(orders), "checked": 0, "agree": 0, "pade_unresolved": [], "disagreements": []}
    for label, p0, p1, allowed, verdict in cases:
        res = [pade_stable(p0, p1, T, n, allowed) for n in orders]
        if len({r[0] for r in res}) > 1:
            out["pade_unresolved"].append(label)
            continue
        out["checked"] += 1
        if res[0][0] == verdict:
            out["agree"] += 1
        else:
            rt = res[-1][1]
            out["disagreements"].append({"case": label, "exotune_stable": verdict, "pade_stable": res[0][0],
                                         "pade_rightmost_root": {"re": float(rt.real), "im": float(rt.imag)}})
    return out
