"""Cross-checks of the feature campaign (benchmarks/fuzz_features.py, docs/benchmarks.md#feature-campaign).

The campaign compared exotune's sampled-data and continuous verdicts on random designs that use the
features the earlier campaigns did not: velocity filters (with and without a DOB), ``structure:
full_filter``, ``precision: float32`` files (their rounded realization), gain schedules at high
sample rates, delays of a fractional number of samples, hysteretic humans and msd boxes. These
are some of its most adversarial designs (members within 1e-3 of an interval end, margins
confirmed to 1e-3), each checked here against a reference written in this file from the documented
equations alone:

* the controller from the file's YAML (``yaml.safe_load``): sos rows in transposed direct form II,
  or a float32 file's stored delta-form realization with its stored ``loop_divisor``; the filters
  on τ_cmd closed as the runtime does, τ = (rest + h)/divisor;
* the plant as a mass–spring–damper chain q = (θ_m, θ_j, θ_h) (docs/method.md#physical-model), made
  first order and discretized with ``scipy.linalg.expm`` (zero-order hold, the delay split into
  whole samples and a fraction inside the period);
* continuous loops (hysteretic humans, box members): a Nyquist count of
  F(jω) = (K_c + Z_h)·det(jωI − A − B C e^{−jωT}) on the imaginary axis with the controller assembled
  from the file's ``continuous`` blocks (docs/method.md#stable-intervals-of-a-human-family: Z_h(0)
  regularized by the real k, the tail from the leading coefficient).
"""

from __future__ import annotations

import math

import control
import numpy as np
import pytest
import scipy.linalg
import yaml

import exotune

SIG = ("theta_m", "omega_m", "tau_s", "dtau_s", "tau_c")


# ------------------------------------------------------------------------------------------------
# The reference: the file's discrete controller
# ------------------------------------------------------------------------------------------------
def _section(row, delta: bool):
    """(A, B, C, D) of one section: a sos row in transposed direct form II, or a delta-form
    section [β0, β1, β2, α1, α2] (y = β0 x + s1; s1 += β1 x − α1 y + s2; s2 += β2 x − α2 y)."""
    if delta:
        b0, b1, b2, a1, a2 = map(float, row)
        A = np.array([[1.0 - a1, 1.0], [-a2, 1.0]])
    else:
        b0, b1, b2, _, a1, a2 = map(float, row)
        A = np.array([[-a1, 1.0], [-a2, 0.0]])
    return A, np.array([b1 - a1 * b0, b2 - a2 * b0]), b0


def _cascade(rows, delta):
    n = 2 * len(rows)
    A, B = np.zeros((n, n)), np.zeros(n)
    u_row, u_in = np.zeros(n), 1.0           # the current section's input over (states, input)
    for k, row in enumerate(rows):
        a, b, d = _section(row, delta)
        i = slice(2 * k, 2 * k + 2)
        A[i] += np.outer(b, u_row)
        A[i, i] += a
        B[i] += b * u_in
        y_row = d * u_row
        y_row[2 * k] += 1.0
        u_row, u_in = y_row, d * u_in
    return A, B, u_row, u_in


def file_controller(ctrl: dict, precision: str):
    """(A, B, C, D): inputs SIG, output τ_cmd, of a ``controller`` mapping as the runtime runs it."""
    real = ctrl.get("realization") if precision == "float32" else None
    if real is not None:
        gains = {s: float(g) for s, g in (real.get("gains") or {}).items()}
        blocks = [(f["input"], _cascade(f["sections"], True)) for f in real["filters"]]
    else:
        gains = {s: float(g["gain"]) for s, g in (ctrl.get("gains") or {}).items()}
        blocks = [(f["input"], _cascade(f["sos"], False)) for f in ctrl["filters"]]
    n = sum(b[1][0].shape[0] for b in blocks)
    A, B = np.zeros((n, n)), np.zeros((n, 5))
    C, D = np.zeros(n), np.zeros(5)
    for s, g in gains.items():
        D[SIG.index(s)] += g
    g_loop, loops, off = 0.0, [], 0
    for inp, (a, b, c, d) in blocks:
        i = slice(off, off + a.shape[0])
        A[i, i] = a
        C[i] += c
        if inp == "tau_cmd":
            g_loop += d
            loops.append((i, b))
        else:
            B[i, SIG.index(inp)] += b
            D[SIG.index(inp)] += d
        off += a.shape[0]
    div = float(real["loop_divisor"]) if real is not None else 1.0 - g_loop
    C, D = C / div, D / div
    for i, b in loops:
        A[i] += np.outer(b, C)
        B[i] += np.outer(b, D)
    return A, B, C, D


# ------------------------------------------------------------------------------------------------
# The reference: the plant as a chain of masses, springs and dampers
# ------------------------------------------------------------------------------------------------
def plant_ss(p: dict, human=None, env="free", zh=None):
    """First-order model (A, B, C, grounded) of q = (θ_m, θ_j[, θ_h]) with input τ_m and outputs
    SIG. human: None (cuff free) or {m, b, k}: m > 0 a body θ_h; m = 0 (b = 0) a spring in series
    with the cuff, or ``zh`` a complex impedance in series. env: "free", "locked" or {m, b, k}."""
    Jm, Bm, Ks, Jj, Kc = (p[k] for k in ("motor_inertia", "motor_damping", "sea_stiffness", "joint_inertia",
                                          "cuff_stiffness"))
    me, be, ke = (0.0, 0.0, 0.0) if isinstance(env, str) else (env["m"], env["b"], env["k"])
    body = human is not None and human["m"] > 0
    ser = zh if zh is not None else (None if human is None or body else human["k"])
    nq = 3 if body else 2
    M = np.diag([Jm, Jj + me, human["m"] if body else 0.0][:nq]).astype(complex)
    Dm = np.diag([Bm, be, human["b"] if body else 0.0][:nq]).astype(complex)
    K = np.zeros((nq, nq), complex)

    def spring(i, j, k):
        K[i, i] += k
        if j is not None:
            K[j, j] += k
            K[i, j] -= k
            K[j, i] -= k

    spring(0, 1, Ks)
    spring(1, None, ke)
    if body:
        spring(1, 2, Kc)
        spring(2, None, human["k"])
    elif ser is not None:
        spring(1, None, Kc * ser / (Kc + ser))
    keep = [0] if env == "locked" else list(range(nq))
    M, Dm, K = (X[np.ix_(keep, keep)] for X in (M, Dm, K))
    n = len(keep)
    Minv = np.linalg.inv(M)
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-Minv @ K, -Minv @ Dm]])
    B = np.concatenate([np.zeros(n), Minv[:, 0]])
    th = np.zeros((3, 2 * n), complex)         # θ_m, θ_j, θ_h as rows over the state
    w = np.zeros((3, 2 * n), complex)
    for j, q in enumerate(keep):
        th[q, j], w[q, n + j] = 1.0, 1.0
    if body:
        tau_c = Kc * (th[2] - th[1])
    elif ser is not None:
        tau_c = -Kc * ser / (Kc + ser) * th[1]
    else:
        tau_c = np.zeros(2 * n)
    C = np.vstack([th[0], w[0], Ks * (th[1] - th[0]), Ks * (w[1] - w[0]), tau_c])
    grounded = env == "locked" or ke > 0 or (human is not None and human["k"] > 0) or zh is not None
    return A, B, C, grounded


def sampled_rho(p, K, fs, T, human=None, env="free"):
    """Spectral radius of the sampled-data loop (the rigid-body z = 1 removed when ungrounded)."""
    A, B, C, grounded = plant_ss(p, human, env)
    A, B, C = A.real, B.real, C.real
    Ak, Bk, Ck, Dk = K
    n, nk = A.shape[0], Ak.shape[0]
    Ts = 1.0 / fs

    def zoh(t):
        E = scipy.linalg.expm(np.block([[A, B[:, None]], [np.zeros((1, n + 1))]]) * t)
        return E[:n, :n], E[:n, n]

    d = int(math.floor(T * fs + 1e-9))
    f = T * fs - d
    f = 0.0 if f < 1e-9 else f
    if f:
        Pf, gf = zoh(f * Ts)
        Pr, gr = zoh((1 - f) * Ts)
        Phi, g_old, g_new = Pr @ Pf, Pr @ gf, gr
    else:
        Phi, g_new = zoh(Ts)
        g_old = np.zeros(n)
    m = d + (1 if f else 0)
    N = n + nk + m
    u = np.zeros(N)
    u[:n], u[n:n + nk] = Dk @ C, Ck

    def lag(j):
        if j == 0:
            return u
        r = np.zeros(N)
        r[n + nk + j - 1] = 1.0
        return r

    Mx = np.zeros((N, N))
    Mx[:n, :n] = Phi
    Mx[:n] += np.outer(g_new, lag(d))
    if f:
        Mx[:n] += np.outer(g_old, lag(d + 1))
    Mx[n:n + nk, :n] = Bk @ C
    Mx[n:n + nk, n:n + nk] = Ak
    if m:
        Mx[n + nk] = u
        for j in range(1, m):
            Mx[n + nk + j, n + nk + j - 1] = 1.0
    ev = np.linalg.eigvals(scipy.linalg.matrix_balance(Mx, permute=False)[0])
    if not grounded:
        ev = np.delete(ev, np.argmin(np.abs(ev - 1.0)))
    return float(np.max(np.abs(ev)))


# ------------------------------------------------------------------------------------------------
# The reference: continuous loops by a Nyquist count on the imaginary axis
# ------------------------------------------------------------------------------------------------
def continuous_controller(ctrl: dict):
    """The file's ``continuous`` blocks as one python-control system (A, B, C, D), inputs SIG, the
    filters on τ_cmd (the DOB's Q) closing u = rest + Q u, i.e. u = rest/(1 − Q)."""
    g = np.zeros((1, 5))
    for s, gv in (ctrl.get("gains") or {}).items():
        g[0, SIG.index(s)] += float(gv["gain"])
    tot, loop = control.ss([], [], [], g), None
    for f in ctrl["filters"]:
        tf = control.ss(control.tf([float(x) for x in f["continuous"]["num"]][::-1],
                                   [float(x) for x in f["continuous"]["den"]][::-1]))
        if f["input"] == "tau_cmd":
            loop = tf if loop is None else control.parallel(loop, tf)
            continue
        sel = np.zeros((1, 5))
        sel[0, SIG.index(f["input"])] = 1.0
        tot = control.parallel(tot, control.series(control.ss([], [], [], sel), tf))
    if loop is not None:
        tot = control.series(tot, control.feedback(control.ss([], [], [], [[1.0]]), loop, sign=+1))
    return np.asarray(tot.A), np.asarray(tot.B), np.asarray(tot.C), np.asarray(tot.D)


def continuous_count(p, Kc, T, human=None, zh=None, zh0=None):
    """Right-half-plane roots (formal count for a hysteretic zh) of the continuous loop, cuff free of
    environment: N = (nπ/2 + arctan(Im c/Re c) − Δarg F)/π over ω ∈ [0, ∞). None if undecided."""
    Kcf = p["cuff_stiffness"]

    def loop(z):
        A, B, C, _ = plant_ss(p, human, "free", z)
        Ak, Bk, Ck, Dk = Kc
        n, nk = A.shape[0], Ak.shape[0]
        AL = np.block([[A, np.zeros((n, nk))], [Bk @ C, Ak]])
        BC = np.outer(np.concatenate([B, np.zeros(nk)]), np.concatenate([(Dk @ C)[0], Ck[0]]))
        return AL, BC

    AL, BC = loop(zh)
    c = (Kcf + zh) if zh is not None else 1.0
    n = AL.shape[0]

    def F(w):
        w = np.atleast_1d(w)
        M = 1j * w[:, None, None] * np.eye(n) - AL - BC * np.exp(-1j * w * T)[:, None, None]
        return c * np.linalg.det(M)

    scale = max(1.0, np.max(np.abs(np.linalg.eigvals(AL))), np.max(np.abs(np.linalg.eigvals(AL + BC))))
    w = np.concatenate([[0.0], np.geomspace(1e-6 * scale, 1e4 * scale, 600)])
    if T > 0:
        w = np.union1d(w, np.arange(0.0, 50 * scale, 2 * math.pi / T / 8)[: 200000])
    v = F(w)
    for _ in range(60):   # halve every step with a phase change above 0.3 rad
        bad = np.flatnonzero(np.abs(np.angle(v[1:] / v[:-1])) > 0.3)
        if bad.size == 0:
            break
        mid = 0.5 * (w[bad] + w[bad + 1])
        w, v = np.insert(w, bad + 1, mid), np.insert(v, bad + 1, F(mid))
    else:
        return None
    dA = float(np.sum(np.angle(v[1:] / v[:-1]))) + float(np.angle(c * 1j ** n / v[-1]))
    if zh0 is not None:   # F(0) regularized by the real stiffness: the straight segment to F(0+)
        AL0, BC0 = loop(zh0)
        dA += float(np.angle(v[0] / ((Kcf + zh0) * np.linalg.det(-AL0 - BC0))))
    psi = math.atan(np.imag(c) / np.real(c)) if zh is not None else 0.0
    N = (n * math.pi / 2 + psi - dA) / math.pi
    return int(round(N)) if abs(N - round(N)) < 0.05 else None


# ------------------------------------------------------------------------------------------------
# Campaign designs (benchmarks/fuzz_features.py --seed 2027), reduced to the families of interest
# ------------------------------------------------------------------------------------------------
PK = ("motor_inertia", "motor_damping", "sea_stiffness", "joint_inertia", "cuff_stiffness")
DK = ("amplification", "felt_inertia", "felt_damping", "zeta", "zeta_hat")


def _design(plant, design, delay, rate, gv, fd, dob, vf, structure, precision, humans, env=(), transmission=None):
    impl = {"delay_s": delay, "sample_rate_hz": rate, "gv_filter": {"cutoff_hz": gv[0], "damping": gv[1]},
            "derivative_filter": {"cutoff_hz": fd}, "dob": None if dob is None else {"cutoff_hz": dob[0], "damping": dob[1]},
            "structure": structure}
    if vf is not None:
        impl["velocity_filter"] = {"cutoff_hz": vf}
    if precision is not None:
        impl["precision"] = precision
    m = {"plant": dict(zip(PK, plant)), "design": dict(zip(DK, design)), "implementation": impl,
         "humans": list(humans), "environment": [{"kind": "locked"}, {"kind": "free"}] + list(env)}
    if transmission:
        m["transmission"] = {"joint_angle_rad": transmission[0], "ratio": transmission[1]}
    return m


# s5: 1 kHz, 2.33 samples, float32, full_filter, velocity filter and DOB (in the campaign with three
# schedule entries: each entry's end of the environment mass family was within 1.5e-7–5.8e-7 of
# |z| = 1 at ±1e-3; the schedule is left to R10 here, for time)
S5 = _design([0.04938622942822332, 29.4680810576485, 2130.196755703885, 0.6483939371208314, 5.364534634637924],
             [13.367347469328804, 0.4346142160479384, 1.9760895579292779, 0.6819228162140769, 0.9203617263712184],
             0.0023273871368512207, 1000.0, (31.522311082897968, 0.39227230644906846), 158.99201240865816,
             (37.649438019576124, 0.26289288956329143), 400.0, "full_filter", "float32", [],
             [{"kind": "mass", "inertia": [0.4, 0.8], "damping": 0.25862047798396826}])
# s14: 10 kHz, 8.18 samples, float32, full_filter, velocity filter without a DOB: an msd inertia end
# within 7e-8 of |z| = 1 at ±1e-3
S14 = _design([0.07437927657241554, 0.32037870151347975, 609.6767134517038, 0.033264721841348356, 39422.018107218886],
              [2.9754461772120666, 0.16206463038865812, 0.06675508943111984, 0.3145923875195386, 0.5662125325270356],
              0.0008180069730475722, 10000.0, (13.64136881588613, 1.2547759579416657), 213.5960668675115, None,
              192.3177214550986, "full_filter", "float32",
              [{"kind": "msd", "inertia": [0.35, 0.7], "damping": 1.609634082805698,
                "stiffness": 498.1947456976363}])
# s20: 20 kHz, 18.58 samples, no DOB, no velocity filter: a mass end within 4e-8 of |z| = 1 at ±1e-3
S20 = _design([0.07884914281647022, 1.2188750383245328, 10668.657636077181, 0.3289675380777534, 17.496502466542733],
              [1.3368794581691066, 0.3625765674720519, 3.897939578202455, 0.06424122306524219, 0.08991683675382621],
              0.0009289955874890143, 20000.0, (24.133450821339668, 0.7088423107453892), 5.349177287955156, None, None,
              "default", None, [{"kind": "mass", "inertia": [0.0018, 0.004], "damping": 0.0}])
# s8: 1 kHz, 2.60 samples, float32, full_filter, velocity filter and DOB: a spring end (sampled) and
# a hysteretic end (certify's continuous check) inside their ranges
S8 = _design([0.0999570669641979, 17.888684492181113, 2691.336691658397, 0.022107813878134944, 400890.39179848414],
             [3.53667426745779, 0.16038475612893976, 0.11013880784385949, 0.5333598730828559, 0.44200362785765734],
             0.0025966644617456507, 1000.0, (21.534191013187314, 0.8635700348685522), 26.12355883284412,
             (27.074425916495876, 1.2918604198713883), 113.42801455723163, "full_filter", "float32",
             [{"kind": "spring", "stiffness": [60.0, 140.0], "damping": 0.0},
              {"kind": "complex_stiffness", "stiffness": [150.0, 300.0], "eta": 0.41824975901390204}])
# c2: continuous, full_filter with a velocity filter, no DOB: a 3-parameter msd box whose four
# inertia edges have an interval end near 0.1118 kg·m², and a hysteretic family with an end near 147
C2 = _design([0.2257174329153883, 13.397700971931673, 259.1334716846487, 0.5289715964340467, 51353.923689611234],
             [14.818721463217463, 0.028285008235374956, 0.21710713950881247, 0.1841066819138596, 0.2626648116316706],
             0.0008414294008611809, None, (68.43633871099561, 0.9739996629928016), 38.126944332670554, None,
             495.7466118490453, "full_filter", None,
             [{"kind": "msd", "inertia": [0.08, 0.16],
               "damping": [0.12547365567718363, 1.2898179600226845], "stiffness": [1.765582522061704, 4.6553660808921835]},
              {"kind": "complex_stiffness", "stiffness": [100.0, 220.0], "eta": 0.5472324588041761}])


def _export(tmp_path, design):
    """The design's controller file (built without export's own predictions, which certify would
    recompute: half the time) read back with yaml.safe_load, and certify's report of it."""
    from exotune.controllerfile import build_export, design_at_rate

    rate = design["implementation"]["sample_rate_hz"]
    doc = build_export(design_at_rate(design, rate), rate, analyses=False, require_latency_margin_s=0.0)
    doc["predicted"] = {}
    for e in (doc.get("gain_schedule") or {}).get("entries", []):
        e["predicted_sampled"] = {}
    out = tmp_path / "controller.yaml"
    out.write_text(yaml.safe_dump(doc, sort_keys=False, allow_unicode=True))
    return yaml.safe_load(out.read_text()), exotune.certify(str(out)).to_dict()


def _plant(section):
    return {k: float(v["value"]) for k, v in section.items()}


def _inside_ends(lo, hi, intervals):
    return [e for iv in intervals for e in iv if lo * (1 + 1e-9) < e < hi * (1 - 1e-9)]


def _in(x, intervals):
    return any(a <= x <= b for a, b in intervals)


def _check_family_ends(p, K, fs, T, fam, member, env_member=False):
    """Every interval end inside the family's range: the reference's verdicts at ×(1 ± 1e-3) are
    exotune's (in a stable interval ⇔ ρ < 1) and differ (the end is a real change of verdict)."""
    lo, hi = fam["range"]
    ends = _inside_ends(lo, hi, fam["stable_intervals"])
    assert ends, "the campaign's design has an interval end inside the range"
    for e in ends:
        got = []
        for x in (e * (1 - 1e-3), e * (1 + 1e-3)):
            arg = member(x)
            rho = sampled_rho(p, K, fs, T, env=arg) if env_member else sampled_rho(p, K, fs, T, human=arg)
            assert (rho < 1.0) == _in(x, fam["stable_intervals"]), (fam["parameter"], x, rho)
            got.append(rho < 1.0)
        assert got[0] != got[1]


def test_float32_full_filter_dob_velocity_filter_environment_end(tmp_path):
    doc, cert = _export(tmp_path, S5)
    fs, T = doc["sample_rate_hz"]["value"], doc["delay_s"]["value"]
    ctrls = [(doc["plant"], doc["controller"], cert["sampled"])]
    assert "realization" in doc["controller"]
    damping = S5["environment"][-1]["damping"]
    for plant, ctrl, sd in ctrls:
        p, K = _plant(plant), file_controller(ctrl, "float32")
        for key in ("free", "locked"):
            rho = sampled_rho(p, K, fs, T, env=key)
            assert rho == pytest.approx(sd[f"{key}_spectral_radius"], rel=1e-7)
            assert (rho < 1) == sd[f"{key}_stable"]
        (fam,) = sd["environment"]
        _check_family_ends(p, K, fs, T, fam, lambda x: {"m": x, "b": damping, "k": 0.0}, env_member=True)


@pytest.mark.parametrize("design", [S14, S20], ids=["s14-10kHz-float32-full_filter-vf", "s20-20kHz-no-dob"])
def test_fractional_delay_high_rate_family_end(tmp_path, design):
    doc, cert = _export(tmp_path, design)
    fs, T = doc["sample_rate_hz"]["value"], doc["delay_s"]["value"]
    assert 0.05 < (T * fs) % 1.0 < 0.95
    prec = design["implementation"].get("precision") or "float64"
    p, K = _plant(doc["plant"]), file_controller(doc["controller"], prec)
    sd = cert["sampled"]
    for key in ("free", "locked"):
        assert sampled_rho(p, K, fs, T, env=key) == pytest.approx(sd[f"{key}_spectral_radius"], rel=1e-7)
    (fam,) = sd["humans"]
    h = design["humans"][0]
    fixed = {"m": h.get("inertia", 0.0), "b": h.get("damping", 0.0), "k": h.get("stiffness", 0.0)}
    _check_family_ends(p, K, fs, T, fam, lambda x: dict(fixed, m=x))
    # the latency margin of record: stable at ΔT(1 − 1e-3), the critical member unstable at ΔT(1 + 1e-3)
    lm = cert["latency_margin"]
    if lm["extra_delay_s"]:
        dT, crit = lm["extra_delay_s"], lm["critical"]
        lo, hi = fam["range"]
        for x in (lo, math.sqrt(lo * hi), hi):
            if _in(x, fam["stable_intervals"]) and fam["robust"]:
                assert sampled_rho(p, K, fs, T + dT * (1 - 1e-3), human=dict(fixed, m=x)) < 1.0
        arg = dict(fixed, m=crit["value"]) if crit["loop"].startswith("human") else None
        env = "free" if arg is not None or crit["loop"] == "free" else "locked"
        assert sampled_rho(p, K, fs, T + dT * (1 + 1e-3), human=arg, env=env) > 1.0


def test_hysteretic_end_of_certify_continuous_check(tmp_path):
    doc, cert = _export(tmp_path, S8)
    fs, T = doc["sample_rate_hz"]["value"], doc["delay_s"]["value"]
    p = _plant(doc["plant"])
    spring, hyst = cert["sampled"]["humans"]
    _check_family_ends(p, file_controller(doc["controller"], "float32"), fs, T, spring,
                       lambda x: {"m": 0.0, "b": 0.0, "k": x})
    cc = hyst["continuous_check"]
    assert cc["checked"] and cc["conclusive"]
    Kc = continuous_controller(doc["controller"])
    eta = S8["humans"][1]["eta"]
    lo, hi = hyst["range"]
    ends = _inside_ends(lo, hi, cc["stable_intervals"])
    assert ends
    for e in ends:
        got = []
        for x in (e * (1 - 1e-3), e * (1 + 1e-3)):
            N = continuous_count(p, Kc, T, zh=complex(x, x * eta), zh0=x)
            assert N is not None and (N == 0) == _in(x, cc["stable_intervals"]), (x, N)
            got.append(N == 0)
        assert got[0] != got[1]
    # η = 0: the count is the spring's, an ordinary loop (the eigenvalue-free cross-check of the count)
    k = math.sqrt(lo * hi)
    assert continuous_count(p, Kc, T, zh=complex(k, 0.0), zh0=k) == continuous_count(p, Kc, T, human={"m": 0.0, "b": 0.0, "k": k})


def test_box_edges_and_hysteretic_family_in_continuous_time():
    from exotune.controllerfile import build_export, design_at_rate

    an = exotune.analyze(C2).to_dict()
    box, hyst = an["humans"]
    raw = dict(C2, humans=[])
    doc = yaml.safe_load(yaml.safe_dump(build_export(design_at_rate(raw, 2000.0), 2000.0, analyses=False)))
    p, Kc, T = _plant(doc["plant"]), continuous_controller(doc["controller"]), C2["implementation"]["delay_s"]
    assert not box["robust"] and len(box["edges"]) == 12
    checked = 0
    for edge in box["edges"]:
        q = edge["parameter"]
        lo, hi = edge["range"]
        for e in _inside_ends(lo, hi, edge["stable_intervals"]):
            for x in (e * (1 - 1e-3), e * (1 + 1e-3)):
                v = dict(edge["at"], **{q: x})
                N = continuous_count(p, Kc, T, human={"m": v["inertia"], "b": v["damping"], "k": v["stiffness"]})
                assert N is not None and (N == 0) == _in(x, edge["stable_intervals"]), (edge["at"], q, x, N)
                checked += 1
    assert checked >= 8
    eta = C2["humans"][1]["eta"]
    lo, hi = hyst["range"]
    ends = _inside_ends(lo, hi, hyst["stable_intervals"])
    assert ends
    for e in ends:
        for x in (e * (1 - 1e-3), e * (1 + 1e-3)):
            N = continuous_count(p, Kc, T, zh=complex(x, x * eta), zh0=x)
            assert N is not None and (N == 0) == _in(x, hyst["stable_intervals"]), (x, N)


# run 2 (--seed 3031) s10: 10 kHz, 9.77 samples, DOB, two schedule entries; the margins (15.6 and
# 29.4 samples) are set by the stiff end of the environment spring range; here as a float32 file (the
# realization of every schedule entry)
R10 = _design([0.0631251373765852, 3.761677116157438, 4054.993570752988, 0.02032695562073, 48.28622503351531],
              [2.6519371256788586, 0.09713677328141902, 0.05283385660156182, 0.9383692020367388, 0.05033945474831251],
              0.0009770645465077674, 10000.0, (27.048490597491405, 0.5038725849045111), 406.0093318242944,
              (25.41132394491359, 1.360165379474813), None, "default", "float32", [],
              [{"kind": "spring", "stiffness": [237.11754626503995, 3101.512200025323], "damping": 0.4190285587949967}],
              ([-1.1413294220858314, 0.9236649016814975], [0.7369039510636467, 1.0986400593061796]))
# run 2 s31: 4 kHz, 5.72 samples, float32, full_filter, DOB; robust families, margin 11.9 samples
# set by the heavy end of the mass family
R31 = _design([0.02701514625750742, 0.7673690273857228, 435.5057822428492, 0.029475535378195285, 12.023554936274595],
              [2.8915935837138704, 0.08054401402109271, 0.31787154140452895, 0.06036840206776891, 0.8808589126032058],
              0.0014309274286098208, 4000.0, (16.04578748151065, 1.2800227452751654), 29.6662771512733,
              (18.507885023361155, 0.3898945714991275), None, "full_filter", "float32",
              [{"kind": "mass", "inertia": [9.890553088886523e-05, 0.0010795807109757422], "damping": 0.16057897661836046},
               {"kind": "spring", "stiffness": [83.92175822793531, 839217.5822793532], "damping": 0.0},
               {"kind": "msd", "inertia": 0.0002513532936585741, "damping": [0.0010752618088511062, 0.053830795176048364],
                "stiffness": 16.229324542532844}])


def _probes(design):
    """(human, env) of the latency-margin probes: free, locked, both ends and the geometric middle
    of every family."""
    out = [(None, "free"), (None, "locked")]
    for h in design["humans"]:
        (q,) = [k for k, v in h.items() if isinstance(v, list)]
        lo, hi = h[q]
        for x in (lo, math.sqrt(lo * hi), hi):
            v = {"inertia": 0.0, "damping": 0.0, "stiffness": 0.0, **{k: w for k, w in h.items() if k != "kind"}, q: x}
            out.append(({"m": v["inertia"], "b": v["damping"], "k": v["stiffness"]}, "free"))
    for e in design["environment"][2:]:
        (q,) = [k for k, v in e.items() if isinstance(v, list)]
        for x in (e[q][0], math.sqrt(e[q][0] * e[q][1]), e[q][1]):
            out.append((None, {"m": x if q == "inertia" else 0.0, "b": e.get("damping", 0.0),
                               "k": x if q == "stiffness" else 0.0}))
    return out


@pytest.mark.parametrize("design", [R10, R31], ids=["r10-10kHz-float32-schedule-dob", "r31-4kHz-float32-full_filter-dob"])
def test_latency_margin_of_every_controller(tmp_path, design):
    """certify's margin of each controller (the main one and every schedule entry, each its own): the
    reference loops are stable at ΔT(1 − 1e-3) and one of them is unstable at ΔT(1 + 1e-3)."""
    doc, cert = _export(tmp_path, design)
    fs, T = doc["sample_rate_hz"]["value"], doc["delay_s"]["value"]
    prec = design["implementation"].get("precision") or "float64"
    lm = cert["latency_margin"]
    ctrls = [(doc["plant"], doc["controller"], lm.get("main_controller_s", lm["extra_delay_s"]))]
    ctrls += [(e["plant"], e["controller"], c["latency_margin"]["extra_delay_s"])
              for e, c in zip((doc.get("gain_schedule") or {}).get("entries", []), cert.get("gain_schedule") or [])]
    assert len(ctrls) == 1 + len((design.get("transmission") or {}).get("ratio", []))
    for plant, ctrl, dT in ctrls:
        assert dT and dT > 5.0 / fs
        p, K = _plant(plant), file_controller(ctrl, prec)
        below = [sampled_rho(p, K, fs, T + dT * (1 - 1e-3), human=h, env=e) for h, e in _probes(design)]
        above = [sampled_rho(p, K, fs, T + dT * (1 + 1e-3), human=h, env=e) for h, e in _probes(design)]
        assert max(below) < 1.0 < max(above), (dT * fs, max(below), max(above))
