"""The exact sampled-data loop batched over designs (the sweep's ``sampled: true`` columns,
docs/sweep-spec.md#sampled-data-columns).

Per design, the controller is the one ``exotune export`` writes: the blocks of
:func:`exotune.sampled.controller_blocks`, each discretized to second-order sections by
:func:`exotune.sampled.sos.tustin_sos` (prewarped at :func:`exotune.sampled.default_prewarp`) and
realized by :func:`exotune.sampled.sos.sos_ss`, assembled by :func:`exotune.sampled.assemble` —
the very functions behind ``controller_section`` and ``discrete_from_file``, so the state space is
bit for bit the one ``certify`` rebuilds from the exported file. The plant (+ human, + environment)
is discretized exactly with the zero-order hold and the fractional delay (Φ, Γ0, Γ1 of
:mod:`exotune.sampled.loop`), and the loop matrix is :func:`exotune.sampled.closed_loop_matrix`'s.

What is batched: the plant matrices of many (design, member, delay) jobs are built as stacks, their
matrix exponentials computed on stacks, the loop matrices assembled on stacks of equal size, and the
eigenvalues found by one ``numpy.linalg.eigvals`` call per stack. The rigid-body eigenvalue z = 1 of
an ungrounded loop is set aside exactly as :func:`exotune.sampled.loop_eigenvalues` does.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg

from .loop import assemble, controller_blocks, default_prewarp
from .sos import sos_ss, tustin_sos

__all__ = ["RIGID_TOL", "BatchLoops", "Loop", "design_controller", "dc_position_feedback"]

RIGID_TOL = 1e-7  # |λ − 1| within which the rigid-body eigenvalue is set aside (loop_eigenvalues)


@dataclass(frozen=True)
class Loop:
    """Which loop a job closes: the human (``None``: cuff free) with ``param`` varied, the others
    ``fixed`` ({inertia, damping, stiffness}); the environment ``env`` ("free", "locked", or
    ``env_param`` varied with ``env_damping``). A human loop varies the human; an environment
    loop (cuff free) varies the environment; free and locked loops vary nothing."""

    name: str
    human: dict | None = None
    param: str | None = None
    env: str = "free"
    env_param: str | None = None
    env_damping: float = 0.0

    def structure(self) -> tuple[bool, bool]:
        """(θ_h and ω_h states, θ_h state only) as :func:`exotune.sampled.plant_ss` chooses them."""
        if self.human is None:
            return False, False
        mass = self.param == "inertia" or self.human.get("inertia", 0.0) > 0
        damped = self.param == "damping" or self.human.get("damping", 0.0) > 0
        return mass, (not mass) and damped

    def grounded(self, v: np.ndarray) -> np.ndarray:
        """Whether a member (values ``v``) grounds the structure (no rigid-body mode)."""
        if self.env == "locked":
            return np.ones(v.shape, bool)
        if self.env_param is not None:
            return (v > 0) if self.env_param == "stiffness" else np.zeros(v.shape, bool)
        if self.human is None:
            return np.zeros(v.shape, bool)
        if self.param == "stiffness":
            return v > 0
        return np.full(v.shape, self.human.get("stiffness", 0.0) > 0)


def dc_position_feedback(static: np.ndarray, filters: list, rtol: float = 1e-12) -> bool:
    """Whether the controller feeds back θ_m at DC: its θ_m gain plus the DC gains of its sos
    filters on θ_m (``[(sos, input), …]``; a section whose numerator sums to zero within ``rtol``
    of its coefficients has DC gain 0) — the test certify makes on the exported file's controller
    (``exotune.controllerfile.fileio.position_feedback``)."""
    total = float(static[0])
    scale = abs(total)
    for sos, inp in filters:
        if inp != "theta_m":
            continue
        gain = [1.0, 1.0]
        for b0, b1, b2, _a0, a1, a2 in np.atleast_2d(sos):
            sb = b0 + b1 + b2
            gain[0] *= 0.0 if abs(sb) <= rtol * (abs(b0) + abs(b1) + abs(b2)) else sb
            gain[1] *= 1.0 + a1 + a2
        if gain[0] == 0.0:
            continue
        if gain[1] == 0.0:
            return True  # an integrator on θ_m
        total += gain[0] / gain[1]
        scale += abs(gain[0] / gain[1])
    return abs(total) > rtol * max(scale, 1e-300) and total != 0.0


def design_controller(cfg, fs: float):
    """(:class:`~exotune.sampled.DiscreteController`, position feedback) of one design at ``fs``
    [Hz]: the controller ``exotune export`` writes for it (module docstring)."""
    from ..model.controller import build_controller

    cs, _ = build_controller(cfg.plant, cfg.design, cfg.implementation)
    static, blocks = controller_blocks(cs, cfg.plant)
    pw = default_prewarp(cfg.implementation)
    static = np.array([float(x) for x in static])
    filters = [(np.array(tustin_sos(b.num, b.den, fs, pw.get(b.prewarp)), dtype=float), b.input) for b in blocks]
    ctrl = assemble(static, [(sos_ss(sos), inp) for sos, inp in filters], fs, float(np.ravel(cfg.implementation.delay_s)[0]))
    return ctrl, dc_position_feedback(static, filters)


class BatchLoops:
    """The sampled-data loops of a batch of designs (:func:`exotune.config.design_row` rows of a
    batch config) at sample rate ``fs``; :meth:`spectra` gives the eigenvalues of many jobs."""

    def __init__(self, rows, fs: float):
        self.fs = float(fs)
        self.Ts = 1.0 / self.fs
        g = lambda name: np.array([float(np.ravel(getattr(r.plant, name))[0]) for r in rows])  # noqa: E731
        self.Jm, self.Bm, self.Ks, self.Jj, self.Kc = g("J_m"), g("B_m"), g("K_s"), g("J_j"), g("K_c")
        self.delay = np.array([float(np.ravel(r.implementation.delay_s)[0]) for r in rows])
        built = [design_controller(r, self.fs) for r in rows]
        self.ctrl = [c for c, _ in built]
        self.position_feedback = np.array([p for _, p in built], dtype=bool)
        self.nz = np.array([c.Ac.shape[0] for c in self.ctrl], dtype=np.int64)
        self.n = len(rows)

    # ---- plant ---------------------------------------------------------------------------
    def plant(self, des: np.ndarray, loop: Loop, v: np.ndarray):
        """Stacks (A, B, C) of :func:`exotune.sampled.plant_ss` for designs ``des`` and members
        ``v`` of ``loop`` (vectorized, same state order)."""
        k = des.size
        Jm, Bm, Ks, Jj, Kc = (x[des] for x in (self.Jm, self.Bm, self.Ks, self.Jj, self.Kc))
        locked = loop.env == "locked"
        me, be, ke = np.zeros(k), np.zeros(k), np.zeros(k)
        if loop.env_param is not None:
            be = np.full(k, loop.env_damping)
            me, ke = (v, ke) if loop.env_param == "inertia" else (me, v)
        hm = hb = hk = np.zeros(k)
        if loop.human is not None:
            h = {q: np.full(k, float(loop.human.get(q, 0.0))) for q in ("inertia", "damping", "stiffness")}
            h[loop.param] = v
            hm, hb, hk = h["inertia"], h["damping"], h["stiffness"]
        mass, first_order = loop.structure()
        names = ["theta_m", "omega_m"] + ([] if locked else ["theta_j", "omega_j"])
        names += ["theta_h", "omega_h"] if mass else ["theta_h"] if first_order else []
        n = len(names)
        ix = {s: i for i, s in enumerate(names)}
        e = lambda s: np.broadcast_to(np.eye(n)[ix[s]], (k, n))  # noqa: E731
        zero = np.zeros((k, n))
        th_m, om_m = e("theta_m"), e("omega_m")
        th_j = zero if locked else e("theta_j")
        om_j = zero if locked else e("omega_j")
        c = lambda x: x[:, None]  # noqa: E731
        if loop.human is None:
            tau_c = zero
        elif "theta_h" in ix:
            tau_c = c(Kc) * (e("theta_h") - th_j)
        else:
            s = Kc + hk
            tau_c = -c(np.where(s > 0, Kc * hk / np.where(s > 0, s, 1.0), 0.0)) * th_j
        tau_s = c(Ks) * (th_j - th_m)
        dtau_s = c(Ks) * (om_j - om_m)
        A = np.zeros((k, n, n))
        B = np.zeros((k, n))
        A[:, ix["theta_m"]] = om_m
        A[:, ix["omega_m"]] = (tau_s - c(Bm) * om_m) / c(Jm)
        B[:, ix["omega_m"]] = 1.0 / Jm
        if not locked:
            A[:, ix["theta_j"]] = om_j
            A[:, ix["omega_j"]] = (tau_c - tau_s - c(be) * om_j - c(ke) * th_j) / c(Jj + me)
        if mass:
            A[:, ix["theta_h"]] = e("omega_h")
            A[:, ix["omega_h"]] = (-tau_c - c(hb) * e("omega_h") - c(hk) * e("theta_h")) / c(hm)
        elif first_order:
            A[:, ix["theta_h"]] = (-tau_c - c(hk) * e("theta_h")) / c(hb)
        C = np.stack([th_m, om_m, tau_s, dtau_s, tau_c], axis=1)
        return A, B, C

    def zoh(self, A: np.ndarray, B: np.ndarray, f: np.ndarray):
        """Stacks (Φ, Γ0, Γ1) of :func:`exotune.sampled.zoh_fractional` (fractions ``f`` per job)."""
        k, n = B.shape
        M = np.zeros((k, n + 1, n + 1))
        M[:, :n, :n] = A
        M[:, :n, n] = B
        E0 = scipy.linalg.expm(M * ((1.0 - f) * self.Ts)[:, None, None])
        Phi0, G0 = E0[:, :n, :n], E0[:, :n, n]
        frac = f > 0
        Phi, G1 = Phi0.copy(), np.zeros((k, n))
        if frac.any():
            E1 = scipy.linalg.expm(M[frac] * (f[frac] * self.Ts)[:, None, None])
            Phi[frac] = Phi0[frac] @ E1[:, :n, :n]
            G1[frac] = np.einsum("kij,kj->ki", Phi0[frac], E1[:, :n, n])
        return Phi, G0, G1

    # ---- loops ---------------------------------------------------------------------------
    def split_delay(self, delay: np.ndarray):
        """(whole samples d, fraction f) of total delays [s], as :func:`closed_loop_matrix` splits them."""
        q = delay / self.Ts
        d = np.floor(q + 1e-9).astype(np.int64)
        f = q - d
        return d, np.where(f < 1e-9, 0.0, f)

    def matrices(self, des: np.ndarray, loop: Loop, v: np.ndarray, delay: np.ndarray):
        """Loop matrices of jobs that share their size: [(job positions, stack (k, N, N))]."""
        A, B, C = self.plant(des, loop, v)
        d, f = self.split_delay(delay)
        Phi, G0, G1 = self.zoh(A, B, f)
        out = []
        key = self.nz[des] * 100_000 + d
        for kv in np.unique(key):
            pos = np.nonzero(key == kv)[0]
            out.append((pos, self._assemble(des[pos], Phi[pos], G0[pos], G1[pos], C[pos], int(d[pos[0]]))))
        return out

    def _assemble(self, des, Phi, G0, G1, C, d: int) -> np.ndarray:
        """:func:`closed_loop_matrix` on a stack (one controller size, one whole-sample delay)."""
        k, n = G0.shape
        Ac = np.stack([self.ctrl[i].Ac for i in des])
        Bc = np.stack([self.ctrl[i].Bc for i in des])
        Cc = np.stack([self.ctrl[i].Cc[0] for i in des])
        Dc = np.stack([self.ctrl[i].Dc[0] for i in des])
        nz, ns = Ac.shape[1], d + 1
        N = n + nz + ns
        s0 = n + nz
        M = np.zeros((k, N, N))
        u = np.zeros((k, N))
        u[:, :n] = np.einsum("km,kmn->kn", Dc, C)
        u[:, n:s0] = Cc
        cur = u if d == 0 else np.broadcast_to(np.eye(N)[s0 + d - 1], (k, N))
        old = np.eye(N)[s0 + d]
        M[:, :n, :n] = Phi
        M[:, :n] += G0[:, :, None] * cur[:, None, :] + G1[:, :, None] * old[None, None, :]
        M[:, n:s0, :n] = Bc @ C
        M[:, n:s0, n:s0] = Ac
        M[:, s0] = u
        j = np.arange(1, ns)
        M[:, s0 + j, s0 + j - 1] = 1.0
        return M

    def spectra(self, des, loop: Loop, v=None, delay=None):
        """(spectral radii (k,), eigenvalue arrays) of the jobs (designs ``des``, members ``v`` of
        ``loop``, total delays ``delay`` [s], default each design's own). The rigid-body
        eigenvalue of an ungrounded loop (within ``RIGID_TOL`` of z = 1) is replaced by 0 so that
        the arrays keep their size; it counts neither in the radius nor as a moving eigenvalue."""
        des = np.asarray(des, dtype=np.int64)
        v = np.zeros(des.size) if v is None else np.asarray(v, dtype=float)
        delay = self.delay[des] if delay is None else np.asarray(delay, dtype=float)
        rho = np.zeros(des.size)
        eig: list = [None] * des.size
        grounded = loop.grounded(v) | self.position_feedback[des]
        with np.errstate(over="ignore", invalid="ignore"):
            for pos, M in self.matrices(des, loop, v, delay):
                lam = _eigvals_or_inf(M)
                free = ~grounded[pos]
                if free.any():
                    r = np.argmin(np.abs(lam - 1.0), axis=1)
                    rows = np.nonzero(free & (np.abs(lam[np.arange(pos.size), r] - 1.0) <= RIGID_TOL))[0]
                    lam[rows, r[rows]] = 0.0
                rho[pos] = np.max(np.abs(lam), axis=1) if lam.shape[1] else 0.0
                for j, p in enumerate(pos):
                    eig[p] = lam[j]
        return rho, eig


def _eigvals_or_inf(M: np.ndarray) -> np.ndarray:
    """Eigenvalues of a stack whose non-finite matrices (an overflowing controller) get +inf."""
    ok = np.all(np.isfinite(M), axis=(1, 2))
    lam = np.full(M.shape[:2], np.inf, dtype=complex)
    if ok.any():
        lam[ok] = np.linalg.eigvals(M[ok])
    return lam

