"""Reference runtime (docs/controller-file.md): loads a controller file and steps it sample by sample.

Deliberately plain — a loop over second-order sections in direct form II transposed, the form a
C/C++ runtime would use — so that it documents the file's semantics and gives the golden vectors
a port is checked against. Per sample k, with the sampled signals y[k]:

1. every filter on a sensed signal runs one step (its state advances);
2. the filter on τ_cmd (the DOB's algebraic loop) is affine in its input, y = g·x + h with
   g = Π b0 over its sections and h its output for x = 0 (read from the current states);
3. τ_cmd = (Σ gain·y + Σ outputs of step 1 + h) / (1 − g) (clamped to ±``limit_nm`` when the
   runtime is given the driver's torque limit, so that the DOB sees the command really applied);
4. the τ_cmd filter advances with x = τ_cmd.

The output τ_cmd[k] is applied by the hardware after the file's ``delay_s`` (not modelled here).
"""

from __future__ import annotations

import math
from typing import Mapping

import numpy as np

from ..sampled import Measured  # the runtime's input signals
from ..units import fmt_num
from .model import ControllerFile, as_controller_file

__all__ = ["SosFilter", "Runtime", "loop_feedthrough"]


class SosFilter:
    """A cascade of second-order sections (scipy ``sos`` rows, a0 = 1), DF-II transposed.

    The arithmetic runs on Python floats (IEEE double, the same operations in the same order as
    on numpy scalars, so the same bits) — a per-sample loop over numpy scalars cost most of a
    100 kHz simulation. ``z`` is the state as a (sections × 2) array: read it, or assign a whole
    new one (``f.z = …``); it is a copy, not a view."""

    def __init__(self, sos):
        self.sos = np.atleast_2d(np.asarray(sos, dtype=float))
        self._coef = [(float(b0), float(b1), float(b2), float(a1), float(a2)) for b0, b1, b2, _a0, a1, a2 in self.sos]
        self._s = [[0.0, 0.0] for _ in self._coef]
        self.feedthrough = float(np.prod(self.sos[:, 0]))  # output per unit input at zero state

    @property
    def coefficients(self) -> tuple[tuple[float, float, float, float, float], ...]:
        """(b0, b1, b2, a1, a2) of each section, as the step uses them (a0 = 1)."""
        return tuple(self._coef)

    @property
    def z(self) -> np.ndarray:
        return np.array(self._s, dtype=float).reshape(len(self._coef), 2)

    @z.setter
    def z(self, value) -> None:
        v = np.asarray(value, dtype=float).reshape(len(self._coef), 2)
        self._s = [[float(a), float(b)] for a, b in v]

    def reset(self) -> None:
        self._s = [[0.0, 0.0] for _ in self._coef]

    def save(self) -> list:
        """A copy of the state, for :meth:`restore`."""
        return [z[:] for z in self._s]

    def restore(self, saved: list) -> None:
        self._s = saved

    def finite(self) -> bool:
        return all(math.isfinite(a) and math.isfinite(b) for a, b in self._s)

    def peek(self, x: float) -> float:
        """Output for input x without advancing the state."""
        x = float(x)
        for (b0, _b1, _b2, _a1, _a2), z in zip(self._coef, self._s):
            x = b0 * x + z[0]
        return x

    def step(self, x: float) -> float:
        x = float(x)
        for (b0, b1, b2, a1, a2), z in zip(self._coef, self._s):
            y = b0 * x + z[0]
            z[0] = b1 * x - a1 * y + z[1]
            z[1] = b2 * x - a2 * y
            x = y
        return x


def loop_feedthrough(loop) -> float:
    """g: the output per unit τ_cmd at zero state of the filters on τ_cmd (the DOB's algebraic
    loop), their feed-throughs summed left to right.

    Parameters
    ----------
    loop : iterable of SosFilter
        The filters on τ_cmd.

    Returns
    -------
    float
        g [–].
    """
    g = 0.0
    for f in loop:
        g += f.feedthrough
    return g


class Runtime:
    """Steps the controller of a validated controller file (a :class:`~exotune.controllerfile.model.ControllerFile`
    or its mapping; see the module docstring)."""

    def __init__(self, doc: ControllerFile | dict, limit_nm: float | None = None, joint_angle_rad: float | None = None):
        cf = as_controller_file(doc)
        if joint_angle_rad is not None and not math.isfinite(joint_angle_rad):
            raise ValueError(f"joint_angle_rad must be a finite angle [rad], got {joint_angle_rad!r}")
        if limit_nm is not None and not (math.isfinite(limit_nm) and limit_nm > 0):
            raise ValueError(f"limit_nm must be a positive, finite torque [N·m], got {limit_nm!r}")
        if joint_angle_rad is not None and cf.schedule_entries:
            # the scheduled controller of the nearest joint angle (entries are complete controllers)
            cf = cf.entry_view(cf.gain_schedule.nearest(joint_angle_rad))
        c = cf.controller
        self.limit_nm = limit_nm  # optional torque limit: the command is clamped before the DOB sees it
        self.sample_rate_hz = float(cf.sample_rate_hz)
        self.delay_s = float(cf.delay_s)
        self.gains = {s: float(g) for s, g in c.gains.items()}
        self.filters = [(f.input, SosFilter(f.sos)) for f in c.filters if f.input != "tau_cmd"]
        self.loop = [SosFilter(f.sos) for f in c.filters if f.input == "tau_cmd"]
        self._all = [f for _, f in self.filters] + self.loop
        self.loop_feedthrough = loop_feedthrough(self.loop)
        if abs(1.0 - self.loop_feedthrough) < 1e-9:
            raise ValueError("the DOB's algebraic loop is singular (the feed-throughs of the filters on tau_cmd add "
                             "up to 1)")

    @classmethod
    def from_file(cls, path) -> "Runtime":
        from .fileio import load_controller_file

        return cls(load_controller_file(path))

    def reset(self) -> None:
        for _, f in self.filters:
            f.reset()
        for f in self.loop:
            f.reset()

    def step(self, y: Mapping[str, float], feedforward_nm: float = 0.0) -> float:
        """τ_cmd [N·m] for the sampled signals ``y`` (θ_m [rad], θ̇_m [rad/s], τ_s [N·m],
        τ̇_s [N·m/s], τ_c [N·m]).

        ``feedforward_nm`` [N·m] is added to the command before the DOB's loop solve (the DOB books
        it as commanded torque): a reference's feedforward in a simulation (a position reference,
        :class:`exotune.simulation.Scenario`); the exported controller and its C port have none.

        A non-finite signal raises ``ValueError`` before any state changes: one NaN would poison
        every filter state for ever (and with a torque limit, ``min``/``max`` would turn it into a
        full-scale command). A real-time port should treat it as a sensor fault: command zero
        torque and latch the fault."""
        vals = {s: float(y[s]) for s in Measured if s in y}
        bad = [s for s, v in vals.items() if not math.isfinite(v)]
        if bad:
            raise ValueError(f"non-finite input {bad[0]} = {vals[bad[0]]!r}: refused, controller state unchanged "
                             "(a sensor fault: command zero torque)")
        saved = [f.save() for f in self._all]
        # Python floats: an overflow gives ±inf or nan (no exception), refused just below. Sums are
        # explicit left-to-right loops (the order a C port uses; Python ≥ 3.12's sum() compensates)
        rest = float(feedforward_nm)
        for s, g in self.gains.items():
            rest += g * vals[s]
        filtered = 0.0
        for s, f in self.filters:
            filtered += f.step(vals[s])
        rest += filtered
        h = 0.0
        for f in self.loop:
            h += f.peek(0.0)
        u = (rest + h) / (1.0 - self.loop_feedthrough)
        if self.limit_nm is not None and math.isfinite(u):  # anti-windup: the DOB sees the applied command
            u = min(self.limit_nm, max(-self.limit_nm, u))
        for f in self.loop:
            f.step(u)
        if not (math.isfinite(u) and all(f.finite() for f in self._all)):
            for f, z in zip(self._all, saved):  # finite inputs too large for floating point
                f.restore(z)
            raise ValueError(f"the command overflows (τ_cmd = {fmt_num(u)} N·m) for inputs {vals}: refused, controller state "
                             "unchanged (a sensor fault: command zero torque)")
        return u

    def run(self, inputs: Mapping[str, np.ndarray]) -> np.ndarray:
        """τ_cmd for whole input sequences (from the current state)."""
        n = len(next(iter(inputs.values())))
        return np.array([self.step({s: v[k] for s, v in inputs.items()}) for k in range(n)])
