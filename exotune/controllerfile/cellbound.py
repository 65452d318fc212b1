"""A proof that a whole cell [a, b] of a one-parameter family of sampled-data loops is stable
(docs/method.md#guarantees, docs/controller-file.md#certification): the rigorous acceptance test
behind :func:`exotune.controllerfile.continuation.stable_intervals`, whose step control only
proposes the cells.

The test (:func:`disc_test`) on a family written over the cell as a polynomial plus a bounded rest,

    M(s) = Σ_k δᵏ M_k + E(s),   δ = s − ½ ∈ [−½, ½],   E(s) = L Δ(s) R,  ‖Δ(s)‖₂ ≤ β,

works in the eigenvector coordinates of the (balanced) midpoint matrix M0 = V Λ V⁻¹: every
eigenvalue of M(s) lies in the union of the Gershgorin discs of D⁻¹V⁻¹M(s)VD for any positive
diagonal D. With F_k = V⁻¹M_kV, the entries of V⁻¹M(s)V are bounded by
P = max_{δ=±½}|F0 + δF1| + Σ_{k≥2} 2⁻ᵏ|F_k| + β·a bᵀ (a_i = ‖(V⁻¹L)_i‖, b_j = ‖(RV)_j‖; |F0 + δF1|
is convex in δ, so its ends bound it) plus a rounding allowance on the diagonal; with d the Perron
vector of P (the best scaling), max_i (Pd)_i/d_i < 1 puts every disc of every member inside the
open unit disk: M(s) is Schur stable for every s in the cell — a statement about each member, no
continuity argument, no sample inside the cell trusted. An eigenvalue whose eigenvector v
satisfies M(s)v = v for every s (the rigid-body z = 1 of an ungrounded structure) is deflated:
with Q = [v Q₂] orthogonal, M(s)Q = Q[[1, *], [0, Q₂ᵀM(s)Q₂]] for every s, and the test runs on
Q₂ᵀM(s)Q₂.

For the sampled-data loop (:func:`loop_cell`), s is the plant's own affine parameter: the plant
matrices of :func:`exotune.sampled.plant_ss` are affine in one monotone function g of the human
or environment parameter (it enters one or two rows as m⁻¹, (J_j + m)⁻¹, b, b⁻¹, k or
k/(K_c + k)), so over the cell A(p) = A(a) + s(p)·(A(b) − A(a)) and C(p) likewise with one
s ∈ [0, 1] (checked at the cell's midpoint: the **assumption** this module rests on). The loop
matrix is M(s) = M_ctrl(s) + U W(s) R(s) with W = [Φ Γ0 Γ1] the top rows of exp(N0 t0)·exp(N1 t1)
(augmented matrices of the plant, t0 = (1 − f)T_s, t1 = f T_s), U the plant rows and R(s), M_ctrl(s)
affine in s. The Taylor coefficients of M in s at s = ½ up to ``ORDER`` = 3 are exact (the first
block row of the exponential of a block-bidiagonal matrix, :func:`taylor_expm`); the remainder is
E(s) = ∫ (s − τ)³/3!·M⁗(τ) dτ with M⁗ = U(W⁗R(τ) + 4W‴R1), and in any fixed diagonal scaling D
‖dᵏ/dsᵏ exp(N(s)t)‖ ≤ (t‖D⁻¹ΔN D‖)ᵏ·exp(μ⁺t) (Dyson expansion; μ⁺ ≥ the logarithmic norm of
D⁻¹N(s)D over the cell, at most μ(N(½)) + ½‖D⁻¹ΔN D‖; Leibniz over the two exponentials) — a
proven bound, not a sample.

Floating-point rounding: the inexact inverse of the eigenvector matrix (the discs are those of
X M X⁻¹, exactly similar to M, bounded entry by entry through R_X = XV − I) and the rounding of the products
X M_k V (≤ 2γ_n|X||M_k||V|) are bounded; the rounding of the matrix exponentials that make the
loop matrix is **estimated** (:func:`exotune.sampled.loop.expm_rounding`: the exponential computed
again in balanced coordinates, plus 64u(1 + ‖X_b‖₁)·max|e^{X_b}|) and added to the remainder β — an
estimate, not a bound: a light human mass on the cuff spring makes ‖A T_s‖ ~1e8 and the
exponential's entries then carry absolute errors of ~1e-9 that can decide a near-undamped mode.
"""

from __future__ import annotations

import math

import numpy as np

from ..sampled.loop import expm_rounding, split_delay

__all__ = ["disc_test", "loop_cell", "taylor_expm", "ORDER", "AFFINE_RTOL"]

ORDER = 3  # Taylor terms of the loop matrix in s kept exactly; the next is bounded (Dyson)
AFFINE_RTOL = 1e-9  # the plant's affine form in s and the rigid eigenvector, checked to this relative size
RIGID_TOL = 1e-7  # an eigenvalue this close to z = 1 of an ungrounded loop is the rigid-body mode


def disc_test(coeffs, left=None, right=None, beta: float = 0.0, rigid=None) -> tuple[bool, float]:
    """Whether Σ_k δᵏ·coeffs[k] + left·Δ·right is Schur stable for every δ ∈ [−½, ½] and every Δ
    with ‖Δ‖₂ ≤ ``beta`` (Gershgorin discs in the eigenvector coordinates of M0 = coeffs[0],
    optimally scaled; module docstring).

    ``rigid``: a right eigenvector v of every member at z = 1 (M(s)v = v for all s, verified by
    the caller): its eigenvalue is deflated. Returns (proven, margin): margin = 1 − the largest
    |centre| + radius over the discs (≤ 0 when not proven; −inf when M0 is not diagonalizable
    in floating point).

    Parameters
    ----------
    coeffs : sequence of numpy.ndarray
        The matrix polynomial's coefficients M0, M1, … (N, N).
    left, right : numpy.ndarray or None, optional
        Factors of the remainder term (N, r) and (r, N); None for the identity.
    beta : float, optional
        Bound of ‖Δ‖₂ (0: no remainder).
    rigid : numpy.ndarray or None, optional
        Common eigenvector at z = 1 to deflate; None for none.

    Returns
    -------
    proven : bool
        Whether stability is proven.
    margin : float
        1 − the largest |centre| + radius.
    """
    Ms = [np.asarray(c, dtype=float) for c in coeffs]
    M0 = Ms[0]
    left = np.eye(M0.shape[0]) if left is None else np.asarray(left, dtype=float)
    right = np.eye(M0.shape[0]) if right is None else np.asarray(right, dtype=float)
    if rigid is not None:  # M(s)Q = Q [[1, *], [0, Q₂ᵀM(s)Q₂]] for Q = [v Q₂] orthogonal, every s
        v = np.asarray(rigid, dtype=float)
        Q, _ = np.linalg.qr(np.column_stack([v / np.linalg.norm(v), np.eye(v.size)]))
        Q2 = Q[:, 1:v.size]
        Ms, left, right = [Q2.T @ c @ Q2 for c in Ms], Q2.T @ left, right @ Q2
        M0 = Ms[0]
    n = M0.shape[0]
    if n == 0:
        return True, 1.0
    from scipy.linalg import matrix_balance

    _, (sc, _) = matrix_balance(M0, permute=False, separate=True)
    sc = np.asarray(sc, dtype=float)
    Ms = [c * sc[None, :] / sc[:, None] for c in Ms]
    M0 = Ms[0]
    left, right = left / sc[:, None], right * sc[None, :]
    lam, V = np.linalg.eig(M0)
    V = V / np.linalg.norm(V, axis=0)
    try:
        X = np.linalg.inv(V)
    except np.linalg.LinAlgError:
        return False, -math.inf
    if not (np.all(np.isfinite(X)) and np.all(np.isfinite(V))):
        # a defective M0 (e.g. chains of identity sections: nilpotent blocks at z = 0) has no
        # usable eigenvector basis: the cell is not proven (never an exception)
        return False, -math.inf
    # X is V⁻¹ only to rounding: the discs are those of G(s) = X M(s) X⁻¹ (similar to M(s) for any
    # invertible X) = F(s)(I + R_X)⁻¹, F = X M V, R_X = XV − I: |G| ≤ |F|(I + |R_X| + r²/(1 − r)·𝟙𝟙ᵀ)
    # entry by entry (r ≥ ‖|R_X|‖₂); the products X M_k V carry rounding ≤ 2γ_n|X||M_k||V|
    eps = np.finfo(float).eps
    gam = 2.0 * n * eps / (1.0 - n * eps)
    aX, aV = np.abs(X), np.abs(V)
    RX = np.abs(X @ V - np.eye(n)) + gam * (aX @ aV)
    if not np.all(np.isfinite(RX)):
        return False, -math.inf
    try:
        r = float(np.linalg.norm(RX, 2))
    except np.linalg.LinAlgError:  # the SVD did not converge: nothing is proven
        return False, -math.inf
    if not math.isfinite(r) or r >= 0.5:
        return False, -math.inf
    F = [X @ c @ V for c in Ms] + [np.zeros((n, n))]
    # |entries| of F(s) over the cell: |F0 + δF1| ≤ the larger of its ends (convex in δ; any fixed
    # scaling keeps the row sums convex), |δᵏF_k| ≤ 2⁻ᵏ|F_k|, the remainder's entries by β·a_i·b_j,
    # the products' rounding
    P = np.maximum(np.abs(F[0] - 0.5 * F[1]), np.abs(F[0] + 0.5 * F[1]))
    for k, (Mk, Fk) in enumerate(zip(Ms, F)):
        P += 0.5 ** k * (gam * (aX @ np.abs(Mk) @ aV) + (np.abs(Fk) if k >= 2 else 0.0))
    if beta > 0.0:
        P += beta * np.outer(np.linalg.norm(X @ left, axis=1), np.linalg.norm(right @ V, axis=0))
    P = P + P @ RX + (np.sum(P, axis=1) * r * r / (1.0 - r))[:, None]
    # Gershgorin discs of D⁻¹(V⁻¹M(s)V)D, D = diag(d): d from the Perron vector of P (the best
    # diagonal scaling), then checked as it is — row sums of D⁻¹PD below 1 prove every disc inside
    d = _perron(P)
    worst = float(np.max((P @ d) / d))
    return worst < 1.0, 1.0 - worst


def _perron(P: np.ndarray) -> np.ndarray:
    """A positive vector d for which max_i (P d)_i / d_i is near ρ(P) (P ≥ 0): the Perron vector
    of P made irreducible by a tiny positive shift; any positive d is a valid scaling, this one is
    nearly the best."""
    Q = P + 1e-12 * max(float(np.max(P)), 1e-300)
    w, V = np.linalg.eig(Q)
    d = np.abs(V[:, int(np.argmax(w.real))])
    return np.maximum(d, 1e-300 + 1e-15 * float(np.max(d)))


def _layout(ctrl, n: int, C: np.ndarray):
    """(t0, t1, d, R) of :func:`exotune.sampled.loop.closed_loop_matrix`'s layout: the loop state
    [x; z; τ_cmd[k−1] … τ_cmd[k−d−1]], plant rows W·R with W = [Φ Γ0 Γ1] and
    R = [[I 0 0]; τ_cmd[k−d]; τ_cmd[k−d−1]] (checked against the matrix by the caller)."""
    Ts = 1.0 / ctrl.sample_rate_hz
    d, f = split_delay(ctrl.delay_s, Ts)
    nz = ctrl.Ac.shape[0]
    N = n + nz + d + 1
    s0 = n + nz
    u = np.zeros(N)
    u[:n] = (ctrl.Dc @ C).reshape(-1)
    u[n:n + nz] = ctrl.Cc.reshape(-1)
    R = np.zeros((n + 2, N))
    R[:n, :n] = np.eye(n)
    R[n] = u if d == 0 else np.eye(N)[s0 + d - 1]
    R[n + 1, s0 + d] = 1.0
    return (1.0 - f) * Ts, f * Ts, d, R


def _augmented(A, B, col: int) -> np.ndarray:
    n = A.shape[0]
    Na = np.zeros((n + 2, n + 2))
    Na[:n, :n] = A
    Na[:n, n + col] = B[:, 0]
    return Na


def _lognorm(X: np.ndarray) -> float:
    """Logarithmic 2-norm: the largest eigenvalue of the symmetric part."""
    return float(np.max(np.linalg.eigvalsh(0.5 * (X + X.T))))


def taylor_expm(Na: np.ndarray, dN: np.ndarray, t: float, order: int) -> list:
    """Taylor coefficients c_k = (1/k!) dᵏ/dsᵏ exp((Na + s·dN) t) at s = 0, k = 0 … order: the
    first block row of the exponential of the block-bidiagonal matrix with Na·t on the diagonal
    and dN·t above it (the Dyson series of each block is exactly that coefficient).

    Parameters
    ----------
    Na : numpy.ndarray
        The matrix at s = 0 (m, m).
    dN : numpy.ndarray
        Its derivative in s (m, m).
    t : float
        The time [s] (a sample period or a part of it).
    order : int
        Highest coefficient K.

    Returns
    -------
    list of numpy.ndarray
        c_0, …, c_K, each (m, m).
    """
    return _taylor_with_rounding(Na, dN, t, order)[0]


def _taylor_with_rounding(Na: np.ndarray, dN: np.ndarray, t: float, order: int):
    """(:func:`taylor_expm`'s coefficients, their rounding estimates entry by entry,
    :func:`exotune.sampled.loop.expm_rounding` of the block-bidiagonal exponential)."""
    from scipy.linalg import expm

    m = Na.shape[0]
    if t == 0.0:
        return [np.eye(m)] + [np.zeros((m, m))] * order, [np.zeros((m, m))] * (order + 1)
    K = order + 1
    big = np.zeros((K * m, K * m))
    for k in range(K):
        big[k * m:(k + 1) * m, k * m:(k + 1) * m] = Na * t
        if k + 1 < K:
            big[k * m:(k + 1) * m, (k + 1) * m:(k + 2) * m] = dN * t
    E = expm(big)
    err = expm_rounding(big, E)
    return [E[:m, k * m:(k + 1) * m] for k in range(K)], [err[:m, k * m:(k + 1) * m] for k in range(K)]


def _plant_terms(A, B, dA, t0: float, t1: float):
    """Taylor coefficients (in δ = s − ½, up to ``ORDER``) of W(s) = top rows of
    exp(N0(s) t0)·exp(N1(s) t1) at the cell's midpoint, the diagonal scaling D (of the augmented
    plant) and the Dyson bounds g ≥ sup‖D⁻¹exp(N(s)τ)D‖ (τ ≤ T_s, s in the cell) and
    h = T_s‖D⁻¹ΔN D‖: ‖D⁻¹W⁽ᵏ⁾(s)D‖ ≤ hᵏ·g for every s in the cell (Leibniz over the two factors)."""
    from scipy.linalg import matrix_balance

    n = A.shape[0]
    N0, N1 = _augmented(A, B, 0), _augmented(A, B, 1)
    dN = np.zeros((n + 2, n + 2))
    dN[:n, :n] = dA
    both = N0.copy()
    both[:n, n + 1] = B[:, 0]
    _, (sc, _) = matrix_balance(both, permute=False, separate=True)
    sc = np.asarray(sc, dtype=float)
    if not np.all(np.isfinite(sc) & (sc > 0)):
        sc = np.ones(n + 2)
    scale = lambda X: X * sc[None, :] / sc[:, None]  # noqa: E731  (D⁻¹ X D)
    nd = float(np.linalg.norm(scale(dN), 2))
    # ‖D⁻¹e^{N(s)τ}D‖ ≤ e^{μ⁺τ}, μ(N(s)) ≤ μ(N(½)) + ½‖D⁻¹ΔN D‖ (subadditive logarithmic norm)
    g = math.exp(max(max(_lognorm(scale(N0)), _lognorm(scale(N1))) + 0.5 * nd, 0.0) * (t0 + t1))
    (c0, e0), (c1, e1) = _taylor_with_rounding(N0, dN, t0, ORDER), _taylor_with_rounding(N1, dN, t1, ORDER)
    W = [sum(c0[j] @ c1[k - j] for j in range(k + 1))[:n] for k in range(ORDER + 1)]  # Cauchy product
    # the exponentials' rounding carried through the products, to first order, entry by entry
    dW = [sum(e0[j] @ np.abs(c1[k - j]) + np.abs(c0[j]) @ e1[k - j] for j in range(k + 1))[:n]
          for k in range(ORDER + 1)]
    return W, dW, sc, g, (t0 + t1) * nd


def loop_cell(plant, ctrl, grounded: bool, member, a: float, b: float, m: float) -> tuple[bool, float]:
    """Whether every loop of the family on [a, b] is Schur stable (proven by :func:`disc_test`
    on the loop's affine parameter s; module docstring). ``member(v)`` → (human, env) for
    :func:`exotune.sampled.plant_ss`; ``m`` a value inside the cell where the affine form is
    checked. Returns (proven, margin); not proven (margin −inf) when the plant is not affine in
    one parameter over the cell, the state count changes, or the rigid mode cannot be deflated.

    Parameters
    ----------
    plant : Plant
        The file's plant.
    ctrl : DiscreteController
        The file's controller.
    grounded : bool
        Whether the controller feeds back the motor position.
    member : callable
        ``member(v)`` → ``(human, env)`` of the family member of value ``v``.
    a, b : float
        The cell, in the family parameter's unit.
    m : float
        A value inside the cell.

    Returns
    -------
    proven : bool
        Whether every member of the cell is proven stable.
    margin : float
        The proof's margin (−inf when not proven).
    """
    from ..sampled.loop import closed_loop_matrix, plant_ss

    (Aa, Ba, Ca), (Ab, Bb, Cb), (Am, Bm, Cm) = (plant_ss(plant, *member(v)) for v in (a, b, m))
    if not (Aa.shape == Ab.shape == Am.shape and np.array_equal(Ba, Bb) and np.array_equal(Ba, Bm)):
        return False, -math.inf
    dA, dC = Ab - Aa, Cb - Ca
    scale2 = float(np.sum(dA * dA) + np.sum(dC * dC))
    size = max(float(np.linalg.norm(np.hstack([Aa.ravel(), Ca.ravel()]))), 1.0)
    if scale2 > 0.0:  # the affine form at m: [A, C](m) − [A, C](a) = s_m·Δ with one s_m ∈ [0, 1]
        s_m = float(np.sum((Am - Aa) * dA) + np.sum((Cm - Ca) * dC)) / scale2
        res = max(float(np.max(np.abs(Am - Aa - s_m * dA))), float(np.max(np.abs(Cm - Ca - s_m * dC))))
        if not (-1e-12 <= s_m <= 1 + 1e-12) or res > AFFINE_RTOL * size:
            return False, -math.inf
    A, B, C = Aa + 0.5 * dA, Ba, Ca + 0.5 * dC
    n = A.shape[0]
    M0 = closed_loop_matrix(A, B, C, ctrl)
    t0, t1, d, R = _layout(ctrl, n, C)
    W, dW, sc, g, h = _plant_terms(A, B, dA, t0, t1)
    if np.max(np.abs(M0[:n] - W[0] @ R)) > AFFINE_RTOL * max(float(np.max(np.abs(M0))), 1.0):
        return False, -math.inf  # the loop's layout is not the one this module knows
    nz = ctrl.Ac.shape[0]
    R1 = np.zeros_like(R)  # R(s) = R + δ·R1: the command row holds D_c C(s) x when d = 0
    if d == 0:
        R1[n, :n] = (ctrl.Dc @ dC).reshape(-1)
    coeffs = [M0]
    for k in range(1, ORDER + 1):  # (W R)_k = W_k R + W_{k−1} R1; the controller rows are affine in C
        Mk = np.zeros_like(M0)
        Mk[:n] = W[k] @ R + W[k - 1] @ R1
        if k == 1:
            Mk[n:n + nz, :n] = ctrl.Bc @ dC
            Mk[n + nz, :n] = (ctrl.Dc @ dC).reshape(-1)
        coeffs.append(Mk)
    # remainder E = ∫_{½}^{s} (s − τ)^K/K!·M^(K+1)(τ) dτ, M^(K+1) = U(W^(K+1) R(τ) + (K+1) W^(K) R1):
    # E = (U D_x)·[Δa, Δb]·[D⁻¹R; D⁻¹R1] with ‖Δa‖ ≤ ρ h^(K+1), ‖Δb‖ ≤ ρ(½h^(K+1) + (K+1)h^K),
    # ρ = g·2^-(K+1)/(K+1)! (|s − ½| ≤ ½)
    K = ORDER
    rho = g * 0.5 ** (K + 1) / math.factorial(K + 1)
    N = M0.shape[0]
    left = np.zeros((N, n))
    left[:n, :n] = np.diag(sc[:n])
    right, beta = R / sc[:, None], rho * h ** (K + 1)
    # the rounding of the exponentials (estimated, :func:`exotune.sampled.loop.expm_rounding`): the
    # plant rows' terms δᵏ(δW_k R + δW_{k−1} R1), |δ| ≤ ½, are (U D_x)·Δ·(D⁻¹R) and (U D_x)·Δ'·(D⁻¹R1)
    # with ‖Δ‖₂ ≤ Σ_k 2⁻ᵏ‖D_x⁻¹ δW_k D‖_F (and Δ' alike from δW_{k−1})
    scaled = [float(np.linalg.norm(e * sc[None, :] / sc[:n, None])) for e in dW]
    beta += sum(0.5 ** k * x for k, x in enumerate(scaled))
    if np.any(R1):
        right = np.vstack([right, R1 / sc[:, None]])
        beta += rho * (0.5 * h ** (K + 1) + (K + 1) * h ** K)
        beta += sum(0.5 ** k * scaled[k - 1] for k in range(1, K + 1))
    rigid = None
    if not (grounded or any(_grounds(*member(v)) for v in (a, b))):
        rigid = _rigid_vector(M0, ctrl, closed_loop_matrix, (Aa, Ba, Ca), (Ab, Bb, Cb))
        if rigid is False:
            return False, -math.inf
    return disc_test(coeffs, left, right, beta, rigid)


def _grounds(human, env) -> bool:
    """Whether a member's human or environment grounds the structure (as
    :func:`exotune.sampled.loop_eigenvalues` decides: locked, or a stiffness)."""
    return (env == "locked" or (isinstance(env, dict) and env.get("stiffness", 0.0) > 0)
            or (human is not None and human.get("stiffness", 0.0) > 0))


def _rigid_vector(M0, ctrl, closed_loop_matrix, ends_a, ends_b):
    """The rigid-body eigenvector v of an ungrounded loop (eigenvalue within ``RIGID_TOL`` of 1),
    verified to be an eigenvector of every member: A(s)x_v = 0 and the command columns of R(s)
    vanish on v at both ends (both affine in s, so for every s: then Φ(s)x_v = x_v), and
    M(s)v = v at both ends (the controller rows are affine in s). None: no such eigenvalue
    (nothing to deflate); False: one near 1 that is not parameter-independent."""
    lam, V = np.linalg.eig(M0)
    k = int(np.argmin(np.abs(lam - 1.0)))
    if abs(lam[k] - 1.0) > RIGID_TOL:
        return None
    v = np.real_if_close(V[:, k])
    if np.iscomplexobj(v):
        return False
    v = v / np.linalg.norm(v)
    n = ends_a[0].shape[0]
    for A_, B_, C_ in (ends_a, ends_b):
        M = closed_loop_matrix(A_, B_, C_, ctrl)
        tol = AFFINE_RTOL * max(float(np.linalg.norm(M, 2)), 1.0)
        _, _, _, Re = _layout(ctrl, n, C_)
        if (np.linalg.norm(A_ @ v[:n]) > tol or np.max(np.abs(Re[n:] @ v)) > tol
                or np.linalg.norm(M @ v - v) > tol):
            return False
    return v
