"""Per-task work budgets of the adaptive frequency-domain algorithms (compiled and numpy alike).

A normal task takes ~50 evaluations and ~100 leaves; a pathological design (e.g. a 1e-12 kg·m²
motor inertia, or a GHz filter, with a delay: the phase of e^{-jωT} winds ~ω_max·T times) could
otherwise run for hours. A task that exhausts its budget is reported unresolved (inconclusive:
never "stable"), not computed forever. Kept apart from the kernels so that the numpy engine never
imports numba (docs/architecture.md).
"""

from __future__ import annotations

__all__ = ["MAX_TASK_EVALS", "MAX_TASK_LEAVES", "MAX_GROUP_EVALS", "GEO_SPLIT_RATIO", "MAG_LEVEL_TOL"]

MAX_TASK_EVALS = 200_000  # argument-principle count: evaluations per task (typical: ~50)
MAX_TASK_LEAVES = 100_000  # adaptive frequency sets: leaves per task (typical: ~100)
# Counts queued as one group (the sub-interval counts of one human family for one design) share
# this budget: a degenerate design can have hundreds of sub-intervals whose counts would each spend
# MAX_TASK_EVALS. A real design's group needs a few thousand evaluations (≤ 84 sub-intervals seen
# with a 50 ms delay); tasks left when it is spent are unresolved.
MAX_GROUP_EVALS = 1_000_000
# Argument-principle counts split a rejected interval [a, b] with b > GEO_SPLIT_RATIO·a at its
# geometric mean (see kernels.phase); the frequency sets (leaves) keep midpoints.
GEO_SPLIT_RATIO = 1.25
# The amplification bandwidth's search accepts a leaf whose ends lie above the −3 dB level only when
# the magnitude provably stays above it inside, up to this many nepers (1e-4 neper ≈ 0.0009 dB): a
# dip below the level by less is not a −3 dB crossing (docs/method.md#amplification). The bound
# tightens as the leaf halves, so a shallow dip just below the level is found, not stepped over.
MAG_LEVEL_TOL = 1e-4
