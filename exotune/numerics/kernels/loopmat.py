"""Compiled assembly of sampled-data loop matrices on a stack: the block structure of
:func:`exotune.sampled.closed_loop_matrix` (docs/method.md#sampled-data-verdicts) filled in one
pass per matrix from the held plant (Φ, Γ0, Γ1), its measurement map C and the controller's
(A_c, B_c, C_c, D_c) — what :meth:`exotune.sampled.batch.BatchLoops.matrices` does with a dozen
numpy operations over the stack (its numpy reference, which the tests compare this with).

State order (N = n + n_z + n_s): the plant's n states, the controller's n_z, then the shift register
of past commands (n_s = d + 1 with a fractional delay, d with a whole-sample one). The command is
u·x with u = [D_c C, C_c, 0]; it enters the plant through Γ0 at once (d = 0) or from the register
(τ_cmd[k − d]), and through Γ1 from the register's last state (τ_cmd[k − d − 1]) when the delay
has a fraction.
"""

from __future__ import annotations

import numpy as np

from .common import AVAILABLE, njit

__all__ = ["assemble_stack"]

if AVAILABLE:

    @njit(cache=True)
    def _assemble_kernel(Phi, G0, G1, C, des, Ac, Bc, Cc, Dc, nz, d, frac, M):
        k, n = G0.shape
        nm = C.shape[1]
        s0 = n + nz
        ns = d + frac
        N = s0 + ns
        u = np.zeros(N)
        for t in range(k):
            g = des[t]
            for j in range(N):
                u[j] = 0.0
                for i in range(N):
                    M[t, i, j] = 0.0
            for j in range(n):
                s = 0.0
                for m in range(nm):
                    s += Dc[g, m] * C[t, m, j]
                u[j] = s
            for j in range(nz):
                u[n + j] = Cc[g, j]
            for i in range(n):
                for j in range(n):
                    M[t, i, j] = Phi[t, i, j]
                if d == 0:
                    for j in range(N):
                        M[t, i, j] += G0[t, i] * u[j]
                else:
                    M[t, i, s0 + d - 1] += G0[t, i]
                if frac:
                    M[t, i, s0 + d] += G1[t, i]
            for i in range(nz):
                for j in range(n):
                    s = 0.0
                    for m in range(nm):
                        s += Bc[g, i, m] * C[t, m, j]
                    M[t, n + i, j] = s
                for j in range(nz):
                    M[t, n + i, n + j] = Ac[g, i, j]
            if ns:
                for j in range(N):
                    M[t, s0, j] = u[j]
                for j in range(1, ns):
                    M[t, s0 + j, s0 + j - 1] = 1.0


def assemble_stack(Phi, G0, G1, C, des, Ac, Bc, Cc, Dc, nz: int, d: int, frac: bool) -> np.ndarray:
    """Loop matrices of a stack of jobs that share the controller size and the delay's split.

    Parameters
    ----------
    Phi, G0, G1 : numpy.ndarray
        The held plant per job: (k, n, n), (k, n), (k, n).
    C : numpy.ndarray
        The plant's measurement map per job, (k, m, n).
    des : numpy.ndarray
        The design (row of the controller arrays) of each job, int, (k,).
    Ac, Bc, Cc, Dc : numpy.ndarray
        The controllers of all designs: (D, ≥nz, ≥nz), (D, ≥nz, m), (D, ≥nz), (D, m).
    nz : int
        Controller states of these jobs.
    d : int
        Whole samples of the delay.
    frac : bool
        Whether the delay has a fraction of a sample.

    Returns
    -------
    numpy.ndarray
        (k, N, N) loop matrices, N = n + nz + d + frac (module docstring).
    """
    k, n = G0.shape
    N = n + nz + d + int(frac)
    M = np.empty((k, N, N))
    if k:
        _assemble_kernel(np.ascontiguousarray(Phi, dtype=float), np.ascontiguousarray(G0, dtype=float),
                         np.ascontiguousarray(G1, dtype=float), np.ascontiguousarray(C, dtype=float),
                         np.ascontiguousarray(des, dtype=np.int64), Ac, Bc, Cc, Dc, int(nz), int(d), int(frac), M)
    return M
