"""Independent reference model of the closed-loop exoskeleton (docs/method.md#physical-model, docs/method.md#controller), for tests only.

This module rebuilds the coupled linear system *directly from the physical equations* as a
state-space model (numpy matrices wrapped in a python-control ``StateSpace``) and returns its
eigenvalues. It deliberately shares no code with ``exotune.analysis`` (nor with
``exotune.model.plant``/``exotune.model.controller``): the controller gains, the cuff-path transfer function
G_c and the DOB are taken as plain numbers / coefficient arrays, and everything else
(physics, signal routing, realizations of the rational blocks, Padé delay) is written out here.

Conventions (docs/method.md#physical-model, paper eq. (5) -- all joint-reflected, SI units
-------------------------------------------------------------------------
    τ_s = K_s (θ_j − θ_m)                          spring torque (sensed)
    J_m θ̈_m + B_m θ̇_m = τ_s + τ_m + δ_f            motor (δ_f: transmission disturbance input)
    J_j θ̈_j = τ_c − τ_s + τ_env                      joint (τ_env: environment torque)
    τ_c = K_c (θ_h − θ_j)                          cuff torque (sensed)
    human node: torque on the node = −Z_h θ_h + τ_h (τ_h: voluntary / test torque), i.e.
        mass/msd:   m θ̈_h + b θ̇_h + k θ_h = τ_h − τ_c
        massless:   b θ̇_h + k θ_h = τ_h − τ_c   (first order if b > 0; algebraic if b = 0:
                    θ_h = (τ_h + K_c θ_j)/(K_c + k), i.e. K_c in series with k)
        None:       cuff free = massless node with k = b = 0  ⇒ τ_c = τ_h (≡ 0 without input)
    environment at θ_j: "free"; "locked" (θ_j ≡ 0: the joint states are removed); or a dict
        {kind: spring|mass|msd, value: k or m, damping: b[, stiffness: k, inertia: m]} giving
        τ_env = τ_env,in − (m_e θ̈_j + b_e θ̇_j + k_e θ_j)   (m_e rigidly added to J_j).

Controller (docs/method.md#controller), torque units:
    τ_cmd = −(K1 θ_m + B1 θ̇_m) + (K2 τ_s + B2 τ̇_s) + G_c(s) τ_c − δ̂,    τ_m = e^{−sT} τ_cmd
    θ̇_m and τ̇_s = K_s(θ̇_j − θ̇_m) are the exact plant states (ideal velocity measurement).
    DOB (optional): δ̂ = Q(s)[(J_m s² + B_m s) θ_m − τ_s − τ_cmd],
        Q(s) = ω_q²/(s² + 2ζ_q ω_q s + ω_q²); realized as the proper block Q·(J_m s² + B_m s)
        acting on θ_m minus the strictly proper block Q acting on (τ_s + τ_cmd).
    Delay: exact (no states) when T == 0, otherwise the (n, n) Padé approximant of
        ``control.pade``, realized in normalized time (A = A_n/T, B = B_n/T) for conditioning.

Argument formats
----------------
plant : dict with J_m, B_m, K_s, J_j, K_c (floats).
gains : dict with K1, B1, K2, B2 (torque units: K2 [–], B2 [s]) and optionally
        ``Gc = (num, den)`` in **ascending** powers of s (proper); missing/None ⇒ G_c = 0.
impl  : dict (or None) with ``T`` (delay [s], default 0) and ``dob`` = None or
        {"cutoff_hz": f, "damping": ζ} (or {"omega": ω_q, "damping": ζ}).
human : None or {"kind": "spring"|"mass"|"msd", "stiffness"|"k", "damping"|"b",
        "inertia"|"m"} (missing parameters are 0).
env   : "free" | "locked" | dict as above.

Exogenous inputs of :func:`closed_loop_system`: ``[τ_h, τ_env, δ_f]``; outputs:
``[θ_h, θ_j, θ_m, τ_c, τ_s, τ_m, τ_cmd]``. With ``human=None``, θ_h/τ_h is the operator-side
compliance C7(s) of paper Table II; with human None and env free, θ_j/τ_env is C5(s) (with the
delay/DOB-modified actuator).
"""

from __future__ import annotations

import math

import control
import numpy as np

__all__ = [
    "INPUTS",
    "OUTPUTS",
    "reference_gains",
    "reference_gc",
    "closed_loop_system",
    "closed_loop_poles",
    "has_rigid_body_mode",
    "free_rigid_body_tolerant_max_real",
    "coupled_verdict",
    "RIGID_BODY_RTOL",
    "free_loop_eigs_mismatched_dob",
]

INPUTS = ("tau_h", "tau_env", "delta_f")
OUTPUTS = ("theta_h", "theta_j", "theta_m", "tau_c", "tau_s", "tau_m", "tau_cmd")

#: Tolerance of the rigid-body eigenvalue removal: the eigenvalue removed must satisfy
#: |λ0| ≤ RIGID_BODY_RTOL · max(1, max_i |λ_i|). The exact eigenvalue is 0; LAPACK computes a
#: simple eigenvalue to about eps·‖A‖·κ, so 1e-6 leaves ~10 decades of headroom for κ while
#: still being far below any physical pole of the systems tested here.
RIGID_BODY_RTOL = 1e-6


# ----------------------------------------------------------------------------------------------
# Gains and G_c from docs/method.md#controller, docs/method.md#double-compliance-shaping, written out independently of exotune
# ----------------------------------------------------------------------------------------------
def reference_gains(plant: dict, design: dict) -> dict:
    """Double compliance shaping gains (docs/method.md#double-compliance-shaping, torque units) and shape parameters.

    design: amplification α, felt_inertia Ĵ_m/α, felt_damping B̂_m/α, zeta ζ, zeta_hat ζ̂.
    """
    a = float(design["amplification"])
    Jh = a * float(design["felt_inertia"])
    Bh = a * float(design["felt_damping"])
    z, zh = float(design["zeta"]), float(design["zeta_hat"])
    J_m, B_m, K_s, K_c = plant["J_m"], plant["B_m"], plant["K_s"], plant["K_c"]
    K2t = K_s / Jh
    B1t = Bh / Jh
    B2t = 2.0 * z * math.sqrt(K_s / Jh)
    return {
        "K1": 0.0,
        "B1": J_m * B1t - B_m,
        "K2": J_m / Jh - 1.0,
        "B2": (B2t - B1t) * J_m / K_s,
        "K2_hat": a - 1.0,
        "B2_hat": (2.0 * zh * math.sqrt(a * K_c * Jh) - Bh) / K_c,
        "K1_tilde": 0.0,
        "B1_tilde": B1t,
        "K2_tilde": K2t,
        "B2_tilde": B2t,
        "J_m_hat": Jh,
        "B_m_hat": Bh,
    }


def reference_gc(plant: dict, design: dict, gv_filter: dict, derivative_filter: dict):
    """docs/method.md#controller default G_c,impl as ascending (num, den), built here with numpy.polynomial:

    G_c,impl = (J_m/Ĵ_m)[1 + (J_j/K_s) F_v s (s² + B̃2 s + K̃2)/(s + B̃1)] (K̂2 + B̂2 s F_d),
    F_v = ω_v²/(s² + 2ζ_v ω_v s + ω_v²), F_d = ω_d/(s + ω_d), ω = 2π·cutoff_hz.
    """
    P = np.polynomial.Polynomial
    g = reference_gains(plant, design)
    wv = 2 * math.pi * float(gv_filter["cutoff_hz"])
    zv = float(gv_filter.get("damping", 0.7))
    wd = 2 * math.pi * float(derivative_filter["cutoff_hz"])
    c = plant["J_j"] / plant["K_s"]
    fv_den = P([wv * wv, 2 * zv * wv, 1.0])
    N = P([0.0, g["K2_tilde"], g["B2_tilde"], 1.0])  # s (s² + B̃2 s + K̃2)
    d1 = P([g["B1_tilde"], 1.0])  # s + B̃1
    inner_num = fv_den * d1 + c * wv * wv * N
    inner_den = fv_den * d1
    outer_num = P([g["K2_hat"] * wd, g["K2_hat"] + g["B2_hat"] * wd])  # K̂2 (s+ω_d) + B̂2 ω_d s
    outer_den = P([wd, 1.0])
    k = plant["J_m"] / g["J_m_hat"]
    num = k * inner_num * outer_num
    den = inner_den * outer_den
    return np.asarray(num.coef, float), np.asarray(den.coef, float)


# ----------------------------------------------------------------------------------------------
# Realizations
# ----------------------------------------------------------------------------------------------
def _trim_high(c) -> np.ndarray:
    c = np.atleast_1d(np.asarray(c, dtype=float)).ravel()
    nz = np.flatnonzero(c)
    return c[: nz[-1] + 1] if nz.size else np.zeros(1)


def _ss_from_asc(num, den):
    """Controllable canonical realization (A, B, C, D) of a proper num/den (ascending)."""
    num, den = _trim_high(num), _trim_high(den)
    n = den.size - 1
    if num.size - 1 > n:
        raise ValueError("improper transfer function cannot be realized")
    if not np.any(num):
        return np.zeros((0, 0)), np.zeros((0, 1)), np.zeros((1, 0)), np.zeros((1, 1))
    an = den[-1]
    a = den / an
    b = np.zeros(n + 1)
    b[: num.size] = num / an
    D = b[n]
    if n == 0:
        return np.zeros((0, 0)), np.zeros((0, 1)), np.zeros((1, 0)), np.array([[D]])
    A = np.zeros((n, n))
    A[:-1, 1:] = np.eye(n - 1)
    A[-1, :] = -a[:n]
    B = np.zeros((n, 1))
    B[-1, 0] = 1.0
    C = (b[:n] - D * a[:n])[None, :]
    return A, B, C, np.array([[D]])


def _pade_ss(T: float, order: int):
    """Padé approximant of e^{−sT} (control.pade) realized in normalized time p = sT."""
    if T == 0:
        return np.zeros((0, 0)), np.zeros((0, 1)), np.zeros((1, 0)), np.ones((1, 1))
    if T < 0:
        raise ValueError("negative delay")
    num_d, den_d = control.pade(1.0, order)
    A, B, C, D = _ss_from_asc(np.asarray(num_d, float)[::-1], np.asarray(den_d, float)[::-1])
    return A / T, B / T, C, D


def _q_omega(dob: dict) -> tuple[float, float]:
    if "omega" in dob:
        w = float(dob["omega"])
    else:
        w = 2 * math.pi * float(dob["cutoff_hz"])
    return w, float(dob.get("damping", 0.7))


# ----------------------------------------------------------------------------------------------
# Human / environment parsing
# ----------------------------------------------------------------------------------------------
def _get(d: dict, *names, default=0.0) -> float:
    for n in names:
        if n in d and d[n] is not None:
            return float(d[n])
    return float(default)


def _human_params(human) -> tuple[str, float, float, float]:
    """-> (kind, m, b, k); kind in {'none', 'massless', 'mass'}."""
    if human is None:
        return "none", 0.0, 0.0, 0.0
    kind = human["kind"]
    m = _get(human, "inertia", "m") if kind in ("mass", "msd") else 0.0
    b = _get(human, "damping", "b")
    k = _get(human, "stiffness", "k") if kind in ("spring", "msd") else 0.0
    if kind not in ("spring", "mass", "msd"):
        raise ValueError(f"unsupported human kind {kind!r} (complex stiffness is not rational)")
    if min(m, b, k) < 0:
        raise ValueError("negative human parameter")
    return ("mass" if m > 0 else "massless"), m, b, k


def _env_params(env) -> tuple[bool, float, float, float]:
    """-> (locked, m_e, b_e, k_e)."""
    if env is None or env == "free":
        return False, 0.0, 0.0, 0.0
    if env == "locked":
        return True, 0.0, 0.0, 0.0
    kind = env["kind"]
    if kind == "free":
        return False, 0.0, 0.0, 0.0
    if kind == "locked":
        return True, 0.0, 0.0, 0.0
    b = _get(env, "damping", "b")
    if kind == "spring":
        return False, 0.0, b, _get(env, "value", "stiffness", "k")
    if kind == "mass":
        return False, _get(env, "value", "inertia", "m"), b, 0.0
    if kind == "msd":
        return False, _get(env, "inertia", "m"), b, _get(env, "stiffness", "k")
    raise ValueError(f"unknown environment kind {kind!r}")


# ----------------------------------------------------------------------------------------------
# The closed loop
# ----------------------------------------------------------------------------------------------
def closed_loop_system(
    plant: dict,
    gains: dict,
    impl: dict | None = None,
    human: dict | None = None,
    env: str | dict = "free",
    pade_order: int = 8,
) -> control.StateSpace:
    """Closed-loop state-space model; inputs :data:`INPUTS`, outputs :data:`OUTPUTS`."""
    impl = impl or {}
    J_m, B_m, K_s, J_j, K_c = (float(plant[k]) for k in ("J_m", "B_m", "K_s", "J_j", "K_c"))
    K1, B1, K2, B2 = (float(gains.get(k, 0.0)) for k in ("K1", "B1", "K2", "B2"))
    hkind, m_h, b_h, k_h = _human_params(human)
    locked, m_e, b_e, k_e = _env_params(env)
    T = float(impl.get("T", impl.get("delay_s", 0.0)) or 0.0)
    dob = impl.get("dob")

    # --- rational blocks -------------------------------------------------------------------
    Gc = gains.get("Gc")
    gc = _ss_from_asc(*Gc) if Gc is not None else _ss_from_asc([0.0], [1.0])
    dl = _pade_ss(T, pade_order)
    if dob is not None:
        wq, zq = _q_omega(dob)
        qden = [wq * wq, 2 * zq * wq, 1.0]
        qm = _ss_from_asc(np.array([0.0, B_m, J_m]) * wq * wq, qden)  # Q·(J_m s² + B_m s)
        qq = _ss_from_asc([wq * wq], qden)  # Q
        assert qq[3][0, 0] == 0.0
    else:
        qm = qq = _ss_from_asc([0.0], [1.0])

    # --- state layout --------------------------------------------------------------------
    names: list[str] = ["th_m", "w_m"]
    if not locked:
        names += ["th_j", "w_j"]
    if hkind == "mass":
        names += ["th_h", "w_h"]
    elif hkind == "massless" and b_h > 0:
        names += ["th_h"]
    n_p = len(names)
    blocks = [("dl", dl), ("gc", gc), ("qm", qm), ("qq", qq)]
    offs = {}
    n = n_p
    for nm, blk in blocks:
        offs[nm] = n
        n += blk[0].shape[0]
    nw = len(INPUTS)
    N = n + nw

    def xs(name):
        r = np.zeros(N)
        r[names.index(name)] = 1.0
        return r

    def ws(name):
        r = np.zeros(N)
        r[n + INPUTS.index(name)] = 1.0
        return r

    def blk_out(nm, inp_row):
        """Row of the output C x_blk + D·inp of a block."""
        A, B, C, D = dict(blocks)[nm]
        r = D[0, 0] * inp_row
        r = r.copy()
        r[offs[nm] : offs[nm] + A.shape[0]] += C[0]
        return r

    zero = np.zeros(N)
    th_m, w_m = xs("th_m"), xs("w_m")
    th_j, w_j = (zero, zero) if locked else (xs("th_j"), xs("w_j"))
    if hkind == "mass" or (hkind == "massless" and b_h > 0):
        th_h = xs("th_h")
    else:  # algebraic massless node: k θ_h + K_c(θ_h − θ_j) = τ_h
        th_h = (ws("tau_h") + K_c * th_j) / (K_c + k_h)
    tau_c = K_c * (th_h - th_j)
    tau_s = K_s * (th_j - th_m)
    tau_s_dot = K_s * (w_j - w_m)

    # --- controller signals (explicit order => no algebraic loop) ------------------------
    y_c = blk_out("gc", tau_c)
    delta_hat = blk_out("qm", th_m)
    # qq is strictly proper: its output depends on its state only
    delta_hat = delta_hat - blk_out("qq", zero)
    tau_cmd = -(K1 * th_m + B1 * w_m) + (K2 * tau_s + B2 * tau_s_dot) + y_c - delta_hat
    tau_m = blk_out("dl", tau_cmd)

    # --- dynamics ------------------------------------------------------------------------
    Acl = np.zeros((n, N))

    def setrow(name, row):
        Acl[names.index(name)] = row

    setrow("th_m", w_m)
    setrow("w_m", (tau_s + tau_m + ws("delta_f") - B_m * w_m) / J_m)
    if not locked:
        setrow("th_j", w_j)
        setrow("w_j", (tau_c - tau_s + ws("tau_env") - b_e * w_j - k_e * th_j) / (J_j + m_e))
    if hkind == "mass":
        setrow("th_h", xs("w_h"))
        setrow("w_h", (ws("tau_h") - tau_c - b_h * xs("w_h") - k_h * th_h) / m_h)
    elif hkind == "massless" and b_h > 0:
        setrow("th_h", (ws("tau_h") - tau_c - k_h * th_h) / b_h)
    for nm, inp in (("dl", tau_cmd), ("gc", tau_c), ("qm", th_m), ("qq", tau_s + tau_cmd)):
        A, B, C, D = dict(blocks)[nm]
        o = offs[nm]
        k = A.shape[0]
        if k == 0:
            continue
        Acl[o : o + k, o : o + k] += A
        Acl[o : o + k] += B[:, :1] * inp[None, :]

    outs = np.vstack([th_h, th_j, th_m, tau_c, tau_s, tau_m, tau_cmd])
    return control.ss(
        Acl[:, :n], Acl[:, n:], outs[:, :n], outs[:, n:], inputs=list(INPUTS), outputs=list(OUTPUTS)
    )


def closed_loop_poles(
    plant: dict,
    gains: dict,
    impl: dict | None = None,
    human: dict | None = None,
    env: str | dict = "free",
    pade_order: int = 8,
) -> np.ndarray:
    """Eigenvalues of the closed-loop state matrix (see module docstring for conventions)."""
    sys = closed_loop_system(plant, gains, impl, human, env, pade_order)
    if sys.nstates == 0:
        return np.zeros(0, complex)
    return np.linalg.eigvals(sys.A).astype(complex)


def has_rigid_body_mode(gains: dict, human: dict | None, env: str | dict = "free") -> bool:
    """True when nothing ties the structure to ground: K1 = 0, no environment stiffness (and
    not locked) and no human stiffness (cuff free, mass, or zero-stiffness spring/msd)."""
    locked, _, _, k_e = _env_params(env)
    _, _, _, k_h = _human_params(human)
    return float(gains.get("K1", 0.0)) == 0.0 and not locked and k_e == 0.0 and k_h == 0.0


def free_rigid_body_tolerant_max_real(
    poles: np.ndarray, rigid_expected: bool, rtol: float = RIGID_BODY_RTOL, check: bool = True
) -> float:
    """max Re(λ) after removing ONE eigenvalue closest to 0 when a rigid-body mode is expected.

    Tolerance: with ``check`` the removed eigenvalue must satisfy
    |λ0| ≤ rtol·max(1, max|λ|) (default :data:`RIGID_BODY_RTOL` = 1e-6); otherwise a
    ``ValueError`` is raised (the configuration does not have the rigid-body mode it claims).
    """
    p = np.asarray(poles, dtype=complex).ravel()
    if rigid_expected:
        if p.size == 0:
            raise ValueError("rigid-body mode expected but there are no poles")
        i = int(np.argmin(np.abs(p)))
        scale = max(1.0, float(np.max(np.abs(p))))
        if check and abs(p[i]) > rtol * scale:
            raise ValueError(f"no rigid-body eigenvalue: closest to 0 is {p[i]!r} (scale {scale:.3g})")
        p = np.delete(p, i)
    return float(np.max(p.real)) if p.size else -math.inf


def coupled_verdict(
    plant: dict,
    gains: dict,
    impl: dict | None = None,
    human: dict | None = None,
    env: str | dict = "free",
    pade_order: int = 8,
) -> tuple[bool, float]:
    """(stable, margin): stable ⇔ max Re λ < 0 (rigid-body mode excepted, detected with
    :func:`has_rigid_body_mode`); margin = |Re λ*|/|λ*| for the rightmost pole λ* (a damping-ratio
    like distance from the imaginary axis, 1 for real poles). Callers skip cases with a small
    margin (e.g. < 1e-6) where the Padé model or rounding could flip the verdict."""
    poles = closed_loop_poles(plant, gains, impl, human, env, pade_order)
    rigid = has_rigid_body_mode(gains, human, env)
    p = poles
    if rigid:
        p = np.delete(p, int(np.argmin(np.abs(p))))
        free_rigid_body_tolerant_max_real(poles, True)  # validates the removed eigenvalue
    if p.size == 0:
        return True, 1.0
    i = int(np.argmax(p.real))
    lam = p[i]
    margin = abs(lam.real) / abs(lam) if abs(lam) > 0 else 0.0
    return bool(lam.real < 0), float(margin)


def pade_qp_roots(p0, p1, T: float, order: int) -> np.ndarray:
    """Roots of P0·d + P1·n with n/d the Padé approximant of e^{−sT} (``control.pade``), built in
    normalized time p = sT (ascending coefficients p0, p1; the rational stand-in for the exact
    quasi-polynomial P0 + P1 e^{−sT})."""
    P = np.polynomial.polynomial
    num, den = control.pade(1.0, order)
    n = np.asarray(num, float)[::-1]
    d = np.asarray(den, float)[::-1]
    q0 = np.asarray(p0, float) / T ** np.arange(len(p0))
    q1 = np.asarray(p1, float) / T ** np.arange(len(p1))
    a = P.polyadd(P.polymul(q0, d), P.polymul(q1, n))
    return P.polyroots(a / np.max(np.abs(a))) / T


def free_loop_eigs_mismatched_dob(q, cs, dob_model, order=10):
    """Closed-loop eigenvalues (python-control interconnection, Padé delay) of the free
    exoskeleton with the plant q = (J_m, B_m, K_s, J_j, …), the controller ``cs`` and a DOB whose
    model is (Ĵ_m, B̂_m): δ̂ = Q(M0 θ_m − τ_s − τ_cmd), τ_cmd = G_θ θ_m + G_s τ_s − δ̂
    (block diagram, independent of char_terms). Improper PD parts act on the velocity outputs.
    ``cs`` is converted with its own ``to_control()``; all eigenvalues are returned (the free
    exoskeleton keeps its rigid-body root near 0)."""
    Jm, Bm, Ks, Jj = (float(v) for v in q[:4])
    A = np.array([[0.0, 1.0, 0.0, 0.0], [-Ks / Jm, -Bm / Jm, Ks / Jm, 0.0],
                  [0.0, 0.0, 0.0, 1.0], [Ks / Jj, 0.0, -Ks / Jj, 0.0]])
    B = np.array([[0.0], [1.0 / Jm], [0.0], [0.0]])
    C = np.array([[1.0, 0, 0, 0], [0, 1.0, 0, 0], [-Ks, 0, Ks, 0], [0, -Ks, 0, Ks]])
    blocks = [control.ss(A, B, C, np.zeros((4, 1)), inputs=["tau_m"], outputs=["th", "om", "ts", "dts"], name="P")]
    terms = []

    def add(sys_, inp, out, sign="+"):
        blocks.append(control.ss(sys_, inputs=[inp], outputs=[out], name=out))
        terms.append(("-" if sign == "-" else "") + out)

    d = cs.to_control()
    for key, x, dx in (("G_theta", "th", "om"), ("G_s", "ts", "dts")):
        g = d[key]
        qn, r = np.polydiv(np.asarray(g.num[0][0], float), np.asarray(g.den[0][0], float))
        qn = np.r_[np.zeros(max(0, 2 - qn.size)), qn]
        add(control.tf([float(qn[-1])], [1.0]), x, key + "0")
        add(control.tf([float(qn[-2])], [1.0]), dx, key + "1")
        add(control.tf(r if np.any(r) else [0.0], g.den[0][0]), x, key + "2")
    if d["Q"] is not None:
        add(d["Q"] * control.tf([dob_model[0], dob_model[1]], [1.0]), "om", "e1", "-")
        add(d["Q"], "ts", "e2")
        add(d["Q"], "tau_cmd", "e3")
    blocks.append(control.summing_junction(inputs=["w"] + terms, output="tau_cmd", name="sum"))
    num, den = control.pade(d["delay_s"], order)
    blocks.append(control.ss(control.tf(num, den), inputs=["tau_cmd"], outputs=["tau_m"], name="delay"))
    cl = control.interconnect(blocks, inplist=["w"], outlist=["th"], inputs=["w"], outputs=["th"])
    return np.linalg.eigvals(cl.A)
