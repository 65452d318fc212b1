"""Strength amplification C6/C5 (output locked, paper §II-D): DC value, −3 dB bandwidth,
minimum phase, with the DOB-modified delay.

C6/C5 = 1 + K_s E_eff G_c / (K_s + J_m s² + B_m s − E_eff (G_θ − K_s G_s)), E_eff the DOB-modified
delay; the denominator is the output-locked characteristic function.

References
----------
Paper §II-D (amplification); docs/method.md#amplification.
"""

from __future__ import annotations

import numpy as np

from ..model.controller import ControllerStructure
from ..model.plant import Plant
from ..numerics.budgets import MAG_LEVEL_TOL
from ..numerics.quasipoly import QP, leaves_pair, log_grid, omega_max
from .brackets import pair_roots
from .charfun import amplification_qps
from .counting import rhp_count

__all__ = ["amplification", "dc_and_bandwidth"]


def _first_by_task(task, Nd):
    out = np.full(Nd, -1)
    if task.size == 0:
        return out
    first = np.r_[True, task[1:] != task[:-1]]
    out[task[first]] = np.nonzero(first)[0]
    return out

def dc_and_bandwidth(num: QP, den: QP, per_decade: int = 2):
    """DC value and first −3 dB frequency [Hz] of C6/C5 = num/den (inf when never reached).

    Parameters
    ----------
    num, den : QP
        Numerator and denominator quasi-polynomials of C6/C5 (:func:`~exotune.analysis.charfun.amplification_qps`).
    per_decade : int
        Initial frequency points per decade of the adaptive search.

    Returns
    -------
    dc, bandwidth_hz : ndarray, shape (N,)
        |C6/C5| at ω → 0 and the first frequency where |C6/C5| falls to dc/√2 (inf when it never
        does, NaN when the search spent its budget first).

    References
    ----------
    Paper §II-D (amplification); docs/method.md#amplification.
    """
    N = num.n
    rows = np.arange(N)
    n0, _ = num.eval(rows, np.zeros(N), deriv=False)
    d0, _ = den.eval(rows, np.zeros(N), deriv=False)
    with np.errstate(divide="ignore", invalid="ignore"):
        dc = np.real(n0 / d0)
    wmax = np.maximum(omega_max(num.p0, num.p1), omega_max(den.p0, den.p1)) * 1e3
    valid = np.isfinite(wmax)
    grid = log_grid(np.where(valid, wmax, 1.0), decades=10, per_decade=per_decade)
    half = 0.5 * dc**2
    lthr = 0.5 * np.log(np.maximum(half, 1e-300))  # log of dc/√2

    def magnitude_ok(task, a, b, va, vb, da, db):
        # f(ω) = log|C6/C5(jω)|, f' = −Im(L_num − L_den). Between the ends f stays above the
        # −3 dB level (up to MAG_LEVEL_TOL) if the margin exceeds a slope-and-curvature bound
        # less the tolerance; ends already below are accepted (the leaf brackets the crossing).
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            fa = np.log(np.abs(va[0] / va[1]))
            fb = np.log(np.abs(vb[0] / vb[1]))
            La = da[0] / va[0] - da[1] / va[1]
            Lb = db[0] / vb[0] - db[1] / vb[1]
            h = b - a
            margin = np.minimum(fa, fb) - lthr[task]
            dip = 0.5 * h * np.maximum(np.abs(La.imag), np.abs(Lb.imag)) + 0.125 * h * np.abs(Lb - La)
        return ~np.isfinite(margin) | (margin <= 0.0) | (margin + MAG_LEVEL_TOL > dip)

    lv = leaves_pair(num, den, grid, valid, magnitude_ok=magnitude_ok, lthr=lthr)
    with np.errstate(divide="ignore", invalid="ignore"):
        ha = np.abs(lv["va"][0] / lv["va"][1]) ** 2 - half[lv["task"]]
        hb = np.abs(lv["vb"][0] / lv["vb"][1]) ** 2 - half[lv["task"]]
    br = (ha > 0) & (hb <= 0)
    first = _first_by_task(lv["task"][br], N)
    bw = np.full(N, np.inf)
    sel = first >= 0
    if sel.any():
        j = np.nonzero(br)[0][first[sel]]
        t = lv["task"][j]

        def h(task, w):
            a, _ = num.eval(task, w, deriv=False)
            b, _ = den.eval(task, w, deriv=False)
            return np.abs(a / b) ** 2 - half[task]

        wb = pair_roots(h, num, den, "mag", t, lv["a"][j], lv["b"][j], ha[j], hb[j], c=half)
        bw[t] = wb / (2 * np.pi)
    exh = lv.get("exhausted")
    if exh is not None:  # the search spent its budget before the −3 dB level: undefined
        bw[exh] = np.nan
    return dc, bw


def amplification(plant: Plant, cs: ControllerStructure, N: int):
    """DC value, −3 dB bandwidth [Hz] and minimum-phase flag of C6/C5 (docs/method.md#analyses-and-metrics), plus the
    output-locked stability verdict (the denominator's RHP count).

    Parameters
    ----------
    plant : Plant
        The plant (scalars or one value per design).
    cs : ControllerStructure
        The controller blocks, with the DOB filter and the delay.
    N : int
        Number of designs.

    Returns
    -------
    dict
        Arrays of shape (N,): ``dc`` (|C6/C5| at ω → 0), ``bandwidth_hz`` (the −3 dB frequency
        [Hz]; inf when never reached, NaN when undefined), ``minimum_phase`` (no zero of C6/C5 in
        the closed right half-plane), ``locked_stable`` (output-locked stability) and
        ``conclusive`` (both root counts exact).

    References
    ----------
    Paper §II-D (amplification); docs/method.md#amplification.
    """
    num, den = amplification_qps(plant, cs, N)
    Nz, rz, okz = rhp_count(num)
    Np, rp, okp = rhp_count(den)
    dc, bw = dc_and_bandwidth(num, den)
    return {
        "dc": dc,
        "bandwidth_hz": bw,
        "minimum_phase": okz & (Nz == 0) & (rz == 0),
        "locked_stable": okp & (Np == 0) & (rp == 0),
        "conclusive": okz & okp,
    }

