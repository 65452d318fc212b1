"""Fast linear stretches: where the joint stays in one affine mode (a spring region, a friction
sign: :meth:`~exotune.simulation.plant.JointPlant.mode`) and no limit is reached, a run is one
linear recursion w[k+1] = M w[k] + N τ_h[k] on w = [plant state; 1; runtime filter states; past
commands].

The runtime's part of M is read off the reference runtime itself (its step is affine in its
filter states and inputs: one step per unit vector), so a fast stretch computes what stepping
:class:`~exotune.controllerfile.runtime.Runtime` computes, to rounding. The engine runs a chunk
this way, checks it (every state, also after the fractional delay's first part, still in the
mode; no command or applied torque at the motor limit; the angles within the state bound), keeps it up to the first sample that fails the check and continues from there
sample by sample.
"""

from __future__ import annotations

import numpy as np

from ..controllerfile import Runtime

__all__ = ["runtime_state", "set_runtime_state", "runtime_matrices", "runtime_input_column", "LinearLoop", "NP"]

SIGNALS = ("theta_m", "omega_m", "tau_s", "dtau_s", "tau_c")


def _filters(rt: Runtime) -> list:
    return [f for _, f in rt.filters] + list(rt.loop)


def runtime_state(rt: Runtime) -> np.ndarray:
    """The runtime's filter states as one vector.

    Parameters
    ----------
    rt : Runtime
        The reference runtime.

    Returns
    -------
    numpy.ndarray
        The states of its sensed filters, then its loop filters.
    """
    zs = [f.z.ravel() for f in _filters(rt)]
    return np.concatenate(zs) if zs else np.zeros(0)


def set_runtime_state(rt: Runtime, z: np.ndarray) -> None:
    """Load the runtime's filter states from one vector (the inverse of :func:`runtime_state`).

    Parameters
    ----------
    rt : Runtime
        The reference runtime, changed in place.
    z : numpy.ndarray
        The states, in :func:`runtime_state`'s order.
    """
    off = 0
    for f in _filters(rt):
        k = f.z.size
        f.z = np.asarray(z[off:off + k]).reshape(f.z.shape)
        off += k


def runtime_matrices(doc) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(A, B, C, D) with z' = A z + B y, τ_cmd = C z + D y (y in ``SIGNALS`` order), read off one
    step of an unlimited reference runtime per unit state and unit input.

    Parameters
    ----------
    doc : ControllerFile or dict
        The validated controller file (float64).

    Returns
    -------
    A : numpy.ndarray
        State update (nz, nz).
    B : numpy.ndarray
        Input matrix (nz, 5).
    C : numpy.ndarray
        Output row (nz,).
    D : numpy.ndarray
        Feed-through (5,).
    """
    rt = Runtime(doc)
    nz = runtime_state(rt).size
    A, B = np.zeros((nz, nz)), np.zeros((nz, len(SIGNALS)))
    C, D = np.zeros(nz), np.zeros(len(SIGNALS))
    zero = dict.fromkeys(SIGNALS, 0.0)
    for i in range(nz):
        e = np.zeros(nz)
        e[i] = 1.0
        set_runtime_state(rt, e)
        C[i] = rt.step(zero)
        A[:, i] = runtime_state(rt)
    for j, s in enumerate(SIGNALS):
        set_runtime_state(rt, np.zeros(nz))
        D[j] = rt.step({**zero, s: 1.0})
        B[:, j] = runtime_state(rt)
    return A, B, C, D


LONG_DELAY_LINE = 48  # loop states from which a run uses the compiled structured recursion
NP = 7  # plant part of w: the joint's six states and the constant 1 of the mode's constant torques


def runtime_input_column(doc) -> np.ndarray:
    """The runtime's filter states after one step from zero with τ_cmd = 1 fed to the DOB's loop
    filters and every sensed signal 0 (the column of the command in the state update: a clamped
    runtime at its limit feeds the limit instead of its own command).

    Parameters
    ----------
    doc : ControllerFile or dict
        The validated controller file (float64).

    Returns
    -------
    numpy.ndarray
        The state column (nz,).
    """
    rt = Runtime(doc)
    for f in rt.loop:
        f.step(1.0)
    return runtime_state(rt)


class LinearLoop:
    """The linear recursion of a run in one affine plant mode (see the module docstring).

    The plant part of ``w`` is [x; 1]: the constant 1 carries the mode's constant torques (the
    Coulomb friction ∓F_c of a sliding motor, the spring's offset ∓K_s·b/2 in contact with
    backlash), so one recursion covers every mode.

    Parameters
    ----------
    plant : JointPlant
        The joint.
    doc : ControllerFile or dict
        The controller file (for :func:`runtime_matrices`).
    Ts, f : float
        Sample period [s] and fractional delay.
    d : int
        Whole samples of delay.
    mode : (int, int)
        (spring region, friction sign) of :meth:`JointPlant.mode`; (1, 0): spring in contact, no
        friction term.
    saturated : ("clamp", ±limit) or ("plant", ±limit), optional
        At the motor limit: ``"clamp"`` — the runtime clamps its command (the command entering the
        delay line and driving the DOB is the limit itself); ``"plant"`` — a runtime without the
        clamp, whose delayed commands are beyond the limit, so the motor applies the limit (the
        runtime itself stays linear). ``raw_row`` is then the unclamped command, to check that the
        stretch stays at the limit.
    """

    def __init__(self, plant, doc, Ts: float, f: float, d: int, mode=(1, 0), saturated=None):
        Ar, Br, Cr, Dr = runtime_matrices(doc)
        raw = (Dr, Cr)  # the unclamped command's rows (over [x; 1] through Cy, and over z)
        if saturated is not None and saturated[0] == "clamp":
            # the clamped runtime at its limit: τ_cmd = ±limit, the DOB's loop filters driven by it
            Bu = runtime_input_column(doc)
            Ar, Br = Ar - np.outer(Bu, Cr), Br - np.outer(Bu, Dr)
        region, _fs = mode
        ks = 0.0 if region == 0 else plant.Ks
        Cy = np.zeros((5, NP))  # the sampled signals as rows over [x; 1]
        Cy[0, 0] = Cy[1, 1] = 1.0
        Cy[2, 0], Cy[3, 1] = -ks, -ks
        Cy[2, 6] = -region * plant.Ks * plant.half_gap if region else 0.0  # τ_s = ks·δ + c
        if not plant.locked:
            Cy[2, 2], Cy[3, 3] = ks, ks
        Cy[4, 4] = plant.Kc
        if not plant.locked:
            Cy[4, 2] = -plant.Kc
        self.Cy, self.mode = Cy, mode
        aug = lambda P, G: (np.block([[P, G[:, 2:3]], [np.zeros((1, 6)), np.ones((1, 1))]]),  # noqa: E731
                            np.concatenate([G[:, :2], np.zeros((1, 2))]))
        P1, G1 = aug(*plant.propagator(mode, (1.0 - f) * Ts))
        self.mid = None
        if f:
            P0, G0 = aug(*plant.propagator(mode, f * Ts))
            self.mid = (P0, G0)  # the state after f·T_s: x_mid = P0 x + G0 [τ_old, τ_h]
            Phi, g_old, g_cur, g_push = P1 @ P0, P1 @ G0[:, 0], G1[:, 0], P1 @ G0[:, 1] + G1[:, 1]
        else:
            Phi, g_old, g_cur, g_push = P1, np.zeros(NP), G1[:, 0], G1[:, 1]
        nz, ns = Ar.shape[0], d + 1
        self.nz, self.ns, self.d, self.saturated = nz, ns, d, saturated
        N = NP + nz + ns
        s0 = NP + nz  # shift state j holds τ_cmd[k−1−j]
        self.raw_row = np.zeros(N)  # the runtime's unclamped command as a row over w
        self.raw_row[:NP] = raw[0] @ Cy
        self.raw_row[NP:NP + nz] = raw[1]
        u = self.raw_row.copy()  # τ_cmd[k] as it enters the delay line
        BrCy = Br @ Cy
        if saturated is not None and saturated[0] == "clamp":  # τ_cmd = the limit: a constant
            u[:] = 0.0
            u[6] = saturated[1]
            BrCy[:, 6] += Bu * saturated[1]
        cur = u if d == 0 else np.eye(N)[s0 + d - 1]
        old = np.eye(N)[s0 + d]
        if saturated is not None and saturated[0] == "plant":  # the motor applies the limit, whatever the command
            Phi = Phi.copy()
            Phi[:, 6] += (g_cur + g_old) * saturated[1]
            g_cur, g_old = np.zeros(NP), np.zeros(NP)
        M = np.zeros((N, N))
        M[:NP, :NP] = Phi
        M[:NP] += np.outer(g_cur, cur) + np.outer(g_old, old)
        M[NP:NP + nz, :NP] = BrCy
        M[NP:NP + nz, NP:NP + nz] = Ar
        M[s0] = u
        for j in range(1, ns):
            M[s0 + j, s0 + j - 1] = 1.0
        self.M, self.Npush, self.u_row, self.cur_row, self.old_row = M, np.zeros(N), u, cur, old
        self.Npush[:NP] = g_push
        # the blocks of M for the structured recursion (numerics.kernels.shiftloop)
        self._blocks = (np.ascontiguousarray(Phi), np.ascontiguousarray(g_cur), np.ascontiguousarray(g_old),
                        np.ascontiguousarray(g_push), np.ascontiguousarray(BrCy), np.ascontiguousarray(Ar),
                        np.ascontiguousarray(u[:NP]), np.ascontiguousarray(u[NP:NP + nz]), int(d))

    def run(self, w: np.ndarray, push: np.ndarray, engine: str | None = None) -> np.ndarray:
        """States w[k] for k = 0 … len(push) (row k+1 after the push of sample k): the compiled
        structured recursion (cost independent of the delay line) for long stretches, the dense
        numpy one otherwise; ``engine`` ("numba"/"numpy") forces one."""
        from ..numerics.engine import resolve_engine, worth_compiling

        # a long delay line (high rate: a 1 ms delay at 100 kHz is 101 shift states) makes the dense
        # recursion cost N² per sample over millions of samples; the compiled one costs the same for any N
        use = (resolve_engine(engine) == "numba" if engine
               else w.size >= LONG_DELAY_LINE and worth_compiling(float(push.size) * w.size * w.size, threshold=0.0))
        if use and push.size > 0:
            from ..numerics.kernels.shiftloop import shift_loop_run

            return shift_loop_run(*self._blocks, np.ascontiguousarray(w, dtype=float),
                                  np.ascontiguousarray(push, dtype=float))
        out = np.empty((push.size + 1, w.size))
        out[0] = w
        M, Np = self.M, self.Npush
        for k in range(push.size):
            w = M @ w + Np * push[k]
            out[k + 1] = w
        return out
