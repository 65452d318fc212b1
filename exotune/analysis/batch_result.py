"""The typed result of :func:`~exotune.analysis.analyze_batch`: every metric of a batch of designs.

Each record holds one numpy array (or one list) per metric, one entry per design (length N). The
sweep's Parquet columns and the optimizer's objective names are the user-facing column names of
docs/sweep-spec.md#columns: :meth:`BatchAnalysis.to_columns` and :meth:`BatchAnalysis.column`
are the one place that spells them; everything inside the package reads the typed fields.

References
----------
docs/method.md#analyses-and-metrics; docs/sweep-spec.md#columns.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from ..model.shaping import Gains

__all__ = ["AmplificationBatch", "BatchAnalysis", "DobBatch", "EnvironmentBatch", "FamilyBatch", "LoopBatch",
           "PassivityBatch", "GAIN_NAMES", "concat_batches", "take_designs"]

GAIN_NAMES = ("K1", "B1", "K2", "B2", "K2_hat", "B2_hat")


@dataclass(frozen=True)
class LoopBatch:
    """One single loop of every design: the cuff-free exoskeleton or the locked output joint
    (docs/method.md#analyses-and-metrics).

    Attributes
    ----------
    stable : ndarray of bool, shape (N,)
        No root in the closed right half-plane (the free loop allows the one rigid-body root at s = 0).
    conclusive : ndarray of bool, shape (N,)
        The root count is exact (False: a root on the axis within float resolution or a search
        that spent its budget; ``stable`` is then False).
    rigid_body_roots : ndarray of int, shape (N,), or None
        Roots at s = 0 of the free loop (None for the locked loop).
    """

    stable: np.ndarray
    conclusive: np.ndarray
    rigid_body_roots: np.ndarray | None = None

    @property
    def verdict(self) -> np.ndarray:
        """``stable``."""
        return self.stable


@dataclass(frozen=True)
class FamilyBatch:
    """One impedance family of every design: the exact stable intervals of its ranged parameter
    (docs/method.md#stable-intervals-of-a-human-family). :meth:`FamilySide.collect
    <exotune.analysis.intervals.FamilySide.collect>` gives one per family (or box edge);
    :class:`BatchAnalysis` one per human family.

    Attributes
    ----------
    kind : str
        The family's kind (``mass``, ``spring``, ``msd``, ``complex_stiffness``, …).
    robust : ndarray of bool, shape (N,)
        Stable over the whole range, conclusively.
    stable_intervals : list of list of [lo, hi]
        Per design, the stable sub-intervals of the range [unit of the parameter]; a box family:
        ``[[lo, hi]]`` of its first ranged parameter when the whole box is stable, else ``[]``.
    conclusive : ndarray of bool, shape (N,)
        Every count exact and, with verification, no mismatch.
    critical : list of list of (value, frequency [Hz])
        Per design, the parameter values where a root crosses the imaginary axis (empty for a box).
    edges : list or None
        A box family only: per design, (edge family, its stable intervals) for every edge.
    verification_mismatches : list of list of float, or None
        With verification (``verify`` > 0) only: per design, the checked values where the exact
        count disagrees with the intervals.
    """

    kind: str
    robust: np.ndarray
    stable_intervals: list
    conclusive: np.ndarray
    critical: list
    edges: list | None = None
    verification_mismatches: list | None = None

    @property
    def verdict(self) -> np.ndarray:
        """``robust``."""
        return self.robust


@dataclass(frozen=True)
class EnvironmentBatch:
    """One environment model of every design: a locked or free output (``stable``), or a spring
    or mass range (``robust`` and ``stable_intervals``, as :class:`FamilyBatch`).

    Attributes
    ----------
    kind : str
        ``locked``, ``free``, ``spring`` or ``mass``.
    stable : ndarray of bool, shape (N,), or None
        Locked/free: the verdict of that loop.
    robust : ndarray of bool, shape (N,), or None
        Spring/mass: stable over the whole range.
    stable_intervals : list of list of [lo, hi], or None
        Spring/mass: per design, the stable sub-intervals of the range [N·m/rad or kg·m²].
    """

    kind: str
    stable: np.ndarray | None = None
    robust: np.ndarray | None = None
    stable_intervals: list | None = None

    @property
    def verdict(self) -> np.ndarray:
        """``stable`` (locked/free) or ``robust`` (spring/mass)."""
        return self.stable if self.stable is not None else self.robust


@dataclass(frozen=True)
class PassivityBatch:
    """Passivity of the operator-side compliance C7 = Δ10/Δ00 (paper §IV-A,
    docs/method.md#passivity-of-the-operator-compliance).

    Attributes
    ----------
    conclusive : ndarray of bool, shape (N,)
        The frequency search resolved every leaf.
    max_phase_excess_deg : ndarray, shape (N,)
        Largest distance of the phase of C7 from the passive band, −180° to 0° [deg] (NaN: partial
        frequency coverage).
    nonpassive_band_hz : list of list of [lo, hi]
        Per design, the frequency bands where C7 is not passive [Hz].
    """

    conclusive: np.ndarray
    max_phase_excess_deg: np.ndarray
    nonpassive_band_hz: list


@dataclass(frozen=True)
class DobBatch:
    """Margins of the disturbance-observer loop L_dob = Q e^{−sT}/(1 − Q) (paper Fig. 4,
    docs/method.md#dob-margins); NaN margins and ``stable`` True for a design without DOB.

    Attributes
    ----------
    phase_margin_deg : ndarray, shape (N,)
        Phase margin [deg].
    gain_margin_db : ndarray, shape (N,)
        Gain margin [dB].
    delay_margin_s : ndarray, shape (N,)
        Delay margin [s] (0 when the closed DOB loop is unstable).
    crossover_hz : ndarray, shape (N,)
        Gain crossover [Hz].
    stable : ndarray of bool, shape (N,)
        The closed DOB loop is stable.
    """

    phase_margin_deg: np.ndarray
    gain_margin_db: np.ndarray
    delay_margin_s: np.ndarray
    crossover_hz: np.ndarray
    stable: np.ndarray

    @classmethod
    def absent(cls, n: int) -> DobBatch:
        """The record of ``n`` designs without a disturbance observer."""
        return cls(np.full(n, np.nan), np.full(n, np.nan), np.full(n, np.nan), np.full(n, np.nan), np.ones(n, bool))


@dataclass(frozen=True)
class AmplificationBatch:
    """Strength amplification C6/C5 with the output locked (paper §II-D, docs/method.md#amplification).

    Attributes
    ----------
    dc : ndarray, shape (N,)
        |C6/C5| at ω → 0 [1].
    bandwidth_hz : ndarray, shape (N,)
        First −3 dB frequency [Hz] (inf: never reached; NaN: search budget spent).
    minimum_phase : ndarray of bool, shape (N,)
        No zero of C6/C5 in the closed right half-plane (False when not conclusive).
    conclusive : ndarray of bool, shape (N,)
        The zero count of the numerator is exact.
    """

    dc: np.ndarray
    bandwidth_hz: np.ndarray
    minimum_phase: np.ndarray
    conclusive: np.ndarray


@dataclass(frozen=True)
class BatchAnalysis:
    """Every docs/method.md#analyses-and-metrics metric of a batch of N designs
    (:func:`~exotune.analysis.analyze_batch`).

    Attributes
    ----------
    free : LoopBatch
        The cuff-free exoskeleton (with ``rigid_body_roots``).
    humans : tuple of FamilyBatch
        One per human family, in the order of the configuration's ``humans``.
    environment : tuple of EnvironmentBatch
        One per environment model, in the order of the configuration's ``environment``.
    passivity : PassivityBatch
        Passivity of C7 (phase excess [deg], non-passive bands [Hz]).
    dob : DobBatch
        DOB-loop margins ([deg], [dB], [s], [Hz]).
    amplification : AmplificationBatch
        DC value, bandwidth [Hz], minimum phase of C6/C5.
    locked : LoopBatch
        The output-locked loop.
    gains : Gains
        The controller gains (:class:`exotune.model.shaping.Gains`), arrays of shape (N,): ``K1``
        [N·m/rad], ``B1`` [N·m·s/rad], ``K2`` [1], ``B2`` [s], ``K2_hat`` [1], ``B2_hat`` [s].
    latency_margin_s : ndarray, shape (N,), or None
        With ``latency=True``: the largest extra delay [s] every loop tolerates
        (docs/method.md#latency-margin); 0 for a design not robust at its nominal delay.

    Examples
    --------
    >>> import exotune
    >>> from exotune.analysis import analyze_batch
    >>> res = analyze_batch(exotune.load_design("examples/scheduled.yaml"))
    >>> res.n, bool(res.free.stable[0]), list(res.to_columns())[:3]
    (1, True, ['free_stable', 'free_rigid_body_roots', 'free_conclusive'])
    """

    free: LoopBatch
    humans: tuple[FamilyBatch, ...]
    environment: tuple[EnvironmentBatch, ...]
    passivity: PassivityBatch
    dob: DobBatch
    amplification: AmplificationBatch
    locked: LoopBatch
    gains: Gains
    latency_margin_s: np.ndarray | None = None

    @property
    def n(self) -> int:
        """The number of designs N."""
        return len(self.free.stable)

    def gain_values(self, t: int) -> dict[str, float]:
        """Design ``t``'s gains by name (:data:`GAIN_NAMES` order), as floats."""
        return {k: float(getattr(self.gains, k)[t]) for k in GAIN_NAMES}

    def human_names(self) -> tuple[str, ...]:
        """``human{i}_{kind}`` per human family: the column prefix and the loop name of the reports."""
        return tuple(f"human{i}_{h.kind}" for i, h in enumerate(self.humans))

    def environment_names(self) -> tuple[str, ...]:
        """``env{i}_{kind}`` per environment model: the column prefix and the loop name of the reports."""
        return tuple(f"env{i}_{e.kind}" for i, e in enumerate(self.environment))

    def loop(self, name: str) -> LoopBatch | FamilyBatch | EnvironmentBatch:
        """The record of the loop called ``name`` in the margin reports (``free``, ``env{i}_{kind}``,
        ``human{i}_{kind}``, a box edge ``human{i}_{kind}_edge{j}``: its box); KeyError if none.
        Its ``verdict`` is ``stable`` of a single loop, ``robust`` of a family."""
        if name == "free":
            return self.free
        base = name.split("_edge")[0]
        for names, recs in ((self.environment_names(), self.environment), (self.human_names(), self.humans)):
            if base in names:
                return recs[names.index(base)]
        raise KeyError(name)

    def loops_ok(self) -> np.ndarray:
        """Per design, the loops of the latency margin all stable: the free exoskeleton, every
        environment, every human family robust over its range (docs/method.md#latency-margin)."""
        ok = self.free.stable.astype(bool)
        for h in self.humans:
            ok = ok & h.robust
        for e in self.environment:
            ok = ok & e.verdict
        return ok

    def all_conclusive(self) -> np.ndarray:
        """Per design, every verdict with an exactness flag conclusive (free, human families,
        passivity, amplification, locked)."""
        ok = self.free.conclusive.astype(bool)
        for x in (*(h.conclusive for h in self.humans), self.passivity.conclusive, self.amplification.conclusive,
                  self.locked.conclusive):
            ok = ok & x
        return ok

    def to_columns(self) -> dict:
        """The columns of docs/sweep-spec.md#columns, in the sweep's schema order: numpy arrays (one
        entry per design) and, for interval-valued metrics, lists of lists of [lo, hi]. The arrays
        are this record's own (not copies)."""
        out: dict = {"free_stable": self.free.stable, "free_rigid_body_roots": self.free.rigid_body_roots,
                     "free_conclusive": self.free.conclusive}
        for key, h in zip(self.human_names(), self.humans):
            out[f"{key}_robust"] = h.robust
            out[f"{key}_stable_intervals"] = h.stable_intervals
            out[f"{key}_conclusive"] = h.conclusive
            out[f"{key}_critical"] = h.critical
            if h.edges is not None:
                out[f"{key}_edges"] = h.edges
            if h.verification_mismatches is not None:
                out[f"{key}_verification_mismatches"] = h.verification_mismatches
        for key, e in zip(self.environment_names(), self.environment):
            if e.stable is not None:
                out[f"{key}_stable"] = e.stable
            else:
                out[f"{key}_robust"] = e.robust
                out[f"{key}_stable_intervals"] = e.stable_intervals
        for prefix, rec in (("passivity", self.passivity), ("dob", self.dob), ("amplification", self.amplification)):
            for f in dataclasses.fields(rec):
                out[f"{prefix}_{f.name}"] = getattr(rec, f.name)
        out["locked_stable"] = self.locked.stable
        out["locked_conclusive"] = self.locked.conclusive
        if self.latency_margin_s is not None:
            out["latency_margin_s"] = self.latency_margin_s
        for g in GAIN_NAMES:
            out[g] = getattr(self.gains, g)
        return out

    def column(self, name: str):
        """One column of :meth:`to_columns` by its name (docs/sweep-spec.md#columns): the lookup of
        user-facing names such as an optimization objective. KeyError when the batch has none."""
        cols = self.to_columns()
        if name not in cols:
            raise KeyError(f"no column {name!r} in this batch analysis")
        return cols[name]

    def take(self, index) -> BatchAnalysis:
        """The designs ``index`` (a slice or an integer array) as a BatchAnalysis."""
        return take_designs(self, index)

    def row(self, i: int) -> BatchAnalysis:
        """Design ``i`` alone: a BatchAnalysis of length 1 (fields indexed ``[0]``)."""
        return take_designs(self, slice(i, i + 1))

    @classmethod
    def concat(cls, parts) -> BatchAnalysis:
        """The designs of ``parts`` (analyses of the same configuration's chunks) in order."""
        return concat_batches(parts)


def take_designs(obj, index):
    """The record ``obj`` (any record of this module) restricted to the designs ``index`` (a slice
    or an integer array): every array and per-design list, nested records and tuples of them
    included; names and None kept.

    Parameters
    ----------
    obj : record, tuple, list, ndarray, str or None
        A record of this module (or one of its fields), one entry per design.
    index : slice or array_like of int
        The designs kept, in this order.

    Returns
    -------
    same type as ``obj``
        The record of those designs alone.
    """
    if obj is None or isinstance(obj, str):
        return obj
    if isinstance(obj, np.ndarray):
        return obj[index]
    if isinstance(obj, list):
        return obj[index] if isinstance(index, slice) else [obj[j] for j in np.asarray(index).tolist()]
    if isinstance(obj, tuple):
        return tuple(take_designs(x, index) for x in obj)
    return type(obj)(**{f.name: take_designs(getattr(obj, f.name), index) for f in dataclasses.fields(obj)})


def concat_batches(parts):
    """The records ``parts`` (same structure: analyses of chunks of one configuration) joined
    design after design: arrays concatenated, per-design lists joined.

    Parameters
    ----------
    parts : sequence of records
        Records of the same structure (the analyses of consecutive chunks), at least one.

    Returns
    -------
    same type as ``parts[0]``
        The record of all their designs, in order.
    """
    first = parts[0]
    if first is None or isinstance(first, str):
        return first
    if isinstance(first, np.ndarray):
        return np.concatenate(parts)
    if isinstance(first, list):
        return [x for p in parts for x in p]
    if isinstance(first, tuple):
        return tuple(concat_batches([p[k] for p in parts]) for k in range(len(first)))
    return type(first)(**{f.name: concat_batches([getattr(p, f.name) for p in parts])
                          for f in dataclasses.fields(first)})
