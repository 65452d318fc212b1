"""Independent verification of the features the verdict campaigns did not cover (docs/benchmarks.md,
"Feature campaign").

    python benchmarks/fuzz_features.py --sampled 100 --continuous 50 --seed 3031 [--shard 0/2]
        [--records OUT.jsonl] [--json OUT] [--keep DIR] [--only s3,c1]

Features: ``implementation.velocity_filter`` (with and without a DOB), ``structure: full_filter``,
``precision: float32`` controller files, gain-scheduled files (``transmission``) at 10–20 kHz,
delays that are not whole samples at 10–20 kHz, hysteretic (``complex_stiffness``) human families,
and msd boxes (two or three ranged parameters; the Edge Theorem).

Sampled-data designs: ``exotune.export`` (``allow_uncertified``, no latency requirement) and
``exotune.certify`` of the file, against references built from the controller YAML alone
(``yaml.safe_load``):

* the controller: every sos row as a transposed direct form II section (float64 files), or for
  float32 files the stored realization (delta-operator sections [β0, β1, β2, α1, α2], the float32
  static gains and the stored ``loop_divisor``: the rounded coefficients as executed), the filters
  on τ_cmd closed by τ = (rest + h)/divisor; each gain-schedule entry with its own plant and
  controller;
* the plant of benchmarks/fuzz_verdicts.py (physical equations), discretized with
  ``scipy.signal.cont2discrete`` (zero-order hold), the delay split into whole samples and a
  fraction f·T_s inside the period; stable iff max |λ| < 1 (the rigid-body z = 1 removed when
  nothing grounds the loop and the controller has no DC position feedback);
* members: both ends, log-spaced interior points and exotune's interval ends × (1 ± 1e-3) of every
  rational family (top level and per schedule entry), free and locked;
* the latency margin: the reference loops (free, locked, environment and family members, exotune's
  critical member, hysteretic members by the formal count below at T + ΔT) scanned at ΔT_ex·k/12
  and at ΔT_ex(1 − 1e-3) (must be stable) and ΔT_ex(1 + 1e-3) (some member must be unstable);
  a crossing found is bisected (whole + fractional samples) to the reference's own margin.

Hysteretic families k(1 + jη sign ω) (certify's continuous check and ``analyze``): the formal
Nyquist count of docs/method.md#stable-intervals-of-a-human-family written here:
F(jω) = (K_c + Z_h)·det(jωI − A − B C e^{−jωT}) with the continuous controller assembled from the
file's ``continuous`` blocks (or, for ``analyze``-only designs, from the equations of
docs/method.md#the-cuff-path), F(0) regularized by the real k, the phase followed on an adaptive
grid (8 points per delay-ripple period where the loop gain exceeds 0.3), the tail from the leading
coefficient c: N = (nπ/2 + arctan(Im c/Re c) − Δarg)/π. Sanity: at η = 0 it must equal the
eigenvalue verdict of the spring.

msd boxes (``exotune.analyze``, continuous): every edge's members (both ends and interior points)
against the edge's reported intervals, the corners, and the centre and interior grid against the
box's ``robust``, each by benchmarks/fuzz_verdicts.py's ``member_verdict`` (Newton witness,
argument principle, Padé 8/14) on the continuous controller.

Classes: ``OPTIMISTIC`` (exotune stable / robust / a larger margin where the reference finds
instability), ``conservative``, ``ref-inconclusive``, ``exotune-inconclusive``; members within
1e-9 of |z| = 1 (1e-10 relative of the axis in continuous time) are tallied as float resolution.
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
import tempfile  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402
from collections import Counter  # noqa: E402
from pathlib import Path  # noqa: E402

import control  # noqa: E402
import numpy as np  # noqa: E402
import scipy.linalg  # noqa: E402
import scipy.signal  # noqa: E402
import yaml  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
import fuzz_verdicts as fv  # noqa: E402

SIGNALS = ("theta_m", "omega_m", "tau_s", "dtau_s", "tau_c")
TWO_PI = 2.0 * math.pi


# ============================================================================================
# Part 1. The discrete controller of a file, from its YAML alone
# ============================================================================================
def _df2t(row):
    """(A, B, C, D) of one sos row [b0, b1, b2, 1, a1, a2], transposed direct form II."""
    b0, b1, b2, a0, a1, a2 = (float(x) for x in row)
    assert a0 == 1.0
    return (np.array([[-a1, 1.0], [-a2, 0.0]]), np.array([b1 - a1 * b0, b2 - a2 * b0]), np.array([1.0, 0.0]), b0)


def _delta(sec):
    """(A, B, C, D) of one delta-form section [β0, β1, β2, α1, α2] as executed:
    y = β0 x + s1; s1 += (β1 x − α1 y) + s2; s2 += β2 x − α2 y."""
    b0, b1, b2, a1, a2 = (float(x) for x in sec)
    return (np.array([[1.0 - a1, 1.0], [-a2, 1.0]]), np.array([b1 - a1 * b0, b2 - a2 * b0]), np.array([1.0, 0.0]), b0)


def _cascade(secs):
    """State space (A, B, C, D) of sections in series (first section first), SISO."""
    n = 2 * len(secs)
    A = np.zeros((n, n))
    B = np.zeros(n)
    # x_k⁺ = A_k x_k + B_k u_k;  u_1 = u;  u_{k+1} = y_k = C_k x_k + D_k u_k
    u_row = np.zeros(n)   # u_k as a row over the states (plus uD: coefficient of the input)
    u_in = 1.0
    for k, (a, b, c, d) in enumerate(secs):
        i = slice(2 * k, 2 * k + 2)
        A[i] += np.outer(b, u_row)
        A[i, i] += a
        B[i] += b * u_in
        y_row = d * u_row
        y_row[i] += c
        u_row, u_in = y_row, d * u_in
    return A, B, u_row, u_in


def file_controller(ctrl: dict, precision: str = "float64"):
    """The controller of one ``controller`` mapping (top level or a schedule entry's) as numpy
    (A, B, C, D): inputs SIGNALS, output τ_cmd. float32: the stored realization (rounded
    coefficients, the stored divisor); float64: the sos rows and the divisor 1 − Σ Π b0."""
    real = ctrl.get("realization") if precision == "float32" else None
    if real is not None:
        gains = {s: float(g) for s, g in (real.get("gains") or {}).items()}
        filters = [(f["input"], [_delta(s) for s in f["sections"]]) for f in real["filters"]]
    else:
        gains = {s: float(g["gain"]) for s, g in (ctrl.get("gains") or {}).items()}
        filters = [(f["input"], [_df2t(r) for r in f["sos"]]) for f in ctrl.get("filters") or []]
    blocks = [(inp, _cascade(secs)) for inp, secs in filters]
    n = sum(b[1][0].shape[0] for b in blocks)
    A = np.zeros((n, n))
    B = np.zeros((n, 5))
    rest_C, rest_D = np.zeros(n), np.zeros(5)
    for s, g in gains.items():
        rest_D[SIGNALS.index(s)] += g
    loop_C, g_loop = np.zeros(n), 0.0
    off = 0
    loops = []
    for inp, (a, b, c, d) in blocks:
        i = slice(off, off + a.shape[0])
        A[i, i] = a
        if inp == "tau_cmd":
            loop_C[i] = c
            g_loop += d
            loops.append((i, b))
        else:
            j = SIGNALS.index(inp)
            B[i, j] += b
            rest_C[i] += c
            rest_D[j] += d
        off += a.shape[0]
    divisor = float(real["loop_divisor"]) if real is not None else 1.0 - g_loop
    C = (rest_C + loop_C) / divisor
    D = rest_D / divisor
    for i, b in loops:   # the filters on τ_cmd advance with x = τ_cmd
        A[i] += np.outer(b, C)
        B[i] += np.outer(b, D)
    return A, B, C[None, :], D[None, :]


def position_feedback(ctrl: dict, precision: str) -> bool:
    """True when the controller has a DC path from θ_m (a static θ_m gain, or a θ_m filter none of
    whose sections has its zero at z = 1): then the rigid-body eigenvalue is not excused."""
    real = ctrl.get("realization") if precision == "float32" else None
    if real is not None:
        if float((real.get("gains") or {}).get("theta_m", 0.0)) != 0.0:
            return True
        return any(f["input"] == "theta_m" and not any(float(s[2]) == 0.0 for s in f["sections"])
                   for f in real["filters"])
    if float(((ctrl.get("gains") or {}).get("theta_m") or {}).get("gain", 0.0)) != 0.0:
        return True
    for f in ctrl.get("filters") or []:
        if f["input"] == "theta_m":
            if not any(abs(r[0] + r[1] + r[2]) <= 1e-12 * (abs(r[0]) + abs(r[1]) + abs(r[2])) for r in f["sos"]):
                return True
    return False


class SampledRef:
    """One controller of a file (top level or a schedule entry) on its plant, at the file's rate:
    loop matrices with any delay (whole + fractional samples) and their verdicts."""

    def __init__(self, plant: dict, ctrl: dict, fs: float, T: float, precision: str):
        self.plant = {k: float(v["value"]) if isinstance(v, dict) else float(v) for k, v in plant.items()}
        self.K = file_controller(ctrl, precision)
        self.fs, self.T = float(fs), float(T)
        self.pos_fb = position_feedback(ctrl, precision)
        self._zoh = {}

    def matrix(self, human, env, T=None):
        T = self.T if T is None else float(T)
        Ap, Bp, Cp, _, grounded = fv.plant_matrices(self.plant, human, env, ("th_m", "w_m", "tau_s", "dtau_s", "tau_c"))
        return fv.delayed_loop_matrix(Ap, Bp, Cp, self.K, T, self.fs), grounded

    def verdict(self, human, env, T=None):
        """(stable, spectral radius) of one loop member."""
        M, grounded = self.matrix(human, env, T)
        Mb, _ = scipy.linalg.matrix_balance(M, permute=False)
        ev = np.linalg.eigvals(Mb)
        if not grounded and not self.pos_fb:
            ev = np.delete(ev, int(np.argmin(np.abs(ev - 1.0))))
        rho = float(np.max(np.abs(ev))) if ev.size else 0.0
        return rho < 1.0, rho


# ============================================================================================
# Part 2. Continuous controllers and the hysteretic human's formal count
# ============================================================================================
def continuous_from_file(ctrl: dict) -> control.StateSpace:
    """The continuous controller of a file's ``controller`` mapping from its filters' ``continuous``
    blocks and static gains (θ̇_m = s θ_m, τ̇_s = s τ_s), as a python-control system with inputs
    (w_m, tau_s, dtau_s, tau_c): a θ_m block must have a zero at s = 0 (K1 = 0), it then acts on
    θ̇_m; the filters on τ_cmd (the DOB's Q) close the loop u = rest + Q u, i.e. u = rest/(1 − Q)."""
    ins = ["w_m", "tau_s", "dtau_s", "tau_c"]
    g = np.zeros((1, 4))
    for sig, gv in (ctrl.get("gains") or {}).items():
        if sig == "theta_m":
            raise ValueError("static theta_m gain (K1 ≠ 0): not supported by the continuous reference")
        g[0, ["omega_m", "tau_s", "dtau_s", "tau_c"].index(sig)] += float(gv["gain"])
    total = control.ss([], [], [], g)
    loop = None
    for f in ctrl.get("filters") or []:
        num = [float(x) for x in f["continuous"]["num"]]
        den = [float(x) for x in f["continuous"]["den"]]
        inp = f["input"]
        if inp == "theta_m":
            if abs(num[0]) > 1e-12 * max(abs(x) for x in num):
                raise ValueError("theta_m block without a zero at s = 0")
            num, inp = num[1:] or [0.0], "w_m"
        tf = fv._tf_ss(num[::-1], den[::-1])
        if inp == "tau_cmd":
            loop = tf if loop is None else control.parallel(loop, tf)
            continue
        sel = np.zeros((1, 4))
        sel[0, ins.index({"omega_m": "w_m"}.get(inp, inp))] = 1.0
        total = control.parallel(total, control.series(control.ss([], [], [], sel), tf))
    if loop is not None:
        total = control.series(total, control.feedback(control.ss([], [], [], [[1.0]]), loop, sign=+1))
    return total


def continuous_controller(plant: dict, design: dict, impl: dict) -> control.StateSpace:
    """The continuous controller of docs/method.md#controller written from the equations, inputs
    (w_m, tau_s, dtau_s, tau_c), output τ_cmd (benchmarks/fuzz_verdicts.py's, with ``structure:
    full_filter`` added: the whole improper cuff path times F_v F_d, exotune.model.controller's
    docstring):

        default:      G_c = (J_m/Ĵ_m)·[1 + (J_j/K_s) F_v s (s² + B̃2 s + K̃2)/(s + B̃1)]·(K̂2 + B̂2 s F_d)
        full_filter:  G_c = (J_m/Ĵ_m)·F_v F_d·[1 + (J_j/K_s) s (s² + B̃2 s + K̃2)/(s + B̃1)]·(K̂2 + B̂2 s)
        τ_cmd = −B1 F θ̇_m + K2 τ_s + B2 F τ̇_s + G_c τ_c − δ̂,  δ̂ = Q [(J_m s + B_m) θ̇_m − τ_s − τ_cmd]
    """
    if impl.get("structure", "default") != "full_filter":
        return fv.continuous_controller(plant, design, impl)
    g = fv.spec_gains(plant, design)
    Jm, Bm, Ks, Jj = (float(plant[k]) for k in ("motor_inertia", "motor_damping", "sea_stiffness", "joint_inertia"))
    wv, zv = TWO_PI * float(impl["gv_filter"]["cutoff_hz"]), float(impl["gv_filter"]["damping"])
    wd = TWO_PI * float(impl["derivative_filter"]["cutoff_hz"])
    gv_num = np.polyadd([1.0, g["B1t"]], (Jj / Ks) * np.array([1.0, g["B2t"], g["K2t"], 0.0]))
    num = np.polymul(np.polymul(gv_num, [wv * wv * wd]), [g["B2_hat"], g["K2_hat"]]) * (Jm / g["Jh"])
    den = np.polymul(np.polymul([1.0, g["B1t"]], [1.0, 2 * zv * wv, wv * wv]), [1.0, wd])
    blocks = [control.ss(fv._tf_ss(num, den), inputs=["tau_c"], outputs=["y_gc"], name="gc")]
    terms = ["y_gc"]
    vf = impl.get("velocity_filter")
    F = fv._tf_ss([TWO_PI * float(vf["cutoff_hz"])], [1.0, TWO_PI * float(vf["cutoff_hz"])]) if vf else \
        control.ss([], [], [], [[1.0]])
    blocks.append(control.ss(F * (-g["B1"]), inputs=["w_m"], outputs=["y_b1"], name="b1"))
    blocks.append(control.ss(F * g["B2"], inputs=["dtau_s"], outputs=["y_b2"], name="b2"))
    blocks.append(control.ss([], [], [], [[g["K2"]]], inputs=["tau_s"], outputs=["y_k2"], name="k2"))
    terms += ["y_b1", "y_b2", "y_k2"]
    dob = impl.get("dob")
    if dob:
        wq, zq = TWO_PI * float(dob["cutoff_hz"]), float(dob["damping"])
        qden = [1.0, 2 * zq * wq, wq * wq]
        blocks.append(control.ss(fv._tf_ss([-Jm * wq * wq, -Bm * wq * wq], qden), inputs=["w_m"], outputs=["q1"], name="q1"))
        blocks.append(control.ss(fv._tf_ss([wq * wq], qden), inputs=["tau_s"], outputs=["q2"], name="q2"))
        blocks.append(control.ss(fv._tf_ss([wq * wq], qden), inputs=["tau_cmd"], outputs=["q3"], name="q3"))
        terms += ["q1", "q2", "q3"]
    blocks.append(control.summing_junction(inputs=terms, output="tau_cmd", name="sum"))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return control.interconnect(blocks, inplist=["w_m", "tau_s", "dtau_s", "tau_c"], outlist=["tau_cmd"],
                                    inputs=["w_m", "tau_s", "dtau_s", "tau_c"], outputs=["tau_cmd"])


def _hyst_loop(plant: dict, K: control.StateSpace, zh: complex):
    """(A, B, C) of the loop broken at the delay, cuff free of environment, a massless human of
    impedance zh in series with the cuff spring (complex zh allowed); states θ_m, ω_m, θ_s, ω_j."""
    Jm, Bm, Ks, Jj, Kc = (float(plant[k]) for k in ("motor_inertia", "motor_damping", "sea_stiffness",
                                                   "joint_inertia", "cuff_stiffness"))
    keff = Kc * zh / (Kc + zh)                  # τ_c = −keff θ_j
    A = np.zeros((4, 4), complex)
    A[0, 1] = 1.0
    A[1, 1], A[1, 2] = -Bm / Jm, Ks / Jm
    A[2, 1], A[2, 3] = -1.0, 1.0
    A[3, 0], A[3, 2] = -keff / Jj, (-keff - Ks) / Jj
    B = np.array([0.0, 1.0 / Jm, 0.0, 0.0], complex)
    Cp = np.array([[0, 1, 0, 0], [0, 0, Ks, 0], [0, -Ks, 0, Ks], [-keff, 0, -keff, 0]], complex)
    Ak, Bk, Ck, Dk = (np.asarray(x, float) for x in (K.A, K.B, K.C, K.D))
    nk = Ak.shape[0]
    AL = np.zeros((4 + nk, 4 + nk), complex)
    AL[:4, :4] = A
    AL[4:, :4] = Bk @ Cp
    AL[4:, 4:] = Ak
    BL = np.concatenate([B, np.zeros(nk)])
    CL = np.concatenate([(Dk @ Cp)[0], Ck[0]])
    return AL, BL, CL


def hysteretic_count(plant: dict, K: control.StateSpace, T: float, k: float, eta: float, budget=400000):
    """Formal count N (int) of the hysteretic member k(1 + jη sign ω), or None when not decidable,
    and a dict of details (min |F|/scale on the axis)."""
    Kc = float(plant["cuff_stiffness"])
    zp = complex(k, k * eta)
    A, B, C = _hyst_loop(plant, K, zp)
    A0, B0, C0 = _hyst_loop(plant, K, complex(k, 0.0))
    n = A.shape[0]
    I = np.eye(n)

    def F(w, A=A, B=B, C=C, z=zp):
        w = np.atleast_1d(np.asarray(w, float))
        e = np.exp(-1j * w * T)
        M = 1j * w[:, None, None] * I[None] - A[None] - (np.outer(B, C)[None] * e[:, None, None])
        return (Kc + z) * np.linalg.det(M)

    def G_abs(w):
        w = np.atleast_1d(np.asarray(w, float))
        M = 1j * w[:, None, None] * I[None] - A[None]
        x = np.linalg.solve(M, np.broadcast_to(B, (w.size, n))[..., None])[..., 0]
        return np.abs(x @ C)

    scale = max(1.0, float(np.max(np.abs(np.linalg.eigvals(A)))), float(np.max(np.abs(np.linalg.eigvals(A + np.outer(B, C))))))
    wmax = 1e4 * scale
    wlo = 1e-6 * scale
    w = np.geomspace(wlo, wmax, 40 * int(math.log10(wmax / wlo) + 1))
    with np.errstate(all="ignore"):
        ga = G_abs(w)
    if T > 0:
        hot = w[np.isfinite(ga) & (ga > 0.3)]
        if hot.size:
            top = float(hot.max()) * 1.5
            step = (TWO_PI / T) / 8.0
            if top / step > 2e5:
                return None, dict(why="ripple grid too large")
            w = np.union1d(w, np.arange(step, top, step))
    for lam in np.linalg.eigvals(A):
        if lam.imag > wlo:
            d = max(abs(lam.real), 1e-12 * abs(lam))
            w = np.union1d(w, lam.imag + d * np.array([-10, -3, -1, 0, 1, 3, 10]))
    w = w[(w >= wlo) & (w <= wmax)]
    u = np.concatenate([[0.0], w])
    res = fv._refine(lambda x: F(x), u, F(u), budget)
    if res is None:
        return None, dict(why="phase budget spent")
    u, fu = res
    f0reg = complex(np.linalg.det(-A0 - np.outer(B0, C0))) * (Kc + k)
    if f0reg == 0 or not np.all(np.isfinite(fu)):
        return None, dict(why="F(0) = 0")
    dA = float(np.angle(fu[0] / f0reg)) + float(np.sum(np.angle(fu[1:] / fu[:-1])))
    c = Kc + zp
    dA += float(np.angle(c * (1j ** n) / fu[-1]))
    psi = math.atan(c.imag / c.real)
    N = (n * math.pi / 2 + psi - dA) / math.pi
    mags = np.abs(fu) / np.maximum(np.abs(c) * np.maximum(u, 1.0) ** n, 1e-300)
    info = dict(N=N, min_rel=float(np.min(mags)), points=int(u.size))
    if abs(N - round(N)) > 0.05:
        return None, dict(info, why="non-integer count")
    return int(round(N)), info


# ============================================================================================
# Part 3. Designs
# ============================================================================================
def _no_box(humans):
    return [h for h in humans if sum(isinstance(v, list) for v in h.values()) <= 1]


def draw_sampled(rng) -> dict:
    """A sampled-data design exercising the features (each drawn independently)."""
    m = fv.draw_design(rng, str(rng.choice(["wide", "wide", "stiffcuff", "softcuff"])))
    impl = m["implementation"]
    hr = rng.uniform() < 0.55
    fs = float(rng.choice([10000.0, 20000.0])) if hr else float(rng.choice([1000.0, 2000.0, 4000.0]))
    impl["sample_rate_hz"] = fs
    samples = float(rng.uniform(0.2, 14.0)) if hr else float(rng.uniform(0.05, 6.0))
    if abs(samples - round(samples)) < 0.02:
        samples += 0.37
    impl["delay_s"] = samples / fs
    impl["velocity_filter"] = dict(cutoff_hz=fv._lu(rng, 20.0, 1500.0)) if rng.uniform() < 0.6 else None
    if impl["velocity_filter"] is None:
        impl.pop("velocity_filter")
    if rng.uniform() < 0.5:
        impl["dob"] = None
    elif impl.get("dob") is None:
        impl["dob"] = dict(cutoff_hz=fv._lu(rng, 5.0, 400.0), damping=float(rng.uniform(0.2, 1.5)))
    impl["structure"] = "full_filter" if rng.uniform() < 0.4 else "default"
    impl["precision"] = "float32" if rng.uniform() < 0.4 else "float64"
    for key in ("gv_filter", "derivative_filter", "dob", "velocity_filter"):
        if impl.get(key):
            impl[key]["cutoff_hz"] = min(impl[key]["cutoff_hz"], 0.4 * fs)
    hum = _no_box(m["humans"])
    if hr:   # one rational family besides the mass, one environment range: export time
        hum = hum[:1] + [hum[1 + int(rng.integers(len(hum) - 1))]] if len(hum) > 1 else hum
        rng_env = [e for e in m["environment"] if e["kind"] in ("spring", "mass")]
        m["environment"] = [dict(kind="locked"), dict(kind="free")] + rng_env[:1]
    span = 1e2 if hr else 1e4   # the families are the vehicles here, not the subject
    for h in hum + [e for e in m["environment"] if e["kind"] in ("spring", "mass")]:
        for key in ("inertia", "stiffness", "damping"):
            if isinstance(h.get(key), list):
                h[key][1] = min(h[key][1], h[key][0] * span)
    if hum and hum[0]["kind"] == "mass":
        hum[0]["inertia"][0] = max(hum[0]["inertia"][0], 1e-5 if hr else 1e-6)
        hum[0]["inertia"][1] = max(hum[0]["inertia"][1], hum[0]["inertia"][0])
    if rng.uniform() < 0.4:
        hum.append(dict(kind="complex_stiffness", stiffness=fv._range(rng, 1.0, 300.0, 3.0, 1e3, 1e6),
                        eta=float(rng.uniform(0.05, 1.0))))
    m["humans"] = hum
    if rng.uniform() < (0.6 if hr else 0.25):
        n = 2 if hr else int(rng.integers(2, 4))
        ang = np.sort(rng.uniform(-1.5, 2.0, n))
        m["transmission"] = dict(joint_angle_rad=[float(a) for a in ang],
                                 ratio=[float(r) for r in np.exp(rng.uniform(math.log(0.6), math.log(1.6), n))])
    return m


def pick_sampled(rng, candidates: int) -> dict:
    """Among a few drawn designs, the one whose continuous analysis (delay + half a sample) is the
    most robust: robust claims (and positive latency margins) are the ones that hurt when wrong."""
    best, score = None, None
    for _ in range(candidates):
        m = draw_sampled(rng)
        c = copy.deepcopy(m)
        c["implementation"]["delay_s"] += 0.5 / c["implementation"]["sample_rate_hz"]
        c["implementation"]["sample_rate_hz"] = None
        c["implementation"].pop("precision", None)
        c.pop("transmission", None)
        try:
            r = fv.exotune_continuous(c)
        except Exception:
            continue
        sc = (bool(r.free.stable[0]), sum(bool(h.robust[0]) for h in r.humans) + sum(bool(e.verdict[0]) for e in r.environment))
        if score is None or sc > score:
            best, score = m, sc
    return best if best is not None else draw_sampled(rng)


def draw_continuous(rng) -> dict:
    """A continuous design with an msd box (2 or 3 ranged parameters) and a hysteretic family."""
    m = fv.draw_design(rng, str(rng.choice(["wide", "wide", "stiffcuff", "softcuff"])))
    impl = m["implementation"]
    if rng.uniform() < 0.5:
        impl["velocity_filter"] = dict(cutoff_hz=fv._lu(rng, 20.0, 1500.0))
    else:
        impl.pop("velocity_filter", None)
    if rng.uniform() < 0.5:
        impl["dob"] = None
    impl["structure"] = "full_filter" if rng.uniform() < 0.4 else "default"
    box = dict(kind="msd", inertia=fv._range(rng, 1e-4, 0.1, 2.0, 300.0, 10.0), damping=float(rng.uniform(0.0, 3.0)),
               stiffness=fv._range(rng, 0.5, 300.0, 2.0, 300.0, 1e6))
    if rng.uniform() < 0.35:
        box["damping"] = fv._range(rng, 0.01, 1.0, 3.0, 100.0, 1e4)
    elif rng.uniform() < 0.3:
        box = dict(kind="msd", inertia=box["inertia"], damping=fv._range(rng, 0.01, 1.0, 3.0, 100.0, 1e4),
                   stiffness=box["stiffness"][0])
    m["humans"] = [box, dict(kind="complex_stiffness", stiffness=fv._range(rng, 0.5, 300.0, 3.0, 1e4, 1e7),
                             eta=float(rng.uniform(0.02, 1.5)))]
    m["environment"] = [dict(kind="locked"), dict(kind="free")]
    return m


def pick_continuous(rng, candidates: int) -> dict:
    best, score = None, None
    for _ in range(candidates):
        m = draw_continuous(rng)
        try:
            r = fv.exotune_continuous(m)
        except Exception:
            continue
        sc = (sum(bool(h.robust[0]) for h in r.humans), bool(r.free.stable[0]))
        if score is None or sc > score:
            best, score = m, sc
    return best if best is not None else draw_continuous(rng)


# ============================================================================================
# Part 4. Comparisons
# ============================================================================================
FLOAT_RES = 1e-9


def _members(fam_src: dict, p: str, x: float) -> tuple:
    """(human, env) of a rational family member (human family: env free)."""
    _, vals = fv._family_param(fam_src)
    v = dict(vals, **{p: x})
    return dict(m=v["inertia"], b=v["damping"], k=v["stiffness"]), "free"


def _env_member(env_src: dict, p: str, x: float):
    return None, dict(m=x if p == "inertia" else 0.0, b=float(env_src.get("damping", 0.0)), k=x if p == "stiffness" else 0.0)


def _rational_families(doc: dict, sd: dict):
    """(name, report entry, source mapping, is_env) of every rational family in a sampled report."""
    hum = doc["certify"]["humans"]
    envs = [e for e in doc["certify"]["environment"] if e["kind"] in ("spring", "mass")]
    out = []
    for i, h in enumerate(sd.get("humans", [])):
        if "skipped" not in h:
            out.append((f"human{i}_{h['kind']}", h, hum[i], False))
    for i, e in enumerate(sd.get("environment", [])):
        out.append((f"env{i}_{e['kind']}", e, envs[i], True))
    return out


def _decided(x, ivs, bad, lo, hi) -> bool:
    """Whether exotune decided member x: in a stable interval, or in a gap between intervals that
    holds no unresolved cell and no inconclusive member (certify does not claim such a gap
    unstable member by member: its unresolved and inconclusive members make the whole gap
    undecided)."""
    if fv.in_intervals(x, ivs):
        return not any(a * (1 - 1e-9) <= x <= b * (1 + 1e-9) for a, b in bad)
    edges = [lo] + [e for iv in ivs for e in iv] + [hi]
    for a, b in zip(edges[::2], edges[1::2]):
        if a <= x <= b:
            return not any(c <= b and d >= a for c, d in bad)
    return True


def compare_controller(ref: SampledRef, doc: dict, sd: dict, tag: str, n_grid: int, Kc) -> dict:
    """Every member verdict of one controller (top level or schedule entry) against the reference."""
    loops, fams = [], []
    for loop, env, key in (("free", "free", "free_stable"), ("locked", "locked", "locked_stable")):
        st, rho = ref.verdict(None, env)
        exv = sd.get(key)
        loops.append(dict(ctrl=tag, loop=loop, member=None, exotune=bool(exv), exotune_conclusive=exv is not None, ref=st,
                          rho=rho, float_resolution=abs(rho - 1) < FLOAT_RES, cls=fv.classify(bool(exv), exv is not None, st)))
    for name, fam, src, is_env in _rational_families(doc, sd):
        p = fam["parameter"]
        lo, hi = fam["range"]
        ivs = [list(iv) for iv in fam["stable_intervals"]]
        bad = [list(c) for c in fam.get("unresolved") or []] + [[v, v] for v in fam.get("inconclusive") or []]
        refs = []
        for x in fv.member_grid(lo, hi, ivs, n_grid):
            if fv.near_end(x, ivs, lo, hi):
                continue
            h, e = _env_member(src, p, x) if is_env else _members(src, p, x)
            st, rho = ref.verdict(h, e)
            exs = fv.in_intervals(x, ivs)
            conc = _decided(x, ivs, bad, lo, hi) and not fam.get("budget_spent") and not fam.get("proofs_spent")
            loops.append(dict(ctrl=tag, loop=name, member={p: x}, exotune=exs, exotune_conclusive=conc, ref=st, rho=rho,
                              float_resolution=abs(rho - 1) < FLOAT_RES, cls=fv.classify(exs, conc, st)))
            refs.append(st)
        fams.append(dict(ctrl=tag, loop=name, robust=bool(fam["robust"]), unresolved=len(bad),
                         cls=fv._family_class(bool(fam["robust"]), not bad, refs), members=len(refs)))
    # hysteretic families: certify's continuous check against the formal count
    if Kc is not None:
        for i, h in enumerate(sd.get("humans", [])):
            cc = h.get("continuous_check")
            if h.get("kind") != "complex_stiffness" or not cc or not cc.get("checked"):
                continue
            src = doc["certify"]["humans"][i]
            lo, hi = h["range"]
            ivs = [list(iv) for iv in cc.get("stable_intervals") or []]
            conc = bool(cc.get("conclusive"))
            refs = []
            for x in fv.member_grid(lo, hi, ivs, 8):
                if fv.near_end(x, ivs, lo, hi):
                    continue
                N, info = hysteretic_count(ref.plant, Kc, ref.T, x, float(src["eta"]))
                st = None if N is None else N == 0
                exs = fv.in_intervals(x, ivs)
                loops.append(dict(ctrl=tag, loop=f"human{i}_complex_stiffness", member={"stiffness": x}, exotune=exs,
                                  exotune_conclusive=conc, ref=st, count=N, min_rel=info.get("min_rel"),
                                  float_resolution=False, cls=fv.classify(exs, conc, st)))
                refs.append(st)
            fams.append(dict(ctrl=tag, loop=f"human{i}_complex_stiffness", robust=bool(cc.get("robust")), unresolved=0,
                             cls=fv._family_class(bool(cc.get("robust")), conc, refs), members=len(refs)))
    return dict(loops=loops, families=fams)


def _margin_probes(doc: dict, sd: dict, lm: dict):
    """The members the latency-margin reference checks: free, locked, every rational family's ends,
    6 log-spaced interior points and exotune's interval ends, exotune's critical member; and the
    hysteretic members (ends + 3 interior)."""
    probes = [("free", None, "free"), ("locked", None, "locked")]
    crit = (lm or {}).get("critical") or {}
    for name, fam, src, is_env in _rational_families(doc, sd):
        p = fam["parameter"]
        lo, hi = fam["range"]
        xs = set(np.geomspace(lo, hi, 8).tolist()) if hi > lo else {lo}
        if crit.get("loop") == name and crit.get("value") is not None:
            xs.add(float(crit["value"]))
        for x in sorted(xs):
            h, e = _env_member(src, p, x) if is_env else _members(src, p, x)
            probes.append((name, {p: x}, (h, e)))
    hyst = []
    for i, h in enumerate(sd.get("humans", [])):
        if h.get("kind") == "complex_stiffness":
            lo, hi = h["range"]
            for x in (np.geomspace(lo, hi, 5) if hi > lo else [lo]):
                hyst.append((f"human{i}_complex_stiffness", float(x), float(doc["certify"]["humans"][i]["eta"])))
    return probes, hyst


def _all_stable(ref: SampledRef, probes, hyst, Kc, T):
    """(all stable, first unstable probe name/member, max ρ, undecided hysteretic members)."""
    worst = 0.0
    for name, member, arg in probes:
        h, e = (None, arg) if isinstance(arg, str) else arg
        st, rho = ref.verdict(h, e, T)
        worst = max(worst, rho)
        if not st:
            return False, (name, member, rho), worst, 0
    undecided = 0
    if Kc is not None:
        for name, k, eta in hyst:
            N, _ = hysteretic_count(ref.plant, Kc, T, k, eta)
            if N is None:
                undecided += 1
            elif N != 0:
                return False, (name, {"stiffness": k}, None), worst, undecided
    return True, None, worst, undecided


def compare_margin(ref: SampledRef, doc: dict, sd: dict, lm: dict, tag: str, Kc) -> dict:
    """The certify latency margin of one controller against the reference loops."""
    rec = dict(ctrl=tag, exotune_s=lm.get("extra_delay_s") if lm else None)
    if not lm:
        rec["cls"] = "no margin reported"
        return rec
    if tag == "main" and lm.get("gain_schedule_entry"):
        # the file's margin is the smallest over the main controller and the entries: compare the
        # main controller with its own (each entry is compared with its own margin)
        lm = dict(lm, extra_delay_s=lm.get("main_controller_s"), critical=None)
    probes, hyst = _margin_probes(doc, sd, lm)
    T0 = ref.T
    dT = lm.get("extra_delay_s")
    rec.update(critical=lm.get("critical"), exotune_s=dT)
    if dT is None:   # no probe unstable up to 200 samples of total delay: check that claim
        up = lm.get("checked_up_to_s") or max(200.0 / ref.fs - T0, 0.0)
        bad = None
        for extra in np.linspace(0.0, up, 25)[1:]:
            ok, first, _, _ = _all_stable(ref, probes, hyst, Kc, T0 + extra)
            if not ok:
                bad = (float(extra), first)
                break
        rec.update(cls="OPTIMISTIC" if bad else "agree", checked_up_to_s=up,
                   why=f"no instability claimed up to {up:.4g} s; reference unstable at +{bad}" if bad else "")
        return rec
    if dT == 0.0:
        ok, first, _, _ = _all_stable(ref, probes, hyst, Kc, T0)
        unsure = (sd.get("free_stable") is None or sd.get("locked_stable") is None
                  or any((f.get("unresolved") or f.get("inconclusive") or f.get("budget_spent"))
                         for f in sd.get("humans", []) + sd.get("environment", [])))
        rec.update(cls="agree" if not ok else ("exotune-inconclusive" if unsure else "conservative"), ref_first=first)
        return rec
    Ts = 1.0 / ref.fs
    prev = 0.0
    for k in list(range(1, 12)) + [None]:
        x = dT * (k / 12.0 if k else 1.0 - 1e-3)
        ok, first, worst, und = _all_stable(ref, probes, hyst, Kc, T0 + x)
        if not ok:
            lo, hi = prev, x
            for _ in range(40):
                mid = 0.5 * (lo + hi)
                if _all_stable(ref, probes, hyst, Kc, T0 + mid)[0]:
                    lo = mid
                else:
                    hi = mid
            rec.update(cls="OPTIMISTIC", ref_s=0.5 * (lo + hi), ref_first=first,
                       ratio=dT / max(0.5 * (lo + hi), 1e-300), ex_samples=dT / Ts, ref_samples=0.5 * (lo + hi) / Ts)
            return rec
        prev = x
    ok, first, worst, und = _all_stable(ref, probes, hyst, Kc, T0 + dT * (1 + 1e-3))
    if not ok:
        rec.update(cls="agree", ref_first=first, ex_samples=dT / Ts)
        return rec
    # reference still stable just above exotune's margin: find the reference's own crossing
    lo = dT * (1 + 1e-3)
    hi = None
    for f_ in (1.01, 1.03, 1.1, 1.3, 2.0):
        if not _all_stable(ref, probes, hyst, Kc, T0 + dT * f_)[0]:
            hi = dT * f_
            break
        lo = dT * f_
    if hi is not None:
        for _ in range(40):
            mid = 0.5 * (lo + hi)
            if _all_stable(ref, probes, hyst, Kc, T0 + mid)[0]:
                lo = mid
            else:
                hi = mid
    rec.update(cls="conservative", ref_s=None if hi is None else 0.5 * (lo + hi), ex_samples=dT / Ts,
               ratio=None if hi is None else dT / (0.5 * (lo + hi)), undecided_hysteretic=und)
    return rec


BUDGET_S = 60.0


def certify_report(path: Path) -> dict:
    """exotune.certify of a file with every unresolved cell listed (as fuzz_verdicts does) and
    the campaign's time budget (a family whose budget is spent is unresolved: not compared)."""
    import exotune
    from exotune.controllerfile import continuation

    saved = getattr(continuation, "MAX_LISTED", None)
    try:
        if saved is not None:
            continuation.MAX_LISTED = 10 ** 9
        return exotune.certify(str(path), time_budget_s=BUDGET_S).to_dict()
    finally:
        if saved is not None:
            continuation.MAX_LISTED = saved


def compare_sampled(mapping: dict, workdir: Path, tag: str, n_grid: int = 10) -> dict:
    import exotune

    rec = dict(design=mapping, loops=[], families=[], margins=[])
    src, out = workdir / f"{tag}.yaml", workdir / f"{tag}.controller.yaml"
    t0 = time.perf_counter()
    try:
        src.write_text(yaml.safe_dump(mapping, sort_keys=False))
        exotune.export(str(src), out=str(out), allow_uncertified=True, require_latency_margin_s=0.0, time_budget_s=BUDGET_S)
        cert = certify_report(out)
    except Exception as e:
        rec["refused"] = f"{type(e).__name__}: {e}"
        return rec
    rec["exotune_s"] = time.perf_counter() - t0
    doc = yaml.safe_load(out.read_text())
    rec["certified"] = bool(cert.get("certified"))
    fs = float(doc["sample_rate_hz"]["value"])
    T = float(doc["delay_s"]["value"])
    prec = (doc.get("implementation") or {}).get("precision", "float64")
    ctrls = [("main", doc["plant"], doc["controller"], cert["sampled"], cert.get("latency_margin"))]
    for i, e in enumerate((doc.get("gain_schedule") or {}).get("entries") or []):
        ce = cert["gain_schedule"][i]
        ctrls.append((f"entry{i}", e["plant"], e["controller"], ce["sampled"], ce.get("latency_margin")))
    # continuous-block sanity (once per file): the file's continuous controller against the
    # equations of docs/method.md (catches a wrong reading of the structures by either side)
    has_hyst = any(h["kind"] == "complex_stiffness" for h in doc["certify"]["humans"])
    Kc_main = None
    try:
        Kc_main = continuous_from_file(doc["controller"])
        plant = {k: float(v["value"]) for k, v in doc["plant"].items()}
        design = {k: float(v["value"]) for k, v in doc["design"].items()}
        Keq = continuous_controller(plant, design, mapping["implementation"])
        w = np.geomspace(0.1, 0.45 * TWO_PI * fs, 60)

        def row(K, x):   # over (θ̇_m, τ_s, τ_c): a τ̇_s path is s times a τ_s path
            r = np.asarray(control.evalfr(K, 1j * x)).ravel()
            return np.array([r[0], r[1] + 1j * x * r[2], r[3]])
        r1 = np.array([row(Kc_main, x) for x in w])
        r2 = np.array([row(Keq, x) for x in w])
        rec["continuous_block_rel_err"] = float(np.max(np.abs(r1 - r2) / np.maximum(np.abs(r2), 1e-9 * np.max(np.abs(r2)))))
    except Exception as e:  # noqa: BLE001 - recorded
        rec["continuous_block_error"] = f"{type(e).__name__}: {e}"
    for tag_c, plant, ctrl, sd, lm in ctrls:
        ref = SampledRef(plant, ctrl, fs, T, prec)
        Kc = None
        if has_hyst:
            Kc = Kc_main if tag_c == "main" else continuous_from_file(ctrl)
        r = compare_controller(ref, doc, sd, tag_c, n_grid, Kc)
        rec["loops"] += r["loops"]
        rec["families"] += r["families"]
        rec["margins"].append(compare_margin(ref, doc, sd, lm, tag_c, Kc))
    rec["seconds"] = time.perf_counter() - t0
    return rec


def compare_continuous(mapping: dict, n_edge: int = 6) -> dict:
    """``exotune.analyze`` of a box + hysteretic design against the continuous references."""
    import exotune

    rec = dict(design=mapping, loops=[], families=[])
    t0 = time.perf_counter()
    try:
        an = exotune.analyze(copy.deepcopy(mapping)).to_dict()
    except Exception as e:
        rec["refused"] = f"{type(e).__name__}: {e}"
        return rec
    rec["exotune_s"] = time.perf_counter() - t0
    plant, impl = mapping["plant"], mapping["implementation"]
    K = continuous_controller(plant, mapping["design"], impl)
    T = float(impl["delay_s"])
    for i, h in enumerate(an["humans"]):
        src = mapping["humans"][i]
        conc = bool(h.get("conclusive"))
        refs = []
        if h.get("box"):
            box = h["box"]
            _, vals = fv._family_param(src)
            for j, edge in enumerate(h.get("edges") or []):
                p = edge["parameter"]
                lo, hi = edge["range"]
                ivs = [list(iv) for iv in edge.get("stable_intervals") or []]
                for x in fv.member_grid(lo, hi, ivs, n_edge):
                    if fv.near_end(x, ivs, lo, hi):
                        continue
                    v = dict(vals, **edge["at"], **{p: x})
                    r = fv.member_verdict(plant, K, T, dict(m=v["inertia"], b=v["damping"], k=v["stiffness"]), "free")
                    exs = fv.in_intervals(x, ivs) if edge.get("stable_intervals") is not None else bool(h["robust"])
                    rec["loops"].append(dict(loop=f"human{i}_box_edge{j}", member=dict(edge["at"], **{p: x}), exotune=exs,
                                             exotune_conclusive=conc, ref=r["ref"], why=r["why"], rel_re=r.get("rel_re"),
                                             float_resolution=r.get("rel_re") is not None and abs(r["rel_re"]) < 1e-10,
                                             cls=fv.classify(exs, conc, r["ref"])))
                    refs.append(r["ref"])
            ranged = [p for p in ("inertia", "damping", "stiffness") if p in box]
            for frac in ([0.5] if len(ranged) == 3 else [0.25, 0.5, 0.75]):
                for frac2 in ([0.5] if len(ranged) == 3 else [0.25, 0.5, 0.75]):
                    v = dict(vals)
                    fr = [frac, frac2, 0.5]
                    for q, p in enumerate(ranged):
                        a, b = box[p]
                        v[p] = a * (b / a) ** fr[q]
                    r = fv.member_verdict(plant, K, T, dict(m=v["inertia"], b=v["damping"], k=v["stiffness"]), "free")
                    ex = bool(h["robust"])
                    rec["loops"].append(dict(loop=f"human{i}_box_interior", member={p: v[p] for p in ranged}, exotune=ex,
                                             exotune_conclusive=conc, ref=r["ref"], why=r["why"], rel_re=r.get("rel_re"),
                                             float_resolution=r.get("rel_re") is not None and abs(r["rel_re"]) < 1e-10,
                                             cls=fv.classify(ex, conc, r["ref"]) if ex else "box-not-robust"))
                    refs.append(r["ref"])
            rec["families"].append(dict(loop=f"human{i}_box{len(ranged)}", robust=bool(h["robust"]), conclusive=conc,
                                        cls=fv._family_class(bool(h["robust"]), conc, refs), members=len(refs)))
        elif h["kind"] == "complex_stiffness":
            lo, hi = h["range"]
            ivs = [list(iv) for iv in h.get("stable_intervals") or []]
            for x in fv.member_grid(lo, hi, ivs, 10, [c[0] if isinstance(c, (list, tuple)) else c.get("value", 0.0)
                                                     for c in h.get("critical") or []]):
                if fv.near_end(x, ivs, lo, hi):
                    continue
                N, info = hysteretic_count(plant, K, T, x, float(src["eta"]))
                st = None if N is None else N == 0
                exs = fv.in_intervals(x, ivs)
                rec["loops"].append(dict(loop=f"human{i}_complex_stiffness", member={"stiffness": x}, exotune=exs,
                                         exotune_conclusive=conc, ref=st, count=N, min_rel=info.get("min_rel"),
                                         float_resolution=info.get("min_rel", 1.0) < 1e-10, cls=fv.classify(exs, conc, st)))
                refs.append(st)
            rec["families"].append(dict(loop=f"human{i}_complex_stiffness", robust=bool(h["robust"]), conclusive=conc,
                                        cls=fv._family_class(bool(h["robust"]), conc, refs), members=len(refs)))
    # sanity of the formal count: η = 0 against the eigenvalue verdict of the spring
    hy = [f for f in mapping["humans"] if f["kind"] == "complex_stiffness"]
    if hy:
        k = float(math.sqrt(hy[0]["stiffness"][0] * hy[0]["stiffness"][1]))
        N, _ = hysteretic_count(plant, K, T, k, 0.0)
        r = fv.member_verdict(plant, K, T, dict(m=0.0, b=0.0, k=k), "free")
        rec["eta0_sanity"] = dict(count=N, ref=r["ref"], ok=(N is None or r["ref"] is None or (N == 0) == r["ref"]))
    rec["seconds"] = time.perf_counter() - t0
    return rec


# ============================================================================================
# Part 5. The campaign
# ============================================================================================
def _jsonable(o):
    return fv._jsonable(o)


def _line(head, rec):
    if "refused" in rec:
        return f"{head} refused: {rec['refused'][:200]}"
    bad = [x for x in rec["loops"] if x["cls"] not in ("agree", "box-not-robust")]
    fr = [x for x in bad if x.get("float_resolution")]
    bad = [x for x in bad if not x.get("float_resolution")]
    fams = [f for f in rec["families"] if f["cls"] != "agree"]
    mar = [m for m in rec.get("margins", []) if m.get("cls") != "agree"]
    s = f"{head} {len(rec['loops']):4d} members {rec['seconds']:6.1f} s (exotune {rec.get('exotune_s', 0):5.1f} s)"
    if bad or fams or mar:
        s += f"  !! {len(bad)} member, {len(fams)} family, {len(mar)} margin disagreement(s)"
    if fr:
        s += f" ({len(fr)} at float resolution)"
    for b in bad[:5]:
        s += "\n        " + json.dumps(_jsonable({k: b.get(k) for k in ("ctrl", "loop", "member", "exotune", "exotune_conclusive",
                                                                        "ref", "rho", "count", "why", "cls")}))
    for f in fams:
        s += "\n        family " + json.dumps(_jsonable(f))
    for m in mar:
        s += "\n        margin " + json.dumps(_jsonable(m))
    for k in ("eta0_sanity", "continuous_block_error"):
        if k in rec and (k != "eta0_sanity" or not rec[k]["ok"]):
            s += f"\n        {k}: {rec[k]}"
    if rec.get("continuous_block_rel_err", 0.0) > 1e-6:
        s += f"\n        continuous blocks differ from the equations: {rec['continuous_block_rel_err']:.2e}"
    return s


def summarize(samp, cont):
    c = Counter()
    for kind, recs in (("sampled", samp), ("continuous", cont)):
        for r in recs:
            if "refused" in r:
                c[f"{kind} refused"] += 1
                continue
            c[f"{kind} designs"] += 1
            for x in r["loops"]:
                key = x["cls"] + (" (float resolution)" if x.get("float_resolution") and x["cls"] != "agree" else "")
                c[f"{kind} members: {key}"] += 1
                if kind == "continuous" or x["loop"].endswith("complex_stiffness"):
                    lk = "hysteretic" if "complex" in x["loop"] else "box"
                    c[f"{kind} {lk} members: {key}"] += 1
            for f in r["families"]:
                c[f"{kind} families: {f['cls']} ({'robust' if f['robust'] else 'not robust'})"] += 1
            for m in r.get("margins", []):
                c[f"margins: {m.get('cls')}"] += 1
            if "eta0_sanity" in r:
                c["eta0 sanity ok" if r["eta0_sanity"]["ok"] else "eta0 sanity FAILED"] += 1
    return dict(sorted(c.items()))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sampled", type=int, default=100)
    ap.add_argument("--continuous", type=int, default=50)
    ap.add_argument("--seed", type=int, default=2027)
    ap.add_argument("--shard", default="0/1", help="i/n: run every n-th design starting at i (same random stream)")
    ap.add_argument("--records", default=None)
    ap.add_argument("--json", default=None)
    ap.add_argument("--only", default=None, help="comma-separated design tags (s3,c1) to run")
    ap.add_argument("--keep", default=None, help="directory to keep the design and controller files in")
    args = ap.parse_args(argv)
    si, sn = (int(x) for x in args.shard.split("/"))
    rng = np.random.default_rng(args.seed)
    sd_ = [("sampled", i, pick_sampled(rng, 6 if rng.uniform() < 0.7 else 1)) for i in range(args.sampled)]
    cd_ = [("continuous", i, pick_continuous(rng, 4 if rng.uniform() < 0.6 else 1)) for i in range(args.continuous)]
    designs = []   # interleaved, so that a run stopped early has both kinds
    while sd_ or cd_:
        designs += sd_[:2] + cd_[:1]
        sd_, cd_ = sd_[2:], cd_[1:]
    records = open(args.records, "a") if args.records else None
    samp, cont = [], []
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as td:
        wd = Path(args.keep) if args.keep else Path(td)
        wd.mkdir(parents=True, exist_ok=True)
        for n_, (kind, i, m) in enumerate(designs):
            if n_ % sn != si:
                continue
            if args.only and f"{kind[0]}{i}" not in args.only.split(","):
                continue
            if kind == "sampled":
                rec = compare_sampled(m, wd, f"s{i}")
                imp = m["implementation"]
                feats = ",".join(x for x, on in (("vf", bool(imp.get("velocity_filter"))), ("dob", bool(imp.get("dob"))),
                                                 ("ff", imp.get("structure") == "full_filter"),
                                                 ("f32", imp.get("precision") == "float32"),
                                                 ("sched", "transmission" in m),
                                                 ("hyst", any(h["kind"] == "complex_stiffness" for h in m["humans"]))) if on)
                head = f"[s{i:3d}] {imp['sample_rate_hz']:6.0f} Hz {imp['delay_s'] * imp['sample_rate_hz']:6.2f} smp {feats:28s}"
                samp.append(dict(rec, index=i))
            else:
                rec = compare_continuous(m)
                imp = m["implementation"]
                nb = sum(isinstance(v, list) for v in m["humans"][0].values())
                head = (f"[c{i:3d}] box{nb} {'vf' if imp.get('velocity_filter') else '  '} {'dob' if imp.get('dob') else '   '} "
                        f"{imp.get('structure', 'default'):11s}")
                cont.append(dict(rec, index=i))
            print(_line(head, rec), flush=True)
            if records:
                records.write(json.dumps(_jsonable(dict(kind=kind, index=i, **rec))) + "\n")
                records.flush()
    summary = dict(seed=args.seed, shard=args.shard, seconds=round(time.perf_counter() - t0, 1), **summarize(samp, cont))
    print(json.dumps(summary, indent=1))
    if args.json:
        Path(args.json).write_text(json.dumps(_jsonable(dict(summary=summary, sampled=samp, continuous=cont)), indent=0))
    return summary


if __name__ == "__main__":
    warnings.simplefilter("ignore", RuntimeWarning)
    main()
