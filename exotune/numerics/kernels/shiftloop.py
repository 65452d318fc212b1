"""Compiled linear recursion of a simulated run with a delay line: the kernel behind
:meth:`exotune.simulation.fastpath.LinearLoop.run`.

The state w = [plant (p), runtime controller (c), shift states s_0 … s_d] evolves as

    p' = Φ p + g_cur·cur + g_old·s_d + g_push·push,   c' = B C p + A c,
    s'_0 = u_p·p + u_c·c,   s'_j = s_{j−1},

with cur = s_{d−1} (cur = s'_0's row u·w when d = 0): the same numbers as w' = M w + N·push with
the dense loop matrix M, but at a cost independent of the delay length (a 1 ms delay at 100 kHz
is a 101-state shift register). The numpy reference is the dense recursion itself.
"""

from __future__ import annotations

import numpy as np

from .common import AVAILABLE, njit

__all__ = ["shift_loop_run"]

if AVAILABLE:

    @njit(cache=True)
    def shift_loop_run(Phi, g_cur, g_old, g_push, BC, A, u_p, u_c, d, w0, push):
        """States w[k], k = 0 … len(push) (row k+1 after the push of sample k), shape (K+1, N)."""
        n_p = Phi.shape[0]
        n_c = A.shape[0]
        ns = d + 1
        N = n_p + n_c + ns
        K = push.shape[0]
        out = np.empty((K + 1, N))
        for i in range(N):
            out[0, i] = w0[i]
        p = w0[:n_p].copy()
        c = w0[n_p:n_p + n_c].copy()
        s = w0[n_p + n_c:].copy()
        p_new = np.empty(n_p)
        c_new = np.empty(n_c)
        for k in range(K):
            u = 0.0
            for i in range(n_p):
                u += u_p[i] * p[i]
            for i in range(n_c):
                u += u_c[i] * c[i]
            cur = u if d == 0 else s[d - 1]
            old = s[d]
            for i in range(n_p):
                acc = g_cur[i] * cur + g_old[i] * old + g_push[i] * push[k]
                for j in range(n_p):
                    acc += Phi[i, j] * p[j]
                p_new[i] = acc
            for i in range(n_c):
                acc = 0.0
                for j in range(n_p):
                    acc += BC[i, j] * p[j]
                for j in range(n_c):
                    acc += A[i, j] * c[j]
                c_new[i] = acc
            for j in range(ns - 1, 0, -1):
                s[j] = s[j - 1]
            s[0] = u
            for i in range(n_p):
                p[i] = p_new[i]
                out[k + 1, i] = p[i]
            for i in range(n_c):
                c[i] = c_new[i]
                out[k + 1, n_p + i] = c[i]
            for j in range(ns):
                out[k + 1, n_p + n_c + j] = s[j]
        return out

else:  # pragma: no cover - numba missing: the dense numpy recursion runs instead
    shift_loop_run = None
