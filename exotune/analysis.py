"""Coupled-stability engine and the metrics of SPEC §5 (continuous time, exact delay).

Method
------
For a plant (SPEC §2) with a human impedance z(s) at θ_h and an environment impedance z_e(s) at
θ_j, closed by any :class:`~exotune.controller.ControllerStructure`, the closed-loop
characteristic function is *multilinear* in (z, z_e):

    Δ(s; z, z_e) = Δ00(s) + z Δ10(s) + z_e Δ01(s) + z z_e Δ11(s),   each Δij = P0 + P1 e^{−sT}

(the plant determinant and cofactors are multilinear in the diagonal impedances; the controller
and the DOB enter through the single delayed actuator path). :func:`char_terms` builds the eight
coefficient arrays for a batch of designs, in "grounded" form so that the rigid-body root at
s = 0 of the free exoskeleton (K1 = 0, SPEC §4) is an *exact* zero coefficient that is divided
out structurally — never a rounding decision.

From these:

* ``free_stable``: RHP count of Δ00 (rigid-body root excepted, exactly one allowed).
* human family with z = z0 + p φ over p ∈ [lo, hi]: Δ = (Δ00 + z0 Δ10) + p φ Δ10. A root can
  only cross the imaginary axis at s = jω where p = −Δ_0(jω)/(φΔ10(jω)) is real, i.e. at the
  zeros of g(ω) = Im[Δ_0 · conj(φ Δ10)], found by bracketing on the adaptive frequency set and
  bisection (to float precision). These critical values split [lo, hi]; each sub-interval is
  classified by an exact RHP count (argument principle, :mod:`exotune.quasipoly`).
  ``stable_intervals`` are therefore exact (no grid of trial values).
* C7(jω) = Δ10/Δ00 (the operator-side compliance), so passivity uses the same data.
* environment: locked ⇔ Δ01 (θ_j ≡ 0); spring/mass families as for the human with Δ01.
* DOB margins: L_dob = Q e^{−sT}/(1 − Q) (paper Fig. DOBtune), gain crossovers as exact roots
  of |n_q|² = |d_q − n_q|², every crossover considered.
* amplification C6/C5 = 1 + K_s E_eff G_c / (K_s + J_m s² + B_m s − E_eff (G_θ − K_s G_s)) (the
  output-locked ratio, paper §III-E), with E_eff the DOB-modified delay.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .controller import ControllerStructure, build_controller
from .humans import EnvModel, HumanFamily, family_split
from .model import Plant
from .poly import as_poly, degree, leading, padd, pmul, pscale, psub, pval, pval_flat, strip_common_low_zeros
from .quasipoly import QP, adaptive_leaves, bisect_roots, count_rhp, log_grid, omega_max

__all__ = [
    "CharTerms",
    "char_terms",
    "amplification_qps",
    "free_stability",
    "family_intervals",
    "passivity",
    "dob_margins",
    "amplification",
    "analyze_batch",
    "analyze_design",
    "format_report",
    "coupled_stable",
    "c7_response",
]


# ----------------------------------------------------------------------------------------------
# characteristic functions
# ----------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class CharTerms:
    """Multilinear characteristic terms Δij = P0ij + P1ij e^{−sT} (batched, ascending coeffs)."""

    terms: dict  # key "00","10","01","11" -> QP
    T: np.ndarray

    def qp(self, key: str) -> QP:
        return self.terms[key]

    def combine(self, key0: str, key1: str, z0: np.ndarray) -> tuple[QP, QP]:
        """(Δ_0, Δ_1') with Δ_0 = Δ{key0} + z0(s)·Δ{key1}, Δ_1' = Δ{key1}."""
        A, B = self.terms[key0], self.terms[key1]
        z0 = np.asarray(z0, dtype=float)
        p0 = padd(A.p0, pmul(B.p0, np.broadcast_to(z0, B.p0.shape[:1] + z0.shape[-1:])))
        p1 = padd(A.p1, pmul(B.p1, np.broadcast_to(z0, B.p1.shape[:1] + z0.shape[-1:])))
        return QP(p0, p1, A.T), B


def _bc(x, N):
    return np.broadcast_to(np.asarray(x, dtype=float), (N,)).copy()


def _blocks(cs: ControllerStructure, N: int):
    out = []
    for r in (cs.motor_position, cs.spring_torque, cs.cuff_torque):
        num = np.broadcast_to(r.num, (N,) + r.num.shape[-1:]).astype(float)
        den = np.broadcast_to(r.den, (N,) + r.den.shape[-1:]).astype(float)
        out.append((num, den))
    return out


def batch_size(*objs) -> int:
    n = 1
    for o in objs:
        for v in (vars(o).values() if hasattr(o, "__dict__") else o):
            if isinstance(v, np.ndarray) and v.ndim >= 1:
                n = max(n, v.shape[0])
    return n


def char_terms(plant: Plant, cs: ControllerStructure, N: int) -> CharTerms:
    """Build Δ00, Δ10, Δ01, Δ11 for N designs (see module docstring).

    Plant (grounded form, exact structural zeros): with A = J_m s² + B_m s + K_s, M = J_m s² + B_m s,
    X0 = M (J_j s² + K_s) + K_s J_j s², C = K_c + z:
      det   = K_c X0 + z (X0 + K_c A) + z_e K_c A + z z_e A
      N_θm  = K_c (J_j s² + K_s) + z (J_j s² + K_s + K_c) + z_e K_c + z z_e
      N_τs  = −K_s [K_c J_j s² + z (J_j s² + K_c) + z_e K_c + z z_e]
      N_τc  = −K_s K_c z
    (θ_m, τ_s, τ_c responses to τ_m are N_x/det). With blocks G_x = n_x/d_x, d = Π d_x and
    Q = n_q/d_q:  P0 = det·d·(d_q − n_q),  P1 = det·d·n_q − d_q Σ_x n_x (d/d_x) N_x.
    """
    Ks, Kc, Jm, Bm, Jj = (_bc(v, N) for v in (plant.K_s, plant.K_c, plant.J_m, plant.B_m, plant.J_j))
    zero = np.zeros(N)
    one = np.ones(N)
    A = as_poly(Ks, Bm, Jm)
    M = as_poly(zero, Bm, Jm)
    Jg = as_poly(zero, zero, Jj)
    JgKs = as_poly(Ks, zero, Jj)
    X0 = padd(pmul(M, JgKs), pscale(Jg, Ks))
    det = {
        "00": pscale(X0, Kc),
        "10": padd(X0, pscale(A, Kc)),
        "01": pscale(A, Kc),
        "11": A,
    }
    Nth = {
        "00": pscale(JgKs, Kc),
        "10": as_poly(Ks + Kc, zero, Jj),
        "01": Kc[:, None],
        "11": one[:, None],
    }
    Nts = {
        "00": pscale(Jg, -Ks * Kc),
        "10": pscale(as_poly(Kc, zero, Jj), -Ks),
        "01": (-Ks * Kc)[:, None],
        "11": (-Ks)[:, None],
    }
    Ntc = {"00": zero[:, None], "10": (-Ks * Kc)[:, None], "01": zero[:, None], "11": zero[:, None]}
    (nth, dth), (nts, dts), (ntc, dtc) = _blocks(cs, N)
    d_all = pmul(pmul(dth, dts), dtc)
    w_th = pmul(nth, pmul(dts, dtc))
    w_ts = pmul(nts, pmul(dth, dtc))
    w_tc = pmul(ntc, pmul(dth, dts))
    if cs.dob_q is not None:
        nq = np.broadcast_to(cs.dob_q.num, (N,) + cs.dob_q.num.shape[-1:]).astype(float)
        dq = np.broadcast_to(cs.dob_q.den, (N,) + cs.dob_q.den.shape[-1:]).astype(float)
    else:
        nq, dq = np.zeros((N, 1)), np.ones((N, 1))
    dmn = psub(dq, nq)
    T = _bc(cs.delay_s, N)
    terms = {}
    for key in ("00", "10", "01", "11"):
        dd = pmul(det[key], d_all)
        S = padd(padd(pmul(w_th, Nth[key]), pmul(w_ts, Nts[key])), pmul(w_tc, Ntc[key]))
        P0 = pmul(dd, dmn)
        P1 = psub(pmul(dd, nq), pmul(dq, S))
        terms[key] = QP(_trim(P0), _trim(P1), T)
    return CharTerms(terms, T)


def _trim(c: np.ndarray) -> np.ndarray:
    """Drop trailing all-zero highest-order columns."""
    nz = np.nonzero(np.any(c != 0, axis=0))[0]
    return c[:, : (nz[-1] + 1 if nz.size else 1)]


def amplification_qps(plant: Plant, cs: ControllerStructure, N: int) -> tuple[QP, QP]:
    """(numerator, denominator) quasi-polynomials of the amplification C6/C5 (output locked).

    Denominator = the output-locked characteristic function; its RHP count is the locked-output
    stability verdict. C6/C5 = num/den (same normalization).
    """
    Ks, Jm, Bm = (_bc(v, N) for v in (plant.K_s, plant.J_m, plant.B_m))
    A = as_poly(Ks, Bm, Jm)
    (nth, dth), (nts, dts), (ntc, dtc) = _blocks(cs, N)
    d_all = pmul(pmul(dth, dts), dtc)
    w_th = pmul(nth, pmul(dts, dtc))
    w_ts = pmul(nts, pmul(dth, dtc))
    w_tc = pmul(ntc, pmul(dth, dts))
    if cs.dob_q is not None:
        nq = np.broadcast_to(cs.dob_q.num, (N,) + cs.dob_q.num.shape[-1:]).astype(float)
        dq = np.broadcast_to(cs.dob_q.den, (N,) + cs.dob_q.den.shape[-1:]).astype(float)
    else:
        nq, dq = np.zeros((N, 1)), np.ones((N, 1))
    T = _bc(cs.delay_s, N)
    Ad = pmul(A, d_all)
    P0 = pmul(Ad, psub(dq, nq))
    Sd = psub(w_th, pscale(w_ts, Ks))
    Sn = psub(Sd, pscale(w_tc, Ks))
    den = QP(_trim(P0), _trim(psub(pmul(Ad, nq), pmul(dq, Sd))), T)
    num = QP(_trim(P0), _trim(psub(pmul(Ad, nq), pmul(dq, Sn))), T)
    return num, den


# ----------------------------------------------------------------------------------------------
# stability
# ----------------------------------------------------------------------------------------------
def _strip(*qps: QP, max_strip=None):
    r, arrs = strip_common_low_zeros(*[a for q in qps for a in (q.p0, q.p1)], max_strip=max_strip)
    out = [QP(_trim(arrs[2 * i]), _trim(arrs[2 * i + 1]), qps[i].T) for i in range(len(qps))]
    return r, out


def rhp_count(qp: QP):
    """(N_rhp, rigid_body_roots, conclusive) with the exact s = 0 roots divided out first."""
    r, (q,) = _strip(qp)
    N, ok = count_rhp(q)
    return N, r, ok


def free_stability(ct: CharTerms):
    """Free exoskeleton (cuff free, no environment): stable except for ≤ 1 rigid-body root."""
    N, r, ok = rhp_count(ct.qp("00"))
    return {"stable": ok & (N == 0) & (r <= 1), "n_rhp": N, "rigid_body_roots": r, "conclusive": ok}


def _family_qps(ct: CharTerms, key0: str, key1: str, fam_kind: str, param: str, fixed: dict, eta: float):
    z0, phi, factor = family_split(fam_kind, param, fixed, eta)
    D0, D1 = ct.combine(key0, key1, z0)
    D1 = QP(pmul(D1.p0, phi[None, :]), pmul(D1.p1, phi[None, :]), D1.T)
    return D0, D1, factor


def family_intervals(D0: QP, D1: QP, factor: complex, lo: float, hi: float, per_decade: int = 8):
    """Exact stable sub-intervals of p ∈ [lo, hi] for Δ(s; p) = Δ_0 + p·f·Δ_1 (f = ``factor``
    for ω > 0, 1 at ω = 0). Returns a list (per design) of [[a, b], ...] and per-design flags.
    """
    Nd = D0.n
    r, (D0s, D1s) = _strip(D0, D1)
    # tail frequency valid for every p in [lo, hi] (coefficients are affine in p)
    n0 = max(D0s.p0.shape[-1], D1s.p0.shape[-1])
    n1 = max(D0s.p1.shape[-1], D1s.p1.shape[-1])
    pad = lambda c, n: np.pad(c, ((0, 0), (0, n - c.shape[-1])))
    A0, B0 = pad(D0s.p0, n0).astype(complex), pad(D1s.p0, n0).astype(complex) * factor
    A1, B1 = pad(D0s.p1, n1).astype(complex), pad(D1s.p1, n1).astype(complex) * factor
    lo_c = A0 + lo * B0
    hi_c = A0 + hi * B0
    P0env = np.maximum(np.abs(lo_c), np.abs(hi_c))
    P1env = np.maximum(np.abs(A1 + lo * B1), np.abs(A1 + hi * B1))
    nlo, nhi = degree(lo_c), degree(hi_c)
    # leading coefficient must keep its degree over the whole range
    cmin = _min_abs_affine(leading(A0 + 0 * B0 if False else lo_c), leading(hi_c), nlo, nhi)
    P0env_lead = P0env.copy()
    rows = np.arange(Nd)
    P0env_lead[rows, np.maximum(nlo, 0)] = np.where(nlo == nhi, cmin, 0.0)
    # emulate omega_max with the envelope (leading coefficient = its minimum over the range)
    wmax = omega_max(P0env_lead, P1env)
    valid = np.isfinite(wmax) & (nlo == nhi) & (cmin > 0)
    grid = log_grid(np.where(valid, wmax, 1.0), per_decade=per_decade)

    def evalfn(idx, w):
        a = D0s.eval(idx, w)
        b = D1s.eval(idx, w)
        return [a, (b[0] * factor, b[1] * factor)]

    lv = adaptive_leaves(evalfn, Nd, grid, valid)

    def g_of(va, vb):
        return np.imag(va * np.conj(vb))

    ga = g_of(lv["va"][0], lv["va"][1])
    gb = g_of(lv["vb"][0], lv["vb"][1])
    # ω = 0 endpoints: g = 0 identically for real data; do not use them as brackets
    atzero = lv["a"] == 0
    br = (np.sign(ga) * np.sign(gb) < 0) & ~atzero
    # also the first leaf [0, w1]: bracket using g just above 0 is impossible; handled by p0 below
    def gfun(task, w):
        a, _ = D0s.eval(task, w, deriv=False)
        b, _ = D1s.eval(task, w, deriv=False)
        return np.imag(a * np.conj(b * factor))

    ws = bisect_roots(gfun, lv["task"][br], lv["a"][br], lv["b"][br], ga[br])
    tk = lv["task"][br]
    a_, _ = D0s.eval(tk, ws, deriv=False)
    b_, _ = D1s.eval(tk, ws, deriv=False)
    with np.errstate(divide="ignore", invalid="ignore"):
        pc = -np.real(a_ * np.conj(b_ * factor)) / np.abs(b_ * factor) ** 2
    # exact zero crossings (a real root through s = 0)
    z0v, _ = D0s.eval(rows, np.zeros(Nd), deriv=False)
    z1v, _ = D1s.eval(rows, np.zeros(Nd), deriv=False)
    with np.errstate(divide="ignore", invalid="ignore"):
        p_at0 = np.where(z1v != 0, -np.real(z0v) / np.real(z1v), np.nan)
    crit_task = np.concatenate([tk, rows])
    crit_p = np.concatenate([pc, p_at0])
    crit_w = np.concatenate([ws, np.zeros(Nd)])
    inside = np.isfinite(crit_p) & (crit_p > lo) & (crit_p < hi)
    crit_task, crit_p, crit_w = crit_task[inside], crit_p[inside], crit_w[inside]
    # sub-intervals and representative points
    order = np.lexsort((crit_p, crit_task))
    crit_task, crit_p, crit_w = crit_task[order], crit_p[order], crit_w[order]
    bounds = [[lo] for _ in range(Nd)]
    for t, p in zip(crit_task.tolist(), crit_p.tolist()):
        if p > bounds[t][-1] * (1 + 1e-12) + 1e-300:
            bounds[t].append(p)
    for t in range(Nd):
        bounds[t].append(hi)
    rep_task, rep_p = [], []
    for t in range(Nd):
        bt = bounds[t]
        for i in range(len(bt) - 1):
            a, b = bt[i], bt[i + 1]
            rep_task.append(t)
            rep_p.append(np.sqrt(a * b) if a > 0 and b > 0 else 0.5 * (a + b))
    rep_task = np.asarray(rep_task, int)
    rep_p = np.asarray(rep_p, float)
    p0 = A0[rep_task] + rep_p[:, None] * B0[rep_task]
    p1 = A1[rep_task] + rep_p[:, None] * B1[rep_task]
    if factor.imag == 0:
        p0, p1 = p0.real, p1.real
        v0 = None
    else:
        v0 = np.real(z0v[rep_task] + rep_p * z1v[rep_task])
    N, ok = count_rhp(QP(_trim(p0), _trim(p1), D0s.T[rep_task]), v0=v0)
    st = ok & (N == 0) & (r[rep_task] <= 1) & valid[rep_task]
    intervals = [[] for _ in range(Nd)]
    conclusive = valid & lv["resolved"]
    conclusive[rep_task[~ok]] = False
    k = 0
    for t in range(Nd):
        bt = bounds[t]
        for i in range(len(bt) - 1):
            if st[k]:
                if intervals[t] and intervals[t][-1][1] == bt[i]:
                    intervals[t][-1][1] = bt[i + 1]
                else:
                    intervals[t].append([bt[i], bt[i + 1]])
            k += 1
    robust = np.array([len(iv) == 1 and iv[0][0] == lo and iv[0][1] == hi for iv in intervals])
    crit = [[] for _ in range(Nd)]
    for t, p, w in zip(crit_task.tolist(), crit_p.tolist(), crit_w.tolist()):
        crit[t].append((p, w / (2 * np.pi)))
    return {
        "stable_intervals": intervals,
        "robust": robust & conclusive,
        "conclusive": conclusive,
        "critical": crit,
        "rigid_body_roots": r,
    }


def _min_abs_affine(c_lo, c_hi, n_lo, n_hi):
    """min over t ∈ [0,1] of |c_lo + t (c_hi − c_lo)| (the leading coefficient over the range)."""
    d = c_hi - c_lo
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.clip(-np.real(np.conj(d) * c_lo) / np.abs(d) ** 2, 0.0, 1.0)
    t = np.where(np.abs(d) > 0, t, 0.0)
    return np.abs(c_lo + t * d)


# ----------------------------------------------------------------------------------------------
# frequency-domain metrics
# ----------------------------------------------------------------------------------------------
def c7_response(ct: CharTerms, w: np.ndarray) -> np.ndarray:
    """C7(jω) = Δ10/Δ00 for every design (rows) at frequencies w (N, K) [rad/N·m]."""
    N = ct.T.shape[0]
    idx = np.repeat(np.arange(N), w.shape[1])
    a, _ = ct.qp("00").eval(idx, w.ravel(), deriv=False)
    b, _ = ct.qp("10").eval(idx, w.ravel(), deriv=False)
    return (b / a).reshape(w.shape)


def passivity(ct: CharTerms, per_decade: int = 8):
    """max_phase_excess_deg and nonpassive_band_hz of C7 (SPEC §5).

    Passive phase band: arg C7 ∈ [−180°, 0°] ⇔ Im C7(jω) ≤ 0. The excess is the angular distance
    of the (wrapped) phase from that band, min(φ, 180° − φ) for φ ∈ (0°, 180°).
    """
    A, B = ct.qp("00"), ct.qp("10")
    Nd = A.n
    As, Bs = A, B
    wmax = np.maximum(omega_max(As.p0, As.p1), omega_max(Bs.p0, Bs.p1))
    valid = np.isfinite(wmax)
    grid = log_grid(np.where(valid, wmax, 1.0), per_decade=per_decade)
    lv = adaptive_leaves(lambda i, w: [As.eval(i, w), Bs.eval(i, w)], Nd, grid, valid)
    def c7(task, w):
        a, _ = As.eval(task, w, deriv=False)
        b, _ = Bs.eval(task, w, deriv=False)
        return b / a

    with np.errstate(divide="ignore", invalid="ignore"):
        ca = lv["va"][1] / lv["va"][0]
        cb = lv["vb"][1] / lv["vb"][0]
    pos = lv["a"] > 0
    ima, imb = np.imag(ca), np.imag(cb)
    br = (np.sign(ima) * np.sign(imb) < 0) & pos
    fim = lambda t, w: np.imag(c7(t, w))
    edges = bisect_roots(fim, lv["task"][br], lv["a"][br], lv["b"][br], ima[br])
    et = lv["task"][br]
    # excess at samples
    def excess(c):
        ph = np.degrees(np.angle(c))
        return np.where(ph > 0, np.minimum(ph, 180.0 - ph), 0.0)

    exb = np.where(np.isfinite(cb), excess(cb), 0.0)
    best = np.zeros(Nd)
    np.maximum.at(best, lv["task"], exb)
    # refine the maximum: golden-section around the best sample of each design
    arg = _argmax_by_task(lv["task"], exb, Nd)
    have = arg >= 0
    if have.any():
        ti = np.nonzero(have)[0]
        j = arg[ti]
        wc = lv["b"][j]
        lo_w = lv["a"][j]
        nxt = np.minimum(j + 1, len(lv["b"]) - 1)
        hi_w = np.where(lv["task"][nxt] == ti, lv["b"][nxt], wc)
        f = lambda w: excess(c7(ti, w))
        a_, b_ = lo_w, hi_w
        gr = 0.5 * (np.sqrt(5) - 1)
        for _ in range(40):
            c1 = b_ - gr * (b_ - a_)
            c2 = a_ + gr * (b_ - a_)
            f1, f2 = f(c1), f(c2)
            left = f1 >= f2
            b_ = np.where(left, c2, b_)
            a_ = np.where(left, a_, c1)
        best[ti] = np.maximum(best[ti], f(0.5 * (a_ + b_)))
    # bands: intervals where Im C7 > 0
    bands = [[] for _ in range(Nd)]
    e_by = [[] for _ in range(Nd)]
    for t, w in zip(et.tolist(), edges.tolist()):
        e_by[t].append(w)
    # sign at the start (lowest positive frequency leaf)
    first_pos = np.full(Nd, np.nan)
    firstidx = _first_by_task(lv["task"][pos], Nd)
    pos_idx = np.nonzero(pos)[0]
    ok = firstidx >= 0
    first_pos[ok] = imb[pos_idx[firstidx[ok]]]
    for t in range(Nd):
        inside = bool(first_pos[t] > 0) if np.isfinite(first_pos[t]) else False
        start = 0.0 if inside else None
        for w in sorted(e_by[t]):
            if inside:
                bands[t].append([start / (2 * np.pi), w / (2 * np.pi)])
                inside = False
            else:
                start = w
                inside = True
        if inside:
            bands[t].append([start / (2 * np.pi), float("inf")])
    return {"max_phase_excess_deg": best, "nonpassive_band_hz": bands, "conclusive": valid & lv["resolved"]}


def _argmax_by_task(task, vals, Nd):
    out = np.full(Nd, -1)
    if task.size == 0:
        return out
    order = np.lexsort((vals, task))
    last = np.r_[task[order][1:] != task[order][:-1], True]
    sel = order[last]
    good = vals[sel] > 0
    out[task[sel][good]] = sel[good]
    return out


def _first_by_task(task, Nd):
    out = np.full(Nd, -1)
    if task.size == 0:
        return out
    first = np.r_[True, task[1:] != task[:-1]]
    out[task[first]] = np.nonzero(first)[0]
    return out


def dob_margins(cs: ControllerStructure, N: int):
    """Gain [dB], phase [deg] and delay [s] margins of L_dob = Q e^{−sT}/(1 − Q) (SPEC §5).

    Gain crossovers are the positive real roots of |n_q(jω)|² − |(d_q − n_q)(jω)|² (a polynomial
    in ω); delay margin = min_k PM_k/ω_k with PM_k ∈ [0, 2π). Phase crossovers (arg L = −180° mod
    360°) are bracketed on a dense log grid of the continuous phase (from the roots of n_q and
    d_q − n_q, so no unwrapping) and bisected; gain margin = min over them of 1/|L|.
    """
    if cs.dob_q is None:
        return None
    nq = np.broadcast_to(cs.dob_q.num, (N,) + cs.dob_q.num.shape[-1:]).astype(float)
    dq = np.broadcast_to(cs.dob_q.den, (N,) + cs.dob_q.den.shape[-1:]).astype(float)
    m = psub(dq, nq)
    T = _bc(cs.delay_s, N)
    # |p(jω)|² as a polynomial in ω
    def sq(c):
        k = np.arange(c.shape[-1])
        jk = 1j ** k
        pc = c * jk  # coefficients of p(jω) in ω
        re, im = np.real(pc), np.imag(pc)
        return padd(pmul(re, re), pmul(im, im))

    u = psub(sq(nq), sq(m))
    roots = _batched_roots(u)
    wc = np.where((np.abs(roots.imag) <= 1e-9 * np.abs(roots)) & (roots.real > 0), roots.real, np.nan)
    zn = _batched_roots(nq)
    zm = _batched_roots(m)
    ln, lm = leading(nq), leading(m)

    def phase(rows, w):  # continuous phase of L(jω) at scattered (row, ω)
        s = (1j * w)[:, None]
        ph = np.angle(ln[rows]) - np.angle(lm[rows]) - w * T[rows]
        ph = ph + np.nansum(np.angle(s - zn[rows]), axis=1)
        return ph - np.nansum(np.angle(s - zm[rows]), axis=1)

    def mag(rows, w):
        s = 1j * w
        return np.abs(pval_flat(nq, rows, s)) / np.abs(pval_flat(m, rows, s))

    rows_c, col_c = np.nonzero(np.isfinite(wc))
    w_c = wc[rows_c, col_c]
    pm_k = np.mod(np.pi + phase(rows_c, w_c), 2 * np.pi)
    pm_wrapped = np.where(pm_k > np.pi, pm_k - 2 * np.pi, pm_k)
    dm = np.full(N, np.inf)
    pm = np.full(N, np.inf)
    fc = np.full(N, np.nan)
    np.minimum.at(dm, rows_c, pm_k / w_c)
    np.minimum.at(pm, rows_c, np.degrees(pm_wrapped))
    fc_tmp = np.full(N, np.inf)
    np.minimum.at(fc_tmp, rows_c, w_c / (2 * np.pi))
    fc = np.where(np.isfinite(fc_tmp), fc_tmp, np.nan)
    # phase crossovers on a log grid spanning the DOB dynamics and the delay
    allr = np.concatenate([zn, zm], axis=1)
    scale = np.nanmax(np.where(np.isfinite(allr), np.abs(allr), 0.0), axis=1)
    scale = np.where(scale > 0, scale, 1.0)
    hi = np.maximum(scale * 1e3, np.where(T > 0, 400.0 / np.maximum(T, 1e-12), 0.0))
    hi = np.minimum(hi, scale * 1e6)
    K = 1500
    wg = np.exp(np.linspace(np.log(scale * 1e-4), np.log(hi), K, axis=1))
    rows_g = np.repeat(np.arange(N), K)
    ph = phase(rows_g, wg.ravel()).reshape(N, K)
    kk = np.floor((ph + np.pi) / (2 * np.pi))
    rr, cc = np.nonzero(kk[:, 1:] != kk[:, :-1])
    target = np.maximum(kk[rr, cc], kk[rr, cc + 1]) * 2 * np.pi - np.pi
    a, b = wg[rr, cc], wg[rr, cc + 1]
    fa = phase(rr, a) - target
    for _ in range(60):
        mid = 0.5 * (a + b)
        f = phase(rr, mid) - target
        same = np.sign(f) == np.sign(fa)
        a = np.where(same, mid, a)
        fa = np.where(same, f, fa)
        b = np.where(same, b, mid)
    gm = np.full(N, np.inf)
    if rr.size:
        np.minimum.at(gm, rr, -20 * np.log10(mag(rr, 0.5 * (a + b))))
    return {"gain_margin_db": gm, "phase_margin_deg": pm, "delay_margin_s": dm, "crossover_hz": fc}


def _batched_roots(c: np.ndarray) -> np.ndarray:
    """Roots of each row (ascending coefficients) via batched companion eigenvalues; NaN-padded."""
    n = degree(c)
    N, m = c.shape
    dmax = int(n.max()) if N else 0
    out = np.full((N, max(dmax, 1)), np.nan + 0j)
    for d in np.unique(n):
        if d <= 0:
            continue
        rows = np.nonzero(n == d)[0]
        cc = c[rows, : d + 1]
        comp = np.zeros((len(rows), d, d), dtype=cc.dtype)
        comp[:, 1:, :-1] = np.eye(d - 1)
        comp[:, :, -1] = -cc[:, :d] / cc[:, d : d + 1]
        out[rows, :d] = np.linalg.eigvals(comp)
    return out


def amplification(plant: Plant, cs: ControllerStructure, N: int, per_decade: int = 8):
    """DC value, −3 dB bandwidth [Hz] and minimum-phase flag of C6/C5 (SPEC §5), plus the
    output-locked stability verdict (the denominator's RHP count)."""
    num, den = amplification_qps(plant, cs, N)
    rows = np.arange(N)
    n0, _ = num.eval(rows, np.zeros(N), deriv=False)
    d0, _ = den.eval(rows, np.zeros(N), deriv=False)
    with np.errstate(divide="ignore", invalid="ignore"):
        dc = np.real(n0 / d0)
    Nz, rz, okz = rhp_count(num)
    Np, rp, okp = rhp_count(den)
    wmax = np.maximum(omega_max(num.p0, num.p1), omega_max(den.p0, den.p1)) * 1e3
    valid = np.isfinite(wmax)
    grid = log_grid(np.where(valid, wmax, 1.0), decades=12, per_decade=per_decade)
    lv = adaptive_leaves(lambda i, w: [num.eval(i, w), den.eval(i, w)], N, grid, valid)
    half = 0.5 * dc**2
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

        wb = bisect_roots(h, t, lv["a"][j], lv["b"][j], ha[j])
        bw[t] = wb / (2 * np.pi)
    # a design whose |C6/C5| never reaches DC/√2 keeps bandwidth = inf
    return {
        "dc": dc,
        "bandwidth_hz": bw,
        "minimum_phase": okz & (Nz == 0) & (rz == 0),
        "locked_stable": okp & (Np == 0) & (rp == 0),
        "conclusive": okz & okp & lv["resolved"],
    }


def coupled_stable(plant: Plant, cs: ControllerStructure, N: int, human: dict | None = None, env: dict | None = None):
    """Closed-loop verdict for specific human / environment impedances (no ranges).

    ``human``: {inertia, damping, stiffness} (any subset; None = cuff free);
    ``env``: None/"free", "locked", or {inertia, damping, stiffness}.
    Returns dict(stable, n_rhp, rigid_body_roots, conclusive) of arrays over the N designs.
    """
    ct = char_terms(plant, cs, N)
    if env == "locked":
        q = ct.qp("01") if human is None else _affine(ct, "01", "11", _zpoly(human))
        N_, r, ok = rhp_count(q)
        return {"stable": ok & (N_ == 0) & (r == 0), "n_rhp": N_, "rigid_body_roots": r, "conclusive": ok}
    zh = _zpoly(human) if human else np.zeros(1)
    ze = _zpoly(env) if isinstance(env, dict) else np.zeros(1)
    # Δ = Δ00 + z Δ10 + ze Δ01 + z ze Δ11
    t = ct.terms
    p0 = padd(padd(t["00"].p0, pmul(t["10"].p0, zh[None])), padd(pmul(t["01"].p0, ze[None]), pmul(t["11"].p0, pmul(zh, ze)[None])))
    p1 = padd(padd(t["00"].p1, pmul(t["10"].p1, zh[None])), padd(pmul(t["01"].p1, ze[None]), pmul(t["11"].p1, pmul(zh, ze)[None])))
    N_, r, ok = rhp_count(QP(_trim(p0), _trim(p1), ct.T))
    return {"stable": ok & (N_ == 0) & (r <= 1), "n_rhp": N_, "rigid_body_roots": r, "conclusive": ok}


def _zpoly(d: dict) -> np.ndarray:
    return np.array([d.get("stiffness", 0.0), d.get("damping", 0.0), d.get("inertia", 0.0)], dtype=float)


def _affine(ct: CharTerms, k0: str, k1: str, z: np.ndarray) -> QP:
    q, _ = ct.combine(k0, k1, z)
    return QP(_trim(q.p0), _trim(q.p1), q.T)


# ----------------------------------------------------------------------------------------------
# batch and single-design drivers
# ----------------------------------------------------------------------------------------------
GAIN_NAMES = ("K1", "B1", "K2", "B2", "K2_hat", "B2_hat")


def analyze_batch(cfg, max_chunk: int = 2048) -> dict:
    """Every SPEC §5 metric for a batch configuration (fields may be arrays of length N).

    Returns a dict of columns named as in SPEC §6: numpy arrays (one entry per design) and, for
    interval-valued metrics, lists of lists of [lo, hi].
    """

    N = _cfg_size(cfg)
    if N > max_chunk:
        parts = [analyze_batch(_slice_cfg(cfg, slice(i, min(i + max_chunk, N))), max_chunk) for i in range(0, N, max_chunk)]
        return _concat_columns(parts)
    cs, ds = build_controller(cfg.plant, cfg.design, cfg.implementation)
    ct = char_terms(cfg.plant, cs, N)
    out: dict = {}
    fr = free_stability(ct)
    out["free_stable"] = fr["stable"]
    out["free_rigid_body_roots"] = fr["rigid_body_roots"]
    out["free_conclusive"] = fr["conclusive"]
    for i, fam in enumerate(cfg.humans):
        D0, D1, f = _family_qps(ct, "00", "10", fam.kind, fam.param, fam.fixed(), fam.eta)
        res = family_intervals(D0, D1, f, fam.lo, fam.hi)
        key = f"human{i}_{fam.kind}"
        out[f"{key}_robust"] = res["robust"]
        out[f"{key}_stable_intervals"] = res["stable_intervals"]
        out[f"{key}_conclusive"] = res["conclusive"]
        out[f"{key}_critical"] = res["critical"]
    for i, env in enumerate(cfg.environment):
        key = f"env{i}_{env.kind}"
        if env.kind == "locked":
            Nn, r, ok = rhp_count(ct.qp("01"))
            out[f"{key}_stable"] = ok & (Nn == 0) & (r == 0)
        elif env.kind == "free":
            out[f"{key}_stable"] = fr["stable"]
        else:
            fixed = {"damping": env.damping}
            D0, D1, f = _family_qps(ct, "00", "01", env.kind, env.param, fixed, 0.0)
            res = family_intervals(D0, D1, f, env.lo, env.hi)
            out[f"{key}_robust"] = res["robust"]
            out[f"{key}_stable_intervals"] = res["stable_intervals"]
    ps = passivity(ct)
    out["passivity_max_phase_excess_deg"] = ps["max_phase_excess_deg"]
    out["passivity_nonpassive_band_hz"] = ps["nonpassive_band_hz"]
    dob = dob_margins(cs, N)
    nanv = np.full(N, np.nan)
    out["dob_phase_margin_deg"] = dob["phase_margin_deg"] if dob else nanv
    out["dob_gain_margin_db"] = dob["gain_margin_db"] if dob else nanv
    out["dob_delay_margin_s"] = dob["delay_margin_s"] if dob else nanv
    out["dob_crossover_hz"] = dob["crossover_hz"] if dob else nanv
    am = amplification(cfg.plant, cs, N)
    out["amplification_dc"] = am["dc"]
    out["amplification_bandwidth_hz"] = am["bandwidth_hz"]
    out["amplification_minimum_phase"] = am["minimum_phase"]
    out["locked_stable"] = am["locked_stable"]
    for g in GAIN_NAMES:
        out[g] = np.broadcast_to(np.asarray(getattr(ds.gains, g), dtype=float), (N,)).copy()
    return out


def _cfg_size(cfg) -> int:
    n = 1
    for obj in (cfg.plant, cfg.design, cfg.implementation):
        for v in vars(obj).values():
            for x in (v, *(vars(v).values() if hasattr(v, "__dataclass_fields__") else ())):
                if isinstance(x, np.ndarray) and x.ndim >= 1:
                    n = max(n, x.shape[0])
    return n


def _slice_dc(obj, sl):
    import dataclasses

    if obj is None or not dataclasses.is_dataclass(obj):
        return obj
    kw = {}
    for f in dataclasses.fields(obj):
        v = getattr(obj, f.name)
        if isinstance(v, np.ndarray) and v.ndim >= 1:
            kw[f.name] = v[sl]
        elif dataclasses.is_dataclass(v):
            kw[f.name] = _slice_dc(v, sl)
        else:
            kw[f.name] = v
    return dataclasses.replace(obj, **kw)


def _slice_cfg(cfg, sl):
    import dataclasses

    return dataclasses.replace(
        cfg,
        plant=_slice_dc(cfg.plant, sl),
        design=_slice_dc(cfg.design, sl),
        implementation=_slice_dc(cfg.implementation, sl),
    )


def _concat_columns(parts: list[dict]) -> dict:
    out = {}
    for k in parts[0]:
        v = parts[0][k]
        if isinstance(v, np.ndarray):
            out[k] = np.concatenate([p[k] for p in parts])
        else:
            out[k] = [x for p in parts for x in p[k]]
    return out
