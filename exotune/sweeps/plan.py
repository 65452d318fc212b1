"""The plan of a sweep: index arithmetic from a dataset row to a design point.

Row ``i`` is grid point ``g = i`` for a full sweep, or ``g = π_seed(i)`` (a seeded Feistel
permutation of the grid index space, restricted to the grid by cycle walking) with ``--sample``;
the grid is flattened in C order over the axes as listed (see the :mod:`exotune.sweeps` package
docstring). Any chunk is generated independently, in memory proportional to the chunk.
"""

from __future__ import annotations

import numpy as np

from ..config import design_from_mapping
from ..config.design import hash_mapping

__all__ = ["SweepPlan", "chunk_points"]

_FEISTEL_ROUNDS = 6


class SweepPlan:
    """A validated sweep: normalized spec, its hash, grid shape and the row → point mapping."""

    def __init__(self, normalized: dict, cfg=None, source: str | None = None, base_source: str | None = None):
        self.spec = normalized
        self.hash = hash_mapping(normalized)
        self.cfg = cfg if cfg is not None else design_from_mapping(normalized["base"], source="<sweep base>")
        self.source = source
        self.base_source = base_source
        self.paths = list(normalized["axes"])
        self.values = [np.asarray(normalized["axes"][p]["values"], dtype=float) for p in self.paths]
        self.shape = tuple(v.size for v in self.values)
        self.grid_points = int(np.prod(self.shape, dtype=object))
        self.sample = normalized.get("sample")
        self.seed = normalized.get("seed")
        self.n_points = self.grid_points if self.sample is None else int(self.sample)
        self.chunk_size = int(normalized["chunk_size"])
        self.n_chunks = -(-self.n_points // self.chunk_size)
        self._keys = None
        if self.sample is not None:
            ss = np.random.SeedSequence([int(self.seed), 0x5EE9])
            self._keys = ss.generate_state(_FEISTEL_ROUNDS, dtype=np.uint64)

    def chunk_range(self, index: int) -> tuple[int, int]:
        if not 0 <= index < self.n_chunks:
            raise IndexError(f"chunk {index} out of range (0..{self.n_chunks - 1})")
        start = index * self.chunk_size
        return start, min(start + self.chunk_size, self.n_points)

    def grid_index(self, positions: np.ndarray) -> np.ndarray:
        """Grid point (C-order flat index) of each dataset row position."""
        pos = np.asarray(positions, dtype=np.int64)
        if self.sample is None:
            return pos.copy()
        return _permute(pos, self.grid_points, self._keys)

    def points(self, positions: np.ndarray) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        g = self.grid_index(positions)
        idx = np.unravel_index(g, self.shape)
        return g, {p: v[i] for p, v, i in zip(self.paths, self.values, idx)}


def _feistel(y: np.ndarray, half: int, keys) -> np.ndarray:
    mask = np.uint64((1 << half) - 1)
    h = np.uint64(half)
    L = y >> h
    R = y & mask
    m1 = np.uint64(0x9E3779B97F4A7C15)
    m2 = np.uint64(0xBF58476D1CE4E5B9)
    m3 = np.uint64(0x94D049BB133111EB)
    for k in keys:
        x = (R ^ np.uint64(k)) * m1
        x ^= x >> np.uint64(30)
        x *= m2
        x ^= x >> np.uint64(27)
        x *= m3
        x ^= x >> np.uint64(31)
        L, R = R, (L ^ x) & mask
    return (L << h) | R


def _permute(x: np.ndarray, M: int, keys) -> np.ndarray:
    """Seeded pseudo-random bijection of [0, M) applied to ``x`` (Feistel network + cycle walking)."""
    if M == 1:
        return np.zeros_like(x)
    bits = max(2, int(M - 1).bit_length())
    bits += bits % 2
    half = bits // 2
    y = x.astype(np.uint64)
    with np.errstate(over="ignore"):
        y = _feistel(y, half, keys)
        out = y >= np.uint64(M)
        while out.any():
            y[out] = _feistel(y[out], half, keys)
            out = y >= np.uint64(M)
    return y.astype(np.int64)


def chunk_points(plan: SweepPlan, index: int) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """(grid indices, {axis path: values}) of the rows of chunk ``index``.

    Parameters
    ----------
    plan : SweepPlan
        The sweep's plan.
    index : int
        Chunk index (from 0).

    Returns
    -------
    indices : numpy.ndarray
        Flat grid index per row (int64).
    values : dict of str to numpy.ndarray
        Each axis' value per row (SI units).
    """
    start, stop = plan.chunk_range(index)
    return plan.points(np.arange(start, stop, dtype=np.int64))
