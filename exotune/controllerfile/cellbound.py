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
satisfies M(s)v = v for every s (the rigid-body z = 1 of an ungrounded structure, v built from
the structure: :mod:`exotune.sampled.rigid`) is deflated:
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

Stiff members (a damped human spring: the pole −(K_c + k)/b far beyond 1/T_s). The Dyson factor
hᵏ integrates the parameter's derivative over the whole sample, while the stiff state forgets it
within b/(K_c + k): the true coefficients fall like (h·b/((K_c + k)T_s))ᵏ, so β is far above
the true remainder, and two more losses meet there: the stiff pole e^{−(K_c + k)T_s/b} near
z = 0 crosses controller poles, and two nearly equal eigenvalues of M0 have nearly parallel
eigenvectors — V⁻¹ and the discs β·a_i·b_j (not the exact polynomial terms) grow by 1e8 and more.
Hence two second attempts when the first fails: (1) :func:`disc_test` tries bases in which each
cluster of close, ill-conditioned eigenvalues shares an orthonormal basis of its invariant
subspace (a triangular block the Perron scaling weighs, :func:`_bases`) — when the test without
β passes in the eigenvector basis, or that basis is severely ill-conditioned; (2) :func:`loop_cell`
recomputes the Taylor model at a higher order K ≤ ``MAX_ORDER`` (the same exact coefficients and
Dyson remainder, now ∝ h^(K+1)/(K+1)!) when the test without β passed in a basis tried. Both are
the same proof in another basis or at another order, no new assumption; the screens only save
work.

Floating-point rounding: the inexact inverse of the basis matrix (the discs are those of
X M X⁻¹, exactly similar to M, bounded entry by entry through R_X = XV − I) and the rounding of
the products X M_k V (≤ γ_{4n+4}|X||M_k||V|, complex V included) are bounded; the rounding of the
matrix exponentials that make the loop matrix is **estimated**
(:func:`exotune.sampled.loop.expm_rounding`: the exponential computed
again in balanced coordinates, plus 64u(1 + ‖X_b‖₁)·max|e^{X_b}|) and added to the remainder β — an
estimate, not a bound: a light human mass on the cuff spring makes ‖A T_s‖ ~1e8 and the
exponential's entries then carry absolute errors of ~1e-9 that can decide a near-undamped mode.
"""

from __future__ import annotations

import math

import numpy as np

from ..sampled.loop import expm_rounding, split_delay
from ..sampled.rigid import rigid_vectors

__all__ = ["disc_test", "loop_cell", "taylor_expm", "ORDER", "AFFINE_RTOL"]

ORDER = 3  # Taylor terms of the loop matrix in s kept exactly; the next is bounded (Dyson)
MAX_ORDER = 12  # the order of a second attempt on a cell ORDER did not prove (loop_cell), at most
AFFINE_RTOL = 1e-9  # the plant's affine form in s and the rigid eigenvector, checked to this relative size
RIGID_TOL = 1e-7  # no structural eigenvector: an eigenvalue this close to z = 1 (ungrounded) is the rigid mode


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
    return _disc_test(coeffs, left, right, beta, rigid)[:2]


def _disc_test(coeffs, left, right, beta: float, rigid) -> tuple[bool, float, bool]:
    """:func:`disc_test`, and ``free``: whether the test without the remainder (β = 0) passed in
    a basis tried. When it did not, a smaller β from a higher Taylor order is not worth its cost
    (:func:`loop_cell`): in the same basis the polynomial part's entry bounds only grow with
    more terms. A screen for work, never part of a proof."""
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
        return True, 1.0, True
    from scipy.linalg import matrix_balance

    _, (sc, _) = matrix_balance(M0, permute=False, separate=True)
    sc = np.asarray(sc, dtype=float)
    Ms = [c * sc[None, :] / sc[:, None] for c in Ms]
    M0 = Ms[0]
    left, right = left / sc[:, None], right * sc[None, :]
    lam, V = np.linalg.eig(M0)
    V = V / np.linalg.norm(V, axis=0)
    try:  # the eigenvalues' condition numbers ‖(V⁻¹)_i‖ (unit columns); NaN: V is unusable
        kappa = np.linalg.norm(np.linalg.inv(V), axis=1)
    except np.linalg.LinAlgError:
        kappa = np.full(n, np.nan)
    best, free = -math.inf, False
    for basis in _bases(M0, lam, V, kappa):  # the eigenvectors first; clusters merged only if they fail
        proven, margin, margin_free = _discs(Ms, left, right, beta, basis)
        if proven:
            return proven, margin, True
        free = free or margin_free > 0.0
        best = max(best, margin)
        if (n > CLUSTER_MAX_STATES or not np.all(np.isfinite(kappa))
                or not (free or np.max(kappa) > SEVERE_KAPPA)):
            # no other basis is tried for a big loop (bounded work: a Schur form per cluster), a
            # defective M0 (as before), or when neither the remainder nor a severely
            # ill-conditioned basis is what fails (a cell too wide for its polynomial part)
            return False, best, free
    return False, best, free


CLUSTER_TOLS = (1e-6, 1e-4, 1e-2, 1e-1)  # distances at which close eigenvalues of M0 share a block (_bases)
CLUSTER_KAPPA = 1e3  # ... when both their eigenvalue condition numbers exceed this
CLUSTER_MAX_STATES = 60  # loops with more states try the eigenvector basis only
SEVERE_KAPPA = 1e6  # the merged bases are tried even when the test without β fails, above this condition number


def _bases(M0: np.ndarray, lam: np.ndarray, V: np.ndarray, kappa: np.ndarray):
    """Candidate bases V for :func:`disc_test` (any invertible V is valid: the discs are those of
    a matrix similar to M(s), and :func:`_discs` bounds X ≈ V⁻¹'s inexactness): the unit
    eigenvectors of M0, then for each tolerance of ``CLUSTER_TOLS`` that merges eigenvalues
    (single linkage, |λ_i − λ_j| ≤ tol, both condition numbers above ``CLUSTER_KAPPA``) the same
    with each merged cluster's columns replaced by an orthonormal basis of its invariant subspace
    (a sorted complex Schur form). Two nearly equal eigenvalues (a stiff human pole
    e^{−(K_c + k)T_s/b} crossing a controller pole near z = 0) have nearly parallel eigenvectors:
    V⁻¹ is then huge and the remainder's discs β·a_i·b_j with it, while in an orthonormal basis
    of their joint subspace the block stays triangular and bounded (its off-diagonal entry is
    weighed by the Perron scaling).

    Parameters
    ----------
    M0 : numpy.ndarray
        The (balanced) midpoint matrix (n, n).
    lam, V : numpy.ndarray
        Its eigenvalues (n,) and unit eigenvectors (n, n).
    kappa : numpy.ndarray
        The eigenvalues' condition numbers ‖(V⁻¹)_i‖ (n,).

    Returns
    -------
    generator of numpy.ndarray
        The bases (n, n), V first.
    """
    from scipy.linalg import schur
    from scipy.sparse.csgraph import connected_components

    yield V
    ill = kappa > CLUSTER_KAPPA  # only ill-conditioned eigenvalues merge
    seen = set()
    for tol in CLUSTER_TOLS:
        close = (np.abs(lam[:, None] - lam[None, :]) <= tol) & ill[:, None] & ill[None, :]
        k, labels = connected_components(close | np.eye(lam.size, dtype=bool), directed=False)
        key = tuple(labels)
        if k == lam.size or key in seen:
            continue
        seen.add(key)
        B = V.astype(complex)
        for c in range(k):
            idx = np.flatnonzero(labels == c)
            if idx.size < 2:
                continue
            try:
                _, Z, sdim = schur(M0.astype(complex), output="complex",
                                   sort=lambda x, ev=lam[idx], t=0.5 * tol: bool(np.min(np.abs(x - ev)) <= t))
            except (np.linalg.LinAlgError, ValueError):
                sdim = -1
            # the leading sdim Schur vectors span the invariant subspace of the selected eigenvalues;
            # when the reordering did not select exactly the cluster, the eigenvectors' own span (QR)
            B[:, idx] = Z[:, :idx.size] if sdim == idx.size else np.linalg.qr(V[:, idx])[0]
        yield B


def _discs(Ms: list, left: np.ndarray, right: np.ndarray, beta: float, V: np.ndarray) -> tuple[bool, float, float]:
    """:func:`disc_test` in the basis V (columns of unit norm, invertible): (proven, margin,
    margin without the remainder term — computed only when not proven, else the margin), margins
    −inf when V is not usable."""
    n = V.shape[0]
    try:
        X = np.linalg.inv(V)
    except np.linalg.LinAlgError:
        return False, -math.inf, -math.inf
    if not (np.all(np.isfinite(X)) and np.all(np.isfinite(V))):
        # a defective M0 (e.g. chains of identity sections: nilpotent blocks at z = 0) has no
        # usable eigenvector basis: the cell is not proven (never an exception)
        return False, -math.inf, -math.inf
    # X is V⁻¹ only to rounding: the discs are those of G(s) = X M(s) X⁻¹ (similar to M(s) for any
    # invertible X) = F(s)(I + R_X)⁻¹, F = X M V, R_X = XV − I: |G| ≤ |F|(I + |R_X| + r²/(1 − r)·𝟙𝟙ᵀ)
    # entry by entry (r ≥ ‖|R_X|‖₂); the products X M_k V carry rounding ≤ γ_{4n+4}|X||M_k||V|
    # (γ_k = kε/(1 − kε)): X M_k, complex by real, is two real inner products (errors ≤ γ_n each
    # in the real and imaginary parts, so ≤ √2·γ_n ≤ γ_{2n} in modulus); by a complex V the
    # complex inner products add ≤ √2·γ_{n+2} ≤ γ_{2n+4} (Higham, Accuracy and Stability of
    # Numerical Algorithms, §3.6); γ_a + γ_b + γ_a·γ_b ≤ γ_{a+b}. The computed X V likewise
    # ≤ γ_{2n+4}|X||V| (real V: γ_n)
    eps = np.finfo(float).eps
    gam = (4 * n + 4) * eps / (1.0 - (4 * n + 4) * eps)
    aX, aV = np.abs(X), np.abs(V)
    RX = np.abs(X @ V - np.eye(n)) + gam * (aX @ aV)
    if not np.all(np.isfinite(RX)):
        return False, -math.inf, -math.inf
    try:
        r = float(np.linalg.norm(RX, 2))
    except np.linalg.LinAlgError:  # the SVD did not converge: nothing is proven
        return False, -math.inf, -math.inf
    if not math.isfinite(r) or r >= 0.5:
        return False, -math.inf, -math.inf
    F = [X @ c @ V for c in Ms] + [np.zeros((n, n))]
    # |entries| of F(s) over the cell: |F0 + δF1| ≤ the larger of its ends (convex in δ; any fixed
    # scaling keeps the row sums convex), |δᵏF_k| ≤ 2⁻ᵏ|F_k|, the remainder's entries by β·a_i·b_j,
    # the products' rounding
    P = np.maximum(np.abs(F[0] - 0.5 * F[1]), np.abs(F[0] + 0.5 * F[1]))
    for k, (Mk, Fk) in enumerate(zip(Ms, F)):
        P += 0.5 ** k * (gam * (aX @ np.abs(Mk) @ aV) + (np.abs(Fk) if k >= 2 else 0.0))
    P0 = P
    if beta > 0.0:
        P = P + beta * np.outer(np.linalg.norm(X @ left, axis=1), np.linalg.norm(right @ V, axis=0))
    worst = _worst(P, RX, r)
    return worst < 1.0, 1.0 - worst, (1.0 - worst if worst < 1.0 or P0 is P else 1.0 - _worst(P0, RX, r))


def _worst(P: np.ndarray, RX: np.ndarray, r: float) -> float:
    """The largest row sum of D⁻¹|G|D (module docstring) from the entry bound P of |F(s)|."""
    P = P + P @ RX + (np.sum(P, axis=1) * r * r / (1.0 - r))[:, None]
    # Gershgorin discs of D⁻¹(V⁻¹M(s)V)D, D = diag(d): d from the Perron vector of P (the best
    # diagonal scaling), then checked as it is — row sums of D⁻¹PD below 1 prove every disc inside
    d = _perron(P)
    return float(np.max((P @ d) / d))


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


def _plant_terms(A, B, dA, t0: float, t1: float, order: int = ORDER):
    """Taylor coefficients (in δ = s − ½, up to ``order``) of W(s) = top rows of
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
    (c0, e0), (c1, e1) = _taylor_with_rounding(N0, dN, t0, order), _taylor_with_rounding(N1, dN, t1, order)
    W = [sum(c0[j] @ c1[k - j] for j in range(k + 1))[:n] for k in range(order + 1)]  # Cauchy product
    # the exponentials' rounding carried through the products, to first order, entry by entry
    dW = [sum(e0[j] @ np.abs(c1[k - j]) + np.abs(c0[j]) @ e1[k - j] for j in range(k + 1))[:n]
          for k in range(order + 1)]
    return W, dW, sc, g, (t0 + t1) * nd


def _dyson(g: float, h: float, order: int, r1: bool) -> float:
    """The bound β of the Taylor remainder's Δ (:func:`_cell_terms`) at ``order`` K: with
    ρ = g·2^-(K+1)/(K+1)!, ρh^(K+1) for the term W^(K+1)R(τ), plus ρ(½h^(K+1) + (K+1)h^K) for
    (K+1)W^(K)R1 when R depends on s (``r1``)."""
    rho = g * 0.5 ** (order + 1) / math.factorial(order + 1)
    return rho * h ** (order + 1) + (rho * (0.5 * h ** (order + 1) + (order + 1) * h ** order) if r1 else 0.0)


def _cell_terms(A, B, C, dA, dC, ctrl, M0, order: int):
    """The loop matrix over the cell for :func:`disc_test` at Taylor order ``order`` K:
    (coeffs, left, right, g, h, r1, β_round) — the exact coefficients M_0 … M_K in δ = s − ½, the
    remainder's factors (its bound is :func:`_dyson` (g, h, K, r1) + β_round, the exponentials'
    rounding estimate) — or None when the loop's layout is not the one this module knows."""
    n = A.shape[0]
    t0, t1, d, R = _layout(ctrl, n, C)
    W, dW, sc, g, h = _plant_terms(A, B, dA, t0, t1, order)
    if np.max(np.abs(M0[:n] - W[0] @ R)) > AFFINE_RTOL * max(float(np.max(np.abs(M0))), 1.0):
        return None  # the loop's layout is not the one this module knows
    nz = ctrl.Ac.shape[0]
    R1 = np.zeros_like(R)  # R(s) = R + δ·R1: the command row holds D_c C(s) x when d = 0
    if d == 0:
        R1[n, :n] = (ctrl.Dc @ dC).reshape(-1)
    coeffs = [M0]
    for k in range(1, order + 1):  # (W R)_k = W_k R + W_{k−1} R1; the controller rows are affine in C
        Mk = np.zeros_like(M0)
        Mk[:n] = W[k] @ R + W[k - 1] @ R1
        if k == 1:
            Mk[n:n + nz, :n] = ctrl.Bc @ dC
            Mk[n + nz, :n] = (ctrl.Dc @ dC).reshape(-1)
        coeffs.append(Mk)
    # remainder E = ∫_{½}^{s} (s − τ)^K/K!·M^(K+1)(τ) dτ, M^(K+1) = U(W^(K+1) R(τ) + (K+1) W^(K) R1):
    # E = (U D_x)·[Δa, Δb]·[D⁻¹R; D⁻¹R1] with ‖Δa‖ ≤ ρ h^(K+1), ‖Δb‖ ≤ ρ(½h^(K+1) + (K+1)h^K),
    # ρ = g·2^-(K+1)/(K+1)! (|s − ½| ≤ ½): :func:`_dyson`
    N = M0.shape[0]
    left = np.zeros((N, n))
    left[:n, :n] = np.diag(sc[:n])
    right = R / sc[:, None]
    # the rounding of the exponentials (estimated, :func:`exotune.sampled.loop.expm_rounding`): the
    # plant rows' terms δᵏ(δW_k R + δW_{k−1} R1), |δ| ≤ ½, are (U D_x)·Δ·(D⁻¹R) and (U D_x)·Δ'·(D⁻¹R1)
    # with ‖Δ‖₂ ≤ Σ_k 2⁻ᵏ‖D_x⁻¹ δW_k D‖_F (and Δ' alike from δW_{k−1})
    scaled = [float(np.linalg.norm(e * sc[None, :] / sc[:n, None])) for e in dW]
    rnd = sum(0.5 ** k * x for k, x in enumerate(scaled))
    r1 = bool(np.any(R1))
    if r1:
        right = np.vstack([right, R1 / sc[:, None]])
        rnd += sum(0.5 ** k * scaled[k - 1] for k in range(1, order + 1))
    return coeffs, left, right, g, h, r1, rnd


def _retry_order(g: float, h: float, r1: bool, rnd: float):
    """The Taylor order of the second attempt on a cell whose proof at ``ORDER`` failed: the
    smallest K ≤ ``MAX_ORDER`` whose Dyson remainder is below the rounding estimate β_round (else
    ``MAX_ORDER``), or None when no higher order lowers the remainder below its value at ``ORDER``."""
    base = _dyson(g, h, ORDER, r1)
    for K in range(ORDER + 1, MAX_ORDER + 1):
        if _dyson(g, h, K, r1) <= rnd:
            return K
    return MAX_ORDER if _dyson(g, h, MAX_ORDER, r1) < 1e-3 * base else None


def loop_cell(plant, ctrl, grounded: bool, member, a: float, b: float, m: float) -> tuple[bool, float]:
    """Whether every loop of the family on [a, b] is Schur stable (proven by :func:`disc_test`
    on the loop's affine parameter s; module docstring). ``member(v)`` → (human, env) for
    :func:`exotune.sampled.plant_ss`; ``m`` a value inside the cell where the affine form is
    checked. Returns (proven, margin); not proven (margin −inf) when the plant is not affine in
    one parameter over the cell, the state count changes, or the rigid mode cannot be deflated.
    The Taylor model has order ``ORDER``; a cell it does not prove is tried once more at a higher
    order (:func:`_retry_order`) when the remainder is what the proof lacks (a stiff damped human:
    the Dyson bound's hᵏ far above the true coefficients; docs/method.md#guarantees).

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

    References
    ----------
    docs/method.md#guarantees.
    """
    from ..sampled.loop import closed_loop_matrix, plant_ss, plant_structure, rigid_plant_vector

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
    M0 = closed_loop_matrix(A, B, C, ctrl)
    terms = _cell_terms(A, B, C, dA, dC, ctrl, M0, ORDER)
    if terms is None:
        return False, -math.inf
    rigid = None
    if not (grounded or any(_grounds(*member(v)) for v in (a, b))):
        x = rigid_plant_vector(plant_structure(*member(m)))
        rigid = _rigid_vector(M0, ctrl, closed_loop_matrix, (Aa, Ba, Ca), (Ab, Bb, Cb), x)
        if rigid is False:
            return False, -math.inf
    coeffs, left, right, g, h, r1, rnd = terms
    proven, margin, free = _disc_test(coeffs, left, right, _dyson(g, h, ORDER, r1) + rnd, rigid)
    K = None if proven or not free else _retry_order(g, h, r1, rnd)
    # the second attempt only when the order-ORDER polynomial with the order-K remainder passes
    # (a cheap screen: the order-K test adds the exact terms 2⁻ᵏ|F_k|, k = ORDER+1 … K, to it)
    if K is None or not disc_test(coeffs, left, right, _dyson(g, h, K, r1) + rnd, rigid)[0]:
        return proven, margin
    coeffs, left, right, g, h, r1, rnd = _cell_terms(A, B, C, dA, dC, ctrl, M0, K)
    return disc_test(coeffs, left, right, _dyson(g, h, K, r1) + rnd, rigid)


def _grounds(human, env) -> bool:
    """Whether a member's human or environment grounds the structure (as
    :func:`exotune.sampled.loop_eigenvalues` decides: locked, or a stiffness)."""
    return (env == "locked" or (isinstance(env, dict) and env.get("stiffness", 0.0) > 0)
            or (human is not None and human.get("stiffness", 0.0) > 0))


def _rigid_vector(M0, ctrl, closed_loop_matrix, ends_a, ends_b, x=None):
    """The rigid-body eigenvector v of an ungrounded loop, verified to be an eigenvector of every
    member: A(s)x_v = 0 and the command columns of R(s) vanish on v at both ends (both affine in
    s, so for every s: then Φ(s)x_v = x_v), and M(s)v = v at both ends (the controller rows are
    affine in s). v is built from the structure (:func:`exotune.sampled.rigid.rigid_vectors` of
    the plant's rigid vector ``x``, :func:`exotune.sampled.loop.rigid_plant_vector`) when it is
    M0's eigenvector at z = 1 to rounding, else the eigenvector of M0's eigenvalue nearest 1 when
    within ``RIGID_TOL`` of it. None: no such vector (nothing to deflate); False: one that is not
    parameter-independent."""
    vs, ok = rigid_vectors(M0[None], x) if x is not None else (None, [False])
    if ok[0]:
        v = vs[0]
    else:
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
