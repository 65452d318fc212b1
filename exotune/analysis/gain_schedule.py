"""The gain schedule of a batch of designs: every design rescheduled at each joint angle of its
``transmission`` section and analysed as the runtime runs it (paper §IV, gain scheduling).

At joint angle θ_e the transmission ratio r_e reflects the motor inertia, the motor damping and
the SEA stiffness by r_e² (:meth:`exotune.model.plant.Plant.reflected`); double compliance shaping
then gives that entry its own gains. The runtime runs every entry, so a design is robust only when
each entry is, and its latency margin is the smallest of its main controller's and its entries'
(docs/method.md#latency-margin). One batch of N·E designs (E entries) is analysed by
:func:`~exotune.analysis.batch.analyze_batch`: the single-design report, the sweep and the
optimizer share this one implementation.

References
----------
Paper §IV (gain scheduling); docs/method.md#gain-scheduling; docs/sweep-spec.md#gain-schedule.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from .batch import analyze_batch, cfg_size, slice_cfg
from .batch_result import BatchAnalysis

__all__ = ["ScheduleBatch", "analyze_schedule", "rescheduled", "worst_over", "WORST_METRICS"]

#: The sweep's scalar metric columns (docs/sweep-spec.md#columns) reduced over a gain schedule, and
#: the direction that is better: ``">="`` (a margin or a bandwidth: the smallest is the worst) or
#: ``"<="`` (the passivity phase excess: the largest is the worst).
WORST_METRICS = {
    "passivity_max_phase_excess_deg": "<=",
    "dob_phase_margin_deg": ">=",
    "dob_gain_margin_db": ">=",
    "dob_delay_margin_s": ">=",
    "amplification_bandwidth_hz": ">=",
}


def worst_over(values, op: str):
    """The worst of each column of ``values`` over its rows (the main controller and the
    gain-schedule entries): the smallest where ``op`` is ``">="``, the largest where it is ``"<="``;
    NaN in a column where any row is NaN (one unknown value leaves the worst unknown).

    Parameters
    ----------
    values : array_like, shape (R, N)
        One row per controller (main first, then the entries), one column per design, in the
        metric's unit.
    op : str
        ``">="`` or ``"<="``: the direction that is better.

    Returns
    -------
    worst : numpy.ndarray, shape (N,)
        The worst value per design, in the metric's unit.
    row : numpy.ndarray of int, shape (N,)
        The row that holds it (0: the main controller).

    References
    ----------
    Paper §IV (gain scheduling); docs/sweep-spec.md#gain-schedule.
    """
    vals = np.asarray(values, dtype=float)
    if op not in (">=", "<="):
        raise ValueError(f"op must be '>=' or '<=', got {op!r}")
    row = (np.argmin(np.where(np.isnan(vals), np.inf, vals), axis=0) if op == ">=" else
           np.argmax(np.where(np.isnan(vals), -np.inf, vals), axis=0))
    worst = np.where(np.isnan(vals).any(axis=0), np.nan, vals[row, np.arange(vals.shape[1])])
    return worst, row


@dataclass(frozen=True)
class ScheduleBatch:
    """The gain-schedule entries of N designs (:func:`analyze_schedule`).

    Attributes
    ----------
    joint_angle_rad : tuple of float
        The entries' joint angles [rad], E of them.
    ratio : tuple of float
        Their transmission ratios [–].
    analysis : BatchAnalysis
        The N·E rescheduled designs, entry by entry: design i of entry e is row e·N + i.
    cfg : DesignConfig
        Their configuration (a batch of N·E designs, in the same order).
    """

    joint_angle_rad: tuple[float, ...]
    ratio: tuple[float, ...]
    analysis: BatchAnalysis
    cfg: object = dataclasses.field(repr=False, default=None)

    @property
    def n(self) -> int:
        """The number of designs N."""
        return self.analysis.n // max(len(self.ratio), 1)

    def entry(self, e: int) -> BatchAnalysis:
        """Entry ``e``'s analysis of the N designs."""
        return self.analysis.take(slice(e * self.n, (e + 1) * self.n))

    def loops_ok(self) -> np.ndarray:
        """Per entry and design, shape (E, N): the entry's loops all stable (free, environments,
        every human family robust: :meth:`BatchAnalysis.loops_ok`)."""
        return self.analysis.loops_ok().reshape(len(self.ratio), self.n)

    def robust(self) -> np.ndarray:
        """Per design: every entry's loops stable, shape (N,)."""
        return self.loops_ok().all(axis=0)

    def failing_entries(self) -> np.ndarray:
        """Per design, the number of entries with a loop that is not stable, shape (N,)."""
        return (~self.loops_ok()).sum(axis=0).astype(np.int64)

    def latency_margin_s(self) -> np.ndarray | None:
        """Per design, the smallest of the entries' latency margins [s] (NaN when one of them is
        unknown), shape (N,); None when the batch was analysed without ``latency``."""
        m = self.analysis.latency_margin_s
        if m is None:
            return None
        m = np.asarray(m, float).reshape(len(self.ratio), self.n)
        return np.where(np.isnan(m).any(axis=0), np.nan, m.min(axis=0))

    def to_columns(self, nominal: BatchAnalysis) -> dict:
        """The gain-schedule columns of docs/sweep-spec.md#gain-schedule, with the main
        controller's analysis ``nominal`` of the same N designs: ``schedule_robust``,
        ``schedule_failing_entries`` and, when latency margins were computed,
        ``latency_margin_s`` (the design's: the smallest of the main controller's and the
        entries') and ``latency_margin_main_s`` (the main controller's alone)."""
        out: dict = {"schedule_robust": self.robust(), "schedule_failing_entries": self.failing_entries()}
        me, mm = self.latency_margin_s(), nominal.latency_margin_s
        if me is not None and mm is not None:
            mm = np.asarray(mm, float)
            out["latency_margin_s"] = np.where(np.isnan(mm) | np.isnan(me), np.nan, np.minimum(mm, me))
            out["latency_margin_main_s"] = mm
        out.update(self.worst_columns(nominal))
        return out

    def worst_columns(self, nominal: BatchAnalysis) -> dict:
        """``schedule_worst_{metric}`` for every metric of :data:`WORST_METRICS`: the worst value
        over the main controller (``nominal``, the same N designs) and the entries, in the
        metric's unit (docs/sweep-spec.md#gain-schedule); and ``schedule_passivity_conclusive``,
        every one of those passivity analyses conclusive."""
        e = len(self.ratio)
        main, entries = nominal.to_columns(), self.analysis.to_columns()
        out: dict = {}
        for col, op in WORST_METRICS.items():
            rows = np.vstack([np.asarray(main[col], float), np.asarray(entries[col], float).reshape(e, self.n)])
            out[f"schedule_worst_{col}"] = worst_over(rows, op)[0]
        ok = np.asarray(self.analysis.passivity.conclusive, bool).reshape(e, self.n).all(axis=0)
        out["schedule_passivity_conclusive"] = ok & np.asarray(nominal.passivity.conclusive, bool)
        return out


def rescheduled(cfg, ratio):
    """The configuration ``cfg`` (one design or a batch) seen through the transmission ratio(s)
    ``ratio`` [–]: the plant reflected by ratio² (:meth:`~exotune.model.plant.Plant.reflected`),
    everything else unchanged, so the gains are recomputed from the reflected plant.

    Parameters
    ----------
    cfg : DesignConfig
        One design or a batch of N.
    ratio : float or numpy.ndarray
        One ratio, or one per design of the batch.

    Returns
    -------
    DesignConfig
        The rescheduled configuration.

    References
    ----------
    Paper §IV (gain scheduling).
    """
    return dataclasses.replace(cfg, plant=cfg.plant.reflected(ratio))


def _batched(cfg) -> bool:
    """Whether ``cfg`` is a batch (its numbers arrays, :func:`exotune.config.batch_config`)."""
    return np.ndim(cfg.design.amplification) >= 1


def analyze_schedule(cfg, latency: bool = False, verify: int = 0) -> ScheduleBatch | None:
    """Analyse every gain-schedule entry of the designs ``cfg`` (module docstring): one
    :func:`~exotune.analysis.batch.analyze_batch` call on the N·E rescheduled designs.

    Parameters
    ----------
    cfg : DesignConfig
        One design or a batch (:func:`exotune.config.batch_config`) whose base has a
        ``transmission`` section.
    latency : bool
        Also compute each entry's latency margin [s] (the sweep's engine).
    verify : int
        Passed to :func:`~exotune.analysis.batch.analyze_batch`.

    Returns
    -------
    ScheduleBatch or None
        None when the design has no gain schedule.

    References
    ----------
    Paper §IV (gain scheduling); docs/method.md#gain-scheduling.
    """
    tr = (cfg.raw or {}).get("transmission")
    if not tr:
        return None
    ratios = np.asarray(tr["ratio"], dtype=float)
    n, e = cfg_size(cfg), ratios.size
    if not _batched(cfg):
        from ..config import batch_config

        cfg = batch_config(cfg, {})  # every number an array of length 1, as in a batch
    tiled = slice_cfg(cfg, np.tile(np.arange(n), e))  # design i of entry k at row k·N + i
    resched = rescheduled(tiled, np.repeat(ratios, n))
    res = analyze_batch(resched, verify=verify, latency=latency)
    return ScheduleBatch(tuple(float(a) for a in tr["joint_angle_rad"]), tuple(float(r) for r in ratios), res, resched)
