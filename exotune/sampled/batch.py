"""The exact sampled-data loop batched over designs (the sweep's ``sampled: true`` columns,
docs/sweep-spec.md#sampled-data-columns).

Per design, the controller is the one ``exotune export`` writes: the blocks of
:func:`exotune.sampled.controller_blocks`, each discretized to second-order sections by
:func:`exotune.sampled.sos.tustin_sos` (prewarped at :func:`exotune.sampled.loop.default_prewarp`) and
realized by :func:`exotune.sampled.sos.sos_ss`, assembled by :func:`exotune.sampled.assemble` —
the very functions behind ``controller_section`` and ``discrete_from_file``, so the state space is
bit for bit the one ``certify`` rebuilds from the exported file. The plant (+ human, + environment)
is discretized exactly with the zero-order hold and the fractional delay (Φ, Γ0, Γ1 of
:mod:`exotune.sampled.loop`), and the loop matrix is :func:`exotune.sampled.closed_loop_matrix`'s.

A batch of one may instead carry a given discrete controller (:meth:`BatchLoops.of_controller`:
a controller file's own realization, for ``exotune certify``'s latency margin, which runs on the
engine of :mod:`exotune.sampled.families`).

What is batched: the plant matrices of many (design, member, delay) jobs are built as stacks, their
matrix exponentials computed on stacks, the loop matrices assembled on stacks of equal size, and the
eigenvalues found by one ``numpy.linalg.eigvals`` call per stack. The rigid-body eigenvalue z = 1 of
an ungrounded loop is set aside as :func:`exotune.sampled.loop_eigenvalues` does: deflated exactly
by its eigenvector (:mod:`exotune.sampled.rigid`, on the stack), else within ``RIGID_TOL`` of 1.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..numerics.engine import compiled
from .loop import NEAR_UNIT as ROUND_NEAR
from .loop import ROUNDING_TRIALS, Measured, expm_rounding, plant_stack, rigid_plant_vector, split_delay
from .rigid import deflate, rigid_deflation
from .sos import bilinear_batch, df2t_batch, sos_ss_batch, tustin_sections_batch

__all__ = ["RIGID_TOL", "NEAR_UNIT", "BatchLoops", "Loop", "batch_controller", "expm_stack"]

RIGID_TOL = 1e-7  # |λ − 1| within which the rigid-body eigenvalue is set aside if not deflated (loop_eigenvalues)
NEAR_UNIT = 1e-6  # |ρ − 1| within which a verdict is decided with the rounding estimate (certify's band)


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


def _vec(x, n: int) -> np.ndarray:
    """A per-design float array (n,) of a batch field (scalar or (n,))."""
    return np.broadcast_to(np.ravel(np.asarray(x, dtype=float)), (n,)).copy()


def _rows(c, n: int) -> np.ndarray:
    """Coefficient rows (n, m) of a batched polynomial (shape (m,), (1, m) or (n, m))."""
    c = np.asarray(c, dtype=float)
    return np.broadcast_to(c.reshape(-1, c.shape[-1]), (n, c.shape[-1])).copy()


def _degree(c: np.ndarray) -> np.ndarray:
    """Degree of each row of ascending coefficients (−1 for a zero row)."""
    nz = c != 0
    return np.where(nz.any(axis=1), c.shape[1] - 1 - np.argmax(nz[:, ::-1], axis=1), -1)


def _controller_parts(cfg, n: int):
    """Static gains (n, 5) on :data:`Measured` and the proper blocks of
    :func:`exotune.sampled.controller_blocks`, batched: [(inputs, num (n, p, ·), den (n, ·),
    prewarp (n,) or None)]; the three DOB blocks share Q's denominator and become one block with
    three inputs (the other two copies are unobservable modes at Q's poles, see BatchLoops)."""
    from ..model.controller import build_controller

    cs, _ = build_controller(cfg.plant, cfg.design, cfg.implementation)
    impl = cfg.implementation
    pw = {}
    if impl.gv_filter is not None:
        pw["tau_c"] = _vec(impl.gv_filter.cutoff_hz, n)
    if impl.velocity_filter is not None:
        pw["theta_m"] = pw["tau_s"] = _vec(impl.velocity_filter.cutoff_hz, n)
    if impl.dob is not None:
        pw["dob"] = _vec(impl.dob.cutoff_hz, n)
    static = np.zeros((n, len(Measured)))
    blocks = []
    for blk, pos, vel in ((cs.motor_position, 0, 1), (cs.spring_torque, 2, 3)):
        num, den = _rows(blk.num, n), _rows(blk.den, n)
        dn, dd = _degree(num), _degree(den)
        improper = dn > dd
        if np.any(improper & ((dd != 0) | (dn > 1))):
            raise ValueError("only K + B s improper parts are implemented with ideal sampled velocities")
        d0 = np.where(improper, den[:, 0], 1.0)
        static[:, pos] += np.where(improper, num[:, 0] / d0, 0.0)
        if num.shape[1] > 1:
            static[:, vel] += np.where(improper, num[:, 1] / d0, 0.0)
        rem = np.where(improper[:, None], 0.0, num)
        if np.any(rem):
            blocks.append(([Measured[pos]], rem[:, None, :], den, pw.get("theta_m" if pos == 0 else "tau_s")))
    blocks.append((["tau_c"], _rows(cs.cuff_torque.num, n)[:, None, :], _rows(cs.cuff_torque.den, n), pw.get("tau_c")))
    if cs.dob_q is not None:
        qn, qd = _rows(cs.dob_q.num, n), _rows(cs.dob_q.den, n)
        Jm, Bm = _vec(cfg.plant.J_m, n), _vec(cfg.plant.B_m, n)
        w = max(qn.shape[1] + 2, qd.shape[1])
        num = np.zeros((n, 3, w))
        num[:, 0, 1:qn.shape[1] + 1] -= qn * Bm[:, None]  # −Q (J_m s² + B_m s) θ_m
        num[:, 0, 2:qn.shape[1] + 2] -= qn * Jm[:, None]
        num[:, 1, :qn.shape[1]] = qn  # + Q τ_s
        num[:, 2, :qn.shape[1]] = qn  # + Q τ_cmd
        blocks.append((["theta_m", "tau_s", "tau_cmd"], num, qd, pw.get("dob")))
    return static, blocks


def batch_controller(cfg, fs: float, n: int):
    """The discrete controllers of the ``n`` designs of a batch config at ``fs`` [Hz]:
    (Ac (n, z, z), Bc (n, z, 5), Cc (n, z), Dc (n, 5), states (n,), position feedback (n,),
    fixed (n, f) moduli of the unobservable modes left out) — zero-padded to the largest state
    count z.

    The transfer function of every block is the one ``exotune export`` writes (the prewarped
    Tustin transform of :func:`exotune.sampled.controller_blocks`' blocks,
    :func:`exotune.sampled.sos.bilinear_batch`), realized in direct form II transposed
    — single-input blocks as cascades of sections (:func:`exotune.sampled.sos.tustin_sections_batch`,
    sections paired differently from the file's), the three DOB blocks as one section with three
    inputs (:func:`exotune.sampled.sos.df2t_batch`) — so the loop matrix differs from certify's by
    a similarity and by the two unobservable copies of the DOB filter's poles, whose moduli are
    kept in ``fixed``: the same eigenvalues up to rounding.
    Position feedback: the θ_m gain plus the DC gains of the θ_m blocks (continuous DC gain = the
    Tustin one) is not zero, as :func:`dc_position_feedback` decides it on the file.

    Parameters
    ----------
    cfg : DesignConfig
        Batch config (:func:`exotune.config.batch_config`): every field a scalar or an (n,) array.
    fs : float
        Sample rate [Hz].
    n : int
        Number of designs.

    Returns
    -------
    Ac : numpy.ndarray
        Controller state matrices (n, z, z).
    Bc : numpy.ndarray
        Input matrices (n, z, 5) of the :data:`~exotune.sampled.loop.Measured` signals.
    Cc : numpy.ndarray
        Output rows (n, z).
    Dc : numpy.ndarray
        Feed-throughs (n, 5).
    states : numpy.ndarray
        State count per design (n,), int.
    position_feedback : numpy.ndarray
        Whether each design feeds back θ_m (n,), bool.
    fixed : numpy.ndarray
        Moduli (n, 2) of the unobservable DOB modes left out of the realization.

    Raises
    ------
    ValueError
        When a design's DOB algebraic loop is singular (Q feed-through of 1).
    """
    static, blocks = _controller_parts(cfg, n)
    degs = np.stack([_degree(den) for _i, _num, den, _pw in blocks], axis=1)
    single = np.array([len(inp) == 1 for inp, _n, _d, _p in blocks])
    nzs = np.where(single, 2 * ((np.clip(degs, 0, None) + 1) // 2), np.clip(degs, 0, None)).sum(axis=1)
    nzmax = int(nzs.max()) if n else 0
    Ac, Bc = np.zeros((n, nzmax, nzmax)), np.zeros((n, nzmax, len(Measured)))
    Cc, Dc = np.zeros((n, nzmax)), np.zeros((n, len(Measured)))
    fixed = np.zeros((n, 2))
    pf = np.zeros(n, bool)
    for sig in np.unique(degs, axis=0):
        rows = np.nonzero(np.all(degs == sig, axis=1))[0]
        k = rows.size
        parts = []
        q0 = np.zeros(k)
        Dy = static[rows].copy()
        total, scale = static[rows, 0].copy(), np.abs(static[rows, 0])
        for (inputs, num, den, pwz), m in zip(blocks, sig):
            num, den = num[rows], den[rows, :m + 1]
            for j, inp in enumerate(inputs):
                if inp == "theta_m":  # DC gain n0/d0 of a θ_m block: an integrator (d0 = 0) feeds back θ_m
                    dc = np.divide(num[:, j, 0], den[:, 0], out=np.where(num[:, j, 0] != 0, np.inf, 0.0),
                                   where=den[:, 0] != 0)
                    total, scale = total + dc, scale + np.abs(dc)
            pwr = None if pwz is None else pwz[rows]
            if len(inputs) == 1 and m > 0:  # a cascade of sections, as the file has it
                A, B, C, D = sos_ss_batch(tustin_sections_batch(num[:, 0, :m + 1], den, fs, pwr))
                B, D = B[:, :, None], D[:, None]
            else:
                b, a = bilinear_batch(num[:, :, :m + 1], den, fs, pwr)
                A, B, C, D = df2t_batch(b, a)
                C = np.broadcast_to(C, (k, C.size))
            for j, inp in enumerate(inputs):
                if inp == "tau_cmd":
                    q0 += D[:, j]
                else:
                    Dy[:, Measured.index(inp)] += D[:, j]
            parts.append((inputs, A, B, C))
            if len(inputs) > 1 and m > 0:  # the merged DOB block: two copies of Q's poles left out
                fixed[rows] = np.max(np.abs(np.linalg.eigvals(A)), axis=1, keepdims=True)
        if np.any(np.abs(1.0 - q0) < 1e-12):
            raise ValueError("the DOB's algebraic loop is singular (Q feed-through = 1)")
        nz = int(nzs[rows[0]])
        Cz = np.concatenate([C for _i, _A, _B, C in parts], axis=1)
        cc, dc_ = Cz / (1.0 - q0)[:, None], Dy / (1.0 - q0)[:, None]
        ac, bc = np.zeros((k, nz, nz)), np.zeros((k, nz, len(Measured)))
        off = 0
        for inputs, A, B, _C in parts:
            m = A.shape[1]
            ac[:, off:off + m, off:off + m] = A
            for j, inp in enumerate(inputs):
                if inp == "tau_cmd":
                    ac[:, off:off + m, :] += B[:, :, j, None] * cc[:, None, :]
                    bc[:, off:off + m, :] += B[:, :, j, None] * dc_[:, None, :]
                else:
                    bc[:, off:off + m, Measured.index(inp)] += B[:, :, j]
            off += m
        Ac[rows, :nz, :nz], Bc[rows, :nz], Cc[rows, :nz], Dc[rows] = ac, bc, cc, dc_
        pf[rows] = (np.abs(total) > 1e-12 * np.maximum(scale, 1e-300)) & (total != 0.0)
    return Ac, Bc, Cc, Dc, nzs, pf, fixed


def expm_stack(M: np.ndarray) -> np.ndarray:
    """e^M of a stack (k, n, n): with the compiled engine one compiled loop, balancing then the
    lowest Padé degree exact to rounding (:func:`exotune.numerics.kernels.expm.expm_stack`); on the
    numpy engine, and for a matrix the kernel does not finish, ``scipy.linalg.expm`` on the stack.

    Parameters
    ----------
    M : numpy.ndarray
        Stack of square matrices (k, n, n).

    Returns
    -------
    numpy.ndarray
        e^M per matrix, (k, n, n).
    """
    k, n, _ = M.shape
    if not k:
        return M.copy()
    if compiled() and n:
        from ..numerics.kernels.expm import expm_stack as compiled_expm

        E, ok = compiled_expm(M)
        if not ok.all():
            E[~ok] = _expm_numpy(M[~ok])
        return E
    return _expm_numpy(M)


def _expm_numpy(M: np.ndarray) -> np.ndarray:
    """:func:`expm_stack` by ``scipy.linalg.expm`` on the stack (the numpy engine, and any matrix the
    compiled kernel does not finish)."""
    import scipy.linalg

    return scipy.linalg.expm(M)


class BatchLoops:
    """The sampled-data loops of the designs of a batch config ``cfg``
    (:func:`exotune.config.batch_config`) at sample rate ``fs``; :meth:`spectra` gives the
    eigenvalues of many jobs (design, member, delay) in a few stacked eigenvalue problems."""

    def __init__(self, cfg, fs: float, n: int | None = None):
        self.fs = float(fs)
        self.Ts = 1.0 / self.fs
        p = cfg.plant
        if n is None:
            n = max(np.size(x) for x in (p.J_m, p.B_m, p.K_s, p.J_j, p.K_c, cfg.implementation.delay_s,
                                         cfg.design.amplification))
        self.n = n
        self.Jm, self.Bm, self.Ks, self.Jj, self.Kc = (_vec(getattr(p, q), n) for q in ("J_m", "B_m", "K_s", "J_j", "K_c"))
        self.delay = _vec(cfg.implementation.delay_s, n)
        self.Ac, self.Bc, self.Cc, self.Dc, self.nz, self.position_feedback, self.fixed = batch_controller(cfg, self.fs, n)

    @classmethod
    def of_controller(cls, plant, ctrl, position_feedback: bool) -> BatchLoops:
        """A batch of one design: the loop of ``plant`` with the given discrete controller ``ctrl``
        (:class:`~exotune.sampled.loop.DiscreteController`, e.g. a controller file's own
        realization), at its rate and delay; nothing is left out of the realization (``fixed`` 0).
        Its loop matrices are :func:`exotune.sampled.closed_loop_matrix`'s (less the unread oldest
        command of a whole-sample delay): the eigenvalues of :func:`exotune.sampled.loop_eigenvalues`."""
        self = cls.__new__(cls)
        self.fs = float(ctrl.sample_rate_hz)
        self.Ts = 1.0 / self.fs
        self.n = 1
        self.Jm, self.Bm, self.Ks, self.Jj, self.Kc = (np.ravel(np.asarray(getattr(plant, q), float))[:1].copy()
                                                       for q in ("J_m", "B_m", "K_s", "J_j", "K_c"))
        self.delay = np.array([float(ctrl.delay_s)])
        nz = int(np.shape(ctrl.Ac)[0])
        self.Ac = np.asarray(ctrl.Ac, dtype=float).reshape(1, nz, nz)
        self.Bc = np.asarray(ctrl.Bc, dtype=float).reshape(1, nz, len(Measured))
        self.Cc = np.asarray(ctrl.Cc, dtype=float).reshape(1, nz)
        self.Dc = np.asarray(ctrl.Dc, dtype=float).reshape(1, len(Measured))
        self.nz, self.position_feedback = np.array([nz]), np.array([bool(position_feedback)])
        self.fixed = np.zeros((1, 2))
        return self

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
        return plant_stack((Jm, Bm, Ks, Jj, Kc), (hm, hb, hk), (me, be, ke),
                           (locked, loop.human is not None, *loop.structure()))

    def zoh(self, A: np.ndarray, B: np.ndarray, f: np.ndarray):
        """Stacks (Φ, Γ0, Γ1) of :func:`exotune.sampled.loop.zoh_fractional` (fractions ``f`` per job)."""
        k, n = B.shape
        M = np.zeros((k, n + 1, n + 1))
        M[:, :n, :n] = A
        M[:, :n, n] = B
        E0 = expm_stack(M * ((1.0 - f) * self.Ts)[:, None, None])
        Phi0, G0 = E0[:, :n, :n], E0[:, :n, n]
        frac = f > 0
        Phi, G1 = Phi0.copy(), np.zeros((k, n))
        if frac.any():
            E1 = expm_stack(M[frac] * (f[frac] * self.Ts)[:, None, None])
            Phi[frac] = Phi0[frac] @ E1[:, :n, :n]
            G1[frac] = np.einsum("kij,kj->ki", Phi0[frac], E1[:, :n, n])
        return Phi, G0, G1

    # ---- loops ---------------------------------------------------------------------------
    def split_delay(self, delay: np.ndarray):
        """(whole samples d, fraction f) of total delays [s], as :func:`closed_loop_matrix` splits them."""
        delay = np.asarray(delay, dtype=float)
        d, f = split_delay(delay.reshape(-1), self.Ts)
        return d.reshape(delay.shape), f.reshape(delay.shape)

    def matrices(self, des: np.ndarray, loop: Loop, v: np.ndarray, delay: np.ndarray):
        """Loop matrices of jobs that share their size: [(job positions, stack (k, N, N))]."""
        A, B, C = self.plant(des, loop, v)
        d, f = self.split_delay(delay)
        Phi, G0, G1 = self.zoh(A, B, f)
        out = []
        key = (self.nz[des] * 100_000 + d) * 2 + (f > 0)
        for kv in np.unique(key):
            pos = np.nonzero(key == kv)[0]
            out.append((pos, self._assemble(des[pos], Phi[pos], G0[pos], G1[pos], C[pos], int(d[pos[0]]),
                                            bool(f[pos[0]] > 0))))
        return out

    def _assemble(self, des, Phi, G0, G1, C, d: int, frac: bool) -> np.ndarray:
        """:func:`closed_loop_matrix` on a stack (one controller size, one whole-sample delay),
        without its one state that nothing reads: with a whole-sample delay (Γ1 = 0) the oldest
        command τ_cmd[k−d−1] only adds the eigenvalue 0, so the shift register keeps d states. With the
        compiled engine, one compiled pass (:func:`exotune.numerics.kernels.loopmat.assemble_stack`)."""
        k, n = G0.shape
        nz = int(self.nz[des[0]])
        if compiled():
            from ..numerics.kernels.loopmat import assemble_stack

            return assemble_stack(Phi, G0, G1, C, des, self.Ac, self.Bc, self.Cc, self.Dc, nz, d, frac)
        ns = d + frac
        N = n + nz + ns
        s0 = n + nz
        M = np.zeros((k, N, N))
        u = np.zeros((k, N))
        u[:, :n] = np.einsum("km,kmn->kn", self.Dc[des], C)
        u[:, n:s0] = self.Cc[des, :nz]
        M[:, :n, :n] = Phi
        if d == 0:
            M[:, :n] += G0[:, :, None] * u[:, None, :]  # τ_cmd[k]
        else:
            M[:, :n, s0 + d - 1] += G0  # τ_cmd[k−d]
        if frac:
            M[:, :n, s0 + d] += G1  # τ_cmd[k−d−1]
        M[:, n:s0, :n] = self.Bc[des, :nz] @ C
        M[:, n:s0, n:s0] = self.Ac[des, :nz, :nz]
        if ns:
            M[:, s0] = u
            j = np.arange(1, ns)
            M[:, s0 + j, s0 + j - 1] = 1.0
        return M

    def spectra(self, des, loop: Loop, v=None, delay=None, width: int | None = None, rounding: bool = True):
        """(spectral radii (k,), eigenvalues (k, width), stable (k,)) of the jobs (designs ``des``,
        members ``v`` of ``loop``, total delays ``delay`` [s], default each design's own).

        The rigid-body eigenvalue of an ungrounded loop is replaced by 0 (deflated exactly by its
        eigenvector, :meth:`_eigenvalues`; else the eigenvalue within ``RIGID_TOL`` of z = 1);
        shorter spectra are padded with distinct constants (:func:`_pad`: neither counts in the
        radius nor moves). The rounding verdict of a deflated loop is the deflated matrix's.
        The radius includes the fixed moduli of the DOB copies left out (:func:`batch_controller`).
        ``stable`` is radius < 1, except within ``NEAR_UNIT`` of 1 where certify's rounding
        estimate decides (:func:`_rounding_verdict`; inconclusive is not stable) — unless
        ``rounding`` is False (the latency margin's probes: certify decides them on the radius alone)."""
        from ..numerics.timebudget import check_time

        check_time()  # inside export/certify's time budget (a no-op elsewhere)
        des = np.asarray(des, dtype=np.int64)
        v = np.zeros(des.size) if v is None else np.asarray(v, dtype=float)
        delay = self.delay[des] if delay is None else np.asarray(delay, dtype=float)
        rho = np.zeros(des.size)
        grounded = loop.grounded(v) | self.position_feedback[des]
        x = rigid_plant_vector((loop.env == "locked", loop.human is not None, *loop.structure()))
        groups = self.matrices(des, loop, v, delay)
        W = max(M.shape[1] for _p, M in groups) if width is None else width
        eig = np.zeros((des.size, W), dtype=complex)
        stable = np.zeros(des.size, bool)
        with np.errstate(over="ignore", invalid="ignore"):
            for pos, M in groups:
                lam, basis, defl = self._eigenvalues(M, ~grounded[pos], x)
                rho[pos] = np.maximum(np.max(np.abs(lam), axis=1) if lam.shape[1] else 0.0,
                                      np.max(self.fixed[des[pos]], axis=1))
                eig[pos, :lam.shape[1]] = lam
                eig[pos, lam.shape[1]:] = _pad(W - lam.shape[1])
                stable[pos] = rho[pos] < 1.0
                near = np.abs(rho[pos] - 1.0) < NEAR_UNIT
                for part, b in ((near & defl, basis), (near & ~defl, None)):
                    if not part.any() or not rounding:
                        continue
                    b = None if b is None else tuple(x_[near[defl]] for x_ in b)
                    jobs, Np = pos[part], M.shape[1] - (b is not None)
                    trial = self._zoh_trial(des[jobs], loop, v[jobs], delay[jobs])
                    stable[jobs] = _rounding_verdict(M[part], lam[part, :Np], trial, b)
        return rho, eig, stable

    @staticmethod
    def _eigenvalues(M: np.ndarray, free: np.ndarray, x):
        """(eigenvalues (k, N), deflations (s, Q₂) of the jobs ``defl`` (in order) or None,
        ``defl`` (k,) bool) of a stack of loop matrices: an ungrounded loop (``free``) whose
        rigid-body eigenvector checks (:func:`exotune.sampled.rigid.rigid_deflation`, plant part
        ``x``) is deflated exactly (the N − 1 eigenvalues of the deflated matrix, then a 0);
        another ungrounded one has its eigenvalue nearest 1 replaced by 0 when within
        ``RIGID_TOL`` of it, as :func:`exotune.sampled.loop_eigenvalues` sets them aside."""
        k, N, _ = M.shape
        defl = np.zeros(k, bool)
        basis = None
        lam = np.zeros((k, N), dtype=complex)
        if x is not None and N > 1 and free.any():
            f = np.nonzero(free)[0]
            ok, s, Q2, Md = rigid_deflation(M[f], x)
            defl[f[ok]] = True
            if ok.any():
                basis = (s, Q2)
                lam[defl, :N - 1] = _eigvals_or_inf(Md)
        rest = np.nonzero(~defl)[0]
        if rest.size:
            lr = _eigvals_or_inf(M[rest])
            r = np.argmin(np.abs(lr - 1.0), axis=1)
            rigid = free[rest] & (np.abs(lr[np.arange(rest.size), r] - 1.0) <= RIGID_TOL)
            lr[np.nonzero(rigid)[0], r[rigid]] = 0.0
            lam[rest] = lr
        return lam, basis, defl


    def _zoh_trial(self, des, loop: Loop, v, delay):
        """``trial(rng, j)``: the loop matrices of jobs ``j`` (positions in ``des``) with their
        zero-order hold perturbed within its rounding estimate (:func:`zoh_error`), reassembled;
        the draws in the order of certify's (:func:`exotune.sampled.loop.loop_verdict`)."""
        A, B, C = self.plant(des, loop, v)
        d, f = self.split_delay(delay)
        Phi, G0, G1 = self.zoh(A, B, f)
        err = self.zoh_error(A, B, f)

        def trial(rng, j):
            moved = [x[j] + e[j] * rng.uniform(-1.0, 1.0, x.shape[1:]) for x, e in zip((Phi, G0, G1), err)]
            return self._assemble(des[j], *moved, C[j], int(d[0]), bool(f[0] > 0))

        return trial

    def zoh_error(self, A: np.ndarray, B: np.ndarray, f: np.ndarray):
        """Rounding estimates (entry by entry) of the stacks (Φ, Γ0, Γ1) of :meth:`zoh`, from
        :func:`exotune.sampled.loop.expm_rounding` of its exponentials (this engine's)."""
        k, n = B.shape
        M = np.zeros((k, n + 1, n + 1))
        M[:, :n, :n] = A
        M[:, :n, n] = B
        X0 = M * ((1.0 - f) * self.Ts)[:, None, None]
        E0 = expm_stack(X0)
        e0 = expm_rounding(X0, E0, expm_stack)
        dPhi, dG0, dG1 = e0[:, :n, :n].copy(), e0[:, :n, n].copy(), np.zeros((k, n))
        frac = f > 0
        if frac.any():
            X1 = M[frac] * (f[frac] * self.Ts)[:, None, None]
            E1 = expm_stack(X1)
            e1 = expm_rounding(X1, E1, expm_stack)
            P0 = np.abs(E0[frac, :n, :n])
            dPhi[frac] = e0[frac, :n, :n] @ np.abs(E1[:, :n, :n]) + P0 @ e1[:, :n, :n]
            dG1[frac] = (np.einsum("kij,kj->ki", e0[frac, :n, :n], np.abs(E1[:, :n, n]))
                         + np.einsum("kij,kj->ki", P0, e1[:, :n, n]))
        return dPhi, dG0, dG1


def _pad(k: int) -> np.ndarray:
    """``k`` fillers of a shorter spectrum: distinct (so that nearest-partner matching pairs them
    one to one), fixed, well inside the unit circle."""
    return 0.5 * np.arange(1, k + 1) / (k + 1)


def _rounding_verdict(M: np.ndarray, lam: np.ndarray, trial=None, basis=None) -> np.ndarray:
    """:func:`exotune.sampled.loop.spectral_verdict` is True, on a stack (eigenvalues ``lam``, the
    rigid-body one already set to 0): every |λ| plus its rounding estimate (ten times its largest
    move under ``ROUNDING_TRIALS`` perturbations: ``trial(rng, j)`` the stack ``j`` with its
    zero-order hold perturbed within its rounding, then relative 8ε perturbations of the entries,
    the same pseudo-random ones as certify's; at least 4Nε) below 1. With the deflations
    ``basis`` = (s (k, N), Q₂ (k, N, N − 1)) of :func:`exotune.sampled.rigid.rigid_deflation`,
    ``lam`` (k, N − 1) are the eigenvalues of the deflated matrices and every perturbed matrix is
    deflated the same way (as :func:`exotune.sampled.loop_verdict` does)."""
    k, N, _ = M.shape
    mod = np.abs(lam)
    eps = np.finfo(float).eps
    err = np.full(lam.shape, 4.0 * lam.shape[1] * eps)
    near = np.abs(mod - 1.0) < ROUND_NEAR
    alive = np.all(mod + err < 1.0, axis=1)  # the estimates only grow: a matrix not stable here never is
    rng = np.random.default_rng(0)
    for _ in range(ROUNDING_TRIALS):
        j = np.nonzero(alive)[0]
        if not j.size:
            break
        base = M[j] if trial is None else trial(rng, j)  # drawn every trial: the same sequence as certify's
        pert = 1.0 + 8.0 * eps * rng.uniform(-1.0, 1.0, (N, N))
        wp = _eigvals_or_inf(base * pert if basis is None else deflate(base * pert, basis[0][j], basis[1][j]))
        moved = np.min(np.abs(wp[:, None, :] - lam[j, :, None]), axis=2)
        err[j] = np.where(near[j], np.maximum(err[j], 10.0 * moved), err[j])
        alive[j] = np.all(mod[j] + err[j] < 1.0, axis=1)
    return alive


def _eigvals_or_inf(M: np.ndarray) -> np.ndarray:
    """Eigenvalues of a stack whose non-finite matrices (an overflowing controller) get +inf.

    With the compiled engine (:func:`exotune.numerics.engine.compiled`, batches such as the sweep's)
    the stack goes through the compiled kernel :func:`exotune.numerics.kernels.eig.eigvals_stack`
    (the same balancing, Hessenberg reduction and double-shift QR as LAPACK's ``dgeev``, without its
    per-call overhead); a matrix it does not finish is solved by ``numpy.linalg.eigvals``, as every
    matrix is on the numpy engine (certify, export)."""
    if compiled() and M.shape[1] > 0:
        from ..numerics.kernels.eig import eigvals_stack

        lam, done = eigvals_stack(M)
        todo = np.nonzero(~done)[0]
        if todo.size:
            lam[todo] = _lapack_or_inf(M[todo])
        return lam
    return _lapack_or_inf(M)


def _lapack_or_inf(M: np.ndarray) -> np.ndarray:
    """``numpy.linalg.eigvals`` of the finite matrices of a stack, +inf for the others."""
    ok = np.all(np.isfinite(M), axis=(1, 2))
    lam = np.full(M.shape[:2], np.inf, dtype=complex)
    if ok.any():
        lam[ok] = np.linalg.eigvals(M[ok])
    return lam
