"""Sampled-data closed loop: a discrete controller on the continuous plant (docs/method.md#controller "Discrete
implementation", the cross-check of docs/method.md#sampled-data, the engine of ``exotune certify``).

What the runtime does at sample rate f_s = 1/T_s: the sensors are sampled at t = kT_s, the
controller computes τ_cmd[k], which is applied through a zero-order hold after the total latency
T = (d + f) T_s (d whole samples, 0 ≤ f < 1: delays need not be whole samples). Over one period
the motor torque is τ_cmd[k−d−1] for the first f T_s and τ_cmd[k−d] for the rest, so the exact
discretization of the continuous plant ẋ = A x + B τ_m (Åström & Wittenmark, fractional delay) is

    x[k+1] = Φ x[k] + Γ0 τ_cmd[k−d] + Γ1 τ_cmd[k−d−1]
    Φ = e^{A T_s},  Γ0 = ∫_0^{(1−f)T_s} e^{Aη} dη B,  Γ1 = e^{A(1−f)T_s} ∫_0^{f T_s} e^{Aη} dη B,

with the past commands as shift states. Closing the loop with the discrete controller gives one
matrix; the sampled-data loop is stable iff its eigenvalues lie inside the unit circle (a
rigid-body mode of the free exoskeleton is the eigenvalue z = 1, tolerated like s = 0 in the
continuous analysis: deflated exactly by its eigenvector, :mod:`exotune.sampled.rigid`).

The plant is written here from the physical equations (docs/method.md#physical-model), independently of the transfer
function algebra of :mod:`exotune.model` / :mod:`exotune.analysis`, so that the continuous analysis
and this model check each other. The discrete controller comes from a
:class:`~exotune.controller.ControllerStructure` (:func:`discretize`): every proper block by the
Tustin (bilinear) transform, optionally prewarped at a frequency per block; the improper parts
K + B s of the SEA blocks act on the sampled positions and ideal sampled velocities (plant states),
as in the continuous analysis (docs/method.md#controller); the DOB's algebraic loop through Q's feed-through is
solved exactly.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np
import scipy.linalg

from ..numerics.statespace import tf2ss
from .rigid import deflate, rigid_deflation

__all__ = ["Measured", "plant_ss", "plant_structure", "plant_states", "rigid_plant_vector", "plant_stack", "loop_matrices", "Block", "controller_blocks", "DiscreteController", "discretize", "assemble",
           "closed_loop_matrix", "sampled_stable", "sampled_verdict", "loop_stable", "loop_verdict", "spectral_verdict", "loop_eigenvalues", "loop_spectra", "tustin", "prewarped",
           "zoh_fractional", "zoh_rounding", "expm_rounding", "split_delay", "default_prewarp"]

# sampled signals the controller may use (order of the plant's output vector)
Measured = ("theta_m", "omega_m", "tau_s", "dtau_s", "tau_c")


def plant_ss(plant, human: dict | None = None, env: str | dict = "free"):
    """(A, B, C) of the joint-reflected plant with the human at θ_h and the environment at θ_j.

    Input τ_m [N·m]; outputs :data:`Measured` = θ_m [rad], θ̇_m [rad/s], τ_s [N·m], τ̇_s [N·m/s],
    τ_c [N·m]. ``human``: None (cuff free, τ_c ≡ 0) or {inertia, damping, stiffness} (any subset;
    no inertia = a massless spring-damper node). ``env``: "free", "locked" (θ_j ≡ 0) or
    {inertia, damping, stiffness} acting on θ_j (docs/method.md#physical-model).

        J_m θ̈_m + B_m θ̇_m = τ_s + τ_m,   τ_s = K_s (θ_j − θ_m)
        J_j θ̈_j = τ_c − τ_s + τ_env,      τ_c = K_c (θ_h − θ_j)
        m θ̈_h + b θ̇_h + k θ_h = −τ_c

    Parameters
    ----------
    plant : Plant
        Joint-reflected plant (:class:`~exotune.model.plant.Plant`; the first member of a batch).
    human : dict or None, optional
        None (cuff free) or a subset of ``inertia`` [kg·m²], ``damping`` [N·m·s/rad] and
        ``stiffness`` [N·m/rad] of the human node behind the cuff.
    env : str or dict, optional
        ``"free"``, ``"locked"`` or a subset of ``inertia`` [kg·m²], ``damping`` [N·m·s/rad] and
        ``stiffness`` [N·m/rad] acting on θ_j.

    Returns
    -------
    A : numpy.ndarray
        State matrix (n, n) over the states θ_m, θ̇_m[, θ_j, θ̇_j][, θ_h[, θ̇_h]] [rad, rad/s].
    B : numpy.ndarray
        Input matrix (n, 1) of τ_m [N·m].
    C : numpy.ndarray
        Output matrix (5, n) of the :data:`Measured` signals.

    Raises
    ------
    ValueError
        When ``env`` is a string other than ``"free"`` or ``"locked"``.
    """
    g = lambda x: np.asarray(x, dtype=float).reshape(-1)[:1]  # noqa: E731
    A, B, C = plant_stack((g(plant.J_m), g(plant.B_m), g(plant.K_s), g(plant.J_j), g(plant.K_c)),
                          *_node_arrays([human], [env]), plant_structure(human, env))
    return A[0], B[0][:, None], C[0]


def plant_structure(human: dict | None, env: str | dict = "free") -> tuple[bool, bool, bool, bool]:
    """The state layout :func:`plant_ss` chooses: (locked, a human node, θ_h and ω_h states, θ_h
    state only). A human with inertia has both states, a massless damped one θ_h only, a massless
    undamped one none (its spring in series with K_c).

    Parameters
    ----------
    human : dict or None
        The human node, as in :func:`plant_ss`.
    env : str or dict, optional
        The environment, as in :func:`plant_ss`.

    Returns
    -------
    tuple of bool
        (locked, human present, mass states, first-order state).

    Raises
    ------
    ValueError
        When ``env`` is a string other than ``"free"`` or ``"locked"``.
    """
    if not isinstance(env, dict) and env not in ("free", "locked"):
        raise ValueError(f"unknown environment {env!r}")
    if human is None:
        return env == "locked", False, False, False
    mass = float(human.get("inertia", 0.0)) > 0
    return env == "locked", True, mass, (not mass) and float(human.get("damping", 0.0)) > 0


def _node_arrays(humans: list, envs: list):
    """(inertia, damping, stiffness) arrays of the human nodes and of the environments (zeros where absent)."""
    keys = ("inertia", "damping", "stiffness")
    hum = [tuple(float(h.get(q, 0.0)) for q in keys) if h is not None else (0.0, 0.0, 0.0) for h in humans]
    env = [tuple(float(e.get(q, 0.0)) for q in keys) if isinstance(e, dict) else (0.0, 0.0, 0.0) for e in envs]
    return tuple(np.array(x) for x in zip(*hum)), tuple(np.array(x) for x in zip(*env))


def plant_stack(joint: tuple, human: tuple, env: tuple, structure: tuple[bool, bool, bool, bool]):
    """Stacks of :func:`plant_ss` for k members of one state layout: the one construction of the
    plant matrices (the single design's, :func:`loop_spectra`'s and the sweep's
    :class:`~exotune.sampled.batch.BatchLoops`).

    Parameters
    ----------
    joint : tuple of numpy.ndarray
        (J_m [kg·m²], B_m [N·m·s/rad], K_s [N·m/rad], J_j [kg·m²], K_c [N·m/rad]), each (k,).
    human : tuple of numpy.ndarray
        The human node's (inertia [kg·m²], damping [N·m·s/rad], stiffness [N·m/rad]), each (k,).
    env : tuple of numpy.ndarray
        The environment's (inertia, damping, stiffness) on θ_j, each (k,) (unused when locked).
    structure : tuple of bool
        :func:`plant_structure` of the members.

    Returns
    -------
    A : numpy.ndarray
        (k, n, n) state matrices over the states of :func:`plant_ss`.
    B : numpy.ndarray
        (k, n) input columns of τ_m [N·m].
    C : numpy.ndarray
        (k, 5, n) output matrices of the :data:`Measured` signals.
    """
    Jm, Bm, Ks, Jj, Kc = joint
    hm, hb, hk = human
    me, be, ke = env
    locked, has_human, mass, first_order = structure
    k = hm.shape[0]
    names = plant_states(structure)
    n = len(names)
    ix = {s: i for i, s in enumerate(names)}
    eye = np.eye(n)
    e = lambda s: eye[ix[s]:ix[s] + 1]  # noqa: E731  (linear forms over the states, (1, n): broadcast over k)
    zero = np.zeros((1, n))
    th_m, om_m = e("theta_m"), e("omega_m")
    th_j = zero if locked else e("theta_j")
    om_j = zero if locked else e("omega_j")
    c = lambda x: x[:, None]  # noqa: E731
    if not has_human:
        tau_c = zero
    elif "theta_h" in ix:
        tau_c = c(Kc) * (e("theta_h") - th_j)
    else:  # massless, undamped: K_c in series with k
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
    C = np.empty((k, 5, n))
    for row, form in enumerate((th_m, om_m, tau_s, dtau_s, tau_c)):
        C[:, row] = form
    return A, B, C


def plant_states(structure: tuple[bool, bool, bool, bool]) -> list[str]:
    """The state names of :func:`plant_ss`'s layout ``structure`` (:func:`plant_structure`):
    θ_m, ω_m[, θ_j, ω_j][, θ_h[, ω_h]] as ``"theta_m"``, ``"omega_m"``, ….

    Parameters
    ----------
    structure : tuple of bool
        (locked, human present, mass states, first-order state).

    Returns
    -------
    list of str
        The plant's states in order.
    """
    locked, _has_human, mass, first_order = structure
    names = ["theta_m", "omega_m"] + ([] if locked else ["theta_j", "omega_j"])
    return names + (["theta_h", "omega_h"] if mass else ["theta_h"] if first_order else [])


def rigid_plant_vector(structure: tuple[bool, bool, bool, bool]) -> np.ndarray | None:
    """The plant's part of the rigid-body mode of layout ``structure``: 1 on every position state,
    0 on every velocity (the whole structure displaced by one radian, every spring undeflected), so
    A x = 0 whenever nothing grounds the structure (no human or environment stiffness); None when
    the joint is locked (grounded). Completed to the loop's eigenvector by
    :func:`exotune.sampled.rigid.rigid_vectors`.

    Parameters
    ----------
    structure : tuple of bool
        (locked, human present, mass states, first-order state) (:func:`plant_structure`).

    Returns
    -------
    numpy.ndarray or None
        x (n,) over :func:`plant_states`, or None for a locked joint.
    """
    if structure[0]:
        return None
    return np.array([1.0 if s.startswith("theta") else 0.0 for s in plant_states(structure)])


@dataclass(frozen=True)
class DiscreteController:
    """z[k+1] = Ac z[k] + Bc y[k],  τ_cmd[k] = Cc z[k] + Dc y[k]  (y = :data:`Measured`), at
    ``sample_rate_hz``, applied after ``delay_s``."""

    Ac: np.ndarray
    Bc: np.ndarray
    Cc: np.ndarray
    Dc: np.ndarray
    sample_rate_hz: float
    delay_s: float


def _row(x: np.ndarray) -> np.ndarray:
    return np.atleast_2d(np.asarray(x, dtype=float))[0]


def prewarped(num: np.ndarray, den: np.ndarray, Ts: float, prewarp_hz: float | None):
    """Coefficients (ascending) of H(λ s), λ = (ω T_s/2)/tan(ω T_s/2): the standard bilinear
    transform of H(λ s) is the Tustin transform of H prewarped at ω = 2π·prewarp_hz.

    Parameters
    ----------
    num, den : numpy.ndarray
        Numerator and denominator coefficients of H(s), ascending powers of s.
    Ts : float
        Sample period [s].
    prewarp_hz : float or None
        Prewarp frequency [Hz]; None or 0 leaves the coefficients unchanged (λ = 1).

    Returns
    -------
    num, den : numpy.ndarray
        The coefficients of H(λ s), ascending powers of s.
    """
    lam = 1.0
    if prewarp_hz:
        w = 2 * math.pi * float(prewarp_hz)
        lam = (w / math.tan(w * Ts / 2)) * Ts / 2
    return num * lam ** np.arange(num.size), den * lam ** np.arange(den.size)


def tustin(num_asc, den_asc, Ts: float, prewarp_hz: float | None):
    """Discrete (A, B, C, D) of a proper num/den (ascending coefficients) by the bilinear
    transform, prewarped at ``prewarp_hz`` when given (s ← K (z−1)/(z+1), K = ω/tan(ωT_s/2)).

    Parameters
    ----------
    num_asc, den_asc : array_like
        Numerator and denominator of the continuous block, ascending powers of s (proper).
    Ts : float
        Sample period [s].
    prewarp_hz : float or None
        Frequency [Hz] where the discrete response equals the continuous one exactly; ``None``
        for the plain bilinear transform.

    Returns
    -------
    A, B, C, D : numpy.ndarray
        The discrete state space (empty A for a static block; all-zero for a zero block).

    References
    ----------
    The controller's discretization for the sampled-data analysis: docs/method.md (sampled-data
    check); the export discretizes the same blocks through zeros and poles
    (:func:`exotune.controllerfile.sos.tustin_sos`).
    """
    num = np.trim_zeros(_row(num_asc), "b")
    den = np.trim_zeros(_row(den_asc), "b")
    if num.size == 0:
        return np.zeros((0, 0)), np.zeros((0, 1)), np.zeros((1, 0)), np.zeros((1, 1))
    if num.size > den.size:
        raise ValueError("an improper controller block cannot be discretized (filter it first)")
    num, den = prewarped(num, den, Ts, prewarp_hz)
    if den.size == 1:
        return np.zeros((0, 0)), np.zeros((0, 1)), np.zeros((1, 0)), np.array([[num[0] / den[0]]])
    import scipy.signal  # here: importing it costs a second, and a continuous design never needs it

    A, B, C, D = tf2ss(num[::-1], den[::-1])  # scipy.signal.tf2ss's realization (numerics.statespace)
    # the companion realization of a block prewarped near Nyquist is badly scaled (coefficients
    # ~1e10): scipy's solve warns about rcond ~1e-26, yet the discrete response matches
    # H(K (z−1)/(z+1)) to ~1e-11 (tests/test_sampled.py); the warning is noise for the user
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", scipy.linalg.LinAlgWarning)
        Ad, Bd, Cd, Dd, _ = scipy.signal.cont2discrete((A, B, C, D), Ts, method="bilinear")
    return Ad, Bd, Cd, Dd


def _split_improper(num_asc, den_asc):
    """num/den = p0 + p1 s + proper remainder (the SEA blocks K + B s with ideal velocity)."""
    num = np.trim_zeros(_row(num_asc), "b")
    den = np.trim_zeros(_row(den_asc), "b")
    if num.size <= den.size:
        return 0.0, 0.0, num, den
    if den.size != 1 or num.size > 2:
        raise ValueError("only K + B s improper parts are implemented with ideal sampled velocities")
    return num[0] / den[0], num[1] / den[0], np.zeros(1), np.ones(1)


@dataclass(frozen=True)
class Block:
    """One proper controller block num/den (ascending coefficients in s) acting on ``input`` (a
    name in :data:`Measured` or ``"tau_cmd"``, the command itself: the DOB's algebraic loop),
    discretized by Tustin prewarped at the frequency of ``prewarp`` (a key of the prewarp map)."""

    name: str
    input: str
    num: np.ndarray
    den: np.ndarray
    prewarp: str


def controller_blocks(cs, plant) -> tuple[np.ndarray, list[Block]]:
    """The runtime form of a single-design :class:`ControllerStructure` (docs/method.md#controller):

        τ_cmd = G_θ θ_m + G_s τ_s + G_c τ_c − δ̂,   δ̂ = Q (J_m s² + B_m s) θ_m − Q (τ_s + τ_cmd)

    as static gains on the sampled signals (the K + B s parts of G_θ and G_s on θ_m, θ̇_m and τ_s,
    τ̇_s; one gain per :data:`Measured` signal) plus proper blocks.

    Parameters
    ----------
    cs : ControllerStructure
        Single-design controller (:class:`~exotune.model.controller.ControllerStructure`).
    plant : Plant
        The plant; its J_m [kg·m²] and B_m [N·m·s/rad] enter the DOB's inverse motor model.

    Returns
    -------
    static : numpy.ndarray
        One static gain per :data:`Measured` signal (τ_cmd per signal unit: [N·m/rad],
        [N·m·s/rad], [1], [s], [1]).
    blocks : list of Block
        The proper blocks (ascending coefficients), each with its input signal and prewarp key.
    """
    Jm, Bm = float(np.ravel(plant.J_m)[0]), float(np.ravel(plant.B_m)[0])
    static = np.zeros(len(Measured))
    blocks = []
    for name, blk, pos, vel in (("motor_position", cs.motor_position, 0, 1), ("spring_torque", cs.spring_torque, 2, 3)):
        p0, p1, rn, rd = _split_improper(blk.num, blk.den)
        static[pos] += p0
        static[vel] += p1
        if np.any(np.trim_zeros(_row(rn), "b")):
            blocks.append(Block(name, Measured[pos], _row(rn), _row(rd), "theta_m" if pos == 0 else "tau_s"))
    blocks.append(Block("cuff_path", "tau_c", _row(cs.cuff_torque.num), _row(cs.cuff_torque.den), "tau_c"))
    if cs.dob_q is not None:
        qn, qd = _row(cs.dob_q.num), _row(cs.dob_q.den)
        q2n = np.convolve(qn, np.array([0.0, Bm, Jm]))  # ascending: Q (B_m s + J_m s²)
        blocks.append(Block("dob_motor", "theta_m", -q2n, qd, "dob"))  # −Q(J_m s² + B_m s) θ_m
        blocks.append(Block("dob_spring", "tau_s", qn, qd, "dob"))  # + Q τ_s
        blocks.append(Block("dob_command", "tau_cmd", qn, qd, "dob"))  # + Q τ_cmd
    return static, blocks


def discretize(cs, plant, sample_rate_hz: float, prewarp: dict | None = None) -> DiscreteController:
    """The discrete controller of a single-design :class:`ControllerStructure`
    (:func:`controller_blocks`), each proper block by Tustin (``prewarp``: {"theta_m"|"tau_s"|
    "tau_c"|"dob": Hz}).

    Parameters
    ----------
    cs : ControllerStructure
        Single-design controller; its ``delay_s`` [s] becomes the discrete controller's delay.
    plant : Plant
        The plant (J_m, B_m of the DOB's inverse model).
    sample_rate_hz : float
        Sample rate [Hz].
    prewarp : dict or None, optional
        Prewarp frequency [Hz] per block kind (``"theta_m"``, ``"tau_s"``, ``"tau_c"``, ``"dob"``);
        a kind left out is transformed without prewarping. See :func:`default_prewarp`.

    Returns
    -------
    DiscreteController
        The state-space controller at ``sample_rate_hz`` with the DOB's algebraic loop solved.

    Raises
    ------
    ValueError
        When the DOB's algebraic loop is singular (Q feed-through of 1).
    """
    Ts = 1.0 / float(sample_rate_hz)
    pw = prewarp or {}
    static, blocks = controller_blocks(cs, plant)
    ss = [(tustin(b.num, b.den, Ts, pw.get(b.prewarp)), b.input) for b in blocks]
    return assemble(static, ss, sample_rate_hz, float(np.ravel(cs.delay_s)[0]))


def assemble(static, blocks, sample_rate_hz: float, delay_s: float) -> DiscreteController:
    """One state-space controller from static gains on :data:`Measured` and discrete blocks
    ``[((A, B, C, D), input), …]``; the algebraic loop τ_cmd → Q → τ_cmd (a block whose input is
    ``"tau_cmd"`` has the feed-through q0) is solved: τ_cmd = (rest)/(1 − q0).

    Parameters
    ----------
    static : array_like
        Static gain per :data:`Measured` signal.
    blocks : list of tuple
        ``((A, B, C, D), input)`` per discrete block; ``input`` is a :data:`Measured` name or
        ``"tau_cmd"``.
    sample_rate_hz : float
        Sample rate [Hz].
    delay_s : float
        Total latency [s] from sampling to the command's application.

    Returns
    -------
    DiscreteController
        The controller ``z[k+1] = Ac z + Bc y``, ``τ_cmd = Cc z + Dc y``.

    Raises
    ------
    ValueError
        When the algebraic loop is singular (the ``"tau_cmd"`` blocks' feed-through sums to 1).
    """
    nz = sum(b[0][0].shape[0] for b in blocks)
    ny = len(Measured)
    # τ_cmd = Σ_i (C_i z_i + D_i u_i) + static·y, with u_i = y[input] or τ_cmd
    Cz = np.zeros(nz)
    Dy = np.array(static, dtype=float).copy()
    q0 = 0.0
    off = 0
    for (A_, B_, C_, D_), inp in blocks:
        k = A_.shape[0]
        Cz[off:off + k] = np.asarray(C_).reshape(-1)[:k]
        if inp == "tau_cmd":
            q0 += float(np.asarray(D_).reshape(-1)[0])
        else:
            Dy[Measured.index(inp)] += float(np.asarray(D_).reshape(-1)[0])
        off += k
    if abs(1.0 - q0) < 1e-12:
        raise ValueError("the DOB's algebraic loop is singular (Q feed-through = 1)")
    Cc = Cz / (1.0 - q0)
    Dc = Dy / (1.0 - q0)
    # states: z_i[k+1] = A_i z_i + B_i u_i, u_i = y[input] or τ_cmd = Cc z + Dc y
    Ac = np.zeros((nz, nz))
    Bc = np.zeros((nz, ny))
    off = 0
    for (A_, B_, C_, D_), inp in blocks:
        k = A_.shape[0]
        Ac[off:off + k, off:off + k] = A_
        b = np.asarray(B_).reshape(-1)[:k]
        if inp == "tau_cmd":
            Ac[off:off + k, :] += np.outer(b, Cc)
            Bc[off:off + k, :] += np.outer(b, Dc)
        else:
            Bc[off:off + k, Measured.index(inp)] += b
        off += k
    return DiscreteController(Ac, Bc, Cc[None, :], Dc[None, :], float(sample_rate_hz), float(delay_s))


def zoh_fractional(A: np.ndarray, B: np.ndarray, Ts: float, f: float):
    """(Φ, Γ0, Γ1) of the module docstring (exact, by block matrix exponentials).

    Parameters
    ----------
    A : numpy.ndarray
        Continuous state matrix (n, n).
    B : numpy.ndarray
        Continuous input matrix (n, m).
    Ts : float
        Sample period [s].
    f : float
        Fraction of a sample of the delay, 0 ≤ f < 1.

    Returns
    -------
    Phi : numpy.ndarray
        e^{A T_s}, (n, n).
    Gamma0 : numpy.ndarray
        Input matrix of τ_cmd[k−d], (n, m).
    Gamma1 : numpy.ndarray
        Input matrix of τ_cmd[k−d−1], (n, m).
    """
    M = _augmented(A, B)
    return _zoh_blocks(A.shape[0], *_zoh_exponentials(M, Ts, f))


def _augmented(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """The block matrix [[A, B], [0, 0]] whose exponential holds the zero-order hold."""
    n, m = B.shape
    M = np.zeros((n + m, n + m))
    M[:n, :n] = A
    M[:n, n:] = B
    return M


def _zoh_exponentials(M: np.ndarray, Ts: float, f: float):
    """(e^{M(1−f)Ts}, e^{M f Ts}) of one augmented matrix or a stack of them (scipy's expm on a
    stack gives each matrix's own result, bit for bit)."""
    E0 = scipy.linalg.expm(M * (1.0 - f) * Ts)
    # a whole-sample delay (f = 0): e^0 = I, exactly what scipy.linalg.expm returns, without its cost
    E1 = np.broadcast_to(np.eye(M.shape[-1]), M.shape) if f == 0.0 else scipy.linalg.expm(M * f * Ts)
    return E0, E1


def _zoh_blocks(n: int, E0: np.ndarray, E1: np.ndarray):
    """(Φ, Γ0, Γ1) from the two exponentials of one augmented matrix."""
    Phi0, G0 = E0[:n, :n], E0[:n, n:]
    Phi = Phi0 @ E1[:n, :n]
    G1 = Phi0 @ E1[:n, n:]
    return Phi, G0, G1


def split_delay(delay_s, Ts: float):
    """(whole samples d, fraction f) of a total delay [s] (a number or an array) at the sample
    period ``Ts`` [s]: T = (d + f)·Ts, 0 ≤ f < 1, a fraction below 1e-9 read as 0 (a whole
    number of samples up to rounding). The one split of the sampled-data loop, its batches and
    the cell proofs.

    Parameters
    ----------
    delay_s : float or array_like
        Total delay [s].
    Ts : float
        Sample period [s].

    Returns
    -------
    d : int or numpy.ndarray
        Whole samples (an int64 array for an array ``delay_s``).
    f : float or numpy.ndarray
        Fraction of a sample, 0 ≤ f < 1.
    """
    q = np.asarray(delay_s, dtype=float) / Ts
    d = np.floor(q + 1e-9).astype(np.int64)
    f = q - d
    f = np.where(f < 1e-9, 0.0, f)
    if f.ndim == 0:
        return int(d), float(f)
    return d, f


def closed_loop_matrix(A, B, C, ctrl: DiscreteController, zoh=None) -> np.ndarray:
    """State matrix of the sampled-data loop on [x; z; τ_cmd[k−1], …, τ_cmd[k−d−1]].

    Parameters
    ----------
    A, B, C : numpy.ndarray
        Continuous plant of :func:`plant_ss`.
    ctrl : DiscreteController
        The discrete controller (its rate and delay set the discretization).
    zoh : tuple of numpy.ndarray, optional
        (Φ, Γ0, Γ1) of :func:`zoh_fractional` when already computed (:func:`loop_spectra`).

    Returns
    -------
    numpy.ndarray
        The loop's square state matrix: plant states, controller states and d + 1 past commands.
    """
    if zoh is None:
        zoh = zoh_fractional(A, B, 1.0 / ctrl.sample_rate_hz, split_delay(ctrl.delay_s, 1.0 / ctrl.sample_rate_hz)[1])
    return loop_matrices(*(x[None] for x in zoh), C[None], ctrl)[0]


def loop_matrices(Phi, G0, G1, C, ctrl: DiscreteController) -> np.ndarray:
    """:func:`closed_loop_matrix` of k held plants that share the controller: the one assembly
    of the loop matrix (state order [x; z; τ_cmd[k−1], …, τ_cmd[k−d−1]]).

    Parameters
    ----------
    Phi : numpy.ndarray
        (k, n, n) e^{A T_s} of :func:`zoh_fractional`.
    G0, G1 : numpy.ndarray
        (k, n, 1) Γ0 and Γ1 of :func:`zoh_fractional`.
    C : numpy.ndarray
        (k, 5, n) output matrices of :func:`plant_ss`.
    ctrl : DiscreteController
        The discrete controller (its rate and delay set the shift register).

    Returns
    -------
    numpy.ndarray
        (k, N, N) loop matrices: plant states, controller states and d + 1 past commands.
    """
    d, _f = split_delay(ctrl.delay_s, 1.0 / ctrl.sample_rate_hz)
    k, n = Phi.shape[0], Phi.shape[1]
    nz, ns = ctrl.Ac.shape[0], d + 1
    N = n + nz + ns
    M = np.zeros((k, N, N))
    # τ_cmd[k] = Cc z + Dc C x
    u = np.zeros((k, N))
    u[:, :n] = (ctrl.Dc @ C)[:, 0, :]
    u[:, n:n + nz] = ctrl.Cc.reshape(-1)
    s0 = n + nz  # shift state j (0-based) holds τ_cmd[k−1−j]
    cur = u if d == 0 else _unit(N, s0 + d - 1)  # τ_cmd[k−d]
    old = _unit(N, s0 + d)  # τ_cmd[k−d−1]
    top = np.zeros((k, n, N))
    top[:, :, :n] = Phi
    M[:, :n] = top + G0 * (cur[:, None, :] if cur.ndim == 2 else cur) + G1 * old
    M[:, n:n + nz, :n] = ctrl.Bc @ C
    M[:, n:n + nz, n:n + nz] = ctrl.Ac
    M[:, s0] = u
    j = np.arange(1, ns)
    M[:, s0 + j, s0 + j - 1] = 1.0  # the delay line: a shift register
    return M


def _unit(N: int, i: int) -> np.ndarray:
    e = np.zeros(N)
    e[i] = 1.0
    return e


def sampled_stable(plant, cs, sample_rate_hz: float, human: dict | None = None, env: str | dict = "free",
                   prewarp: dict | None = None, rigid_tol: float = 1e-7) -> tuple[bool, float]:
    """(stable, spectral radius) of the sampled-data loop of a :class:`ControllerStructure`
    (:func:`loop_stable` on :func:`discretize`).

    Parameters
    ----------
    plant : Plant
        The plant.
    cs : ControllerStructure
        Single-design controller.
    sample_rate_hz : float
        Sample rate [Hz].
    human : dict or None, optional
        The human node, as in :func:`plant_ss`.
    env : str or dict, optional
        The environment, as in :func:`plant_ss`.
    prewarp : dict or None, optional
        Prewarp frequencies [Hz] per block kind (:func:`discretize`).
    rigid_tol : float, optional
        Distance from z = 1 within which the rigid-body eigenvalue is dropped when it cannot be
        deflated by its eigenvector (:mod:`exotune.sampled.rigid`).

    Returns
    -------
    stable : bool
        True when the loop is Schur stable (an inconclusive verdict counts as not stable).
    rho : float
        Spectral radius of the loop matrix.
    """
    K1 = -float(np.ravel(cs.motor_position.num)[0]) / float(np.ravel(cs.motor_position.den)[0])
    return loop_stable(plant, discretize(cs, plant, sample_rate_hz, prewarp), K1 != 0.0, human, env, rigid_tol)


def sampled_verdict(plant, cs, sample_rate_hz: float, human: dict | None = None, env: str | dict = "free",
                    prewarp: dict | None = None, rigid_tol: float = 1e-7) -> tuple[bool | None, float, float]:
    """:func:`loop_verdict` (stable, inconclusive as None; spectral radius; rounding) of the
    sampled-data loop of a :class:`ControllerStructure`.

    Parameters
    ----------
    plant : Plant
        The plant.
    cs : ControllerStructure
        Single-design controller.
    sample_rate_hz : float
        Sample rate [Hz].
    human : dict or None, optional
        The human node, as in :func:`plant_ss`.
    env : str or dict, optional
        The environment, as in :func:`plant_ss`.
    prewarp : dict or None, optional
        Prewarp frequencies [Hz] per block kind (:func:`discretize`).
    rigid_tol : float, optional
        Distance from z = 1 within which the rigid-body eigenvalue is dropped when it cannot be
        deflated by its eigenvector (:mod:`exotune.sampled.rigid`).

    Returns
    -------
    stable : bool or None
        The verdict; None when rounding cannot decide it.
    rho : float
        Spectral radius of the loop matrix.
    rounding : float
        Rounding bound of the eigenvalue deciding the verdict.
    """
    K1 = -float(np.ravel(cs.motor_position.num)[0]) / float(np.ravel(cs.motor_position.den)[0])
    return loop_verdict(plant, discretize(cs, plant, sample_rate_hz, prewarp), K1 != 0.0, human, env, rigid_tol)


def loop_stable(plant, ctrl: DiscreteController, position_feedback: bool, human: dict | None = None,
                env: str | dict = "free", rigid_tol: float = 1e-7) -> tuple[bool, float]:
    """(stable, spectral radius) of the discrete controller ``ctrl`` on the plant (+ human,
    + environment); see :func:`loop_eigenvalues`. A verdict that rounding cannot decide
    (:func:`loop_verdict`) counts as not stable here (margins built on it stay conservative).

    Parameters
    ----------
    plant : Plant
        The plant.
    ctrl : DiscreteController
        The discrete controller.
    position_feedback : bool
        Whether the controller feeds back the motor position (K1 ≠ 0), which grounds the structure.
    human : dict or None, optional
        The human node, as in :func:`plant_ss`.
    env : str or dict, optional
        The environment, as in :func:`plant_ss`.
    rigid_tol : float, optional
        Distance from z = 1 within which the rigid-body eigenvalue is dropped when it cannot be
        deflated by its eigenvector (:mod:`exotune.sampled.rigid`).

    Returns
    -------
    stable : bool
        True only for a conclusive stable verdict.
    rho : float
        Spectral radius of the loop matrix.

    Raises
    ------
    exotune.errors.ConfigError
        When the loop matrix overflows, or when an active time budget is spent.
    """
    stable, rho, _ = loop_verdict(plant, ctrl, position_feedback, human, env, rigid_tol)
    return stable is True, rho


def loop_verdict(plant, ctrl: DiscreteController, position_feedback: bool, human: dict | None = None,
                 env: str | dict = "free", rigid_tol: float = 1e-7) -> tuple[bool | None, float, float]:
    """(stable, spectral radius, rounding) of the sampled-data loop, where ``stable`` is None
    (inconclusive) when an eigenvalue's modulus is within its rounding bound of 1
    (:func:`spectral_verdict`).

    Parameters
    ----------
    plant : Plant
        The plant.
    ctrl : DiscreteController
        The discrete controller.
    position_feedback : bool
        Whether the controller feeds back the motor position (K1 ≠ 0).
    human : dict or None, optional
        The human node, as in :func:`plant_ss`.
    env : str or dict, optional
        The environment, as in :func:`plant_ss`.
    rigid_tol : float, optional
        Distance from z = 1 within which the rigid-body eigenvalue is dropped when it cannot be
        deflated by its eigenvector (:mod:`exotune.sampled.rigid`).

    Returns
    -------
    stable : bool or None
        The verdict; None when inconclusive.
    rho : float
        Spectral radius of the loop matrix.
    rounding : float
        Rounding bound of the eigenvalue deciding the verdict.

    Raises
    ------
    exotune.errors.ConfigError
        When the loop matrix overflows, or when an active time budget is spent.
    """
    M, (lam, Md, basis, drop) = _loop_spectrum(plant, ctrl, position_feedback, human, env, rigid_tol)
    held = []  # the zero-order hold and its rounding estimate, computed once for every trial

    def trial(rng):
        if not held:
            held.append(_held(plant_ss(plant, human, env), ctrl))
        Mt = _zoh_trial(held[0], ctrl, M, rng)
        return Mt if basis is None else deflate(Mt[None], *(b[None] for b in basis))[0]  # as M is deflated

    if Md is not None:  # the rigid-body mode deflated exactly: the verdict on the other eigenvalues
        return _verdict(Md, lam, None, trial)
    return _verdict(M, lam, None if drop is None else rigid_tol, trial)


NEAR_UNIT = 1e-4  # eigenvalues whose modulus is this close to 1 get a rounding estimate
ROUNDING_TRIALS = 4


def spectral_verdict(M: np.ndarray, rigid_tol: float | None = None) -> tuple[bool | None, float, float]:
    """Schur stability of the matrix ``M`` that says "inconclusive" rather than guess.

    Each eigenvalue λ_i near the unit circle carries a rounding estimate e_i: ten times the largest
    move of λ_i when every entry of ``M`` is perturbed by a relative 8ε (``ROUNDING_TRIALS``
    fixed pseudo-random perturbations; the entries of the loop matrix are themselves results of
    rounded arithmetic, and a near-defective or ill-conditioned eigenvalue moves by far more than ε
    under such perturbations). The loop is **stable** when every |λ_i| + e_i < 1, **unstable**
    when some |λ_i| − e_i > 1, and **inconclusive** (None) otherwise — near the limits of double
    precision (a very high sample rate, an undamped mode) exotune never reports a rounding
    artefact as "UNSTABLE" or "stable". With ``rigid_tol``, the eigenvalue nearest z = 1 is
    excluded when within that distance (the rigid-body mode of an ungrounded structure).

    Parameters
    ----------
    M : numpy.ndarray
        Square state matrix of a discrete-time loop.
    rigid_tol : float or None, optional
        Distance from z = 1 within which the nearest eigenvalue is excluded; None excludes nothing.

    Returns
    -------
    (stable, spectral radius, rounding bound of the eigenvalue deciding the verdict)

    Examples
    --------
    >>> import numpy as np
    >>> spectral_verdict(np.diag([0.5, 1.0 - 1e-6]))[0]
    True
    >>> spectral_verdict(np.diag([0.5, 1.0 + 1e-17]))[0] is None   # 1 within rounding
    True
    """
    M = np.asarray(M, dtype=float)
    if M.size == 0:
        return True, 0.0, 0.0
    return _verdict(M, np.linalg.eigvals(M), rigid_tol)


def _verdict(M: np.ndarray, w: np.ndarray, rigid_tol: float | None, trial=None) -> tuple[bool | None, float, float]:
    """:func:`spectral_verdict` of ``M`` whose eigenvalues ``w`` (``np.linalg.eigvals(M)``) are known;
    ``trial(rng)`` gives one perturbed matrix (default: every entry by a relative 8ε; a sampled-data
    loop adds the rounding of its zero-order hold, :func:`zoh_rounding`)."""
    if M.size == 0:
        return True, 0.0, 0.0
    keep = np.ones(w.size, dtype=bool)
    if rigid_tol is not None:
        i = int(np.argmin(np.abs(w - 1.0)))
        keep[i] = not abs(w[i] - 1.0) <= rigid_tol
    if not keep.any():
        return True, 0.0, 0.0
    mod = np.abs(w)
    err = np.full(w.size, 4.0 * w.size * np.finfo(float).eps)
    near = np.nonzero(keep & (np.abs(mod - 1.0) < NEAR_UNIT))[0]
    if near.size:
        rng = np.random.default_rng(0)
        for _ in range(ROUNDING_TRIALS):
            wp = np.linalg.eigvals(_relative_trial(M, rng) if trial is None else trial(rng))
            moved = np.min(np.abs(wp[None, :] - w[near, None]), axis=1)
            err[near] = np.maximum(err[near], 10.0 * moved)
    mod, err = mod[keep], err[keep]
    rho = float(np.max(mod))
    if np.any(mod - err > 1.0):
        i = int(np.argmax(mod - err))
        return False, rho, float(err[i])
    i = int(np.argmax(mod + err))
    if mod[i] + err[i] < 1.0:
        return True, rho, float(err[i])
    return None, rho, float(err[i])


def _relative_trial(M: np.ndarray, rng) -> np.ndarray:
    """``M`` with every entry perturbed by a relative 8ε (one rounding trial of :func:`spectral_verdict`)."""
    return M * (1.0 + 8.0 * np.finfo(float).eps * rng.uniform(-1.0, 1.0, M.shape))


def _held(plant_matrices, ctrl: DiscreteController):
    """(C, the zero-order hold (Φ, Γ0, Γ1), its rounding estimate) of a loop: what every rounding
    trial of :func:`loop_verdict` perturbs."""
    A, B, C = plant_matrices
    Ts = 1.0 / ctrl.sample_rate_hz
    _d, f = split_delay(ctrl.delay_s, Ts)
    return C, zoh_fractional(A, B, Ts, f), zoh_rounding(A, B, Ts, f)


def _zoh_trial(held, ctrl: DiscreteController, M: np.ndarray, rng) -> np.ndarray:
    """One rounding trial of a sampled-data loop matrix ``M``: its zero-order hold (Φ, Γ0, Γ1)
    perturbed entry by entry within the rounding estimate of :func:`zoh_rounding`, the loop
    assembled again, then every entry perturbed by a relative 8ε. ``held``: :func:`_held`."""
    C, zoh, err = held
    moved = [x + e * rng.uniform(-1.0, 1.0, x.shape) for x, e in zip(zoh, err)]
    Mt = loop_matrices(*(x[None] for x in moved), C[None], ctrl)[0]
    return _relative_trial(Mt if Mt.shape == M.shape else M, rng)


def expm_rounding(X: np.ndarray, E: np.ndarray, expm=None) -> np.ndarray:
    """Entry-by-entry estimate of the rounding error of ``E``, the floating-point exponential of
    ``X`` (docs/method.md#sampled-data, "Inconclusive verdicts"): the difference from the
    exponential computed again in balanced coordinates (X = T X_b T⁻¹, e^X = T e^{X_b} T⁻¹, T
    diagonal) plus 64u(1 + ‖X_b‖₁) times the largest entry of e^{X_b}, mapped back through T.
    Scaling and squaring loses accuracy in proportion to ‖X‖: a light human mass on the stiff cuff
    spring makes ‖A T_s‖ ~1e8 while its spectrum is ~1e2, and the exponential's entries then carry
    absolute errors of 1e-7 that a relative 8ε perturbation of the loop matrix does not represent.

    Parameters
    ----------
    X : numpy.ndarray
        Square matrix (m, m), or a stack of them (k, m, m).
    E : numpy.ndarray
        Its computed exponential, of the shape of ``X``.
    expm : callable, optional
        The exponential of a stack of balanced matrices (default ``scipy.linalg.expm``; the batch
        engine passes its own, the one that computed ``E``).

    Returns
    -------
    numpy.ndarray
        Non-negative estimate of |E − e^X| entry by entry, of the shape of ``X``.
    """
    m = X.shape[-1]
    Xs = np.asarray(X, dtype=float).reshape(-1, m, m)
    bal = [scipy.linalg.matrix_balance(x, permute=False, separate=True) for x in Xs]
    Xb = np.stack([b[0] for b in bal])
    sc = np.stack([np.asarray(b[1][0], dtype=float) for b in bal])
    ratio = sc[:, :, None] / sc[:, None, :]
    Eb = (scipy.linalg.expm if expm is None else expm)(Xb)
    u = 0.5 * np.finfo(float).eps
    uniform = 64.0 * u * (1.0 + np.max(np.sum(np.abs(Xb), axis=1), axis=1)) * np.max(np.abs(Eb), axis=(1, 2))
    err = np.abs(np.reshape(E, Xs.shape) - Eb * ratio) + uniform[:, None, None] * ratio
    return err.reshape(np.shape(X))


def zoh_rounding(A: np.ndarray, B: np.ndarray, Ts: float, f: float):
    """Rounding estimates (entry by entry, absolute) of (Φ, Γ0, Γ1) of :func:`zoh_fractional`,
    from :func:`expm_rounding` of its one or two exponentials.

    Parameters
    ----------
    A : numpy.ndarray
        Continuous state matrix (n, n).
    B : numpy.ndarray
        Continuous input matrix (n, m).
    Ts : float
        Sample period [s].
    f : float
        Fraction of a sample of the delay, 0 ≤ f < 1.

    Returns
    -------
    dPhi, dGamma0, dGamma1 : numpy.ndarray
        Non-negative estimates of the errors of Φ (n, n), Γ0 (n, m) and Γ1 (n, m).
    """
    n = A.shape[0]
    X = _augmented(A, B)
    E0, E1 = _zoh_exponentials(X, Ts, f)
    e0 = expm_rounding(X * ((1.0 - f) * Ts), E0)
    if f == 0.0:
        return e0[:n, :n], e0[:n, n:], np.zeros_like(B)
    e1 = expm_rounding(X * (f * Ts), E1)
    P0, P1 = np.abs(E0[:n, :n]), np.abs(E1[:n, :n])
    return (e0[:n, :n] @ P1 + P0 @ e1[:n, :n], e0[:n, n:], e0[:n, :n] @ np.abs(E1[:n, n:]) + P0 @ e1[:n, n:])


def loop_eigenvalues(plant, ctrl: DiscreteController, position_feedback: bool, human: dict | None = None,
                     env: str | dict = "free", rigid_tol: float = 1e-7) -> np.ndarray:
    """Eigenvalues of the sampled-data loop; the rigid-body eigenvalue z = 1 is set aside when
    nothing grounds the structure (no position feedback K1, no human or environment stiffness, not
    locked), as in the continuous analysis: deflated exactly by its eigenvector, built from the
    structure (:mod:`exotune.sampled.rigid`: the other eigenvalues are those of the deflated
    matrix), or — when that vector is not an eigenvector to rounding — the eigenvalue nearest 1
    dropped if within ``rigid_tol`` of it.

    Parameters
    ----------
    plant : Plant
        The plant.
    ctrl : DiscreteController
        The discrete controller.
    position_feedback : bool
        Whether the controller feeds back the motor position (K1 ≠ 0).
    human : dict or None, optional
        The human node, as in :func:`plant_ss`.
    env : str or dict, optional
        The environment, as in :func:`plant_ss`.
    rigid_tol : float, optional
        Distance from z = 1 within which the rigid-body eigenvalue is dropped when it cannot be
        deflated by its eigenvector (:mod:`exotune.sampled.rigid`).

    Returns
    -------
    numpy.ndarray
        Complex eigenvalues of the loop matrix (z-plane).

    Raises
    ------
    exotune.errors.ConfigError
        When the loop matrix overflows, or when an active time budget is spent.
    """
    _M, (lam, _Md, _basis, drop) = _loop_spectrum(plant, ctrl, position_feedback, human, env, rigid_tol)
    return lam if drop is None else np.delete(lam, drop)


def _loop_spectrum(plant, ctrl, position_feedback, human, env, rigid_tol):
    """(loop matrix, :func:`_spectra` of it)."""
    from ..numerics.timebudget import check_time

    check_time()  # export/certify at a high rate: stop once the time budget is spent
    A, B, C = plant_ss(plant, human, env)
    M = _finite(closed_loop_matrix(A, B, C, ctrl))
    return M, _spectra(M[None], [_rigid_plant(position_feedback, human, env)], rigid_tol)[0]


def _rigid_plant(position_feedback: bool, human, env):
    """:func:`rigid_plant_vector` of a loop that nothing grounds, else None."""
    grounded = (env == "locked" or (isinstance(env, dict) and env.get("stiffness", 0.0) > 0)
                or (human is not None and human.get("stiffness", 0.0) > 0) or position_feedback)
    return None if grounded else rigid_plant_vector(plant_structure(human, env))


def _spectra(Ms: np.ndarray, rigid: list, rigid_tol: float) -> list:
    """Per loop matrix of the stack ``Ms``: (eigenvalues, deflated matrix, deflation (s, Q₂),
    index of the rigid-body eigenvalue to drop). ``rigid[i]``: :func:`_rigid_plant` of matrix i.
    A loop whose rigid-body eigenvector checks (:func:`exotune.sampled.rigid.rigid_deflation`) is
    deflated exactly (the eigenvalues are the deflated matrix's, nothing to drop); another
    ungrounded loop drops its eigenvalue nearest 1 when within ``rigid_tol`` of it (matrix and
    basis None). One LAPACK call per matrix: each result is the same in a stack of any size."""
    out: list = [None] * Ms.shape[0]
    free = [i for i, x in enumerate(rigid) if x is not None]
    if free:
        ok, s, Q2, Md = rigid_deflation(Ms[free], np.stack([rigid[i] for i in free]))
        good = [i for i, o in zip(free, ok) if o]
        if good:
            for j, (i, lam) in enumerate(zip(good, np.linalg.eigvals(Md))):
                out[i] = (lam, Md[j], (s[j], Q2[j]), None)
    rest = [i for i, o in enumerate(out) if o is None]
    if rest:
        for i, lam in zip(rest, np.linalg.eigvals(Ms[rest])):
            out[i] = (lam, None, None, _rigid_index(lam, rigid[i] is not None, rigid_tol))
    return out


def _finite(M: np.ndarray) -> np.ndarray:
    """``M``, or the error of a loop matrix that overflows."""
    if not np.all(np.isfinite(M)):
        from ..errors import ConfigError

        raise ConfigError("controller", "the sampled-data loop matrix overflows (gains or filter coefficients too "
                                        "large for floating point)")
    return M


def _rigid_index(lam: np.ndarray, free: bool, rigid_tol: float):
    """Index of the rigid-body eigenvalue (|λ − 1| ≤ rigid_tol) of a loop that nothing grounds
    (``free``), else None."""
    if free and lam.size:
        i = int(np.argmin(np.abs(lam - 1.0)))
        if abs(lam[i] - 1.0) <= rigid_tol:
            return i
    return None


def loop_spectra(plant, ctrl: DiscreteController, position_feedback: bool, humans: list, env: str | dict | list = "free",
                 rigid_tol: float = 1e-7) -> list:
    """:func:`loop_eigenvalues` for several human (or environment) nodes at once: the plant
    matrices (:func:`plant_stack`), the matrix exponentials, the loop matrices
    (:func:`loop_matrices`) and the eigenvalue problems of loops of one state layout run on
    stacks. Each result is bit for bit the point-wise one (scipy's ``expm`` and numpy's ``eigvals`` treat every matrix of a
    stack as they treat it alone; tested).

    Parameters
    ----------
    plant : Plant
        The plant.
    ctrl : DiscreteController
        The discrete controller.
    position_feedback : bool
        Whether the controller feeds back the motor position (K1 ≠ 0).
    humans : list of (dict or None)
        The human node of each loop, as in :func:`plant_ss`.
    env : str, dict or list, optional
        The environment, as in :func:`plant_ss`, one for all loops or a list (one per loop).
    rigid_tol : float, optional
        Distance from z = 1 within which the rigid-body eigenvalue is dropped when it cannot be
        deflated by its eigenvector (:mod:`exotune.sampled.rigid`).

    Returns
    -------
    list of numpy.ndarray
        The eigenvalues of each loop (z-plane), in the order of ``humans``.

    Raises
    ------
    exotune.errors.ConfigError
        When a loop matrix overflows, or when an active time budget is spent.
    """
    from ..numerics.timebudget import check_time

    check_time()
    envs = env if isinstance(env, list) else [env] * len(humans)
    Ts = 1.0 / ctrl.sample_rate_hz
    _d, f = split_delay(ctrl.delay_s, Ts)
    g = lambda x: np.asarray(x, dtype=float).reshape(-1)[:1]  # noqa: E731
    joint = (g(plant.J_m), g(plant.B_m), g(plant.K_s), g(plant.J_j), g(plant.K_c))
    groups: dict = {}
    for i, (h, e) in enumerate(zip(humans, envs)):
        groups.setdefault(plant_structure(h, e), []).append(i)
    out: list = [None] * len(humans)
    for structure, idx in groups.items():
        k = len(idx)
        human, env_ = _node_arrays([humans[i] for i in idx], [envs[i] for i in idx])
        A, B, C = plant_stack(tuple(np.broadcast_to(x, (k,)) for x in joint), human, env_, structure)
        n = A.shape[1]
        aug = np.zeros((k, n + 1, n + 1))
        aug[:, :n, :n] = A
        aug[:, :n, n] = B
        E0, E1 = _zoh_exponentials(aug, Ts, f)
        Phi0 = E0[:, :n, :n]
        Ms = _finite(loop_matrices(Phi0 @ E1[:, :n, :n], E0[:, :n, n:], Phi0 @ E1[:, :n, n:], C, ctrl))
        spectra = _spectra(Ms, [_rigid_plant(position_feedback, humans[i], envs[i]) for i in idx], rigid_tol)
        for (lam, _Md, _basis, drop), i in zip(spectra, idx):
            out[i] = lam if drop is None else np.delete(lam, drop)
    return out


def default_prewarp(impl) -> dict:
    """Prewarp frequencies [Hz] per block (docs/method.md#controller: Tustin prewarped at the cutoff): G_c at the
    G_v filter cutoff, the DOB blocks at the Q cutoff, the SEA blocks at the velocity-filter cutoff
    when there is one.

    Parameters
    ----------
    impl : Implementation
        The implementation options (:class:`~exotune.model.controller.Implementation`) with the
        G_v filter, the DOB and the velocity filter.

    Returns
    -------
    dict
        Prewarp frequency [Hz] per block kind (``"tau_c"``, ``"dob"``, ``"theta_m"``, ``"tau_s"``);
        a kind without a filter is left out.
    """
    f = lambda x: float(np.ravel(x)[0])  # noqa: E731
    pw = {}
    if impl.gv_filter is not None:
        pw["tau_c"] = f(impl.gv_filter.cutoff_hz)
    if impl.dob is not None:
        pw["dob"] = f(impl.dob.cutoff_hz)
    if impl.velocity_filter is not None:
        pw["theta_m"] = pw["tau_s"] = f(impl.velocity_filter.cutoff_hz)
    return pw
