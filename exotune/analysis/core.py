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

import contextlib
import gc
from dataclasses import dataclass

import numpy as np

from ..model.controller import ControllerStructure, build_controller
from ..model.humans import HumanFamily, family_split
from ..model.plant import Plant
from ..numerics.poly import pad_cols, as_poly, degree, leading, padd, pmul, pscale, psub, pval_flat, strip_common_low_zeros
from ..numerics.quasipoly import QP, bisect_roots, count_rhp, leaves_pair, log_grid, omega_max

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


def _controller_polys(cs: ControllerStructure, N: int):
    """Common-denominator form of the controller: d = Π d_x, w_x = n_x · d/d_x for the blocks on
    θ_m, τ_s, τ_c, and the DOB filter Q = n_q/d_q (n_q = 0, d_q = 1 without a DOB)."""
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
    return d_all, w_th, w_ts, w_tc, nq, dq


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
    d_all, w_th, w_ts, w_tc, nq, dq = _controller_polys(cs, N)
    dmn = psub(dq, nq)
    T = _bc(cs.delay_s, N)
    terms = {}
    for key in ("00", "10", "01", "11"):
        dd = pmul(det[key], d_all)
        S = padd(padd(pmul(w_th, Nth[key]), pmul(w_ts, Nts[key])), pmul(w_tc, Ntc[key]))
        P0 = pmul(dd, dmn)
        P1 = psub(pmul(dd, nq), pmul(dq, S))
        terms[key] = QP(trim_poly(P0), trim_poly(P1), T)
    return CharTerms(terms, T)


def trim_poly(c: np.ndarray) -> np.ndarray:
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
    d_all, w_th, w_ts, w_tc, nq, dq = _controller_polys(cs, N)
    T = _bc(cs.delay_s, N)
    Ad = pmul(A, d_all)
    P0 = pmul(Ad, psub(dq, nq))
    Sd = psub(w_th, pscale(w_ts, Ks))
    Sn = psub(Sd, pscale(w_tc, Ks))
    den = QP(trim_poly(P0), trim_poly(psub(pmul(Ad, nq), pmul(dq, Sd))), T)
    num = QP(trim_poly(P0), trim_poly(psub(pmul(Ad, nq), pmul(dq, Sn))), T)
    return num, den


# ----------------------------------------------------------------------------------------------
# stability
# ----------------------------------------------------------------------------------------------
def strip_qps(*qps: QP, max_strip=None):
    r, arrs = strip_common_low_zeros(*[a for q in qps for a in (q.p0, q.p1)], max_strip=max_strip)
    out = [QP(trim_poly(arrs[2 * i]), trim_poly(arrs[2 * i + 1]), qps[i].T) for i in range(len(qps))]
    return r, out


def rhp_count(qp: QP):
    """(N_rhp, rigid_body_roots, conclusive) with the exact s = 0 roots divided out first."""
    c = _Counter()
    h = c.add(qp.p0, qp.p1, qp.T)
    c.run()
    return c.result(h)


class _Counter:
    """Collects RHP-count tasks of several analyses and runs them in one vectorized call.

    Every task is stripped of its *exact* common low-order zero coefficients first (the rigid-body
    root at s = 0, SPEC §4); the number stripped is returned as ``rigid_body_roots``. Tasks of the
    hysteretic human carry a real "regularized" twin (k instead of k(1 + jη)) whose value at
    ω = 0 is used as Δ(j0) (see :func:`exotune.quasipoly.count_rhp`).
    """

    def __init__(self):
        self.items = []
        self.n = 0

    def add(self, p0, p1, T, reg=None, group=None):
        """Queue the rows of (p0, p1, T) [with their regularized twin ``reg``]; rows with the same
        ``group`` id (consecutive) share one work budget (``_fastphase.MAX_GROUP_EVALS``)."""
        T = np.broadcast_to(np.asarray(T, float), p0.shape[:1])
        self.items.append((p0, p1, T, reg, group))
        h = slice(self.n, self.n + p0.shape[0])
        self.n += p0.shape[0]
        return h

    def run(self, engine: str | None = None):
        """Count every queued task (compiled pipeline :func:`exotune._fastphase.count_tasks` by
        default; ``engine="numpy"``: the reference path strip → count_rhp)."""
        if self.n == 0:
            self.N = np.zeros(0, int)
            self.r = np.zeros(0, int)
            self.ok = np.zeros(0, bool)
            return
        w0 = max(i[0].shape[-1] for i in self.items)
        w1 = max(i[1].shape[-1] for i in self.items)
        cplx = any(np.iscomplexobj(i[0]) or np.iscomplexobj(i[1]) for i in self.items)
        dt = complex if cplx else float
        pad = lambda c, w: pad_cols(np.asarray(c), w).astype(dt)
        P0 = np.concatenate([pad(i[0], w0) for i in self.items])
        P1 = np.concatenate([pad(i[1], w1) for i in self.items])
        T = np.concatenate([i[2] for i in self.items])
        R0 = np.concatenate([pad(i[3][0] if i[3] is not None else i[0], w0) for i in self.items]).real
        R1 = np.concatenate([pad(i[3][1] if i[3] is not None else i[1], w1) for i in self.items]).real
        has_reg = np.concatenate([np.full(i[0].shape[0], i[3] is not None) for i in self.items])
        if (engine is None and _compiled()) or engine == "numba":
            from ..numerics import kernels as _fastphase
            from ..numerics.quasipoly import ARG_STEP, DER_STEP, MAX_LEVELS

            groups, base = [], 0
            for i in self.items:
                g = np.arange(i[0].shape[0]) if i[4] is None else np.asarray(i[4], np.int64)
                groups.append(base + g)
                base += int(g.max()) + 1 if g.size else 0
            group = np.concatenate(groups)
            self.N, self.r, self.ok = _fastphase.count_tasks(P0, P1, T, R0, R1, has_reg, ARG_STEP, DER_STEP, MAX_LEVELS,
                                                             group=group)
            return
        r, (P0s, P1s, R0s, R1s) = strip_common_low_zeros(P0, P1, R0, R1)
        v0 = np.where(has_reg, R0s[:, 0] + R1s[:, 0], np.nan)
        if not cplx:
            v0 = None
        N, ok = count_rhp(QP(trim_poly(P0s), trim_poly(P1s), T), v0=v0)
        self.N, self.r, self.ok = N, r, ok

    def result(self, h):
        return self.N[h], self.r[h], self.ok[h]


def free_stability(ct: CharTerms):
    """Free exoskeleton (cuff free, no environment): stable except for ≤ 1 rigid-body root."""
    N, r, ok = rhp_count(ct.qp("00"))
    return {"stable": ok & (N == 0) & (r <= 1), "n_rhp": N, "rigid_body_roots": r, "conclusive": ok}




class _Side:
    """One side of the loop (human at θ_h or environment at θ_j) with a list of families.

    Families with the same fixed impedance z0 share one adaptive frequency set tracking
    Δ_0 = Δ{key0} + z0 Δ{key1} and Δ{key1}; each family's crossing function is
    g(ω) = Im[Δ_0 · conj(f φ(jω) Δ{key1})] (f = 1 + jη for the hysteretic human).
    """

    def __init__(self, ct: CharTerms, key0: str, key1: str, families, per_decade: int = 2, verify: int = 0):
        self.ct, self.key0, self.key1 = ct, key0, key1
        self.verify = int(verify)
        self.fams = list(families)
        self.per_decade = per_decade
        self.groups: dict = {}
        for i, fam in enumerate(self.fams):
            z0, phi, factor = family_split(fam.kind, fam.param, fam.fixed(), fam.eta)
            self.groups.setdefault(tuple(z0), []).append((i, phi, factor))
        self.leaves = {}
        self.results = [None] * len(self.fams)

    def group_functions(self, z0):
        if not np.any(z0):  # Δ_0 = Δ{key0} (the product with z0 = 0 would add only zeros)
            A = self.ct.qp(self.key0)
            return QP(trim_poly(A.p0), trim_poly(A.p1), A.T), self.ct.qp(self.key1)
        D0, D1 = self.ct.combine(self.key0, self.key1, np.asarray(z0))
        return QP(trim_poly(D0.p0), trim_poly(D0.p1), D0.T), D1

    def compute_leaves(self, z0, extra_wmax=None):
        D0, D1 = self.group_functions(z0)
        # the functions' own tail bound (always: a group may have no family, e.g. the z0 = 0 group
        # that passivity uses), then every member family's range envelope
        wmax = np.maximum(omega_max(D0.p0, D0.p1), omega_max(D1.p0, D1.p1))
        if extra_wmax is not None:
            wmax = np.maximum(wmax, extra_wmax)
        for i, phi, factor in self.groups.get(tuple(z0), []):
            fam = self.fams[i]
            wmax = np.maximum(wmax, _family_wmax(D0, D1, phi, factor, fam.lo, fam.hi))
        valid = np.isfinite(wmax) & (wmax > 0)
        grid = log_grid(np.where(valid, wmax, 1.0), decades=6, per_decade=self.per_decade)
        lv = leaves_pair(D0, D1, grid, valid)
        lv["valid"] = valid
        self.leaves[tuple(z0)] = (D0, D1, lv)
        return self.leaves[tuple(z0)]

    def submit(self, counter: _Counter):
        """Find every family's critical values and queue its sub-interval RHP counts."""
        for z0, members in self.groups.items():
            D0, D1, lv = self.leaves.get(z0) or self.compute_leaves(z0)
            Nd = D0.n
            rows = np.arange(Nd)
            for i, phi, factor in members:
                fam = self.fams[i]
                k = int(np.nonzero(phi)[0][0])

                def g(task, w, k=k, factor=factor):
                    a, _ = D0.eval(task, w, deriv=False)
                    b, _ = D1.eval(task, w, deriv=False)
                    return np.imag(a * np.conj(factor * (1j * w) ** k * b))

                ga, gb, br, sus = _classify(lv, k, factor, fam.lo, fam.hi)
                tk, ba, bb, bga, bgb = lv["task"][br], lv["a"][br], lv["b"][br], ga[br], gb[br]
                if sus.any():
                    st, sa_, sb_ = lv["task"][sus], lv["a"][sus], lv["b"][sus]
                    sub = _subsample_brackets(g, D0, D1, k, factor, st, sa_, sb_)
                    if sub[0].size:
                        tk, ba, bb, bga, bgb = (np.concatenate([x, y]) for x, y in zip((tk, ba, bb, bga, bgb), sub))
                ws = _refine_crossings(g, D0, D1, k, factor, tk, ba, bb, bga, bgb)
                a_, _ = D0.eval(tk, ws, deriv=False)
                b_ = (factor * 1j**k) * (ws**k * D1.eval(tk, ws, deriv=False)[0])  # f (jω)^k Δ1
                with np.errstate(divide="ignore", invalid="ignore"):
                    pc = -np.real(a_ * np.conj(b_)) / np.abs(b_) ** 2
                # a real root through s = 0 at p = −Δ_0(0)/(φ Δ1)(0) (only φ = 1 can vanish there)
                z0v = np.real(D0.eval(rows, np.zeros(Nd), deriv=False)[0])
                z1v = np.real(D1.eval(rows, np.zeros(Nd), deriv=False)[0]) if k == 0 else np.zeros(Nd)
                with np.errstate(divide="ignore", invalid="ignore"):
                    p_at0 = np.where(z1v != 0, -z0v / z1v, np.nan)
                ct_ = np.concatenate([tk, rows])
                cp = np.concatenate([pc, p_at0])
                cw = np.concatenate([ws, np.zeros(Nd)])
                inside = np.isfinite(cp) & (cp > fam.lo) & (cp < fam.hi)
                ct_, cp, cw = ct_[inside], cp[inside], cw[inside]
                order = np.lexsort((cp, ct_))
                ct_, cp, cw = ct_[order], cp[order], cw[order]
                bounds, crit = _bounds(Nd, ct_, cp, cw, fam.lo, fam.hi)
                # a design with more critical values in the range than MAX_FAMILY_PIECES is not
                # counted piece by piece (each count is bounded, their number is not): inconclusive
                too_many = np.diff(bounds[1]) - 1 > MAX_FAMILY_PIECES
                rep_t, rep_p, rep_ab = _representatives(*bounds)
                if too_many.any():
                    kept = ~too_many[rep_t]
                    rep_t, rep_p, rep_ab = rep_t[kept], rep_p[kept], (rep_ab[0][kept], rep_ab[1][kept])
                h = _queue_points(counter, D0, D1, phi, factor, rep_t, rep_p)
                res = dict(bounds=bounds, crit=crit, rep_t=rep_t, rep_ab=rep_ab, handle=h,
                           leaves_ok=lv["valid"] & lv["resolved"] & ~too_many, too_many=too_many)
                if self.verify:
                    # independent check of the interval structure: exact counts at a grid of values
                    vp = np.geomspace(fam.lo, fam.hi, self.verify) if fam.lo > 0 else np.linspace(fam.lo, fam.hi, self.verify)
                    ver_t = np.repeat(np.arange(Nd), vp.size)
                    ver_p = np.tile(vp, Nd)
                    res.update(ver_t=ver_t, ver_p=ver_p, ver_handle=_queue_points(counter, D0, D1, phi, factor, ver_t, ver_p))
                self.results[i] = res

    def collect(self, counter: _Counter, allowed_rigid: int = 1):
        out = []
        for i, fam in enumerate(self.fams):
            R = self.results[i]
            N, r, ok = counter.result(R["handle"])
            st = ok & (N == 0) & (r <= allowed_rigid)
            bv, bo = R["bounds"]
            Nd = len(bo) - 1
            conclusive = R["leaves_ok"].copy()
            conclusive[R["rep_t"][~ok]] = False
            # sub-interval j of design rep_t[j] is [sa[j], sb[j]] (same order as the counts);
            # runs of consecutive stable sub-intervals of one design are the stable intervals
            t_ = R["rep_t"]
            sa, sb = R["rep_ab"]
            first = np.r_[True, t_[1:] != t_[:-1]] if t_.size else np.zeros(0, bool)
            starts = st & (first | ~np.r_[False, st[:-1]])
            ends = st & np.r_[(t_[1:] != t_[:-1]) | ~st[1:], True] if t_.size else np.zeros(0, bool)
            run_t, run_a, run_b = t_[starts], sa[starts], sb[ends]
            intervals = [[] for _ in range(Nd)]
            for t, a, b in zip(run_t.tolist(), run_a.tolist(), run_b.tolist()):
                intervals[t].append([a, b])
            nrun = np.bincount(run_t, minlength=Nd)
            whole = np.zeros(Nd, bool)
            whole[run_t[(run_a == fam.lo) & (run_b == fam.hi)]] = True
            robust = (nrun == 1) & whole
            mismatches = [[] for _ in range(Nd)]
            if "ver_handle" in R:
                Nv, rv, okv = counter.result(R["ver_handle"])
                stv = okv & (Nv == 0) & (rv <= allowed_rigid)
                for t_v, p_, s_, ok_ in zip(R["ver_t"].tolist(), R["ver_p"].tolist(), stv.tolist(), okv.tolist()):
                    edges = bv[bo[t_v] + 1: bo[t_v + 1] - 1].tolist()
                    if not ok_ or R["too_many"][t_v] or any(abs(p_ - e) <= 1e-6 * max(abs(e), 1e-300) for e in edges):
                        continue
                    if s_ != any(a <= p_ <= b for a, b in intervals[t_v]):
                        mismatches[t_v].append(p_)
                bad = np.array([bool(m) for m in mismatches], dtype=bool)
                conclusive &= ~bad
            out.append({
                "verification_mismatches": mismatches,
                "stable_intervals": intervals,
                "robust": robust & conclusive,
                "conclusive": conclusive,
                "critical": R["crit"],
            })
        return out


# More critical values than this in one family's range (one design) make the family inconclusive
# for that design: each sub-interval costs an exact count (a real design has a handful: ≤ 84 seen
# with a 50 ms delay; a degenerate one, e.g. a 1e-9 kg·m² felt inertia with a 0.2 s delay, has
# ~10⁴ and would take minutes).
MAX_FAMILY_PIECES = 1000

NEAR_REAL_RAD = 1.0  # leaves with κ this close (in angle) to the real axis at an end are sub-sampled
_SIN_NEAR = float(np.sin(NEAR_REAL_RAD))


def _classify_numpy(lv: dict, k: int, factor: complex, lo: float, hi: float):
    """Crossing function at both ends of every leaf, and which leaves hold a sign-change bracket
    or must be sub-sampled, for one family (f φ = factor·(jω)^k) of a pair's leaves ``lv``
    (numpy reference of :func:`exotune._fastphase.classify_leaves`). Returns (ga, gb, br, sus).

    Brackets are kept only when their crossing value can lie in [lo, hi]: within a leaf the phase
    of κ = −Δ_0/(fφΔ1) moves < 1 rad, so a crossing at p > 0 has Re κ > 0 at an end; |κ| is bounded
    loosely (factor 1e3) from the end values. A leaf can hold several crossings (an even number
    without a sign change at its ends, or three with one) when κ comes near the positive real
    axis — e.g. a nearly decoupled light mass on the cuff spring at high frequency, where the delay
    makes Im κ ripple with period 2π/T. The leaf criteria bound each function's phase step
    (< 0.8 rad) and its departure from the trapezoid estimate (≤ 0.5 rad), so arg κ cannot swing by
    ≳ 1 rad inside a leaf and back: every plausible leaf with κ within NEAR_REAL_RAD of the real
    axis at an end is sub-sampled (≥ 8 points, ≥ 8 per ripple period) by the caller."""
    # f (jω)^k v as a complex constant times a real power (no complex power)
    fl = lambda v, w: (factor * 1j**k) * (w**k * v)  # noqa: E731
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        fva, fvb = fl(lv["va"][1], lv["a"]), fl(lv["vb"][1], lv["b"])
        ga = np.imag(lv["va"][0] * np.conj(fva))
        gb = np.imag(lv["vb"][0] * np.conj(fvb))
        br = (np.sign(ga) * np.sign(gb) < 0) & (lv["a"] > 0)
        ka = -lv["va"][0] / fva
        kb = -lv["vb"][0] / fvb
    kmin = np.minimum(np.abs(ka), np.abs(kb))
    kmax = np.maximum(np.abs(ka), np.abs(kb))
    plausible = ((ka.real > 0) | (kb.real > 0)) & ~(kmax * 1e3 < lo) & ~(kmin > hi * 1e3)
    br &= plausible | ~np.isfinite(kmax)
    with np.errstate(divide="ignore", invalid="ignore"):
        near_real = (np.abs(ka.imag) <= _SIN_NEAR * np.abs(ka)) | (np.abs(kb.imag) <= _SIN_NEAR * np.abs(kb))
    sus = (lv["a"] > 0) & plausible & near_real & ~(kmax * 4.0 < lo) & ~(kmin > hi * 4.0)
    br &= ~sus
    return ga, gb, br, sus


def _classify(lv: dict, k: int, factor: complex, lo: float, hi: float):
    """:func:`_classify_numpy`, compiled when available; leaves with a zero or non-finite value
    (where numpy's complex inf/nan rules decide) go through the numpy reference."""
    if not _compiled():
        return _classify_numpy(lv, k, factor, lo, hi)
    from ..numerics import kernels as _fastphase

    ga, gb, br, sus, deg = _fastphase.classify_leaves(lv, k, factor, lo, hi, _SIN_NEAR)
    if deg.any():
        sub = {"a": lv["a"][deg], "b": lv["b"][deg], "va": [lv["va"][0][deg], lv["va"][1][deg]],
               "vb": [lv["vb"][0][deg], lv["vb"][1][deg]]}
        _, _, br[deg], sus[deg] = _classify_numpy(sub, k, factor, lo, hi)
    return ga, gb, br, sus


def _compiled() -> bool:
    from ..numerics.engine import compiled

    return compiled()


def _subsample_brackets(g, D0: QP, D1: QP, k: int, factor: complex, st, sa, sb):
    """Sign-change brackets (task, a, b, g(a), g(b)) of the crossing function g on M equally
    spaced points of each leaf [sa, sb] (ends included; M ≥ 8 and ≥ 8 per delay ripple period
    2π/T, at most 512); compiled when available."""
    if _compiled():
        from ..numerics import kernels as _fastphase

        return _fastphase.subsample_brackets(D0, D1, k, factor, st, sa, sb)
    Tt = D0.T[st]
    per = np.where(Tt > 0, 2 * np.pi / np.maximum(Tt, 1e-300), np.inf)
    M = np.clip(np.ceil(8.0 * (sb - sa) / per), 8, 512).astype(int)
    rep = np.repeat(np.arange(len(st)), M)
    # M points per leaf, both ends included (a sign change at the ends is kept)
    frac = (np.arange(rep.size) - np.repeat(np.cumsum(M) - M, M)) / np.repeat(M - 1, M)
    wsub = sa[rep] + frac * (sb - sa)[rep]
    gsub = _pair_values(g, D0, D1, "cross", st[rep], wsub, k=k, factor=factor)
    nxt = np.r_[rep[1:] == rep[:-1], False]
    j = np.nonzero(nxt & (np.sign(gsub) * np.sign(np.r_[gsub[1:], 0.0]) < 0))[0]
    return st[rep[j]], wsub[j], wsub[j + 1], gsub[j], gsub[j + 1]


def _refine_crossings(g, D0: QP, D1: QP, k: int, factor: complex, task, a, b, fa, fb):
    """Zeros of the crossing function g on its brackets (compiled Illinois when available)."""
    return _pair_roots(g, D0, D1, "cross", task, a, b, fa, fb, k=k, factor=factor)


def _pair_roots(fun, qa: QP, qb: QP, mode: str, task, a, b, fa, fb, k: int = 0, factor: complex = 1.0, c=None):
    """Illinois refinement of sign-change brackets of ``fun`` (numpy reference), or of the same
    function compiled (:func:`exotune._fastphase.pair_roots`, ``mode``/``k``/``factor``/``c``)."""
    if _compiled():
        from ..numerics import kernels as _fastphase

        return _fastphase.pair_roots(qa, qb, mode, task, a, b, fa, fb, k=k, factor=factor, c=c)
    return bisect_roots(fun, task, a, b, fa, fb=fb)


def _pair_values(fun, qa: QP, qb: QP, mode: str, task, w, k: int = 0, factor: complex = 1.0, c=None):
    """``fun(task, w)`` (numpy reference) or the same function compiled."""
    if _compiled():
        from ..numerics import kernels as _fastphase

        return _fastphase.pair_values(qa, qb, mode, task, w, k=k, factor=factor, c=c)
    return fun(task, w)


def _queue_points(counter: _Counter, D0: QP, D1: QP, phi, factor: complex, rows: np.ndarray, p: np.ndarray):
    """Queue exact RHP counts of Δ(s; p) = D0 + p f φ D1 for the given (design row, p) pairs
    (complex coefficients with the real regularized twin for the hysteretic human)."""
    phi_arr = np.asarray(phi, float)
    D1p0 = pmul(D1.p0, phi_arr[None, :])
    D1p1 = pmul(D1.p1, phi_arr[None, :])
    reg = None
    if factor.imag != 0:
        reg = (padd(D0.p0[rows], p[:, None] * D1p0[rows]), padd(D0.p1[rows], p[:, None] * D1p1[rows]))
    P0 = padd(D0.p0[rows].astype(complex if reg else float), (factor if reg else 1.0) * p[:, None] * D1p0[rows])
    P1 = padd(D0.p1[rows].astype(complex if reg else float), (factor if reg else 1.0) * p[:, None] * D1p1[rows])
    return counter.add(P0, P1, D0.T[rows], reg, group=rows)


def _bounds(Nd, ct_, cp, cw, lo, hi):
    """Sub-interval bounds of every design, flat: design t owns ``bv[bo[t]:bo[t + 1]]`` = lo, its
    distinct critical values (ascending), hi; and the list of critical (value, frequency [Hz]) per
    design. The crossings arrive sorted by (design, value); a value within 1e-12 (relative) of the
    last kept one of its design is the same critical value."""
    crit = [[] for _ in range(Nd)]
    keep = np.zeros(len(cp), bool)
    last_t, last_p = -1, lo
    for j, (t, p, w) in enumerate(zip(ct_.tolist(), cp.tolist(), cw.tolist())):
        crit[t].append((p, w / (2 * np.pi)))
        if t != last_t:
            last_t, last_p = t, lo
        if p > last_p * (1 + 1e-12):
            keep[j] = True
            last_p = p
    tk, pk = ct_[keep], cp[keep]
    nk = np.bincount(tk, minlength=Nd)
    bo = np.r_[0, np.cumsum(nk + 2)]
    bv = np.empty(bo[-1])
    bv[bo[:-1]] = lo
    bv[bo[1:] - 1] = hi
    kstart = np.r_[0, np.cumsum(nk)][:-1]
    bv[bo[tk] + 1 + np.arange(tk.size) - kstart[tk]] = pk
    return (bv, bo), crit


def _representatives(bv, bo):
    """One value inside each sub-interval (geometric mean when positive): (design, value, (a, b))."""
    Nd = len(bo) - 1
    last = np.zeros(len(bv), bool)
    last[bo[1:] - 1] = True
    j = np.nonzero(~last)[0]
    a, b = bv[j], bv[j + 1]
    rep_t = np.repeat(np.arange(Nd), np.diff(bo) - 1)
    with np.errstate(invalid="ignore"):
        rep_p = np.where((a > 0) & (b > 0), np.sqrt(a * b), 0.5 * (a + b))
    return rep_t, rep_p, (a, b)


def _family_wmax(D0: QP, D1: QP, phi, factor, lo, hi):
    """A tail frequency valid for every p in [lo, hi] (coefficients are affine in p)."""
    phi = np.asarray(phi, float)
    real = not any(np.iscomplexobj(x) for x in (D0.p0, D0.p1, D1.p0, D1.p1))
    if real and _compiled():
        from ..numerics import kernels as _fastphase

        return _fastphase.family_wmax(D0.p0, D0.p1, D1.p0, D1.p1, phi, factor, lo, hi)
    B0 = pmul(D1.p0, phi[None, :]).astype(complex) * factor
    B1 = pmul(D1.p1, phi[None, :]).astype(complex) * factor
    n0 = max(D0.p0.shape[-1], B0.shape[-1])
    n1 = max(D0.p1.shape[-1], B1.shape[-1])
    pad = lambda c, n: np.pad(c, ((0, 0), (0, n - c.shape[-1])))
    A0, B0 = pad(D0.p0, n0).astype(complex), pad(B0, n0)
    A1, B1 = pad(D0.p1, n1).astype(complex), pad(B1, n1)
    lo_c, hi_c = A0 + lo * B0, A0 + hi * B0
    env0 = np.maximum(np.abs(lo_c), np.abs(hi_c))
    env1 = np.maximum(np.abs(A1 + lo * B1), np.abs(A1 + hi * B1))
    nlo, nhi = degree(lo_c), degree(hi_c)
    cmin = _min_abs_affine(leading(lo_c), leading(hi_c), nlo, nhi)
    rows = np.arange(D0.n)
    env0[rows, np.maximum(nlo, 0)] = np.where(nlo == nhi, cmin, 0.0)
    w = omega_max(env0, env1)
    return np.where((nlo == nhi) & (cmin > 0), w, np.inf)


def family_intervals(ct: CharTerms, fam: HumanFamily, key0: str = "00", key1: str = "10"):
    """Exact stable sub-intervals of one family (convenience wrapper around :class:`_Side`)."""
    side = _Side(ct, key0, key1, [fam])
    c = _Counter()
    side.submit(c)
    c.run()
    return side.collect(c)[0]


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
    """C7(jω) = Δ10/Δ00 for every design (rows) at frequencies w (N, K) [rad/(N·m)]."""
    N = ct.T.shape[0]
    idx = np.repeat(np.arange(N), w.shape[1])
    a, _ = ct.qp("00").eval(idx, w.ravel(), deriv=False)
    b, _ = ct.qp("10").eval(idx, w.ravel(), deriv=False)
    return (b / a).reshape(w.shape)


BAND_MIN_EXCESS_DEG = 0.1


def passivity(side: _Side):
    """max_phase_excess_deg and nonpassive_band_hz of C7 = Δ10/Δ00 (SPEC §5).

    Passive phase band: arg C7 ∈ [−180°, 0°] ⇔ Im C7(jω) ≤ 0. The excess is the angular distance
    of the (wrapped) phase from that band, min(φ, 180° − φ) for φ ∈ (0°, 180°); its maximum is
    refined by golden-section search. Band edges are the exact zeros of Im C7. With a delay,
    C7 → 1/K_c with a decaying ripple of period 1/T in frequency, giving infinitely many tiny
    bands: bands whose peak excess is below ``BAND_MIN_EXCESS_DEG`` (0.1°) are not listed
    (``max_phase_excess_deg`` itself is exact, and the band holding it is listed whenever it
    reaches 0.1°; other bands are judged by their sampled peak).
    """
    z0 = (0.0, 0.0, 0.0)
    D0, D1, lv = side.leaves.get(z0) or side.compute_leaves(z0)
    Nd = D0.n

    def c7(task, w):
        a, _ = D0.eval(task, w, deriv=False)
        b, _ = D1.eval(task, w, deriv=False)
        return b / a

    def excess(c):
        ph = np.degrees(np.angle(c))
        return np.where(ph > 0, np.minimum(ph, 180.0 - ph), 0.0)

    def excess_where(c, im):
        # excess(c) where it can be positive (Im c > 0 ⇔ phase in (0°, 180°)), 0 elsewhere and
        # where c is not finite; the same values as excess(c) without the angles of the rest
        out = np.zeros(c.shape)
        sel = (im > 0) & np.isfinite(c)
        out[sel] = excess(c[sel])
        return out

    pos = lv["a"] > 0
    # the leaves with a > 0 (all of them unless a grid starts at ω = 0): no copies when all
    on = (lambda x: x) if pos.all() else (lambda x: x[pos])  # noqa: E731
    task = on(lv["task"])
    a_l, b_l = on(lv["a"]), on(lv["b"])
    with np.errstate(divide="ignore", invalid="ignore"):
        cb = on(lv["vb"][1]) / on(lv["vb"][0])
    imb = np.imag(cb)
    leaf = np.flatnonzero(pos)

    def ima(k):  # Im C7 at the a-end of leaves k (only the bracketing leaves need it)
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.imag(lv["va"][1][leaf[k]] / lv["va"][0][leaf[k]])

    exb = excess_where(cb, imb)
    best = np.zeros(Nd)
    np.maximum.at(best, task, exb)
    arg = _argmax_by_task(task, exb, Nd)
    have = arg >= 0
    if have.any():
        ti = np.nonzero(have)[0]
        j = arg[ti]
        nxt = np.minimum(j + 1, len(b_l) - 1)
        a_ = a_l[j]
        b_ = np.where(task[nxt] == ti, b_l[nxt], b_l[j])
        if _compiled():
            from ..numerics import kernels as _fastphase

            peak = _fastphase.golden_max(D0, D1, "excess", ti, a_, b_, iters=40)
        else:
            f = lambda w: excess(c7(ti, w))
            gr = 0.5 * (np.sqrt(5) - 1)
            c1 = b_ - gr * (b_ - a_)
            c2 = a_ + gr * (b_ - a_)
            f1, f2 = f(c1), f(c2)
            for _ in range(40):  # golden section, one new evaluation per iteration
                left = f1 >= f2
                b_ = np.where(left, c2, b_)
                a_ = np.where(left, a_, c1)
                c2n = np.where(left, c1, a_ + gr * (b_ - a_))
                c1n = np.where(left, b_ - gr * (b_ - a_), c2)
                new = np.where(left, c1n, c2n)
                fn = f(new)
                f1, f2 = np.where(left, fn, f2), np.where(left, f1, fn)
                c1, c2 = c1n, c2n
            peak = f(0.5 * (a_ + b_))
        best[ti] = np.maximum(best[ti], peak)
    # bands = runs of consecutive samples with Im C7 > 0; only runs whose sampled peak excess
    # reaches the threshold get their two edges refined (exact zeros of Im C7)
    # the sign of Im C7 is only trusted above the float resolution (|Im C7| > 1e-8 |C7|); samples
    # below it inherit the state of the previous sample of the same design, so rounding noise in
    # the high-frequency tail (C7 → 1/K_c) neither splits nor ends a band
    resolved_sign = np.abs(imb) > 1e-8 * np.abs(cb)
    inside = imb > 0
    if task.size:
        first_of_task = np.r_[True, task[1:] != task[:-1]]
        keep = resolved_sign | first_of_task
        last = np.maximum.accumulate(np.where(keep, np.arange(task.size), 0))
        inside = inside[last]
        # the a-end of a leaf is the b-end of the previous leaf of the same design
        resolved_a = np.r_[False, resolved_sign[:-1]] & ~first_of_task
    else:
        resolved_a = np.zeros(0, bool)
    if task.size:
        newrun = np.r_[True, (task[1:] != task[:-1]) | (inside[1:] != inside[:-1])]
    else:
        newrun = np.zeros(0, bool)
    rid = np.cumsum(newrun) - 1
    nrun = int(rid[-1]) + 1 if rid.size else 0
    peak = np.zeros(nrun)
    np.maximum.at(peak, rid, exb)
    if have.any():  # the refined maximum counts for the band that holds its leaf
        np.maximum.at(peak, rid[j], np.where(np.isfinite(best[ti]), best[ti], 0.0))
    starts = np.nonzero(newrun)[0]
    qual = inside[starts] & (peak >= BAND_MIN_EXCESS_DEG)
    qs = starts[qual]
    # the run after each qualifying run (same task) holds the closing edge in its first leaf
    nxt_run = np.searchsorted(starts, qs, side="right")
    has_end = nxt_run < len(starts)
    je = np.where(has_end, starts[np.minimum(nxt_run, len(starts) - 1)], -1)
    has_end &= task[np.maximum(je, 0)] == task[qs]
    fim = lambda t_, w: np.imag(c7(t_, w))
    # the band edges are the zeros of Im C7 = Im(Δ10/Δ00); the compiled refinement uses the same
    # zeros of Im(Δ00·conj Δ10) = −|Δ00|² Im C7 (no division): its bracket values change sign
    # (computed for the bracketing leaves only; index k among the leaves with a > 0)
    def gva(k):
        with np.errstate(over="ignore", invalid="ignore"):  # only their signs are used
            return np.imag(lv["va"][0][leaf[k]] * np.conj(lv["va"][1][leaf[k]]))

    def gvb(k):
        with np.errstate(over="ignore", invalid="ignore"):
            return np.imag(lv["vb"][0][leaf[k]] * np.conj(lv["vb"][1][leaf[k]]))

    bracket_start = (np.sign(ima(qs)) != np.sign(imb[qs])) & resolved_sign[qs] & resolved_a[qs]
    ws = a_l[qs].copy()
    if bracket_start.any():
        k = qs[bracket_start]
        ws[bracket_start] = _edge_roots(fim, D0, D1, task[k], a_l[k], b_l[k], ima(k), imb[k], gva(k), gvb(k))
    we = np.full(len(qs), np.inf)
    jj = np.maximum(je, 0)
    closes = has_end & (np.sign(ima(jj)) != np.sign(imb[jj])) & resolved_sign[jj] & resolved_a[jj]
    we[has_end & ~closes] = b_l[np.maximum(je, 0)][has_end & ~closes] if (has_end & ~closes).any() else we[has_end & ~closes]
    has_end = closes
    if has_end.any():
        k = je[has_end]
        we[has_end] = _edge_roots(fim, D0, D1, task[k], a_l[k], b_l[k], ima(k), imb[k], gva(k), gvb(k))
    bands = [[] for _ in range(Nd)]
    for t_, w0, w1 in zip(task[qs].tolist(), ws.tolist(), we.tolist()):
        bands[t_].append([w0 / (2 * np.pi), w1 / (2 * np.pi)])
    exh = lv.get("exhausted")
    if exh is not None and exh.any():  # partial frequency coverage: the metrics are undefined
        best[exh] = np.nan
        for t in np.flatnonzero(exh):
            bands[t] = []
    return {"max_phase_excess_deg": best, "nonpassive_band_hz": bands, "conclusive": lv["valid"] & lv["resolved"]}


def _edge_roots(fim, D0, D1, task, a, b, ima, imb, ga, gb):
    if _compiled():
        return _pair_roots(None, D0, D1, "cross", task, a, b, ga, gb)
    return bisect_roots(fim, task, a, b, ima, fb=imb)


def _argmax_by_task(task, vals, Nd):
    """Index of the largest positive value of each task (-1 when none); ties: the last index."""
    out = np.full(Nd, -1)
    if task.size == 0:
        return out
    best = np.full(Nd, -np.inf)
    np.maximum.at(best, task, vals)
    hit = np.nonzero((vals == best[task]) & (vals > 0))[0]
    # indices ascending: for repeated tasks the last assignment (largest index) wins
    out[task[hit]] = hit
    return out


def _first_by_task(task, Nd):
    out = np.full(Nd, -1)
    if task.size == 0:
        return out
    first = np.r_[True, task[1:] != task[:-1]]
    out[task[first]] = np.nonzero(first)[0]
    return out


def dob_margins(cs: ControllerStructure, N: int):
    """Gain [dB], phase [deg] and delay [s] margins of L_dob = Q e^{−sT}/(1 − Q) (SPEC §5), and
    whether the closed DOB loop is stable (delay margin 0 when it is not).

    Gain crossovers are the positive real roots of |n_q(jω)|² − |(d_q − n_q)(jω)|² (a polynomial
    in ω); delay margin = min_k PM_k/ω_k with PM_k ∈ [0, 2π). Phase crossovers (arg L = −180° mod
    360°) are bracketed on a dense log grid of the continuous phase (from the roots of n_q and
    d_q − n_q, so no unwrapping) and bisected; gain margin = min over them of 1/|L|.
    """
    if cs.dob_q is None:
        return None
    nq = np.broadcast_to(cs.dob_q.num, (N,) + cs.dob_q.num.shape[-1:]).astype(float)
    dq = np.broadcast_to(cs.dob_q.den, (N,) + cs.dob_q.den.shape[-1:]).astype(float)
    T = _bc(cs.delay_s, N)
    # the margins depend on (Q, T) only: compute once per distinct row (sweeps repeat them)
    key = np.concatenate([nq, dq, T[:, None]], axis=1)
    uniq, inv = np.unique(key, axis=0, return_inverse=True)
    inv = inv.ravel()
    if len(uniq) < N:
        nu = nq.shape[1]
        res = _dob_margins_rows(uniq[:, :nu], uniq[:, nu:-1], uniq[:, -1])
        return {k: v[inv] for k, v in res.items()}
    return _dob_margins_rows(nq, dq, T)


def _dob_margins_standard(nq, dq, T):
    """Closed forms for the standard Q = ω_q²/(s² + 2ζω_q s + ω_q²) (SPEC §3):
    L_dob = ω_q² e^{−sT}/(s (s + a)), a = 2ζω_q, has monotone gain and phase, one gain crossover
    ω_c = ω_q √(√(4ζ⁴ + 1) − 2ζ²), unwrapped PM = π/2 − atan(ω_c/a) − ω_c T, and the smallest gain
    margin at the first −180° crossing, π/2 − atan(ω/a) − ωT = 0 (bisected on [0, π/(2T)])."""
    wq2 = nq[:, 0]
    a = dq[:, 1]
    wq = np.sqrt(wq2)
    zeta = a / (2 * wq)
    wc = wq * np.sqrt(np.sqrt(4 * zeta**4 + 1) - 2 * zeta**2)
    pm_unwrapped = np.pi / 2 - np.arctan(wc / a) - wc * T
    pm_k = np.mod(pm_unwrapped, 2 * np.pi)
    pm = np.degrees(np.where(pm_k > np.pi, pm_k - 2 * np.pi, pm_k))
    dm = pm_k / wc
    lo = np.zeros_like(T)
    hi = np.where(T > 0, np.pi / (2 * np.maximum(T, 1e-300)), 1.0)
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        f = np.pi / 2 - np.arctan(mid / a) - mid * T
        lo = np.where(f > 0, mid, lo)
        hi = np.where(f > 0, hi, mid)
    wp = 0.5 * (lo + hi)
    with np.errstate(over="ignore", divide="ignore"):  # T → 0+: the margin → +inf
        gm = np.where(T > 0, -20 * np.log10(wq2 / (wp * np.hypot(wp, a))), np.inf)
    return {"gain_margin_db": gm, "phase_margin_deg": pm, "delay_margin_s": dm, "crossover_hz": wc / (2 * np.pi)}


def _dob_margins_rows(nq, dq, T):
    N = len(T)
    m = psub(dq, nq)
    standard = (nq.shape[1] == 1) and (dq.shape[1] == 3) and np.all(dq[:, 2] == 1) and np.all(dq[:, 0] == nq[:, 0])
    if standard:
        out = _dob_margins_standard(nq, dq, T)
        Nd, rd, okd = rhp_count(QP(trim_poly(m), trim_poly(nq), T))
        stable = okd & (Nd == 0) & (rd == 0)
        out["delay_margin_s"] = np.where(stable, out["delay_margin_s"], 0.0)
        out["stable"] = stable
        return out
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
    K = 400
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
    # closed DOB loop 1 + L_dob ∝ (d_q − n_q) + n_q e^{−sT}: if it is already unstable the loop
    # tolerates no extra delay — the wrapped PM_k/ω_k of SPEC §5 would read as a (misleading)
    # positive margin, so the delay margin is 0 then
    Nd, rd, okd = rhp_count(QP(trim_poly(m), trim_poly(nq), T))
    stable = okd & (Nd == 0) & (rd == 0)
    dm = np.where(stable, dm, 0.0)
    return {"gain_margin_db": gm, "phase_margin_deg": pm, "delay_margin_s": dm, "crossover_hz": fc, "stable": stable}


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


def _amp_dc_bandwidth(num: QP, den: QP, per_decade: int = 2):
    """DC value and first −3 dB frequency [Hz] of C6/C5 = num/den (inf when never reached)."""
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
        # −3 dB level if the margin exceeds a slope-and-curvature bound; shallower approaches
        # (< 0.01 neper ≈ 0.09 dB) and ends already below are accepted.
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            fa = np.log(np.abs(va[0] / va[1]))
            fb = np.log(np.abs(vb[0] / vb[1]))
            La = da[0] / va[0] - da[1] / va[1]
            Lb = db[0] / vb[0] - db[1] / vb[1]
            h = b - a
            margin = np.minimum(fa, fb) - lthr[task]
            dip = 0.5 * h * np.maximum(np.abs(La.imag), np.abs(Lb.imag)) + 0.125 * h * np.abs(Lb - La)
        return ~np.isfinite(margin) | (margin <= 0.01) | (margin > dip)

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

        wb = _pair_roots(h, num, den, "mag", t, lv["a"][j], lv["b"][j], ha[j], hb[j], c=half)
        bw[t] = wb / (2 * np.pi)
    exh = lv.get("exhausted")
    if exh is not None:  # the search spent its budget before the −3 dB level: undefined
        bw[exh] = np.nan
    return dc, bw


def amplification(plant: Plant, cs: ControllerStructure, N: int):
    """DC value, −3 dB bandwidth [Hz] and minimum-phase flag of C6/C5 (SPEC §5), plus the
    output-locked stability verdict (the denominator's RHP count)."""
    num, den = amplification_qps(plant, cs, N)
    Nz, rz, okz = rhp_count(num)
    Np, rp, okp = rhp_count(den)
    dc, bw = _amp_dc_bandwidth(num, den)
    return {
        "dc": dc,
        "bandwidth_hz": bw,
        "minimum_phase": okz & (Nz == 0) & (rz == 0),
        "locked_stable": okp & (Np == 0) & (rp == 0),
        "conclusive": okz & okp,
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
    zh = np.broadcast_to(_zpoly(human) if human else np.zeros(1), (N, 3 if human else 1))
    ze = np.broadcast_to(_zpoly(env) if isinstance(env, dict) else np.zeros(1), (N, 3 if isinstance(env, dict) else 1))
    # Δ = Δ00 + z Δ10 + ze Δ01 + z ze Δ11
    t = ct.terms
    p0 = padd(padd(t["00"].p0, pmul(t["10"].p0, zh)), padd(pmul(t["01"].p0, ze), pmul(t["11"].p0, pmul(zh, ze))))
    p1 = padd(padd(t["00"].p1, pmul(t["10"].p1, zh)), padd(pmul(t["01"].p1, ze), pmul(t["11"].p1, pmul(zh, ze))))
    N_, r, ok = rhp_count(QP(trim_poly(p0), trim_poly(p1), ct.T))
    return {"stable": ok & (N_ == 0) & (r <= 1), "n_rhp": N_, "rigid_body_roots": r, "conclusive": ok}


def _zpoly(d: dict) -> np.ndarray:
    """[k, b, m] ascending coefficients of Z(s) = k + b s + m s²; values may be arrays (per design)."""
    return as_poly(*(np.asarray(d.get(k, 0.0), dtype=float) for k in ("stiffness", "damping", "inertia")))


def _affine(ct: CharTerms, k0: str, k1: str, z: np.ndarray) -> QP:
    q, _ = ct.combine(k0, k1, z)
    return QP(trim_poly(q.p0), trim_poly(q.p1), q.T)


# ----------------------------------------------------------------------------------------------
# batch and single-design drivers
# ----------------------------------------------------------------------------------------------
GAIN_NAMES = ("K1", "B1", "K2", "B2", "K2_hat", "B2_hat")


def analyze_batch(cfg, max_chunk: int = 2048, verify: int = 0) -> dict:
    """Every SPEC §5 metric for a batch configuration (fields may be arrays of length N).

    Returns a dict of columns named as in SPEC §6: numpy arrays (one entry per design) and, for
    interval-valued metrics, lists of lists of [lo, hi].

    ``verify`` > 0 additionally counts RHP roots exactly at that many log-spaced values of every
    family's range and checks them against the intervals; a mismatch makes the family
    inconclusive (hence not robust) and is listed in ``human{i}_{kind}_verification_mismatches``.
    The single-design report uses 64; sweeps use 0 (the interval method alone).
    """

    # extreme designs overflow intermediate numbers; every result is checked for finiteness and
    # reported inconclusive, so numpy's warnings would only clutter a sweep's terminal
    with _gc_paused(), np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        N = _cfg_size(cfg)
        if N > max_chunk:
            parts = [_analyze_chunk(_slice_cfg(cfg, slice(i, min(i + max_chunk, N))), verify) for i in range(0, N, max_chunk)]
            return _concat_columns(parts)
        return _analyze_chunk(cfg, verify)


@contextlib.contextmanager
def _gc_paused():
    """The interval columns are lists of small lists (one per design): allocating them lets
    Python's cyclic garbage collector re-scan every live container again and again (it was a
    third of the run time). The analysis creates no reference cycles, so it is paused here."""
    was = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if was:
            gc.enable()


def _analyze_chunk(cfg, verify: int) -> dict:
    N = _cfg_size(cfg)
    cs, ds = build_controller(cfg.plant, cfg.design, cfg.implementation)
    ct = char_terms(cfg.plant, cs, N)
    out: dict = {}
    counter = _Counter()
    h_free = counter.add(ct.qp("00").p0, ct.qp("00").p1, ct.T)
    num, den = amplification_qps(cfg.plant, cs, N)
    h_num = counter.add(num.p0, num.p1, num.T)
    h_den = counter.add(den.p0, den.p1, den.T)
    # box families (several ranged msd parameters) are analysed through their edges
    edge_fams, edge_of = [], []
    for fam in cfg.humans:
        es = fam.edges()
        edge_of.append(list(range(len(edge_fams), len(edge_fams) + len(es))))
        edge_fams.extend(es)
    human = _Side(ct, "00", "10", edge_fams, verify=verify)
    human.compute_leaves((0.0, 0.0, 0.0))  # shared with passivity
    human.submit(counter)
    env_fams = [e for e in cfg.environment if e.kind in ("spring", "mass")]
    env_side = _Side(ct, "00", "01", [HumanFamily(e.kind, e.param, e.lo, e.hi, damping=e.damping) for e in env_fams])
    env_side.submit(counter)
    counter.run()
    Nf, rf, okf = counter.result(h_free)
    free_stable = okf & (Nf == 0) & (rf <= 1)
    out["free_stable"] = free_stable
    out["free_rigid_body_roots"] = rf
    out["free_conclusive"] = okf
    edge_res = human.collect(counter)
    for i, fam in enumerate(cfg.humans):
        key = f"human{i}_{fam.kind}"
        if not fam.box:
            res = edge_res[edge_of[i][0]]
            out[f"{key}_robust"] = res["robust"]
            out[f"{key}_stable_intervals"] = res["stable_intervals"]
            out[f"{key}_conclusive"] = res["conclusive"]
            out[f"{key}_critical"] = res["critical"]
            if verify:
                out[f"{key}_verification_mismatches"] = res["verification_mismatches"]
            continue
        # Edge Theorem: the box is robustly stable iff every edge is; the stable set of a box is
        # not one interval, so the interval column holds [[lo, hi]] of the first ranged parameter
        # when the whole box is stable and [] otherwise (per-edge details: analyze_design)
        ers = [edge_res[j] for j in edge_of[i]]
        robust = np.logical_and.reduce([r["robust"] for r in ers])
        out[f"{key}_robust"] = robust
        out[f"{key}_stable_intervals"] = [[[fam.lo, fam.hi]] if rb else [] for rb in robust]
        out[f"{key}_conclusive"] = np.logical_and.reduce([r["conclusive"] for r in ers])
        out[f"{key}_critical"] = [[] for _ in range(N)]  # per edge (different parameters): see _edges
        out[f"{key}_edges"] = [[(edge_fams[j], ers[k]["stable_intervals"][t_]) for k, j in enumerate(edge_of[i])] for t_ in range(N)]
        if verify:
            out[f"{key}_verification_mismatches"] = [[m for r in ers for m in r["verification_mismatches"][t_]] for t_ in range(N)]
    Nn, rn, okn = counter.result(h_num)
    Nd_, rd, okd = counter.result(h_den)
    locked_stable = okd & (Nd_ == 0) & (rd == 0)
    env_res = iter(env_side.collect(counter))
    for i, env in enumerate(cfg.environment):
        key = f"env{i}_{env.kind}"
        if env.kind == "locked":
            out[f"{key}_stable"] = locked_stable
        elif env.kind == "free":
            out[f"{key}_stable"] = free_stable
        else:
            res = next(env_res)
            out[f"{key}_robust"] = res["robust"]
            out[f"{key}_stable_intervals"] = res["stable_intervals"]
    ps = passivity(human)
    out["passivity_conclusive"] = ps["conclusive"]
    out["passivity_max_phase_excess_deg"] = ps["max_phase_excess_deg"]
    out["passivity_nonpassive_band_hz"] = ps["nonpassive_band_hz"]
    dob = dob_margins(cs, N)
    nanv = np.full(N, np.nan)
    out["dob_phase_margin_deg"] = dob["phase_margin_deg"] if dob else nanv
    out["dob_gain_margin_db"] = dob["gain_margin_db"] if dob else nanv
    out["dob_delay_margin_s"] = dob["delay_margin_s"] if dob else nanv
    out["dob_crossover_hz"] = dob["crossover_hz"] if dob else nanv
    out["dob_stable"] = dob["stable"] if dob else np.ones(N, bool)
    dc, bw = _amp_dc_bandwidth(num, den)
    out["amplification_dc"] = dc
    out["amplification_bandwidth_hz"] = bw
    out["amplification_minimum_phase"] = okn & (Nn == 0) & (rn == 0)
    out["amplification_conclusive"] = okn  # False: the minimum-phase verdict is unknown (reported False)
    out["locked_stable"] = locked_stable
    out["locked_conclusive"] = okd
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


# ----------------------------------------------------------------------------------------------
# single design (CLI)
# ----------------------------------------------------------------------------------------------
METRIC_UNITS = {
    "passivity.max_phase_excess_deg": "deg",
    "passivity.nonpassive_band_hz": "Hz",
    "passivity.kyp.*.shortage": "rad/(N·m·s) (admittance: −min Re{jω C7(jω)}, 0 when passive)",
    "passivity.kyp.*.lossless_compliance": "rad/(N·m) (the q1 of the lossless term q1·s of s·C7; 1/K_c)",
    "passivity.kyp.*.relative_shortage": "1 (shortage / largest Hankel singular value of the strictly proper part)",
    "passivity.kyp.*.truncation_bound": "rad/(N·m·s)",
    "passivity.kyp.*.shortage_upper": "rad/(N·m·s) (the SDP's d*, an upper bound on the shortage)",
    "passivity.kyp.*.witness_frequency_hz": "Hz (where Re{jω C7} is smallest: the non-passivity witness)",
    "passivity.kyp.*.certificate_residual": "1 (largest eigenvalue of the LMI at the solution / its norm)",
    "dob.gain_margin_db": "dB",
    "dob.phase_margin_deg": "deg",
    "dob.delay_margin_s": "s (extra delay on top of the modelled T)",
    "dob.crossover_hz": "Hz",
    "amplification.dc": "1 (|C6/C5| at ω → 0)",
    "amplification.bandwidth_hz": "Hz (first −3 dB frequency of |C6/C5|)",
    "delay_s": "s",
}


VERIFY_POINTS = 64


def analyze_design(cfg) -> dict:
    """All SPEC §5 metrics for one design, as a JSON-ready dict (SPEC §8 ``analyze --json``).
    Overflow in an extreme design is reported through the inconclusive flags and warnings of
    the result, not as numpy's floating-point warnings."""
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        return _analyze_design(cfg)


def _analyze_design(cfg) -> dict:
    from ..model.shaping import GAIN_UNITS_TORQUE, double_compliance_shaping

    from ..config.design import check_analysis_filters

    check_analysis_filters(cfg.implementation)
    cols = analyze_batch(cfg, verify=VERIFY_POINTS)
    ds = double_compliance_shaping(cfg.plant, cfg.design)
    g = lambda k: float(np.asarray(cols[k])[0])
    humans = []
    for i, fam in enumerate(cfg.humans):
        key = f"human{i}_{fam.kind}"
        iv = cols[f"{key}_stable_intervals"][0]
        entry = {
            "kind": fam.kind,
            "parameter": fam.param,
            "unit": fam.unit,
            "range": [fam.lo, fam.hi],
            "fixed": {k: v for k, v in {**fam.fixed(), **({"eta": fam.eta} if fam.kind == "complex_stiffness" else {})}.items() if k != fam.param},
            "stable_intervals": iv,
            "robust": bool(cols[f"{key}_robust"][0]),
            "conclusive": bool(cols[f"{key}_conclusive"][0]),
            "critical": [{"value": p, "frequency_hz": f} for p, f in cols[f"{key}_critical"][0]],
            "verified_points": VERIFY_POINTS,
            "verification_mismatches": cols[f"{key}_verification_mismatches"][0],
        }
        if fam.box:
            boxed = {fam.param: [fam.lo, fam.hi], **{q: [lo, hi] for q, lo, hi in fam.box}}
            entry["box"] = boxed
            entry["fixed"] = {k: v for k, v in fam.fixed().items() if k not in boxed}
            entry["stable_intervals"] = None  # a box's stable set is not an interval
            entry["method"] = "Edge Theorem: the box is robustly stable iff each of its edges is (exact intervals per edge)"
            entry["edges"] = [
                {"parameter": e.param, "range": [e.lo, e.hi],
                 "at": {q: getattr(e, q) for q in boxed if q != e.param}, "stable_intervals": ivs}
                for e, ivs in cols[f"{key}_edges"][0]
            ]
        elif iv:
            # the stable interval reaching the top of the range gives e.g. the lightest stable inertia
            top = [x for x in iv if x[1] == fam.hi]
            entry["lowest_stable_value_below_range_top"] = top[0][0] if top else None
        humans.append(entry)
    env = []
    for i, e in enumerate(cfg.environment):
        key = f"env{i}_{e.kind}"
        if e.kind in ("locked", "free"):
            env.append({"kind": e.kind, "stable": bool(cols[f"{key}_stable"][0])})
        else:
            env.append(
                {
                    "kind": e.kind,
                    "parameter": e.param,
                    "range": [e.lo, e.hi],
                    "stable_intervals": cols[f"{key}_stable_intervals"][0],
                    "robust": bool(cols[f"{key}_robust"][0]),
                }
            )
    dob = None
    if cfg.implementation.dob is not None:
        dob = {
            "gain_margin_db": g("dob_gain_margin_db"),
            "phase_margin_deg": g("dob_phase_margin_deg"),
            "delay_margin_s": g("dob_delay_margin_s"),
            "crossover_hz": g("dob_crossover_hz"),
            "stable": bool(cols["dob_stable"][0]),
        }
    ratio = float(ds.J_m_hat / cfg.plant.J_j)
    warnings = list(ds.warnings)
    sampled = None
    if cfg.implementation.sample_rate_hz:
        from ..sampled.loop import check_design

        sampled = check_design(cfg, {"humans": humans, "environment": env})
        fs = sampled["sample_rate_hz"]
        for name in ("free", "locked"):
            if sampled[f"{name}_stable"] != bool(cols[f"{name}_stable"][0]):
                warnings.append(f"at {fs:g} Hz the sampled-data loop is {'stable' if sampled[f'{name}_stable'] else 'UNSTABLE'} "
                                f"{'with the cuff free' if name == 'free' else 'with the output locked'}, unlike the continuous analysis")
        for side, fams in (("human", sampled["humans"]), ("environment", sampled["environment"])):
            for h in fams:
                for b in h.get("boundaries", []):
                    if b["sampled_unstable_where_continuous_stable"]:
                        lo_, hi_ = b["sampled_unstable_where_continuous_stable"]
                        warnings.append(f"at {fs:g} Hz the sampled-data loop is UNSTABLE for {side} {h['kind']} "
                                        f"{h['parameter']} in [{lo_:.5g}, {hi_:.5g}], where the continuous analysis says stable")
                if h.get("disagreements"):
                    vals = ", ".join(f"{d['value']:.4g}" for d in h["disagreements"][:6])
                    warnings.append(f"at {fs:g} Hz the sampled-data loop disagrees with the continuous {side} {h['kind']} "
                                    f"intervals at {h['parameter']} = {vals}" + (" …" if len(h["disagreements"]) > 6 else ""))
    schedule = _schedule_check(cfg) if cfg.raw.get("transmission") else None
    for e in schedule or []:
        if not e["robust"]:
            warnings.append(f"at joint angle {e['joint_angle_rad']:g} rad (transmission ratio {e['ratio']:g}) the "
                            f"rescheduled design is not robust: {', '.join(e['not_robust'])}")
    kyp = kyp_certificates(cfg)  # a non-passive nominal C7 is the B2_hat < 0 warning of shaping
    if not bool(cols["passivity_conclusive"][0]):
        warnings.append("the passivity analysis is inconclusive (a zero of Δ00 or Δ10 on the axis, or the "
                        "adaptive frequency search spent its per-task budget: extreme parameters)")
    if not all(bool(cols[k][0]) for k in cols if k.endswith("_conclusive")):
        warnings.append("some verdicts are inconclusive (a root on the imaginary axis within float resolution, an "
                        "adaptive search that spent its per-task budget, or a human range with more than "
                        f"{MAX_FAMILY_PIECES} critical values: extreme parameters): treated as NOT stable")
    return {
        "model": "continuous-time, exact delay e^{-sT} (SPEC §3); verdicts by the argument principle on the closed-loop characteristic quasi-polynomial",
        "structure": cfg.implementation.structure,
        "delay_s": float(np.asarray(cfg.implementation.delay_s)),
        "gain_convention": "torque",
        "gains": {k: g(k) for k in GAIN_NAMES},
        "units": dict(GAIN_UNITS_TORQUE),
        "free_stable": bool(cols["free_stable"][0]),
        "free": {
            "stable": bool(cols["free_stable"][0]),
            "rigid_body_roots": int(cols["free_rigid_body_roots"][0]),
            "note": "the rigid-body root at s = 0 (K1 = 0, cuff free) is physical and removed exactly (SPEC §4)",
        },
        "locked_stable": bool(cols["locked_stable"][0]),
        "humans": humans,
        "environment": env,
        "passivity": {
            "max_phase_excess_deg": g("passivity_max_phase_excess_deg"),
            "nonpassive_band_hz": cols["passivity_nonpassive_band_hz"][0],
            "kyp": kyp,
        },
        "dob": dob,
        "amplification": {
            "dc": g("amplification_dc"),
            "bandwidth_hz": g("amplification_bandwidth_hz"),
            "minimum_phase": bool(cols["amplification_minimum_phase"][0]),
        },
        "J_m_hat_over_J_j": ratio,
        "sampled_data": sampled,
        "gain_schedule": schedule,
        "metric_units": METRIC_UNITS,
        "warnings": warnings,
    }


def kyp_certificates(cfg) -> dict:
    """KYP passivity certificates of the rational models of C7 (:mod:`exotune.kyp`, cvxpy); a
    missing or failing SDP solver is reported in the result, not raised."""
    try:
        from .kyp import operator_certificates

        return operator_certificates(cfg)
    except (ImportError, ValueError, ArithmeticError, np.linalg.LinAlgError) as e:
        return {"error": f"KYP certificates not computed: {type(e).__name__}: {e}"}


def _schedule_check(cfg) -> list[dict]:
    """Continuous analysis of the design rescheduled at every joint angle of its ``transmission``
    section (paper §VI: J_m, B_m, K_s × ratio², gains recomputed; one batch over the angles)."""
    tr = cfg.raw["transmission"]
    r2 = np.asarray(tr["ratio"], float) ** 2
    g = lambda x: float(np.ravel(x)[0])  # noqa: E731
    from ..config.design import batch_config

    cols = analyze_batch(batch_config(cfg, {"plant.motor_inertia": g(cfg.plant.J_m) * r2,
                                            "plant.motor_damping": g(cfg.plant.B_m) * r2,
                                            "plant.sea_stiffness": g(cfg.plant.K_s) * r2}))
    fams = [k[: -len("_robust")] for k in cols if k.startswith(("human", "env")) and k.endswith("_robust")]
    out = []
    for i, (angle, ratio) in enumerate(zip(tr["joint_angle_rad"], tr["ratio"])):
        bad = [k for k in fams if not bool(cols[f"{k}_robust"][i])]
        bad += [k for k in ("free_stable", "locked_stable") if not bool(cols[k][i])]
        bad += [k for k in cols if k.startswith("env") and k.endswith("_stable") and not bool(cols[k][i])]
        out.append({"joint_angle_rad": float(angle), "ratio": float(ratio), "robust": not bad, "not_robust": bad,
                    "gains": {k: float(cols[k][i]) for k in GAIN_NAMES},
                    "human_stable_intervals": {k: cols[f"{k}_stable_intervals"][i] for k in fams
                                               if f"{k}_stable_intervals" in cols}})
    return out


TEXT_LIST_MAX = 12  # the text report lists at most this many intervals / boundaries (--json: all)


def _fmt_iv(iv, unit):
    if not iv:
        return "none"
    s = ", ".join(f"[{a:.6g}, {b:.6g}]" for a, b in iv[:TEXT_LIST_MAX]) + f" {unit}"
    if len(iv) > TEXT_LIST_MAX:
        s += f" … ({len(iv)} intervals in all; --json lists every one)"
    return s


def format_report(r: dict) -> str:
    """Readable text report of :func:`analyze_design` with units."""
    L = []
    yn = lambda b: "yes" if b else "NO"
    L.append("exotune analyze — " + r["model"])
    L.append(f"delay T = {r['delay_s'] * 1e3:.4g} ms, controller structure '{r['structure']}'")
    L.append("")
    L.append("Gains (torque units, SPEC §4):")
    for k, v in r["gains"].items():
        L.append(f"  {k:7s} = {v:12.6g}  [{r['units'][k]}]")
    L.append("")
    L.append(f"Free exoskeleton (cuff free) stable: {yn(r['free_stable'])} (rigid-body roots at s=0 removed: {r['free']['rigid_body_roots']})")
    L.append(f"Output locked stable:               {yn(r['locked_stable'])}")
    for e in r["environment"]:
        if "stable" in e:
            L.append(f"Environment {e['kind']}: stable {yn(e['stable'])}")
        else:
            L.append(f"Environment {e['kind']} {e['parameter']} {e['range']}: robust {yn(e['robust'])}, stable on {_fmt_iv(e['stable_intervals'], '')}")
    L.append("")
    L.append("Coupled stability with the human models:")
    for h in r["humans"]:
        if h.get("box"):
            box = ", ".join(f"{q} in [{a:.6g}, {b:.6g}]" for q, (a, b) in h["box"].items())
            L.append(f"  {h['kind']:17s} box {box}: robust {yn(h['robust'])} (Edge Theorem, {len(h['edges'])} edges)")
            for e in h["edges"]:
                if e["stable_intervals"] != [e["range"]]:
                    at = ", ".join(f"{q} = {v:.6g}" for q, v in e["at"].items())
                    L.append(f"    edge {e['parameter']} at {at}: stable on {_fmt_iv(e['stable_intervals'], '')}")
            continue
        L.append(f"  {h['kind']:17s} {h['parameter']} in [{h['range'][0]:.6g}, {h['range'][1]:.6g}] {h['unit']}: robust {yn(h['robust'])}")
        L.append(f"    stable on {_fmt_iv(h['stable_intervals'], h['unit'])}")
        for c in h["critical"][:TEXT_LIST_MAX]:
            L.append(f"    boundary at {h['parameter']} = {c['value']:.6g} {h['unit']} (crossing at {c['frequency_hz']:.4g} Hz)")
        if len(h["critical"]) > TEXT_LIST_MAX:
            L.append(f"    … {len(h['critical'])} boundaries in all (--json lists every one)")
        if h.get("verification_mismatches"):
            L.append(f"    VERIFICATION FAILED at {h['parameter']} = {h['verification_mismatches']}: treated as not robust")
        if h.get("lowest_stable_value_below_range_top") is not None and h["kind"] in ("mass", "msd") and h["parameter"] == "inertia":
            L.append(f"    lightest stable inertia: {h['lowest_stable_value_below_range_top']:.6g} kg·m²")
    L.append("")
    p = r["passivity"]
    L.append(f"Passivity of C7: max phase excess {p['max_phase_excess_deg']:.4g} deg outside [-180°, 0°]; non-passive bands: {_fmt_iv(p['nonpassive_band_hz'], 'Hz')}")
    from .kyp import format_certificates

    L += format_certificates(p.get("kyp"))
    if r["dob"]:
        d = r["dob"]
        L.append(
            f"DOB loop L_dob = Q e^(-sT)/(1-Q): gain margin {d['gain_margin_db']:.4g} dB, phase margin {d['phase_margin_deg']:.4g} deg, "
            f"delay margin {d['delay_margin_s'] * 1e3:.4g} ms (extra delay), crossover {d['crossover_hz']:.4g} Hz"
        )
        if not d["stable"]:
            L.append("  the closed DOB loop is UNSTABLE with the modelled delay (delay margin reported as 0)")
    else:
        L.append("DOB: none")
    a = r["amplification"]
    L.append(f"Amplification C6/C5: DC {a['dc']:.6g}, -3 dB bandwidth {a['bandwidth_hz']:.4g} Hz, minimum phase {yn(a['minimum_phase'])}")
    L.append(f"J_m_hat / J_j = {r['J_m_hat_over_J_j']:.4g}")
    for e in r.get("gain_schedule") or []:
        L.append(f"Gain schedule, joint angle {e['joint_angle_rad']:g} rad (ratio {e['ratio']:g}): "
                 + ("robust" if e["robust"] else "NOT robust: " + ", ".join(e["not_robust"]))
                 + f"; K2 = {e['gains']['K2']:.6g}, B2 = {e['gains']['B2']:.6g} s")
    sd = r.get("sampled_data")
    if sd:
        L.append(f"Sampled-data check at {sd['sample_rate_hz']:g} Hz ({sd['method']}):")
        L.append(f"  cuff free stable: {yn(sd['free_stable'])}; output locked stable: {yn(sd['locked_stable'])}")
        for side, fams in (("human", sd["humans"]), ("environment", sd.get("environment", []))):
            for h in fams:
                if "skipped" in h:
                    L.append(f"  {side} {h['kind']}: skipped ({h['skipped']})")
                    continue
                L.append(f"  {side} {h['kind']}: {h['stable_points']} of {h['points']} grid values stable, "
                         f"{len(h['disagreements'])} disagreement(s) with the continuous intervals")
                for b in h["boundaries"]:
                    moved = "not found within a factor 2" if b["sampled"] is None else f"{b['sampled']:.5g}"
                    L.append(f"    boundary {h['parameter']} = {b['continuous']:.5g} (continuous) -> {moved} (sampled)")
    cc = r.get("cross_check")
    if cc:
        L.append(
            f"Cross-check (Padé {cc['pade_orders']} roots + Newton on the exact Δ): {cc['agree']} of {cc['checked']} verdicts agree"
            + (f"; {len(cc['unconfirmed'])} unstable verdicts not confirmed by the root search" if cc["unconfirmed"] else "")
        )
        for d in cc["disagreements"]:
            L.append(f"  DISAGREEMENT at {d['case']}: exotune says stable, but Δ has a root at "
                     f"{d['rhp_root']['re']:.6g} + {d['rhp_root']['im']:.6g}j rad/s")
    for w in r["warnings"]:
        L.append(f"warning: {w}")
    return "\n".join(L)
