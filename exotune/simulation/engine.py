"""One time-domain run: the exported runtime controller stepped once per sample on the joint.

The controller is the reference runtime (:class:`exotune.controllerfile.runtime.Runtime`), stepped
exactly as a real-time port would. Its command is applied through a zero-order hold after the
file's total latency T = (d + f)·T_s (d whole samples; for the fraction f of each period the
previous command is still applied) and clipped to the motor limit. The joint is integrated by
:class:`~exotune.simulation.plant.JointPlant`: exactly (matrix exponential) where it is linear, so
a run without nonlinearities equals the sampled-data model of :mod:`exotune.sampled` sample by
sample. Where the joint stays in one affine mode (a friction sign, a backlash contact side) and
the motor stays either below its limit or at it (the clamped runtime commanding the limit, or an
unclamped one whose delayed commands are beyond it), chunks of up to ``CHUNK`` samples run as one
linear recursion whose runtime part is read off the runtime's step (:mod:`.fastpath`; the same
numbers to rounding, about as fast as a plain linear simulation); a chunk that leaves its mode is
continued sample by sample from where it left it (``SLOW_RUN`` samples, at least the delay line's
length, then fast again).

Start: ``"zero"`` (every controller state and past command zero) or ``"bumpless"`` (every filter
at the steady state of its initial input, the DOB at a zero disturbance estimate — the command
τ_0 = −τ_s(0) that holds the motor still against the measured spring torque — and the delay line
holding τ_0).
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Callable

import numpy as np

from ..controllerfile import ControllerFile, Runtime, as_controller_file
from ..numerics.timebudget import check_time
from .fastpath import NP, LinearLoop, runtime_state, set_runtime_state
from .plant import JointPlant

__all__ = ["simulate", "bumpless_start", "strip_dob", "check_start", "STATE_BOUND", "STARTS", "CHUNK"]

CHUNK = 1000  # samples per fast linear stretch
SLOW_RUN = 8  # samples stepped one by one from where a fast stretch reached a limit (or the delay line + 2)
MIN_SPAN = 64  # the shortest fast attempt
STATE_BOUND = 1e6  # an angle beyond this bound [rad] ends the run as diverged
STARTS = ("bumpless", "zero")
SERIES = ("t", "theta_m", "omega_m", "theta_j", "theta_h", "tau_s", "dtau_s", "tau_c", "tau_cmd", "tau_m", "push",
          "friction")


def _sos_steady(sos, x: float) -> tuple[list, float]:
    """DF-II-T states of a cascade at the steady state of a constant input ``x`` (a section with a
    pole at z = 1 and a non-zero input has none: ValueError)."""
    states = []
    for b0, b1, b2, _a0, a1, a2 in sos:
        den = 1.0 + a1 + a2
        if abs(den) <= 1e-12 * (1.0 + abs(a1) + abs(a2)):
            if x != 0.0:
                raise ValueError("integrating section")
            y = 0.0
        else:
            y = (b0 + b1 + b2) / den * x
        states.append((y - b0 * x, b2 * x - a2 * y))
        x = y
    return states, x


def bumpless_start(rt: Runtime, y0: dict) -> tuple[float, str]:
    """Set the runtime's filter states for a bumpless start with the measurements ``y0``.

    Parameters
    ----------
    rt : Runtime
        A freshly built runtime (its states are overwritten).
    y0 : dict
        The initial sampled signals.

    Returns
    -------
    (float, str)
        The command τ_0 [N·m] the delay line holds, and a note ("" or which filter had no
        steady state and started at zero).

    References
    ----------
    docs/method.md#simulation.
    """
    note = []
    tau0 = -float(y0["tau_s"])  # the motor at rest against the spring: zero disturbance estimate
    if rt.limit_nm is not None:
        tau0 = min(rt.limit_nm, max(-rt.limit_nm, tau0))
    pairs = [(f, float(y0[s])) for s, f in rt.filters] + [(f, tau0) for f in rt.loop]
    for f, x in pairs:
        try:
            states, _ = _sos_steady(f.sos, x)
        except ValueError:
            f.reset()
            note.append("a filter integrates its input and starts at zero")
            continue
        f.z = [(z0, z1) for z0, z1 in states]
    if not rt.loop:  # without a DOB: the controller's steady command for y0
        tau0 = sum(g * float(y0[s]) for s, g in rt.gains.items()) + sum(f.peek(float(y0[s])) for s, f in rt.filters)
        if rt.limit_nm is not None:
            tau0 = min(rt.limit_nm, max(-rt.limit_nm, tau0))
    return tau0, "; ".join(sorted(set(note)))


def strip_dob(doc: ControllerFile | dict) -> ControllerFile:
    """A copy of the controller file ``doc`` without the DOB (its filters and ``dob`` section).

    Parameters
    ----------
    doc : ControllerFile or dict
        The controller file.

    Returns
    -------
    ControllerFile
        A copy without the DOB's filters, ``dob`` null
        (:meth:`~exotune.controllerfile.model.ControllerFile.without_dob`).
    """
    return as_controller_file(doc).without_dob()


def check_start(start) -> str:
    """The initial controller state of a run (``start``, ``--start``): one of :data:`STARTS`.

    Parameters
    ----------
    start : Any
        The value given.

    Returns
    -------
    str
        ``start``.

    Raises
    ------
    exotune.errors.ConfigError
        Field ``start``: not one of :data:`STARTS`.
    """
    from ..errors import ConfigError

    if not (isinstance(start, str) and start in STARTS):
        raise ConfigError("start", f"must be one of {', '.join(STARTS)}, got {start!r}")
    return start


def simulate(doc: ControllerFile | dict, scenario, without_dob: bool = False, duration_s: float | None = None,
             start: str = "bumpless", clamp: bool = True,
             progress: Callable[[float], None] | None = None, fast: bool = True,
             series: "tuple[str, ...] | None" = None) -> dict:
    """Run ``scenario`` with the controller file ``doc``.

    Parameters
    ----------
    doc : ControllerFile or dict
        A validated controller file.
    scenario : Scenario
        What to run (:data:`exotune.simulation.SCENARIOS`).
    without_dob : bool
        Remove the DOB's filters from the controller.
    duration_s : float, optional
        Run length [s] (default: the scenario's).
    start : {"bumpless", "zero"}
        Initial controller state (see the module docstring).
    clamp : bool
        Give the runtime the motor limit (it clamps its command before the DOB sees it); False:
        the runtime does not know the limit (the motor still saturates).
    progress : callable, optional
        Called with the completed fraction (0–1) after every chunk of ``CHUNK`` samples.
    fast : bool
        Run linear stretches by the linear recursion of :mod:`.fastpath` (same result to
        rounding); False: every sample through the runtime's step.
    series : tuple of str, optional
        Record only these of :data:`SERIES` (default: all; 8 bytes per sample each): a run
        kept only for one signal needs no memory for the others.

    Returns
    -------
    dict
        ``series`` (per-sample arrays), ``sample_rate_hz``, ``delay_samples``, ``locked``,
        ``start``, ``diverged`` (None, or why the run stopped: an angle beyond ``STATE_BOUND``, a
        non-finite state or command), ``nonlinear_intervals`` (plant intervals integrated by
        ``solve_ivp``), ``fast_samples`` (samples run by the linear recursion).

    Raises
    ------
    exotune.errors.ConfigError
        On ``time_budget_s``, when the enclosing time budget
        (:func:`exotune.numerics.timebudget.time_budget`) is spent: checked once per stretch
        (at most ``CHUNK`` samples, or a short run sample by sample).
    ValueError
        When ``series`` names a signal that is not one of :data:`SERIES`.

    References
    ----------
    Paper §V (sampled-data loop), §V (experiments); docs/method.md#simulation.
    """
    check_start(start)
    doc = strip_dob(doc) if without_dob else as_controller_file(doc)
    sc = scenario if duration_s is None else replace(scenario, duration_s=float(duration_s))
    run = _Run(doc, sc, clamp)
    fast = fast and sc.reference_rad == 0.0  # the linear recursion has no reference input
    note = ""
    if start == "bumpless":
        tau0, note = bumpless_start(run.rt, run.plant.measure(run.x))
        run.past = [tau0] * len(run.past)
    n = max(1, int(round(sc.duration_s * run.fs)))
    keep = SERIES if series is None else tuple(series)
    if not set(keep) <= set(SERIES):
        raise ValueError(f"series: unknown {sorted(set(keep) - set(SERIES))} (known: {', '.join(SERIES)})")
    run.rec = {k: np.empty(n) if k in keep else _DISCARD for k in SERIES}
    k = 0
    span = CHUNK  # the next fast attempt's length: shrinks while attempts stop early (a limit, a mode
    # change: the rest of the attempt is computed for nothing), grows back while they succeed
    with np.errstate(over="ignore", invalid="ignore"):
        while k < n and run.diverged is None:
            check_time()  # once per stretch: at most CHUNK samples, or a short run sample by sample
            end = min(n, k + span)
            k1 = run.fast(k, end) if fast else k
            if k1 < end:  # at a limit or a mode change: sample by sample for a while
                span = max(MIN_SPAN, span // 4)
                k1 = run.slow(k1, min(n, k1 + max(SLOW_RUN, run.d + 2)))
            else:
                span = min(CHUNK, 2 * span)
            k = k1
            if progress is not None:
                progress(k / n)
    rec = {key: v[:k] for key, v in run.rec.items() if key in keep}
    return {"series": rec, "sample_rate_hz": run.fs, "delay_samples": run.q, "locked": sc.locked,
            "start": start + (f" ({note})" if note else ""), "diverged": run.diverged,
            "nonlinear_intervals": run.plant.nonlinear_intervals, "fast_samples": run.fast_samples,
            "duration_s": sc.duration_s}


class _Discard:
    """A series that is not recorded: every write to it is dropped."""

    def __setitem__(self, index, value) -> None:
        pass


_DISCARD = _Discard()


class _Run:
    """The state of one run (plant state, runtime, delay line, records) and its two steppers."""

    def __init__(self, doc: ControllerFile, sc, clamp: bool):
        self.doc, self.sc = doc, sc
        self.fs = float(doc.sample_rate_hz)
        self.Ts = 1.0 / self.fs
        self.q = float(doc.delay_s) * self.fs
        self.d = int(math.floor(self.q + 1e-9))
        self.f = self.q - self.d if self.q - self.d > 1e-9 else 0.0
        self.sat = float(sc.nonlinear.saturation_nm)
        self.plant = JointPlant(doc.plant.values(), sc.human, sc.locked, sc.nonlinear)
        self.rt = Runtime(doc, limit_nm=self.sat if (clamp and math.isfinite(self.sat)) else None)
        self.x = np.zeros(6)
        self.x[4] = sc.theta_h0
        self.past = [0.0] * (self.d + 1)  # τ_cmd[k−1], …, τ_cmd[k−d−1]
        self.rec: dict = {}
        self.diverged = None
        self.fast_samples = 0
        self._loops: dict = {}  # LinearLoop per (affine plant mode, motor-limit mode)
        # the delay-line entries the motor applies: τ_cmd[k−d] (when d ≥ 1) and τ_cmd[k−d−1] (when f > 0)
        self._applied = [j for j in ((self.d - 1) if self.d >= 1 else None, self.d if self.f else None) if j is not None]

    def feedforward(self, t: float) -> float:
        """The reference's feedforward [N·m] at ``t``: −g_θm θ_ref − g_ωm θ̇_ref (the controller's
        own position and velocity gains acting on the reference; 0 without one)."""
        if self.sc.reference_rad == 0.0:
            return 0.0
        r, w = self.sc.reference(t)
        return -self.rt.gains.get("theta_m", 0.0) * r - self.rt.gains.get("omega_m", 0.0) * w

    def clip(self, v: float) -> float:
        return max(-self.sat, min(self.sat, v)) if math.isfinite(self.sat) else v

    def _bad(self, x) -> bool:
        return not np.all(np.isfinite(x)) or max(abs(x[0]), abs(x[2]), abs(x[4])) > STATE_BOUND

    def slow(self, k0: int, k1: int) -> int:
        """Samples k0 … k1−1 one by one (runtime step, exact or adaptive plant interval); returns
        the sample reached (earlier when the run diverges)."""
        sc, rec, plant, Ts, f, d = self.sc, self.rec, self.plant, self.Ts, self.f, self.d
        for k in range(k0, k1):
            t = k * Ts
            y = plant.measure(self.x)
            try:
                u = self.rt.step(y, self.feedforward(t))
            except ValueError as e:  # an overflowing command: the loop has diverged
                self.diverged = f"the runtime refused its inputs at t = {t:.6g} s ({e})"
                return k
            cur = u if d == 0 else self.past[d - 1]
            old = self.past[d]
            push = sc.push(t)
            x = self.x
            rec["t"][k], rec["theta_m"][k], rec["omega_m"][k] = t, x[0], x[1]
            rec["theta_j"][k] = 0.0 if sc.locked else x[2]
            rec["theta_h"][k], rec["tau_s"][k], rec["tau_c"][k] = x[4], y["tau_s"], y["tau_c"]
            rec["dtau_s"][k] = y["dtau_s"]
            rec["tau_cmd"][k], rec["tau_m"][k], rec["push"][k] = u, self.clip(cur), push
            rec["friction"][k] = plant.friction(x)
            if f:  # the first f·T_s still applies τ_cmd[k−d−1], the rest τ_cmd[k−d]
                x = plant.advance(x, self.clip(old), push, f * Ts)
            self.x = plant.advance(x, self.clip(cur), push, (1.0 - f) * Ts)
            self.past = [u] + self.past[:-1]
            if self._bad(self.x):
                self.diverged = f"an angle exceeded {STATE_BOUND:g} rad at t = {t + Ts:.6g} s"
                return k + 1
        return k1

    def _loop(self, mode, sat=None) -> LinearLoop:
        """The linear recursion of (plant mode, motor-limit mode), built once per run."""
        if (mode, sat) not in self._loops:
            self._loops[(mode, sat)] = LinearLoop(self.plant, self.doc, self.Ts, self.f, self.d, mode, sat)
        return self._loops[(mode, sat)]

    def _saturation(self, mode, w0: np.ndarray):
        """The motor-limit mode a fast stretch from ``w0`` starts in: None (below the limit),
        ("clamp", ±limit) (the clamped runtime at its limit), ("plant", ±limit) (a runtime
        without the clamp whose delayed commands are beyond the limit), or False (none of these:
        step sample by sample)."""
        if not math.isfinite(self.sat):
            return None
        u0 = float(w0 @ self._loop(mode).raw_row)
        if abs(u0) < self.sat and np.all(np.abs(self.past) < self.sat):
            return None
        if self.rt.limit_nm is not None:
            return ("clamp", math.copysign(self.sat, u0)) if abs(u0) >= self.sat else False
        line = np.asarray(self.past)[self._applied]
        if self.d >= 1 and (np.all(line >= self.sat) or np.all(line <= -self.sat)):
            return ("plant", math.copysign(self.sat, line[0]))
        return False

    def fast(self, k0: int, k1: int) -> int:
        """Samples k0 … k1−1 by the linear recursion of the plant's current affine mode
        (:mod:`.fastpath`), up to the first sample whose state leaves the mode (also after the
        fractional delay's first part), whose command or applied torque reaches the motor limit, or
        whose next state is not finite or beyond the state bound; returns the sample reached (k0:
        nothing changed — also when the state is in no affine mode, e.g. a motor about to stick)."""
        plant = self.plant
        mode = plant.mode(self.x)
        if mode is None:
            return k0
        w0 = np.concatenate([self.x, [1.0], runtime_state(self.rt), self.past])
        sat = self._saturation(mode, w0)
        if sat is False:
            return k0
        L = self._loop(mode, sat)
        t = np.arange(k0, k1) * self.Ts
        push = np.array([self.sc.push(v) for v in t])
        W = L.run(w0, push)
        U, cur, raw = W[:-1] @ L.u_row, W[:-1] @ L.cur_row, W[:-1] @ L.raw_row
        s0 = NP + L.nz
        ok = np.isfinite(raw) & np.all(np.isfinite(W[1:]), axis=1)
        ok &= np.max(np.abs(W[1:, [0, 2, 4]]), axis=1) <= STATE_BOUND
        ok &= plant.in_mode(W[1:, :6], mode)
        if L.mid is not None:  # the state after the fractional delay's first part
            P0, G0 = L.mid
            old = W[:-1] @ L.old_row if sat is None or sat[0] == "clamp" else np.full(push.size, sat[1])
            Xm = W[:-1, :NP] @ P0.T + np.outer(old, G0[:, 0]) + np.outer(push, G0[:, 1])
            ok &= plant.in_mode(Xm[:, :6], mode)
        if sat is None and math.isfinite(self.sat):
            ok &= (np.abs(U) < self.sat) & (np.max(np.abs(W[:-1, s0:]), axis=1) < self.sat)
        elif sat is not None and sat[0] == "clamp":  # the unclamped command stays at or beyond the limit
            ok &= np.sign(sat[1]) * raw >= self.sat
        elif sat is not None:  # the delayed commands the motor applies stay beyond the limit
            lim = np.sign(sat[1]) * W[:-1, s0:][:, self._applied] >= self.sat
            ok &= np.all(lim, axis=1)
            cur = np.full(push.size, sat[1])
        m = int(np.argmin(ok)) if not ok.all() else ok.size  # accepted samples: the prefix before a failure
        if m == 0:
            return k0
        k1 = k0 + m
        X = W[:m, :NP]
        Y = X @ L.Cy.T
        rec = self.rec
        rec["t"][k0:k1], rec["theta_m"][k0:k1], rec["omega_m"][k0:k1] = t[:m], X[:, 0], X[:, 1]
        rec["theta_j"][k0:k1] = 0.0 if self.sc.locked else X[:, 2]
        rec["theta_h"][k0:k1], rec["tau_s"][k0:k1], rec["dtau_s"][k0:k1] = X[:, 4], Y[:, 2], Y[:, 3]
        rec["tau_c"][k0:k1], rec["tau_cmd"][k0:k1], rec["tau_m"][k0:k1] = Y[:, 4], U[:m], cur[:m]
        # |θ̇_m| > FRICTION_LINEAR·ε in the mode: tanh(θ̇_m/ε) is ±1 exactly
        rec["push"][k0:k1], rec["friction"][k0:k1] = push[:m], plant.Fc * mode[1]
        self.x = W[m, :6].copy()
        set_runtime_state(self.rt, W[m, NP:s0])
        self.past = [float(v) for v in W[m, s0:]]
        self.fast_samples += m
        return k1
