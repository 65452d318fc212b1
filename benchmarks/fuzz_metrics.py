"""Independent, adversarial cross-check of exotune's NUMERIC METRICS (the verdicts are
``benchmarks/fuzz_verdicts.py``'s job; this file reuses its reference building blocks).

    python benchmarks/fuzz_metrics.py --designs 150 --seed 7 [--latency 20] [--json OUT] [--cases DIR]

Random designs (``fuzz_verdicts.draw_design``: amplification 1.1–60, delays 0–12 ms that are not
round numbers, DOB on/off, human masses down to 1e-8 kg·m², stiff and soft cuffs) are analysed by
exotune (``analyze_batch(batch_config(...), latency=True).to_columns()``) and by references
written from docs/method.md and the paper alone. Nothing of ``exotune.analysis``, ``exotune.model``
or ``exotune.controllerfile`` is imported by the references: the gains, the controller
(python-control) and the plant come from ``fuzz_verdicts``; the frequency responses are evaluated
here (batched resolvent solves, checked against python-control at start-up).

Metrics and references
----------------------
* DOB margins (docs/method.md#dob-margins): L_dob = Q e^{−sT}/(1 − Q). Gain crossover and the
  delay-free phase margin from ``control.stability_margins`` of Q/(1 − Q); the delay subtracts
  ω_c·T from the phase (|e^{−jωT}| = 1 leaves the crossover in place); the phase crossovers of the
  delayed loop by brentq on the exact phase; the delay margin PM/ω_c; ``dob_stable`` from the
  closed loop s² + 2ζω_q s + ω_q² e^{−sT} (stable iff the unwrapped phase margin is positive:
  one gain crossover, |L| decreasing), cross-checked by the eigenvalues of a (14,14) Padé model
  when ω_c T is small enough for Padé to be exact to 1e-3.
* Amplification (docs/method.md#amplification): C6/C5 = 1 − τ_s/τ_c with the output locked and the
  cuff torque τ_c applied (the controller reads it), with the exact delay. DC at s = 0, bandwidth =
  first ω where |C6/C5| = dc/√2 on a dense log grid (400/decade + points around every lightly
  damped pole; with a delay, plus 64 points per ripple period up to the first log-grid point
  below the level) refined by brentq.
* Passivity (docs/method.md#passivity-of-the-operator-compliance): C7 = θ_h/τ_c of the free
  exoskeleton driven by a torque source on the cuff, C7 = θ_j/τ_c + 1/K_c, exact delay. Phase
  excess = distance of arg C7 from [−180°, 0°]; its maximum refined by bounded Brent around the
  largest grid maxima; bands = zeros of Im C7 (brentq), listed when their peak ≥ 0.1°.
* Human-family critical values (docs/method.md#stable-intervals-of-a-human-family):
  1 + z C7 = 0 with z = z0 + p φ ⇒ p(ω) = (−1/C7(jω) − z0(jω))/φ(jω); the critical values are
  the real crossings: zeros of Im[(−1 − z0 C7)·conj(φ C7)] (brentq) with Re p in [lo, hi]. The
  grid is log (400/decade) plus, with a delay, a linear grid of 16 points per period 2π/T
  where p(ω) can be in range. Every exotune pair [value, f] is also point-checked (Im p(jω) ≈ 0).
  Ends of the stable intervals must be range ends or reference critical values.
* Latency margin (docs/method.md#latency-margin), on designs exotune finds robust: per loop member
  (free, locked, environment members, 48 log-spaced members of each human family + Brent
  refinement near the smallest), the loop G (broken at the delay, ``fuzz_verdicts.loop_matrices``)
  crosses |G(jω)| = 1 at ω_k (dense grid + brentq); a root reaches jω at τ = (arg G + 2πk)/ω; the
  member margin is min_k (first τ > T) − T. The reference margin at the critical member is then
  checked by ``fuzz_verdicts.member_verdict`` (exact argument principle/Newton/Padé): stable at
  T + ΔT(1 − 1e-4), unstable at T + ΔT(1 + 1e-4).

Tolerances (relative unless stated): DOB margins, crossover 1e-6 (closed forms on both sides:
float-level agreement expected; 1e-6 leaves room for bisection ends); amplification dc 1e-8 (the reference evaluates the DOB's integrator at s = jε: about 2e-9),
bandwidth 1e-6 (brentq to 1e-14 on a smooth |·|²); passivity max excess 1e-3 deg absolute (a
golden-section/Brent maximum of a function with a kink at 90°), band ends 1e-6; critical values
and their frequencies 1e-6 (simple zeros of a smooth function); latency margin 1e-4 (exotune's
sweep column refines minima by golden section on a 40/decade grid; the reference's member
refinement is ~1e-7).

Classification: ``agree``; ``disagree`` (outside tolerance, after the reference was refined);
``ex-inconclusive`` (a critical value exotune does not list, or lists off the tolerance, in a
family it reports inconclusive: it claims no interval there, so this is no disagreement; tallied
apart); ``ref-inconclusive``
(the reference cannot settle it: a band peak within 5 % of the 0.1° listing
threshold, a band end beyond which |Im C7| stays below exotune's float resolution 1e-8 |C7| (exotune
extends the band to infinity), a crossing at a range end to 1e-9, a double (tangent) crossing, a shallow −3 dB
approach within 0.01 neper that exotune documents it accepts, a margin where the reference's
verdict check failed on its own side).
"""

from __future__ import annotations

import os

for _k in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_k, "1")

import argparse  # noqa: E402
import copy  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402
from pathlib import Path  # noqa: E402

import control  # noqa: E402
import numpy as np  # noqa: E402
import scipy.linalg  # noqa: E402
import scipy.optimize  # noqa: E402
import yaml  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
import fuzz_verdicts as fv  # noqa: E402

TWO_PI = 2.0 * math.pi
TOL = dict(dob_phase_margin_deg=1e-6, dob_gain_margin_db=1e-6, dob_delay_margin_s=1e-6, dob_crossover_hz=1e-6,
           amplification_dc=1e-8, amplification_bandwidth_hz=1e-6, passivity_max_phase_excess_deg=1e-3,
           passivity_nonpassive_band_hz=1e-6, critical_value=1e-6, critical_freq=1e-6, interval_end=1e-6,
           latency_margin_s=1e-4)
CHUNK = 16384


# ============================================================================================
# Frequency responses (batched resolvent solves)
# ============================================================================================
class Resp:
    """H(s) = C (sI − A)⁻¹ B + D for a (balanced) state space; ``__call__(s)`` → (ns, p, m)."""

    def __init__(self, A, B, C, D=None):
        A = np.asarray(A, float)
        B = np.asarray(B, float).reshape(A.shape[0], -1)
        C = np.asarray(C, float).reshape(-1, A.shape[0])
        if A.shape[0]:
            A, (sc, _) = scipy.linalg.matrix_balance(A, permute=False, separate=True)
            B, C = B / sc[:, None], C * sc[None, :]
        self.A, self.B, self.C = A, B, C
        self.D = np.zeros((C.shape[0], B.shape[1])) if D is None else np.asarray(D, float).reshape(C.shape[0], B.shape[1])
        self.n = A.shape[0]

    def __call__(self, s):
        s = np.atleast_1d(np.asarray(s, complex))
        out = np.empty((s.size,) + self.D.shape, complex)
        if self.n == 0:
            out[:] = self.D
            return out
        eye = np.eye(self.n)
        for i in range(0, s.size, CHUNK):
            ss = s[i:i + CHUNK]
            M = ss[:, None, None] * eye[None] - self.A[None]
            X = np.linalg.solve(M, np.broadcast_to(self.B, (ss.size,) + self.B.shape))
            out[i:i + CHUNK] = self.C[None] @ X + self.D[None]
        return out

    def states(self, s):
        """(sI − A)⁻¹ B in the original coordinates is not needed; X for the balanced ones."""
        raise NotImplementedError


def _ss(sysx):
    return tuple(np.asarray(x, float) for x in (sysx.A, sysx.B, sysx.C, sysx.D))


class Ref:
    """The reference objects of one design: controller (fuzz_verdicts), plant responses."""

    def __init__(self, mapping):
        self.m = mapping
        self.plant = {k: float(v) for k, v in mapping["plant"].items()}
        self.impl = mapping["implementation"]
        self.T = float(self.impl["delay_s"])
        self.K = fv.continuous_controller(self.plant, mapping["design"], self.impl)
        self.Kr = Resp(*_ss(self.K))                       # 1 × 4: w_m, tau_s, dtau_s, tau_c
        Kc = self.plant["cuff_stiffness"]
        self.Kc = Kc
        # free plant, torque source τ_c on the cuff: inputs [τ_m, τ_c], outputs
        # [w_m, tau_s, dtau_s, (tau_c ≡ 0 in the plant), θ_j]
        A, B, C, names, _ = fv.plant_matrices(self.plant, None, "free", ("w_m", "tau_s", "dtau_s", "th_m"))
        ix = {n: i for i, n in enumerate(names)}
        E = np.zeros((A.shape[0], 1))
        E[ix["w_j"], 0] = 1.0 / self.plant["joint_inertia"]
        th_j = np.zeros((1, A.shape[0]))
        th_j[0, ix["th_m"]] = 1.0
        th_j[0, ix["th_s"]] = 1.0
        C = np.vstack([C[:3], np.zeros((1, A.shape[0])), th_j])
        # drop θ_m (cyclic, K1 = 0): its column is zero except through θ_j, which we keep by
        # evaluating at s ≠ 0 only (the rigid-body pole is physical)
        self.Pfree = Resp(A, np.hstack([B, E]), C)
        Al, Bl, Cl, _, _ = fv.plant_matrices(self.plant, None, "locked", ("w_m", "tau_s", "dtau_s", "tau_s"))
        self.Plock = Resp(Al, Bl, Cl[:3])                  # τ_m → [w_m, tau_s, dtau_s]

    def c7(self, w):
        """θ_h/τ_c of the free exoskeleton with a torque source on the cuff, exact delay."""
        s = 1j * np.asarray(w, float)
        K = self.Kr(s)[:, 0, :]                           # (ns, 4)
        P = self.Pfree(s)                                 # (ns, 5, 2)
        e = np.exp(-s * self.T)
        G = np.einsum("nk,nk->n", K[:, :4], P[:, :4, 0])
        F = np.einsum("nk,nk->n", K[:, :4], P[:, :4, 1]) + K[:, 3]   # τ_c read by the controller
        tcmd = F / (1.0 - G * e)
        th_j = P[:, 4, 0] * e * tcmd + P[:, 4, 1]
        return th_j + 1.0 / self.Kc

    def amp(self, w):
        """C6/C5 = 1 − τ_s/τ_c, output locked, τ_c applied (controller input), exact delay."""
        s = 1j * np.asarray(w, float)
        return self.amp_s(s)

    def amp_s(self, s):
        K = self.Kr(s)[:, 0, :]
        P = self.Plock(s)[:, :, 0]                        # (ns, 3)
        e = np.exp(-s * self.T)
        G = np.einsum("nk,nk->n", K[:, :3], P)
        tcmd = K[:, 3] / (1.0 - G * e)
        return 1.0 - P[:, 1] * e * tcmd

    def feature_freqs(self):
        """Imaginary parts and widths of the lightly damped poles that matter (free and locked
        closed loops via Padé 14, plant, controller)."""
        lams = []
        for env in ("free", "locked"):
            A, B, C = fv.loop_matrices(self.plant, self.K, None, env)
            lams += list(np.linalg.eigvals(A))
            try:
                lams += list(np.linalg.eigvals(fv.closed_loop_pade(A, B, C, self.T, 14)))
            except Exception:
                pass
        lams = np.array(lams)
        return lams


def _grid(lams, wlo, whi, per_decade=400):
    pts = [np.geomspace(wlo, whi, int(per_decade * math.log10(whi / wlo)) + 2)]
    ks = np.array([0.0, 0.1, 0.3, 0.6, 1.0, 1.5, 2.0, 3.0, 5.0, 10.0, 30.0])
    for lam in lams:
        if lam.imag > 0 and wlo < lam.imag < whi:
            d = max(abs(lam.real), 1e-12 * abs(lam))
            pts.append(lam.imag + d * np.concatenate([ks, -ks[1:]]))
    w = np.unique(np.concatenate(pts))
    return w[(w >= wlo) & (w <= whi)]


def _scale(lams):
    a = np.abs(lams)
    a = a[a > 1e-9]
    return (float(a.min()) if a.size else 1.0), (float(a.max()) if a.size else 1.0)


def _brent(f, a, b, fa=None, fb=None):
    try:
        return scipy.optimize.brentq(f, a, b, xtol=1e-300, rtol=4 * np.finfo(float).eps, maxiter=200)
    except Exception:
        return 0.5 * (a + b)


def _rel(a, b):
    if a == b:
        return 0.0
    if not (math.isfinite(a) and math.isfinite(b)):
        return math.inf
    return abs(a - b) / max(abs(a), abs(b), 1e-300)


# ============================================================================================
# 1. DOB margins
# ============================================================================================
def ref_dob(m):
    dob = m["implementation"].get("dob")
    T = float(m["implementation"]["delay_s"])
    if not dob:
        return None
    wq, zq = TWO_PI * float(dob["cutoff_hz"]), float(dob["damping"])
    L0 = control.tf([wq * wq], [1.0, 2 * zq * wq, 0.0])    # Q/(1 − Q)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        gm0, pm0, sm, wpc0, wgc0, wms = control.stability_margins(L0, returnall=False)
    # closed form of the crossover |L| = 1: ω⁴ + 4ζ²ω_q²ω² − ω_q⁴ = 0
    wc_cf = wq * math.sqrt(math.sqrt(4 * zq ** 4 + 1) - 2 * zq * zq)
    wc = float(wgc0)
    if _rel(wc, wc_cf) > 1e-8:   # python-control's root finder vs the closed form: keep the closed form
        wc = wc_cf
    pm0_rad = math.pi / 2 - math.atan(wc / (2 * zq * wq))
    pm_un = pm0_rad - wc * T                               # the delay shifts the phase by −ωT
    pm_k = pm_un % TWO_PI
    pm = math.degrees(pm_k - TWO_PI if pm_k > math.pi else pm_k)
    stable = pm_un > 0
    # phase crossovers of the delayed loop: arg L = −π/2 − atan(ω/2ζω_q) − ωT = −π − 2πk
    if T > 0:
        f = lambda w: math.pi / 2 - math.atan(w / (2 * zq * wq)) - w * T  # noqa: E731
        wpc = scipy.optimize.brentq(f, 1e-12, math.pi / (2 * T) + 1.0, xtol=1e-300, rtol=1e-15)
        Lm = wq * wq / (wpc * math.hypot(wpc, 2 * zq * wq))
        gm = -20 * math.log10(Lm)                           # |L| decreasing: the first is the smallest
    else:
        gm = math.inf
    dm = pm_k / wc if stable else 0.0
    # Padé cross-check of the closed loop s² + 2ζω_q s + ω_q² e^{−sT}
    pade = None
    if T > 0 and wc * T < 2.0:
        A, B, C = np.array([[0.0, 1.0], [0.0, -2 * zq * wq]]), np.array([[0.0], [1.0]]), np.array([[-wq * wq, 0.0]])
        ev = np.linalg.eigvals(fv.closed_loop_pade(A, B, C, T, 14))
        pade = bool(np.max(ev.real) < 0)
    return dict(dob_phase_margin_deg=pm, dob_gain_margin_db=gm, dob_delay_margin_s=dm, dob_crossover_hz=wc / TWO_PI,
                dob_stable=stable, pm0_python_control=float(pm0), pade_stable=pade, pm_unwrapped_deg=math.degrees(pm_un))


# ============================================================================================
# 2. Amplification
# ============================================================================================
def ref_amplification(R: Ref, lams):
    lo, hi = _scale(lams)
    # the DOB's 1/(1 − Q) is an integrator: the limit s → 0 along jε (Re is even in ε: O(ε²) error)
    dc = R.amp(np.array([1e-7 * lo]))[0]
    w = _grid(lams, 1e-5 * lo, 1e4 * hi)
    a = np.abs(R.amp(w)) ** 2
    thr = 0.5 * abs(dc) ** 2
    below = np.flatnonzero(a <= thr)
    if R.T > 0:
        # the delay ripple (period 2π/T) can dip below the level between log-grid points at high
        # frequency: 64 points per period up to the first log-grid point below it (capped)
        wend = float(w[below[0]]) if below.size else float(w[-1])
        step = math.pi / (32 * R.T)
        wl = np.arange(step, min(wend, 4e5 * step), step)
        if wl.size:
            w = np.unique(np.concatenate([w, wl]))
            a = np.abs(R.amp(w)) ** 2
            below = np.flatnonzero(a <= thr)
    info = {}
    if below.size == 0:
        bw = math.inf
    else:
        j = int(below[0])
        if j == 0:
            bw = float("nan")
        else:
            fn = lambda x: float(np.abs(R.amp(np.array([x]))[0]) ** 2 - thr)  # noqa: E731
            bw = _brent(fn, w[j - 1], w[j]) / TWO_PI
            # how deep does the first excursion below the level go? (shallow: documented acceptance)
            k = j
            while k < a.size and a[k] <= thr:
                k += 1
            info["first_dip_depth_neper"] = float(0.5 * math.log(thr / max(np.min(a[j:k]), 1e-300)))
            info["first_dip_end_hz"] = float(w[min(k, a.size - 1)] / TWO_PI)
    return dict(amplification_dc=float(dc.real), dc_imag=float(dc.imag), amplification_bandwidth_hz=bw, **info)


# ============================================================================================
# 3. Passivity
# ============================================================================================
def _excess(c):
    ph = np.angle(c)
    return np.where(ph > 0, np.minimum(ph, math.pi - ph), 0.0)


def passivity_grid(R: Ref, lams):
    lo, hi = _scale(lams)
    wlo, whi = 1e-5 * lo, 1e4 * hi
    w = _grid(lams, wlo, whi)
    c = R.c7(w)
    if R.T > 0:
        # the delay ripple: 16 points per period 2π/T up to where |K_c C7 − 1| < 1e-5 (excess < 6e-4°)
        dev = np.abs(R.Kc * c - 1.0)
        big = np.flatnonzero(dev > 1e-5)
        wend = min(float(w[big[-1]]) * 2 if big.size else whi, whi, 2e5 * math.pi / (8 * R.T))
        wl = np.arange(math.pi / (8 * R.T), wend, math.pi / (8 * R.T))
        if wl.size:
            w = np.unique(np.concatenate([w, wl]))
            c = R.c7(w)
    return w, c


def ref_passivity(R: Ref, w, c):
    ex = np.degrees(_excess(c))
    im = c.imag
    f_ex = lambda x: -float(np.degrees(_excess(R.c7(np.array([x])))[0]))  # noqa: E731
    # maximum: refine around the 8 largest local maxima of the grid
    cand = np.flatnonzero((ex[1:-1] >= ex[:-2]) & (ex[1:-1] >= ex[2:]) & (ex[1:-1] > 0)) + 1
    cand = cand[np.argsort(ex[cand])[::-1][:8]]
    best = float(ex.max()) if ex.size else 0.0
    for i in cand:
        r = scipy.optimize.minimize_scalar(f_ex, bounds=(w[i - 1], w[i + 1]), method="bounded",
                                           options=dict(xatol=1e-12 * w[i], maxiter=500))
        best = max(best, -float(r.fun))
    # bands: sign changes of Im C7
    pos = im > 0
    ch = np.flatnonzero(pos[1:] != pos[:-1])
    fim = lambda x: float(R.c7(np.array([x]))[0].imag)  # noqa: E731
    edges = [_brent(fim, w[i], w[i + 1]) for i in ch]
    bands = []
    starts = [e for e, i in zip(edges, ch) if not pos[i]]
    ends = [e for e, i in zip(edges, ch) if pos[i]]
    if pos[0]:
        starts = [w[0]] + starts
    if pos[-1]:
        ends = ends + [math.inf]
    for a_, b_ in zip(starts, ends):
        sel = (w >= a_) & (w <= b_)
        pk = float(ex[sel].max()) if sel.any() else 0.0
        ii = np.flatnonzero(sel)
        if ii.size:
            i = ii[int(np.argmax(ex[ii]))]
            r = scipy.optimize.minimize_scalar(f_ex, bounds=(max(a_, w[max(i - 1, 0)]), min(b_, w[min(i + 1, w.size - 1)])),
                                               method="bounded", options=dict(xatol=1e-12 * w[i], maxiter=500))
            pk = max(pk, -float(r.fun))
        bands.append((a_ / TWO_PI, b_ / TWO_PI, pk))
    return dict(passivity_max_phase_excess_deg=best, bands=bands)


# ============================================================================================
# 4. Critical values of human families
# ============================================================================================
def family_spec(fam):
    """(param, lo, hi, z0(s), φ(s)) of a one-parameter family; None for a box."""
    ranged, vals = fv._family_param(fam)
    if len(ranged) != 1:
        return None
    p = ranged[0]
    lo, hi = vals[p]
    m, b, k = (0.0 if q == p else float(vals[q]) for q in ("inertia", "damping", "stiffness"))
    z0 = lambda s: m * s * s + b * s + k  # noqa: E731
    phi = {"inertia": lambda s: s * s, "damping": lambda s: s, "stiffness": lambda s: np.ones_like(s)}[p]
    return p, float(lo), float(hi), z0, phi


def ref_criticals(R: Ref, w, c, fam):
    spec = family_spec(fam)
    if spec is None:
        return None
    p, lo, hi, z0, phi = spec
    s = 1j * w

    def hfun(ss, cc):
        ph = phi(ss) * cc
        return (-1.0 - z0(ss) * cc) * np.conj(ph), np.abs(ph) ** 2

    num, den = hfun(s, c)
    pv = num.real / den
    # densify with a delay where p(ω) can be in range (linear grid: 16 points per period)
    if R.T > 0:
        step = math.pi / (8 * R.T)
        inr = (pv > lo / 4) & (pv < hi * 4)
        if inr.any():
            wa, wb = float(w[inr].min()), float(w[inr].max())
            # the linear grid of passivity_grid may stop early; extend it over [wa, wb] (capped)
            n = min(int((wb - wa) / step) + 2, 600000)
            wl = np.linspace(max(wa * 0.98, step), wb * 1.02, n)
            wl = wl[(wl > w[0]) & (wl < w[-1])]
            if wl.size:
                w = np.unique(np.concatenate([w, wl]))
                c = R.c7(w)
                s = 1j * w
                num, den = hfun(s, c)
                pv = num.real / den
    im = num.imag
    sg = np.sign(im)
    ch = np.flatnonzero(sg[1:] * sg[:-1] < 0)
    out = []

    def f_im(x):
        ss = np.array([1j * x])
        n_, _ = hfun(ss, R.c7(np.array([x])))
        return float(n_[0].imag)

    for i in ch:
        pa, pb = pv[i], pv[i + 1]
        if not ((lo * (1 - 1e-3) <= pa <= hi * (1 + 1e-3)) or (lo * (1 - 1e-3) <= pb <= hi * (1 + 1e-3))
                or (pa - lo) * (pb - lo) < 0 or (pa - hi) * (pb - hi) < 0):
            continue
        x = _brent(f_im, w[i], w[i + 1])
        ss = np.array([1j * x])
        n_, d_ = hfun(ss, R.c7(np.array([x])))
        pc = float(n_[0].real / d_[0])
        # a pole of p (C7 → 0) changes the sign of Im through infinity: not a crossing
        if not math.isfinite(pc) or abs(pc) > 1e300:
            continue
        if lo <= pc <= hi or min(abs(pc - lo) / lo, abs(pc - hi) / hi) < 1e-9:
            out.append(dict(value=pc, freq_hz=x / TWO_PI, at_end=min(abs(pc - lo) / lo, abs(pc - hi) / hi) < 1e-9))
    return dict(param=p, lo=lo, hi=hi, crit=out, hfun=hfun)


def point_check(R: Ref, fam, value, freq_hz):
    """Is exotune's pair a crossing? p(j2πf) is real and equal to value (relative)."""
    spec = family_spec(fam)
    p, lo, hi, z0, phi = spec
    x = TWO_PI * freq_hz
    s = np.array([1j * x])
    c = R.c7(np.array([x]))
    g = (-1.0 / c - z0(s)) / phi(s)
    return float(abs(g[0].imag) / max(abs(g[0]), 1e-300)), _rel(float(g[0].real), value)


def compare_family(R, fam, crit_ex, ivs_ex, refc):
    """Match exotune's critical pairs to the reference's (greedy, nearest in value)."""
    ref = list(refc["crit"])
    used = [False] * len(ref)
    rows = []
    for v, f in crit_ex:
        best, bi = math.inf, -1
        for j, r in enumerate(ref):
            if used[j]:
                continue
            d = max(_rel(r["value"], v), _rel(r["freq_hz"], f))
            if d < best:
                best, bi = d, j
        if bi >= 0 and best <= 1e-4:
            used[bi] = True
            rows.append(dict(kind="matched", value=v, freq_hz=f, ref_value=ref[bi]["value"], ref_freq_hz=ref[bi]["freq_hz"],
                             dv=_rel(ref[bi]["value"], v), df=_rel(ref[bi]["freq_hz"], f)))
        else:
            im_rel, dv = point_check(R, fam, v, f)
            rows.append(dict(kind="exotune-only", value=v, freq_hz=f, point_im_rel=im_rel, point_dv=dv))
    for j, r in enumerate(ref):
        if not used[j]:
            rows.append(dict(kind="reference-only", ref_value=r["value"], ref_freq_hz=r["freq_hz"], at_end=r["at_end"]))
    # interval ends
    ends = []
    for a_, b_ in ivs_ex:
        for e in (a_, b_):
            if e in (refc["lo"], refc["hi"]):
                continue
            d = min((_rel(e, r["value"]) for r in ref), default=math.inf)
            ends.append(dict(end=e, d=d, in_exotune_critical=any(_rel(e, c[0]) < 1e-12 for c in crit_ex)))
    return rows, ends


# ============================================================================================
# 5. Latency margin
# ============================================================================================
def member_margin(plant, K, T, human, env):
    """min over the crossings |G(jω)| = 1 of the first delay τ > T that puts a root at jω, − T."""
    A, B, C = fv.loop_matrices(plant, K, human, env)
    loop = fv.ExactLoop(A, B, C, 0.0)
    lams = loop.poles
    lo, hi = _scale(lams)
    w = _grid(lams, 1e-6 * lo, 1e4 * hi, per_decade=150)
    g = np.log(np.abs(loop.G(1j * w)))
    sg = np.sign(g)
    ch = np.flatnonzero(sg[1:] * sg[:-1] < 0)
    best, wbest = math.inf, None
    fl = lambda x: float(np.log(np.abs(loop.G(1j * x)[0])))  # noqa: E731
    for i in ch:
        x = _brent(fl, w[i], w[i + 1])
        ph = float(np.angle(loop.G(1j * x)[0]))
        # G e^{−jωτ} = 1 ⇔ ωτ = ph + 2πk
        tau = (ph % TWO_PI) / x
        while tau <= T:
            tau += TWO_PI / x
        if tau - T < best:
            best, wbest = tau - T, x
    return best, wbest


def ref_latency(m, K, n_members=48):
    plant = {k: float(v) for k, v in m["plant"].items()}
    T = float(m["implementation"]["delay_s"])
    loops = []

    def add(name, member, human, env):
        dt, wx = member_margin(plant, K, T, human, env)
        loops.append(dict(loop=name, member=member, margin=dt, w=wx, human=human, env=env))
        return dt

    add("free", None, None, "free")
    add("locked", None, None, "locked")
    envs = [e for e in m["environment"] if e["kind"] in ("spring", "mass")]
    fams = []
    for j, env in enumerate(envs):
        p = fv.PARAM[env["kind"]]
        lo, hi = env[p]
        mk = lambda x, env=env, p=p: (None, dict(m=x if p == "inertia" else 0.0, b=float(env.get("damping", 0.0)),  # noqa: E731
                                                 k=x if p == "stiffness" else 0.0))
        fams.append((f"env{j}_{env['kind']}", lo, hi, mk))
    for i, fam in enumerate(m["humans"]):
        ranged, vals = fv._family_param(fam)
        if len(ranged) != 1:
            continue
        p = ranged[0]
        lo, hi = vals[p]
        mk = lambda x, vals=vals, p=p: (dict(m=dict(vals, **{p: x})["inertia"], b=dict(vals, **{p: x})["damping"],  # noqa: E731
                                             k=dict(vals, **{p: x})["stiffness"]), "free")
        fams.append((f"human{i}_{fam['kind']}", lo, hi, mk))
    for name, lo, hi, mk in fams:
        xs = np.geomspace(lo, hi, n_members) if hi > lo else np.array([lo])
        vals_ = [add(name, float(x), *mk(float(x))) for x in xs]
        order = np.argsort(vals_)[:2]
        for k in order:
            if not math.isfinite(vals_[k]):
                continue
            a_ = math.log(xs[max(k - 1, 0)])
            b_ = math.log(xs[min(k + 1, xs.size - 1)])
            if b_ <= a_:
                continue
            f = lambda u: member_margin(plant, K, T, *mk(math.exp(u)))[0]  # noqa: E731
            r = scipy.optimize.minimize_scalar(f, bounds=(a_, b_), method="bounded", options=dict(xatol=1e-9, maxiter=80))
            x = float(math.exp(r.x))
            add(name, x, *mk(x))
    i = int(np.argmin([l_["margin"] for l_ in loops]))
    return loops[i], loops


# ============================================================================================
# exotune side
# ============================================================================================
def exotune_columns(mapping):
    from exotune.analysis.batch import analyze_batch
    from exotune.api import load_design
    from exotune.config import batch_config

    cfg = load_design(copy.deepcopy(mapping))
    return analyze_batch(batch_config(cfg, {}), latency=True).to_columns()


def _f(cols, k):
    v = cols[k]
    return float(np.asarray(v).ravel()[0])


# ============================================================================================
# Campaign
# ============================================================================================
class Tally:
    def __init__(self):
        self.rows = {}
        self.dis = []

    def add(self, metric, cls, rel=None, detail=None):
        r = self.rows.setdefault(metric, dict(compared=0, agree=0, disagree=0, ref_inconclusive=0, ex_inconclusive=0,
                                              max_rel=0.0))
        r["compared"] += 1
        r[cls.replace("-", "_")] += 1
        if rel is not None and math.isfinite(rel) and cls not in ("ref-inconclusive", "ex-inconclusive"):
            r["max_rel"] = max(r["max_rel"], rel)
        if cls == "disagree" and detail is not None:
            self.dis.append(dict(metric=metric, **detail))


def cmp_scalar(t, metric, ex, ref, tol, detail, absolute=False):
    if isinstance(ref, bool) or isinstance(ex, bool):
        ok = bool(ex) == bool(ref)
        t.add(metric, "agree" if ok else "disagree", 0.0 if ok else 1.0, dict(detail, exotune=ex, reference=ref))
        return ok
    if math.isnan(ex) and math.isnan(ref):
        t.add(metric, "agree", 0.0)
        return True
    if math.isinf(ex) or math.isinf(ref):
        ok = ex == ref
        t.add(metric, "agree" if ok else "disagree", 0.0 if ok else math.inf, dict(detail, exotune=ex, reference=ref))
        return ok
    d = abs(ex - ref) if absolute else _rel(ex, ref)
    ok = d <= tol
    t.add(metric, "agree" if ok else "disagree", d, dict(detail, exotune=ex, reference=ref, diff=d))
    return ok


def write_case(cases: Path, name, mapping, note):
    cases.mkdir(parents=True, exist_ok=True)
    p = cases / f"{name}.yaml"
    txt = "".join(f"# {line}\n" for line in note.splitlines()) + yaml.safe_dump(mapping, sort_keys=False)
    p.write_text(txt)
    return str(p)


def compare_design(m, t: Tally, idx, cases: Path):
    rec = dict(index=idx)
    t0 = time.perf_counter()
    try:
        cols = exotune_columns(m)
    except Exception as e:
        rec["refused"] = f"{type(e).__name__}: {e}"
        return rec
    rec["exotune_s"] = time.perf_counter() - t0
    R = Ref(m)
    lams = R.feature_freqs()
    det = dict(design=idx)
    notes = []

    # ---- 1. DOB
    rd = ref_dob(m)
    if rd is None:
        for k in ("dob_phase_margin_deg", "dob_gain_margin_db", "dob_delay_margin_s", "dob_crossover_hz"):
            cmp_scalar(t, k, _f(cols, k), float("nan"), 0, det)
    else:
        for k in ("dob_phase_margin_deg", "dob_gain_margin_db", "dob_delay_margin_s", "dob_crossover_hz"):
            ok = cmp_scalar(t, k, _f(cols, k), rd[k], TOL[k], det)
            if not ok:
                notes.append(f"{k}: exotune {_f(cols, k)!r} reference {rd[k]!r}")
        ok = cmp_scalar(t, "dob_stable", bool(np.asarray(cols["dob_stable"]).ravel()[0]), rd["dob_stable"], 0, det)
        if rd["pade_stable"] is not None and rd["pade_stable"] != rd["dob_stable"]:
            rec["dob_pade_mismatch"] = True
        if not ok:
            notes.append(f"dob_stable: exotune {cols['dob_stable']} reference {rd['dob_stable']}")
        rec["dob"] = rd

    # ---- 2. amplification
    ra = ref_amplification(R, lams)
    rec["amp"] = ra
    if not cmp_scalar(t, "amplification_dc", _f(cols, "amplification_dc"), ra["amplification_dc"], TOL["amplification_dc"], det):
        notes.append(f"amplification_dc: exotune {_f(cols, 'amplification_dc')!r} reference {ra['amplification_dc']!r}")
    exbw = _f(cols, "amplification_bandwidth_hz")
    d = _rel(exbw, ra["amplification_bandwidth_hz"])
    if d > TOL["amplification_bandwidth_hz"] and ra.get("first_dip_depth_neper", 1.0) < 0.01:
        t.add("amplification_bandwidth_hz", "ref-inconclusive")
        rec["bw_shallow"] = dict(exotune=exbw, ref=ra)
    elif not cmp_scalar(t, "amplification_bandwidth_hz", exbw, ra["amplification_bandwidth_hz"],
                        TOL["amplification_bandwidth_hz"], dict(det, dip=ra.get("first_dip_depth_neper"))):
        notes.append(f"amplification_bandwidth_hz: exotune {exbw!r} reference {ra['amplification_bandwidth_hz']!r} "
                     f"(first dip depth {ra.get('first_dip_depth_neper')} neper)")

    # ---- 3. passivity
    w, c = passivity_grid(R, lams)
    rp = ref_passivity(R, w, c)
    exmax = _f(cols, "passivity_max_phase_excess_deg")
    if not cmp_scalar(t, "passivity_max_phase_excess_deg", exmax, rp["passivity_max_phase_excess_deg"],
                      TOL["passivity_max_phase_excess_deg"], det, absolute=True):
        notes.append(f"passivity_max_phase_excess_deg: exotune {exmax!r} reference {rp['passivity_max_phase_excess_deg']!r}")
    exb = [list(b) for b in cols["passivity_nonpassive_band_hz"][0]]
    refb = [b for b in rp["bands"] if b[2] >= 0.1 * 1.05]
    amb = [b for b in rp["bands"] if 0.1 * 0.95 <= b[2] < 0.1 * 1.05]
    rec["bands"] = dict(exotune=exb, ref=[list(b) for b in rp["bands"] if b[2] >= 0.095])
    used = [False] * len(exb)

    def below_resolution(f_hz):
        # past the reference's band end, |Im C7| stays below exotune's documented float resolution
        # (1e-8 |C7|): a band exotune extends to infinity there is a float-resolution case
        fz = np.geomspace(f_hz * 1.05, f_hz * 1e3, 200)
        cz = R.c7(TWO_PI * fz)
        return bool(np.all(np.abs(cz.imag) < 1e-8 * np.abs(cz)))

    for b in list(refb):
        k = [j for j in range(len(exb)) if not used[j] and exb[j][1] == math.inf and _rel(exb[j][0], b[0]) < 1e-6]
        if k and math.isfinite(b[1]) and below_resolution(b[1]):
            used[k[0]] = True
            refb.remove(b)
            t.add("passivity_nonpassive_band_hz", "ref-inconclusive")
    for b in refb:
        j = min((j for j in range(len(exb)) if not used[j]), default=None,
                key=lambda j: _rel(exb[j][0], b[0]) + _rel(exb[j][1], b[1]))
        if j is None or max(_rel(exb[j][0], b[0]), _rel(exb[j][1], b[1])) > 1e-3:
            t.add("passivity_nonpassive_band_hz", "disagree", math.inf, dict(det, reference_band=b, exotune_bands=exb))
            notes.append(f"passivity band {b} (peak {b[2]:.4f} deg) not listed by exotune {exb}")
            continue
        used[j] = True
        d = max(_rel(exb[j][0], b[0]), _rel(exb[j][1], b[1]))
        ok = d <= TOL["passivity_nonpassive_band_hz"]
        t.add("passivity_nonpassive_band_hz", "agree" if ok else "disagree", d,
              dict(det, reference_band=b, exotune_band=exb[j]))
        if not ok:
            notes.append(f"passivity band ends: exotune {exb[j]} reference {b[:2]}")
    for j, b in enumerate(exb):
        if used[j]:
            continue
        if any(max(_rel(b[0], a[0]), _rel(b[1], a[1])) < 1e-3 for a in amb):
            t.add("passivity_nonpassive_band_hz", "ref-inconclusive")
            continue
        t.add("passivity_nonpassive_band_hz", "disagree", math.inf, dict(det, exotune_band=b, reference_bands=rp["bands"][:20]))
        notes.append(f"passivity band {b} listed by exotune, not by the reference (peaks ≥ 0.1°: {refb[:6]})")

    # ---- 4. critical values
    rec["families"] = []
    for i, fam in enumerate(m["humans"]):
        key = f"human{i}_{fam['kind']}"
        refc = ref_criticals(R, w, c, fam)
        if refc is None:
            continue
        crit_ex = [tuple(map(float, x)) for x in cols[f"{key}_critical"][0]]
        ivs_ex = [tuple(map(float, x)) for x in cols[f"{key}_stable_intervals"][0]]
        rows, ends = compare_family(R, fam, crit_ex, ivs_ex, refc)
        frec = dict(family=key, n_ex=len(crit_ex), n_ref=len(refc["crit"]), problems=[])
        conclusive = bool(cols[f"{key}_conclusive"][0])
        frec["exotune_conclusive"] = conclusive
        # exotune declared the family inconclusive (no interval is claimed): a critical value it did
        # not list, or one off the tolerance, is not a disagreement; it is tallied apart
        bad = "disagree" if conclusive else "ex-inconclusive"
        for r in rows:
            if not conclusive and r["kind"] != "matched":
                t.add("human_critical_value", "ex-inconclusive")
                continue
            if r["kind"] == "matched":
                ok = r["dv"] <= TOL["critical_value"] and r["df"] <= TOL["critical_freq"]
                t.add("human_critical_value", "agree" if r["dv"] <= TOL["critical_value"] else bad, r["dv"],
                      dict(det, family=key, **r))
                t.add("human_critical_freq", "agree" if r["df"] <= TOL["critical_freq"] else bad, r["df"],
                      dict(det, family=key, **r))
                if not ok and conclusive:
                    frec["problems"].append(r)
            elif r["kind"] == "exotune-only":
                # a genuine crossing missed by the reference grid (point check passes) or a spurious one
                if r["point_im_rel"] < 1e-6 and r["point_dv"] < 1e-6:
                    t.add("human_critical_value", "ref-inconclusive")
                    frec.setdefault("ref_missed", []).append(r)
                else:
                    t.add("human_critical_value", "disagree", math.inf, dict(det, family=key, **r))
                    frec["problems"].append(r)
            else:
                if r.get("at_end"):
                    t.add("human_critical_value", "ref-inconclusive")
                else:
                    t.add("human_critical_value", "disagree", math.inf, dict(det, family=key, **r))
                    frec["problems"].append(r)
        for e in ends:
            ok = e["d"] <= TOL["interval_end"]
            t.add("human_interval_end", "agree" if ok else "disagree", e["d"], dict(det, family=key, **e))
            if not ok:
                frec["problems"].append(dict(kind="interval-end", **e))
        if frec["problems"]:
            notes.append(f"{key}: {len(frec['problems'])} critical-value problem(s): "
                         + json.dumps(fv._jsonable(frec["problems"][:4])))
        rec["families"].append(frec)
    rec["notes"] = notes
    if notes:
        rec["case"] = write_case(cases, f"design{idx}", m, "fuzz_metrics disagreement(s):\n" + "\n".join(notes))
    rec["seconds"] = time.perf_counter() - t0
    rec["latency_margin_s"] = _f(cols, "latency_margin_s")
    return rec


# ---- latency subset ------------------------------------------------------------------------
def _shrink(rng, a_, b_, rng_range):
    """A stable interval moved inward at its critical ends by a relative 1e-3 or 1e-2 (never
    more than a quarter of its log-width): robust, with members close to the boundary."""
    s0 = float(rng.choice([1e-3, 1e-2]))
    s = min(s0, math.expm1(0.25 * math.log(b_ / a_))) if b_ > a_ else 0.0
    lo0, hi0 = rng_range
    return (a_ if a_ == lo0 else a_ * (1 + s)), (b_ if b_ == hi0 else b_ / (1 + s))


def make_robust(rng, tries=60):
    """A design exotune finds robust (latency_margin_s > 0): a random design whose families are
    narrowed to one of their stable intervals (shrunk 1 % inward) and whose boxes are dropped."""
    for _ in range(tries):
        m = fv.draw_design(rng, str(rng.choice(["wide", "wide", "light", "stiffcuff", "softcuff"])))
        m["humans"] = [h for h in m["humans"] if len(fv._family_param(h)[0]) == 1]
        try:
            cols = exotune_columns(m)
        except Exception:
            continue
        if not (cols["free_stable"][0] and cols["locked_stable"][0]):
            continue
        ok = True
        for i, fam in enumerate(list(m["humans"])):
            ivs = list(cols[f"human{i}_{fam['kind']}_stable_intervals"][0])
            if not ivs:
                ok = False
                break
            a_, b_ = ivs[int(rng.integers(len(ivs)))]
            p = fv._family_param(fam)[0][0]
            a_, b_ = _shrink(rng, a_, b_, fam[p])
            fam[p] = [float(a_), float(b_)]
        if not ok:
            continue
        envs = [e for e in m["environment"] if e["kind"] in ("spring", "mass")]
        keep = [e for e in m["environment"] if e["kind"] not in ("spring", "mass")]
        for j, env in enumerate(envs):
            ivs = list(cols[f"env{j + 2}_{env['kind']}_stable_intervals"][0]) \
                if f"env{j + 2}_{env['kind']}_stable_intervals" in cols else []
            if ivs:
                a_, b_ = ivs[0]
                p = fv.PARAM[env["kind"]]
                a_, b_ = _shrink(rng, a_, b_, env[p])
                env[p] = [float(a_), float(b_)]
                keep.append(env)
        m["environment"] = keep
        try:
            cols = exotune_columns(m)
        except Exception:
            continue
        lm = _f(cols, "latency_margin_s")
        if lm > 0:
            return m, lm
    return None, None


def compare_latency(m, lm_ex, t: Tally, idx, cases: Path):
    t0 = time.perf_counter()
    plant = {k: float(v) for k, v in m["plant"].items()}
    K = fv.continuous_controller(plant, m["design"], m["implementation"])
    T = float(m["implementation"]["delay_s"])
    crit, loops = ref_latency(m, K)
    lm_ref = crit["margin"]
    rec = dict(index=idx, exotune=lm_ex, reference=lm_ref, loop=crit["loop"], member=crit["member"],
               crossing_hz=(crit["w"] / TWO_PI if crit["w"] else None))
    # independent verdict check at the critical member
    chk = None
    if math.isfinite(lm_ref):
        chk = {}
        for tag, f in (("below", 1 - 1e-4), ("above", 1 + 1e-4)):
            r = fv.member_verdict(plant, K, T + lm_ref * f, crit["human"], crit["env"])
            chk[tag] = r["ref"]
        if math.isfinite(lm_ex) and _rel(lm_ex, lm_ref) > TOL["latency_margin_s"]:
            for tag, f in (("ex_below", 1 - 1e-4), ("ex_above", 1 + 1e-4)):
                chk[tag] = fv.member_verdict(plant, K, T + lm_ex * f, crit["human"], crit["env"])["ref"]
    rec["verdict_check"] = chk
    ref_ok = chk is None or (chk["below"] is True and chk["above"] is False)
    d = _rel(lm_ex, lm_ref)
    if not ref_ok:
        t.add("latency_margin_s", "ref-inconclusive")
        rec["cls"] = "ref-inconclusive"
    else:
        ok = cmp_scalar(t, "latency_margin_s", lm_ex, lm_ref, TOL["latency_margin_s"],
                        dict(design=idx, loop=crit["loop"], member=crit["member"]))
        rec["cls"] = "agree" if ok else "disagree"
        if not ok:
            rec["case"] = write_case(cases, f"latency{idx}", m,
                                     f"latency_margin_s: exotune {lm_ex!r}, reference {lm_ref!r} at {crit['loop']} "
                                     f"member {crit['member']} crossing {rec['crossing_hz']} Hz; verdicts {chk}")
    rec["diff"] = d
    rec["design"] = m
    rec["seconds"] = time.perf_counter() - t0
    return rec


def selftest():
    """The batched responses against python-control's own evaluation."""
    rng = np.random.default_rng(0)
    m = fv.draw_design(rng, "wide")
    R = Ref(m)
    w = np.array([0.3, 7.0, 130.0, 4000.0])
    mine = R.Kr(1j * w)[:, 0, :]
    theirs = np.array([[complex(R.K(1j * x)[0, k]) for k in range(4)] for x in w])
    return float(np.max(np.abs(mine - theirs) / np.maximum(np.abs(theirs), 1e-300)))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--designs", type=int, default=150)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--latency", type=int, default=20, help="robust designs for the latency-margin comparison")
    ap.add_argument("--json", default=None)
    ap.add_argument("--cases", default="/tmp/fm/cases")
    args = ap.parse_args(argv)
    cases = Path(args.cases)
    print(f"self-test: batched controller response vs python-control: max rel diff {selftest():.1e}", flush=True)
    rng = np.random.default_rng(args.seed)
    t = Tally()
    recs = []
    t0 = time.perf_counter()
    for i in range(args.designs):
        regime = str(fv.REGIMES[int(rng.integers(len(fv.REGIMES)))])
        if regime == "boundary":
            regime = "wide"
        m = fv.draw_design(rng, regime)
        rec = compare_design(m, t, i, cases)
        rec["regime"] = regime
        recs.append(rec)
        msg = f"[{i:4d}] {regime:10s} {rec.get('seconds', 0):5.1f} s"
        if "refused" in rec:
            msg += " refused: " + rec["refused"][:100]
        for n in rec.get("notes", []):
            msg += "\n        !! " + n[:400]
        print(msg, flush=True)
    lat = []
    lrng = np.random.default_rng(args.seed + 1000)
    for i in range(args.latency):
        m, lm = make_robust(lrng)
        if m is None:
            print(f"[L{i}] no robust design found", flush=True)
            continue
        r = compare_latency(m, lm, t, i, cases)
        lat.append(r)
        print(f"[L{i:3d}] exotune {lm:.9g} reference {r['reference']:.9g} rel {r['diff']:.1e} at {r['loop']} "
              f"{r['member']} {r['cls']} verdicts {r['verdict_check']} {r['seconds']:.1f} s", flush=True)
    print()
    hdr = (f"{'metric':34s} {'compared':>8s} {'agree':>6s} {'disagree':>8s} {'max rel diff':>12s} {'ref-inconcl':>11s} "
           f"{'ex-inconcl':>10s}")
    print(hdr)
    print("-" * len(hdr))
    for k, r in t.rows.items():
        print(f"{k:34s} {r['compared']:8d} {r['agree']:6d} {r['disagree']:8d} {r['max_rel']:12.2e} {r['ref_inconclusive']:11d} "
              f"{r['ex_inconclusive']:10d}")
    print(f"\n{len(recs)} designs ({sum('refused' in r for r in recs)} refused), {len(lat)} latency designs, "
          f"{time.perf_counter() - t0:.0f} s; disagreements: {len(t.dis)}; cases in {cases}")
    if args.json:
        Path(args.json).write_text(json.dumps(fv._jsonable(dict(table=t.rows, disagreements=t.dis, designs=recs,
                                                                latency=lat)), indent=0, default=str))
    return t


if __name__ == "__main__":
    warnings.simplefilter("ignore", RuntimeWarning)
    main()
