"""Logs of the plant with a person on the cuff, simulated independently of exotune's
identification code (the plant's equations, paper eq. (5), written out here), for many seeds at
once:

* ``smooth``: a smooth applied torque (a multisine), open loop or through an analog PD feedback
  on the true motor angle; the exact periodic steady state, computed from the frequency response
  of the state-space model (no integration error at all).
* ``held``: a command held between samples and applied one sample after it is logged (exact
  zero-order-hold discretization of the plant), open loop or from a digital PD on the noisy
  measured motor angle (closed loop: the command depends on past sensor noise).

Sensor noise at the documented level: encoders 2e-6 rad, torque sensors (τ_s, τ_c) 0.02 N·m.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

TRUE = {"motor_inertia": 0.44, "motor_damping": 17.9, "sea_stiffness": 1180.0, "joint_inertia": 0.29,
        "cuff_stiffness": 300.0}
HUMAN = (0.1, 0.5, 20.0)  # m_h [kg·m²], b_h [N·m·s/rad], k_h [N·m/rad]
NOISE = {"theta_m": 2e-6, "theta_j": 2e-6, "theta_h": 2e-6, "tau_s": 0.02, "tau_c": 0.02}
PD = (150.0, 2.0)  # closed loop: τ = u − kp θ_m − kd θ̇_m [N·m/rad, N·m·s/rad]


def plant_matrices(p=TRUE):
    """States θ_m, θ̇_m, θ_j, θ̇_j, θ_h, θ̇_h; inputs τ_m, τ_h (the human's muscle torque)."""
    Jm, Bm, Ks, Jj, Kc = (p[k] for k in ("motor_inertia", "motor_damping", "sea_stiffness", "joint_inertia",
                                         "cuff_stiffness"))
    m, b, k = HUMAN
    A = np.zeros((6, 6))
    A[0, 1] = A[2, 3] = A[4, 5] = 1.0
    A[1, [0, 1, 2]] = [-Ks / Jm, -Bm / Jm, Ks / Jm]  # J_m θ̈_m + B_m θ̇_m = τ_s + τ_m, τ_s = K_s(θ_j − θ_m)
    A[3, [0, 2, 4]] = [Ks / Jj, -(Ks + Kc) / Jj, Kc / Jj]  # J_j θ̈_j = τ_c − τ_s, τ_c = K_c(θ_h − θ_j)
    A[5, [2, 4, 5]] = [Kc / m, -(Kc + k) / m, -b / m]  # m θ̈_h + b θ̇_h + k θ_h = τ_h − τ_c
    B = np.zeros((6, 2))
    B[1, 0] = 1 / Jm
    B[5, 1] = 1 / m
    return A, B


def _multisine(rng, seeds):
    f = np.geomspace(0.3, 40.0, 25)
    return f, 0.6 * np.ones(f.size), rng.uniform(0, 2 * np.pi, (seeds, f.size))


def _columns(x, t, noise_rng=None, p=TRUE):
    """x: (seeds, 6, n) states → list of column dicts (with noise when ``noise_rng``)."""
    out = []
    for xs in x:
        th_m, th_j, th_h = xs[0], xs[2], xs[4]
        c = {"t": t, "theta_m": th_m, "tau_s": p["sea_stiffness"] * (th_j - th_m), "theta_j": th_j,
             "tau_c": p["cuff_stiffness"] * (th_h - th_j), "theta_h": th_h}
        if noise_rng is not None:
            c = {k: (v + NOISE[k] * noise_rng.standard_normal(v.size) if k in NOISE else v) for k, v in c.items()}
        out.append(c)
    return out


def smooth_logs(seeds, fs, seconds, closed=False, noise=True, seed0=0):
    """Exact steady state under a smooth multisine torque u (open loop: τ_m = u; closed: τ_m =
    u − kp θ_m − kd θ̇_m on the true states); human torque two sinusoids."""
    rng = np.random.default_rng(1000 + seed0)
    A, B = plant_matrices()
    if closed:
        A = A - np.outer(B[:, 0], [PD[0], PD[1], 0, 0, 0, 0])
    t = np.arange(int(seconds * fs)) / fs
    f, amp, ph = _multisine(rng, seeds)
    x = np.zeros((seeds, 6, t.size))
    u = np.zeros((seeds, t.size))
    comps = [(2 * np.pi * fk, amp[i], ph[:, i], 0) for i, fk in enumerate(f)]
    comps += [(2 * np.pi * 0.7, 2.0, np.zeros(seeds), 1), (2 * np.pi * 2.3, 1.0, np.ones(seeds), 1)]
    for w, a, phase, inp in comps:
        X = np.linalg.solve(1j * w * np.eye(6) - A, B[:, inp])  # response to e^{jwt}
        e = np.exp(1j * (w * t[None, :] + phase[:, None]))  # (seeds, n)
        x += a * np.imag(X[None, :, None] * e[:, None, :])
        if inp == 0:
            u += a * np.imag(e)
    tau_m = u - (PD[0] * x[:, 0] + PD[1] * x[:, 1] if closed else 0.0)
    cols = _columns(x, t, np.random.default_rng(2000 + seed0) if noise else None)
    for c, tm in zip(cols, tau_m):
        c["tau_m"] = tm
    return cols


def held_logs(seeds, fs, seconds, closed=False, noise=True, delay=1, seed0=0, p=TRUE):
    """Exact zero-order hold: the command (a multisine plus broadband noise; closed loop: minus a
    digital PD on the measured, noisy motor angle) is logged as tau_cmd and applied ``delay``
    samples later; the human torque is held too."""
    rng = np.random.default_rng(3000 + seed0)
    A, B = plant_matrices(p)
    Ts = 1 / fs
    E = scipy.linalg.expm(np.block([[A, B], [np.zeros((2, 8))]]) * Ts)
    Ad, Bd = E[:6, :6], E[:6, 6:]
    n = int(seconds * fs)
    t = np.arange(n) * Ts
    f, amp, ph = _multisine(rng, seeds)
    u = (amp * np.sin(2 * np.pi * f * t[:, None, None] + ph)).sum(-1).T + 0.5 * rng.standard_normal((seeds, n))
    tau_h = 2.0 * np.sin(2 * np.pi * 0.7 * t) + np.sin(2 * np.pi * 2.3 * t + 1)
    nrng = np.random.default_rng(4000 + seed0)
    enc = NOISE["theta_m"] * nrng.standard_normal((seeds, n)) if noise else np.zeros((seeds, n))
    x = np.zeros((seeds, 6, n))
    cmd = np.zeros((seeds, n))
    for k in range(n):
        if closed:
            th = x[:, 0, k] + enc[:, k]
            th1 = x[:, 0, k - 1] + enc[:, k - 1] if k else th
            cmd[:, k] = u[:, k] - PD[0] * th - PD[1] * (th - th1) * fs
        else:
            cmd[:, k] = u[:, k]
        if k + 1 < n:
            applied = cmd[:, k - delay] if k >= delay else np.zeros(seeds)
            x[:, :, k + 1] = x[:, :, k] @ Ad.T + np.outer(applied, Bd[:, 0]) + tau_h[k] * Bd[:, 1]
    cols = _columns(x, t, nrng if noise else None, p)
    for i, c in enumerate(cols):
        if noise:
            c["theta_m"] = x[i, 0] + enc[i]  # the encoder noise the controller saw
        c["tau_cmd"] = cmd[i]
    return cols


def command_log(cmd, fs, delay=1, noise=True, seed=0, p=TRUE):
    """The log of an open-loop run with the given held command ``cmd`` (logged as tau_cmd,
    applied ``delay`` samples later) and the person's torque of :func:`held_logs`: the exact
    zero-order-hold discretization, run mode by mode through ``scipy.signal.lfilter`` (no
    per-sample loop: minutes of 10 kHz data in seconds); sensor noise when ``noise``."""
    import scipy.signal

    A, B = plant_matrices(p)
    E = scipy.linalg.expm(np.block([[A, B], [np.zeros((2, 8))]]) / fs)
    Ad, Bd = E[:6, :6], E[:6, 6:]
    cmd = np.asarray(cmd, float)
    n = cmd.size
    t = np.arange(n) / fs
    applied = np.concatenate([np.zeros(delay), cmd[: n - delay]])
    tau_h = 2.0 * np.sin(2 * np.pi * 0.7 * t) + np.sin(2 * np.pi * 2.3 * t + 1)
    lam, V = np.linalg.eig(Ad)
    G = np.linalg.solve(V, Bd)
    x = np.zeros((6, n))
    for i, li in enumerate(lam):  # z_i[k+1] = λ_i z_i[k] + G_i·u[k] from the zero state
        z = scipy.signal.lfilter([0.0, 1.0], [1.0, -li], (G[i, 0] * applied + G[i, 1] * tau_h).astype(complex))
        x += np.real(np.outer(V[:, i], z))
    cols = _columns(x[None], t, np.random.default_rng(5000 + seed) if noise else None, p)[0]
    cols["tau_cmd"] = cmd
    return cols
