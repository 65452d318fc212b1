"""What a sweep report computes from the rows: robustness, the key metrics and their worst cases.

Definitions (robust design, lightest stable inertia, stiffest stable spring) are in the
:mod:`exotune.plots.sweep_report` module docstring.
"""

from __future__ import annotations

import re

import numpy as np

from ..units import path_unit

__all__ = ["AXIS_UNITS", "METRICS", "TABLE_METRICS", "MAX_PAIR_AXES", "interval_ends", "derived_metrics",
           "robust_mask", "aggregate"]

AXIS_UNITS = {p: path_unit(p, dimensionless="–") for p in (
    "plant.motor_inertia", "plant.motor_damping", "plant.sea_stiffness", "plant.joint_inertia", "plant.cuff_stiffness",
    "design.amplification", "design.felt_inertia", "design.felt_damping", "design.zeta", "design.zeta_hat",
    "implementation.delay_s", "implementation.gv_filter.cutoff_hz", "implementation.gv_filter.damping",
    "implementation.derivative_filter.cutoff_hz", "implementation.dob.cutoff_hz", "implementation.dob.damping",
    "implementation.velocity_filter.cutoff_hz")}

# column -> (title, unit shown, display factor, worst-case reduction "min"|"max", colormap)
METRICS = {
    "latency_margin_s": ("latency margin (extra delay every loop tolerates)", "ms", 1e3, "min", "viridis"),
    "sampled_latency_margin_samples": ("sampled-data latency margin (extra delay the runtime's loop tolerates)", "samples", 1.0, "min", "viridis"),
    "plant_margin_lower": ("plant-uncertainty margin, certified lower bound (multiples of the declared uncertainty)", "–", 1.0, "min", "viridis"),
    "dob_delay_margin_s": ("DOB delay margin (extra delay tolerated)", "ms", 1e3, "min", "viridis"),
    "dob_phase_margin_deg": ("DOB phase margin", "deg", 1.0, "min", "viridis"),
    "dob_gain_margin_db": ("DOB gain margin", "dB", 1.0, "min", "viridis"),
    "passivity_max_phase_excess_deg": ("max phase excess of C7 outside [−180°, 0°]", "deg", 1.0, "max", "magma_r"),
    "amplification_bandwidth_hz": ("amplification −3 dB bandwidth", "Hz", 1.0, "min", "viridis"),
}
TABLE_METRICS = ("latency_margin_s", "sampled_latency_margin_samples", "plant_margin_lower", "dob_delay_margin_s", "passivity_max_phase_excess_deg", "amplification_bandwidth_hz")
MAX_PAIR_AXES = 4
_FAMILY_RE = re.compile(r"^(sampled_)?(human|env)(\d+)_(.+)_stable_intervals$")


# ---------------------------------------------------------------------------------------------
# Derived quantities
# ---------------------------------------------------------------------------------------------
def interval_ends(col) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(count, first_lo, first_hi, last_lo, last_hi) per row of a ``list<list<double>>`` column
    (a pyarrow (Chunked)Array, or a sequence of lists of [lo, hi]); NaN where there is none.

    Parameters
    ----------
    col : pyarrow.Array, pyarrow.ChunkedArray or sequence
        The interval column.

    Returns
    -------
    count : numpy.ndarray
        Intervals per row (int).
    first_lo, first_hi, last_lo, last_hi : numpy.ndarray
        Ends of the first and the last interval per row, in the column's unit.

    Raises
    ------
    ValueError
        When an entry is not a [lo, hi] pair.
    """
    import pyarrow as pa
    import pyarrow.compute as pc

    if not isinstance(col, (pa.Array, pa.ChunkedArray)):
        col = pa.array([[list(map(float, iv)) for iv in row] for row in col], type=pa.list_(pa.list_(pa.float64())))
    chunks = col.chunks if isinstance(col, pa.ChunkedArray) else [col]
    outs = []
    for arr in chunks:
        counts = pc.fill_null(pc.list_value_length(arr), 0).to_numpy(zero_copy_only=False).astype(np.int64)
        inner = pc.list_flatten(arr)
        flat = pc.list_flatten(inner).to_numpy(zero_copy_only=False).astype(float)
        lens = pc.list_value_length(inner).to_numpy(zero_copy_only=False)
        if lens.size and not np.all(lens == 2):
            raise ValueError("interval column with entries that are not [lo, hi] pairs")
        pairs = flat.reshape(-1, 2)
        n = counts.size
        first = np.full((n, 2), np.nan)
        last = np.full((n, 2), np.nan)
        has = counts > 0
        start = np.concatenate([[0], np.cumsum(counts)[:-1]]) if n else np.zeros(0, np.int64)
        first[has] = pairs[start[has]]
        last[has] = pairs[start[has] + counts[has] - 1]
        outs.append((counts, first[:, 0], first[:, 1], last[:, 0], last[:, 1]))
    if not outs:
        z = np.zeros(0)
        return z.astype(np.int64), z, z, z, z
    return tuple(np.concatenate([o[k] for o in outs]) for k in range(5))


def _family_info(manifest: dict, side: str, i: int):
    key = "humans" if side == "human" else "environment"
    fams = (manifest.get("spec", {}).get("base", {}) or {}).get(key) or []
    if i >= len(fams):
        return None
    fam = fams[i]
    kind = fam.get("kind")
    ranged = [q for q in ("inertia", "stiffness", "damping")
              if isinstance(fam.get(q), (list, tuple)) and len(fam[q]) == 2 and fam[q][0] != fam[q][1]]
    if len(ranged) > 1:  # a box family: its interval column is [[lo, hi]] when robust, [] otherwise
        return None
    for param in ("inertia", "stiffness", "damping"):
        v = fam.get(param)
        if isinstance(v, (list, tuple)) and len(v) == 2:
            return kind, param, float(v[0]), float(v[1])
    return None


def _checked_column(table, name: str):
    """The interval column ``name`` less the unresolved cells of its ``…_unresolved_cells`` column,
    when it has one (the sampled-data families: :func:`~exotune.sweeps.sampledcols.checked_intervals`)."""
    import pyarrow.compute as pc

    col = table.column(name)
    cells_name = name[: -len("_stable_intervals")] + "_unresolved_cells"
    if cells_name not in table.column_names:
        return col
    cells = table.column(cells_name)
    if not np.any(pc.fill_null(pc.list_value_length(cells), 0).to_numpy(zero_copy_only=False)):
        return col
    from .sampledcols import checked_intervals

    return [checked_intervals(iv or [], c or []) for iv, c in zip(col.to_pylist(), cells.to_pylist())]


def derived_metrics(table, manifest: dict) -> dict[str, tuple[np.ndarray, dict]]:
    """Lightest stable inertia / stiffest stable spring per family, from the interval columns (less
    the unresolved cells a sampled-data family lists: only checked members count).

    Returns {name: (values, info)} with names ``human{i}_lightest_stable_inertia`` (kg·m²) and
    ``human{i}_stiffest_stable_stiffness`` (N·m/rad) (``env{i}_…`` likewise); ``info`` holds
    title, unit, worst-case reduction and the family range.

    Parameters
    ----------
    table : pyarrow.Table
        The sweep's rows (with the ``*_stable_intervals`` columns).
    manifest : dict
        The sweep's manifest (the family kinds and ranges of its spec).

    Returns
    -------
    dict
        ``{name: (values, info)}`` as described above.
    """
    out = {}
    for name in table.column_names:
        mt = _FAMILY_RE.match(name)
        if not mt:
            continue
        pre, side, i, kind = mt.group(1) or "", mt.group(2), int(mt.group(3)), mt.group(4)
        fi = _family_info(manifest, side, i)
        if fi is None:
            continue
        _kind, param, lo, hi = fi
        cnt, flo, fhi, llo, lhi = interval_ends(_checked_column(table, name))
        tol = 1e-9
        who = "human" if side == "human" else "environment"
        if param == "inertia":
            reach = (cnt > 0) & (lhi >= hi * (1 - tol))
            vals = np.where(reach, llo, np.inf)
            out[f"{pre}{side}{i}_lightest_stable_inertia"] = (vals, {
                "title": f"{'sampled-data ' if pre else ''}lightest stable inertia, {who} {i} ({kind}, range [{lo:g}, {hi:g}] kg·m²)",
                "unit": "kg·m²", "factor": 1.0, "worst": "max", "cmap": "magma", "log": True,
                "family": name, "range": (lo, hi)})
        elif param == "stiffness":
            reach = (cnt > 0) & (flo <= lo * (1 + tol))
            vals = np.where(reach, fhi, 0.0)
            out[f"{pre}{side}{i}_stiffest_stable_stiffness"] = (vals, {
                "title": f"{'sampled-data ' if pre else ''}stiffest stable spring, {who} {i} ({kind}, range [{lo:g}, {hi:g}] N·m/rad)",
                "unit": "N·m/rad", "factor": 1.0, "worst": "min", "cmap": "viridis", "log": True,
                "family": name, "range": (lo, hi)})
    return out


def robust_mask(columns: dict) -> tuple[np.ndarray, list[str]]:
    """robust = free_stable ∧ human*_robust ∧ env*_stable/env*_robust (∧ schedule_robust with a gain
    schedule), and with sampled-data columns also sampled_free_stable ∧ sampled_locked_stable ∧
    sampled_*_robust (∧ sampled_schedule_robust); returns (mask, columns used).

    Parameters
    ----------
    columns : dict
        Column name → per-row values (the verdict columns of the sweep).

    Returns
    -------
    mask : numpy.ndarray
        Whether each row is robust (bool).
    used : list of str
        The columns the mask combines.
    """
    used = [c for c in columns if c == "free_stable"]
    used += sorted(c for c in columns if re.match(r"^human\d+_.+_robust$", c))
    used += sorted(c for c in columns if re.match(r"^env\d+_.+_(stable|robust)$", c))
    used += sorted(c for c in columns if c in ("sampled_free_stable", "sampled_locked_stable"))
    used += sorted(c for c in columns if re.match(r"^sampled_(human|env)\d+_.+_robust$", c))
    used += [c for c in ("schedule_robust", "sampled_schedule_robust") if c in columns]
    n = len(next(iter(columns.values()))) if columns else 0
    mask = np.ones(n, dtype=bool)
    for c in used:
        mask &= np.asarray(columns[c], dtype=bool)
    return mask, used


# ---------------------------------------------------------------------------------------------
# Aggregation
# ---------------------------------------------------------------------------------------------
def aggregate(cells: np.ndarray, ncells: int, values: np.ndarray, how: str) -> np.ndarray:
    """Reduce ``values`` per cell: mean | min | max (NaN-ignoring; NaN for empty cells).

    Parameters
    ----------
    cells : numpy.ndarray
        Cell index per value (int).
    ncells : int
        Number of cells.
    values : numpy.ndarray
        The values.
    how : str
        ``"mean"``, ``"min"`` or ``"max"``.

    Returns
    -------
    numpy.ndarray
        One value per cell (ncells,).
    """
    values = np.asarray(values, dtype=float)
    if how == "mean":
        ok = ~np.isnan(values)
        s = np.bincount(cells[ok], weights=values[ok], minlength=ncells)
        c = np.bincount(cells[ok], minlength=ncells)
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(c > 0, s / np.maximum(c, 1), np.nan)
    out = np.full(ncells, np.nan)
    if how == "min":
        np.fmin.at(out, cells, values)
    else:
        np.fmax.at(out, cells, values)
    return out
