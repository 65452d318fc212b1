"""The rigid-body mode of an ungrounded sampled-data loop, set aside exactly
(docs/method.md#sampled-data).

When nothing grounds the structure (no position feedback, no human or environment stiffness, not
locked), the whole structure may translate: every position state equal, every velocity zero. The
plant's part x_r of that mode (1 on every position state, 0 on every velocity:
:func:`exotune.sampled.loop.rigid_plant_vector`) satisfies A x_r = 0 exactly (every spring
undeflected, every damper at rest), so Φ x_r = x_r and the sensors read θ_m = 1 and every other
signal 0. The rest of the loop's eigenvector at z = 1 follows from the loop's own rows: the
controller and delay-line states w solve (M − I)[x_r; w] = 0, N equations for the N − n unknowns
(consistent; solved by least squares, a QR factorization of the columns of M − I after the n
plant states bordered by the right-hand side). The controller rows alone would give w = (I − M22)⁻¹M21 x_r (the controller
settled at z = (I − A_c)⁻¹ B_c e_θm, every delayed command at the controller's DC gain from θ_m,
0 without position feedback), but I − M22 is singular when the controller itself has a pole at
z = 1 (a disturbance observer: 1/(1 − Q) at DC), and then only the plant rows (the commands
vanish) fix w.

Everything runs in the balanced coordinates of each matrix (M_b = D⁻¹ M D, D the powers of two
of LAPACK's ``dgebal`` or the compiled engine's twin, :func:`balancing`: an exact similarity): the vector v_b = [D⁻¹x_r; w_b]
is kept only when it is an eigenvector at z = 1 to rounding (‖M_b v_b − v_b‖ ≤
``RIGID_ULPS``·N·ε·‖M_b‖_F·‖v_b‖); otherwise the callers fall back to the eigenvalue nearest 1.

Deflation (:func:`rigid_deflation`, :func:`deflate`): the Householder reflector H with
H e1 = ±v_b/‖v_b‖ gives Hᵀ M_b H = [[λ, *], [r, M']], r = Q₂ᵀ(M_b v̂ − v̂) with Q₂ = H[:, 1:];
so M' = Q₂ᵀ M_b Q₂ holds the other N − 1 eigenvalues of M up to a perturbation of norm
‖M_b v̂ − v̂‖, rounding — the backward error of the eigen-solver itself. The verdict then no longer
depends on how well the eigen-solver resolves the rigid eigenvalue: a slow mode within 5e-6 of
z = 1 next to it (a nearly defective pair) put the computed rigid eigenvalue 3.5e-7 from 1, beyond
any tolerance that tells it from a physical mode, and moved the slow mode by as much. Balancing
first matters: an orthogonal reflector of the unbalanced matrix (‖M‖ ~ 1e12 with a companion
realization of the cuff filter, most entries of order 1) spreads the rounding of its largest entries over all of
them, and the eigenvalues near the circle lost 3e-8; in balanced coordinates they keep 1e-14.

Engines: with the compiled engine (:func:`exotune.numerics.engine.compiled`: the sweep's sampled
columns, the latency margin) :func:`rigid_deflation` and :func:`deflate` run as one compiled loop
over the stack, :mod:`exotune.numerics.kernels.rigid` (the same steps; equal to rounding, not bit
for bit: another QR); the numpy code here is their reference and runs on the numpy engine
(certify, export).
"""

from __future__ import annotations

import numpy as np

__all__ = ["RIGID_ULPS", "balancing", "rigid_vectors", "rigid_deflation", "deflate"]

RIGID_ULPS = 64.0  # ‖M_b v − v‖ ≤ RIGID_ULPS·N·ε·‖M_b‖_F·‖v‖ (balanced): an eigenvector to rounding


def balancing(M: np.ndarray) -> np.ndarray:
    """The diagonal scalings (powers of two) that balance each matrix of a stack as LAPACK's
    ``dgebal`` does (no permutation; with the compiled engine, its compiled twin): M_b = D⁻¹ M D,
    D = diag(s), exact in floating point.

    Parameters
    ----------
    M : numpy.ndarray
        Finite matrices (k, N, N).

    Returns
    -------
    numpy.ndarray
        s (k, N).
    """
    return _balance(np.asarray(M, dtype=float))[1]


def _balance(M: np.ndarray):
    """(M_b, s) of :func:`balancing`, one matrix at a time (the same scaling in a stack of any
    size): LAPACK's ``dgebal``, or with the compiled engine its twin
    :func:`exotune.numerics.kernels.eig.balance` (without the per-call overhead); s = 1 and
    M_b = M for a matrix not scaled to positive finite factors."""
    from ..numerics.engine import compiled

    Mb, s = np.array(M, dtype=float, order="C"), np.ones(M.shape[:2])
    if compiled() and M.shape[1]:
        from ..numerics.kernels.eig import balance

        for i in range(M.shape[0]):
            balance(Mb[i], s[i])
    else:
        from scipy.linalg.lapack import dgebal

        for i in range(M.shape[0]):
            Mb[i], _lo, _hi, s[i], _info = dgebal(M[i], scale=1, permute=0)
    bad = ~np.all(np.isfinite(s) & (s > 0.0), axis=1)
    s[bad], Mb[bad] = 1.0, M[bad]
    return Mb, s


def _balanced(M: np.ndarray, s: np.ndarray) -> np.ndarray:
    """D⁻¹ M D for the scalings ``s`` (k, N) of a stack (exact: powers of two)."""
    return M * (s[:, None, :] / s[:, :, None])


def _vectors(M: np.ndarray, x: np.ndarray):
    """(v_b (k, N) in the balanced coordinates of :func:`balancing`, s (k, N), ok (k,), M_b) of
    :func:`rigid_vectors`."""
    M = np.asarray(M, dtype=float)
    k, N, _ = M.shape
    x = np.asarray(x, dtype=float)
    n = x.shape[-1]
    ok = np.all(np.isfinite(M), axis=(1, 2))
    Mb, s = _balance(M if ok.all() else np.where(ok[:, None, None], M, 0.0))
    v = np.zeros((k, N))
    v[:, :n] = np.broadcast_to(x, (k, n)) / s[:, :n]
    if N > n:
        E = Mb - np.eye(N)  # (M_b − I) v = 0: N equations for the N − n unknowns
        # least squares (consistent) by a QR factorization of [E_w, −E_x x]: its R holds R_w and Qᵀb
        b = -np.einsum("kij,kj->ki", E[:, :, :n], v[:, :n])
        R = np.linalg.qr(np.concatenate([E[:, :, n:], b[:, :, None]], axis=2), mode="r")
        Rw, rhs = R[:, :N - n, :N - n], R[:, :N - n, N - n:]
        ok &= np.all(np.diagonal(Rw, axis1=1, axis2=2) != 0.0, axis=1)
        if ok.any():  # R_w is triangular: back substitution by solve (one LAPACK call per matrix)
            v[ok, n:] = np.linalg.solve(Rw[ok], rhs[ok])[:, :, 0]
    res = np.linalg.norm(np.einsum("kij,kj->ki", Mb, v) - v, axis=1)
    vn = np.linalg.norm(v, axis=1)
    size = np.linalg.norm(Mb.reshape(k, -1), axis=1) * vn
    ok &= (res <= RIGID_ULPS * N * np.finfo(float).eps * size) & (vn > 0.0)  # NaN: not ok
    v[~ok] = 0.0
    return v, s, ok, Mb


def rigid_vectors(M: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The rigid-body eigenvectors of a stack of loop matrices (module docstring), found and
    checked in balanced coordinates (:func:`balancing`).

    Parameters
    ----------
    M : numpy.ndarray
        Loop matrices (k, N, N), the n plant states first (:func:`exotune.sampled.loop.loop_matrices`'s
        layout, or :class:`exotune.sampled.batch.BatchLoops`').
    x : numpy.ndarray
        The plant's rigid-body vector (n,) or one per matrix (k, n): 1 on the position states,
        0 on the velocities.

    Returns
    -------
    v : numpy.ndarray
        The vectors [x; w] (k, N), w the least-squares solution of (M − I)[x; w] = 0 (zero where
        not ``ok``).
    ok : numpy.ndarray
        (k,) bool: M v = v holds to rounding (a finite M, the columns of M − I after the plant's
        of full rank).
    """
    with np.errstate(all="ignore"):
        v, s, ok, _Mb = _vectors(M, x)
    return v * s, ok


def rigid_deflation(M: np.ndarray, x: np.ndarray):
    """The exact deflation of the rigid-body eigenvalue of a stack of loop matrices (module
    docstring): in the balanced coordinates of each matrix (:func:`balancing`), the last N − 1
    columns Q₂ of the Householder reflector H = I − 2uuᵀ/uᵀu, u = v̂ + sign(v̂₁)e₁, whose first
    column is −sign(v̂₁)v̂ (v̂ the unit rigid-body eigenvector, :func:`rigid_vectors`). Compiled
    with the compiled engine (:func:`exotune.numerics.kernels.rigid.rigid_deflation_stack`).

    Parameters
    ----------
    M : numpy.ndarray
        Loop matrices (k, N, N), the plant states first.
    x : numpy.ndarray
        The plant's rigid-body vector (n,) or (k, n).

    Returns
    -------
    ok : numpy.ndarray
        (k,) bool: the matrices whose rigid-body eigenvector checks (:func:`rigid_vectors`).
    s : numpy.ndarray
        The balancing scalings (m, N) of the ``ok`` matrices, in order.
    Q2 : numpy.ndarray
        Their bases (m, N, N − 1): Q₂ᵀQ₂ = I, Q₂ᵀv̂ = 0.
    deflated : numpy.ndarray
        Their deflated matrices (m, N − 1, N − 1), :func:`deflate` (M, s, Q₂) (the other
        eigenvalues).
    """
    from ..numerics.engine import compiled

    if compiled():
        from ..numerics.kernels.rigid import rigid_deflation_stack

        return rigid_deflation_stack(M, x, RIGID_ULPS)
    with np.errstate(all="ignore"):
        v, s, ok, Mb = _vectors(M, x)
    u = v[ok] / np.linalg.norm(v[ok], axis=1, keepdims=True)
    u[:, 0] += np.where(u[:, 0] >= 0.0, 1.0, -1.0)
    N = u.shape[1]
    H = np.eye(N) - (2.0 / np.sum(u * u, axis=1))[:, None, None] * (u[:, :, None] * u[:, None, :])
    Q2 = np.ascontiguousarray(H[:, :, 1:])
    return ok, s[ok], Q2, _project(Mb[ok], Q2)


def _project(Mb: np.ndarray, Q2: np.ndarray) -> np.ndarray:
    """Q₂ᵀ M_b Q₂ of a stack."""
    return np.ascontiguousarray(np.swapaxes(Q2, 1, 2)) @ (Mb @ Q2)


def deflate(M: np.ndarray, s: np.ndarray, Q2: np.ndarray) -> np.ndarray:
    """Q₂ᵀ D⁻¹ M D Q₂ of a stack (k, N, N) with the scalings and bases of :func:`rigid_deflation`:
    the loop matrices with their rigid-body eigenvalue taken out (module docstring). Compiled with
    the compiled engine (:func:`exotune.numerics.kernels.rigid.deflate_stack`: the projection of
    :func:`rigid_deflation`'s kernel, so the deflated matrix of a loop and its deflation by its basis
    are the same numbers on either engine).

    Parameters
    ----------
    M : numpy.ndarray
        Loop matrices (k, N, N).
    s : numpy.ndarray
        Scalings (k, N).
    Q2 : numpy.ndarray
        Bases (k, N, N − 1).

    Returns
    -------
    numpy.ndarray
        The deflated matrices (k, N − 1, N − 1).
    """
    from ..numerics.engine import compiled

    if compiled():
        from ..numerics.kernels.rigid import deflate_stack

        return deflate_stack(M, s, Q2)
    return _project(_balanced(np.asarray(M, dtype=float), s), Q2)
