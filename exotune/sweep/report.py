"""Stability maps and summary tables of a sweep (``exotune report DIR``, SPEC §6).

:func:`make_report` reads a sweep directory (:mod:`exotune.sweep`) and writes, into ``OUT``
(default ``DIR/report``):

``summary.md``
    the sweep (spec hash, exotune version, points, sampling, axes with units), the definition of a
    *robust* design, the overall robust fraction and which criterion fails how often, for every
    axis a table over its values (designs, fraction robust, worst-case key metrics over the other
    axes) with the value ranges where robust designs exist / where every design is robust, the
    robust design with the largest α (when α is swept), and the list of figures.
``axis_<path>.csv``
    the per-axis tables of ``summary.md`` as CSV (SI units, column names carry the unit).
``robust_<a>__<b>.png``
    heatmap over axes a × b of the fraction of robust designs, the other axes aggregated (all
    pairs when there are at most 4 axes, else the pairs of the first 4).
``metrics_<a>__<b>.png``
    one panel per key metric over the same pair, worst case over the other axes: DOB delay margin
    (min), phase and gain margins (min), max phase excess of C7 (max), amplification bandwidth
    (min), the lightest stable inertia of each mass family (max) and the stiffest stable spring of
    each spring-like family (min, only when some design is not robust for that family).
``profile_<path>.png``
    with a single axis: robustness and the key metrics against the axis.

Definitions
-----------
* robust = ``free_stable`` ∧ every ``human*_robust`` ∧ every environment verdict
  (``env*_stable`` for locked/free environments, ``env*_robust`` for spring/mass environment
  ranges). Inconclusive analyses already count as not robust (``*_robust`` requires conclusive).
* lightest stable inertia of a mass family with inertia range [lo, hi]: the lower end of the stable
  interval that contains hi (∞ when hi itself is unstable: no inertia near the heavy end is stable).
* stiffest stable spring of a spring/complex-stiffness family with range [lo, hi]: the upper end of
  the stable interval that contains lo (0 when lo itself is unstable).
* ∞ in a heatmap (no DOB gain crossover, bandwidth never reached, nothing stable) is drawn in the
  colour of the colour bar's "over" arrow; NaN (undefined, e.g. no DOB) is left blank (grey).

Every file is rendered in memory first and then written atomically; matplotlib uses Agg.
"""

from __future__ import annotations

import io
import math
import os
import re
from pathlib import Path

import numpy as np

from ..errors import ConfigError
from ..jsonio import write_atomic
from .engine import read_tables, load_manifest

__all__ = ["make_report", "derived_metrics", "robust_mask", "AXIS_UNITS", "interval_ends"]

AXIS_UNITS = {
    "plant.motor_inertia": "kg·m²",
    "plant.motor_damping": "N·m·s/rad",
    "plant.sea_stiffness": "N·m/rad",
    "plant.joint_inertia": "kg·m²",
    "plant.cuff_stiffness": "N·m/rad",
    "design.amplification": "–",
    "design.felt_inertia": "kg·m²",
    "design.felt_damping": "N·m·s/rad",
    "design.zeta": "–",
    "design.zeta_hat": "–",
    "implementation.delay_s": "s",
    "implementation.gv_filter.cutoff_hz": "Hz",
    "implementation.gv_filter.damping": "–",
    "implementation.derivative_filter.cutoff_hz": "Hz",
    "implementation.dob.cutoff_hz": "Hz",
    "implementation.dob.damping": "–",
    "implementation.velocity_filter.cutoff_hz": "Hz",
}

# column -> (title, unit shown, display factor, worst-case reduction "min"|"max", colormap)
_METRICS = {
    "dob_delay_margin_s": ("DOB delay margin (extra delay tolerated)", "ms", 1e3, "min", "viridis"),
    "dob_phase_margin_deg": ("DOB phase margin", "deg", 1.0, "min", "viridis"),
    "dob_gain_margin_db": ("DOB gain margin", "dB", 1.0, "min", "viridis"),
    "passivity_max_phase_excess_deg": ("max phase excess of C7 outside [−180°, 0°]", "deg", 1.0, "max", "magma_r"),
    "amplification_bandwidth_hz": ("amplification −3 dB bandwidth", "Hz", 1.0, "min", "viridis"),
}
_TABLE_METRICS = ("dob_delay_margin_s", "passivity_max_phase_excess_deg", "amplification_bandwidth_hz")
_MAX_PAIR_AXES = 4
_FAMILY_RE = re.compile(r"^(human|env)(\d+)_(.+)_stable_intervals$")


# ---------------------------------------------------------------------------------------------
# Derived quantities
# ---------------------------------------------------------------------------------------------
def interval_ends(col) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(count, first_lo, first_hi, last_lo, last_hi) per row of a ``list<list<double>>`` column
    (a pyarrow (Chunked)Array, or a sequence of lists of [lo, hi]); NaN where there is none."""
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


def derived_metrics(table, manifest: dict) -> dict[str, tuple[np.ndarray, dict]]:
    """Lightest stable inertia / stiffest stable spring per family, from the interval columns.

    Returns {name: (values, info)} with names ``human{i}_lightest_stable_inertia`` (kg·m²) and
    ``human{i}_stiffest_stable_stiffness`` (N·m/rad) (``env{i}_…`` likewise); ``info`` holds
    title, unit, worst-case reduction and the family range.
    """
    out = {}
    for name in table.column_names:
        mt = _FAMILY_RE.match(name)
        if not mt:
            continue
        side, i, kind = mt.group(1), int(mt.group(2)), mt.group(3)
        fi = _family_info(manifest, side, i)
        if fi is None:
            continue
        _kind, param, lo, hi = fi
        cnt, flo, fhi, llo, lhi = interval_ends(table.column(name))
        tol = 1e-9
        who = "human" if side == "human" else "environment"
        if param == "inertia":
            reach = (cnt > 0) & (lhi >= hi * (1 - tol))
            vals = np.where(reach, llo, np.inf)
            out[f"{side}{i}_lightest_stable_inertia"] = (vals, {
                "title": f"lightest stable inertia, {who} {i} ({kind}, range [{lo:g}, {hi:g}] kg·m²)",
                "unit": "kg·m²", "factor": 1.0, "worst": "max", "cmap": "magma", "log": True,
                "family": name, "range": (lo, hi)})
        elif param == "stiffness":
            reach = (cnt > 0) & (flo <= lo * (1 + tol))
            vals = np.where(reach, fhi, 0.0)
            out[f"{side}{i}_stiffest_stable_stiffness"] = (vals, {
                "title": f"stiffest stable spring, {who} {i} ({kind}, range [{lo:g}, {hi:g}] N·m/rad)",
                "unit": "N·m/rad", "factor": 1.0, "worst": "min", "cmap": "viridis", "log": True,
                "family": name, "range": (lo, hi)})
    return out


def robust_mask(columns: dict) -> tuple[np.ndarray, list[str]]:
    """robust = free_stable ∧ human*_robust ∧ env*_stable/env*_robust; returns (mask, columns used)."""
    used = [c for c in columns if c == "free_stable"]
    used += sorted(c for c in columns if re.match(r"^human\d+_.+_robust$", c))
    used += sorted(c for c in columns if re.match(r"^env\d+_.+_(stable|robust)$", c))
    n = len(next(iter(columns.values()))) if columns else 0
    mask = np.ones(n, dtype=bool)
    for c in used:
        mask &= np.asarray(columns[c], dtype=bool)
    return mask, used


# ---------------------------------------------------------------------------------------------
# Aggregation
# ---------------------------------------------------------------------------------------------
def _aggregate(cells: np.ndarray, ncells: int, values: np.ndarray, how: str) -> np.ndarray:
    """Reduce ``values`` per cell: mean | min | max (NaN-ignoring; NaN for empty cells)."""
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


def _fmt(x, digits=4) -> str:
    if x is None:
        return "—"
    x = float(x)
    if math.isnan(x):
        return "—"
    if math.isinf(x):
        return "∞" if x > 0 else "−∞"
    return f"{x:.{digits}g}"


def _safe(path: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", path)


def _wrap(text: str, width: int = 48) -> str:
    import textwrap

    return "\n".join(textwrap.wrap(text, width))


def _axis_label(path: str) -> str:
    return f"{path} [{AXIS_UNITS.get(path, '?')}]"


# ---------------------------------------------------------------------------------------------
# Plotting
# ---------------------------------------------------------------------------------------------
def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _ticks(values: np.ndarray, maxn: int = 8):
    n = values.size
    step = max(1, int(math.ceil(n / maxn)))
    idx = list(range(0, n, step))
    if idx[-1] != n - 1 and n - 1 - idx[-1] >= step / 2:
        idx.append(n - 1)
    return idx, [f"{values[i]:.3g}" for i in idx]


def _png(fig) -> bytes:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    _plt().close(fig)
    return buf.getvalue()


def _draw_heatmap(fig, ax, grid: np.ndarray, xvals, yvals, xlabel, ylabel, title, cbar_label, *, vmin=None,
                  vmax=None, cmap="viridis", log=False, annotate=False, fmt="{:.2f}", fontsize=10) -> None:
    """Draw grid[iy, ix] into ``ax`` with a colour bar; +inf cells get the colormap's "over" colour,
    NaN cells are grey."""
    from matplotlib import colors

    plt = _plt()
    data = np.array(grid, dtype=float)
    finite = data[np.isfinite(data)]
    has_over = bool(np.any(np.isposinf(data)))
    has_under = bool(np.any(np.isneginf(data)))
    if log:
        pos = finite[finite > 0]
        if pos.size == 0 or (pos.max() / pos.min() < 10):
            log = False
    if vmin is None:
        vmin = (finite[finite > 0].min() if log else finite.min()) if finite.size else 0.0
    if vmax is None:
        vmax = finite.max() if finite.size else 1.0
    if vmax <= vmin:
        vmax = vmin + (abs(vmin) * 0.01 or 1.0)
    cm = plt.get_cmap(cmap).with_extremes(bad="#d0d0d0", over="#ffffff" if cmap.endswith("_r") else "#ff00ff",
                                          under="#000000")
    if log:
        data = np.where((data <= 0) & np.isfinite(data), np.nan, data)
        norm = colors.LogNorm(vmin=vmin, vmax=vmax)
    else:
        norm = colors.Normalize(vmin=vmin, vmax=vmax)
    plot = np.where(np.isposinf(data), vmax * 10 if vmax > 0 else vmax + 1e300, data)
    plot = np.where(np.isneginf(plot), -1e300, plot)
    im = ax.imshow(np.ma.masked_invalid(plot), origin="lower", aspect="auto", cmap=cm, norm=norm,
                   interpolation="nearest")
    extend = "both" if has_over and has_under else "max" if has_over else "min" if has_under else "neither"
    cb = fig.colorbar(im, ax=ax, extend=extend)
    cb.set_label(cbar_label + ("  (arrow: ∞)" if has_over else ""), fontsize=fontsize - 1)
    xi, xl = _ticks(np.asarray(xvals))
    yi, yl = _ticks(np.asarray(yvals))
    ax.set_xticks(xi, xl, rotation=45, ha="right")
    ax.set_yticks(yi, yl)
    ax.set_xlabel(xlabel, fontsize=fontsize - 1)
    ax.set_ylabel(ylabel, fontsize=fontsize - 1)
    ax.set_title(title, fontsize=fontsize)
    if annotate:
        for iy in range(grid.shape[0]):
            for ix in range(grid.shape[1]):
                v = grid[iy, ix]
                if not np.isnan(v):
                    pv = plot[iy, ix]
                    rgba = cm(norm(pv)) if np.isfinite(pv) and not (log and pv <= 0) else (1, 1, 1, 1)
                    lum = 0.299 * rgba[0] + 0.587 * rgba[1] + 0.114 * rgba[2]
                    ax.text(ix, iy, "∞" if np.isinf(v) else fmt.format(v), ha="center", va="center", fontsize=7,
                            color="white" if lum < 0.5 else "black")


def _heatmap(grid: np.ndarray, xvals, yvals, xlabel, ylabel, title, cbar_label, **kw) -> bytes:
    """One heatmap figure as PNG bytes (see :func:`_draw_heatmap`)."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(7.2, 5.4))
    kw.setdefault("annotate", grid.size <= 144)
    _draw_heatmap(fig, ax, grid, xvals, yvals, xlabel, ylabel, title, cbar_label, **kw)
    fig.subplots_adjust(left=0.15, right=0.98, bottom=0.17, top=0.92)
    return _png(fig)


def _heatmap_panels(panels: list[dict], xvals, yvals, xlabel, ylabel, suptitle) -> bytes:
    """Several heatmaps over the same pair of axes in one figure (one panel per metric)."""
    plt = _plt()
    n = len(panels)
    ncols = 1 if n == 1 else 2 if n <= 4 else 3
    nrows = -(-n // ncols)
    fig, axes = plt.subplots(nrows, ncols, figsize=(5.6 * ncols, 4.3 * nrows + 0.5), squeeze=False)
    for ax, p in zip(axes.ravel(), panels):
        grid = p.pop("grid")
        _draw_heatmap(fig, ax, grid, xvals, yvals, xlabel, ylabel, fontsize=9,
                      annotate=grid.size <= 36, **p)
    for ax in axes.ravel()[n:]:
        ax.set_visible(False)
    fig.suptitle(suptitle, fontsize=11)
    H = 4.3 * nrows + 0.5
    fig.subplots_adjust(left=0.25 / ncols, right=0.97, bottom=0.75 / H, top=1 - 0.95 / H, wspace=0.45,
                        hspace=0.6)
    return _png(fig)


def _profile(x, series, xlabel, logx, title) -> bytes:
    plt = _plt()
    n = len(series)
    fig, axes = plt.subplots(n, 1, figsize=(7, 1.9 * n + 0.8), sharex=True, squeeze=False)
    for ax, (label, y) in zip(axes[:, 0], series):
        y = np.asarray(y, float)
        fin = np.isfinite(y)
        ax.plot(x[fin], y[fin], "o-", ms=3)
        if np.any(np.isposinf(y)):
            top = np.nanmax(y[fin]) if fin.any() else 1.0
            ax.plot(x[np.isposinf(y)], np.full(int(np.isposinf(y).sum()), top), "^", color="m", ms=5, label="∞")
            ax.legend(fontsize=7, loc="best")
        ax.set_ylabel(label, fontsize=8)
        ax.grid(True, alpha=0.3)
        if logx:
            ax.set_xscale("log")
    axes[-1, 0].set_xlabel(xlabel)
    axes[0, 0].set_title(title, fontsize=10)
    fig.tight_layout()
    return _png(fig)


# ---------------------------------------------------------------------------------------------
# The report
# ---------------------------------------------------------------------------------------------
def make_report(sweep_dir, out_dir=None) -> Path:
    """Write stability maps and summary tables of the sweep in ``sweep_dir`` (see the module
    docstring); returns the output directory. A partial sweep is reported as such."""
    sweep_dir = os.fspath(sweep_dir)
    m = load_manifest(sweep_dir)
    out = Path(out_dir) if out_dir is not None else Path(sweep_dir) / "report"
    col_names = [c[0] for c in (m.get("columns") or [])]
    if not col_names:
        raise ConfigError(sweep_dir, "the sweep has no results yet (no chunk finished); run `exotune sweep` first")
    paths = [a["path"] for a in m["axes"]]
    values = [np.asarray(m["spec"]["axes"][p]["values"], dtype=float) for p in paths]
    scales = [m["spec"]["axes"][p].get("scale", "list") for p in paths]
    shape = tuple(v.size for v in values)

    want = {"point_index", "free_stable", *paths, *_METRICS, "amplification_dc"}
    want |= {c for c in col_names if re.match(r"^(human|env)\d+_.+_(robust|stable|conclusive|stable_intervals)$", c)}
    want |= {c for c in col_names if c.endswith("_conclusive")}
    cols = [c for c in col_names if c in want]
    _, table, missing = read_tables(sweep_dir, cols, allow_partial=True)
    if table is None:
        raise ConfigError(sweep_dir, "the sweep has no results yet (no chunk finished); run `exotune sweep` first")
    n = table.num_rows
    simple = {c: table.column(c).to_numpy() for c in cols if "intervals" not in c}
    robust, used = robust_mask({c: simple[c] for c in simple if c == "free_stable"
                                or re.match(r"^(human|env)\d+_.+_(robust|stable)$", c)})
    gidx = np.asarray(simple["point_index"], dtype=np.int64)
    axis_idx = list(np.unravel_index(gidx, shape))
    # maps, ranges and tables go by value: an axis listed out of order is sorted here
    for j, v in enumerate(values):
        order = np.argsort(v, kind="stable")
        rank = np.empty_like(order)
        rank[order] = np.arange(order.size)
        axis_idx[j], values[j] = rank[axis_idx[j]], v[order]
    axis_idx = tuple(axis_idx)

    metrics: dict[str, tuple[np.ndarray, dict]] = {}
    for c, (title, unit, factor, worst, cmap) in _METRICS.items():
        if c in simple:
            v = np.asarray(simple[c], dtype=float)
            if np.all(np.isnan(v)):
                continue
            metrics[c] = (v, {"title": title, "unit": unit, "factor": factor, "worst": worst, "cmap": cmap, "log": False})
    derived = derived_metrics(table, m)
    for k, (v, info) in derived.items():
        fam_rob = info["family"].replace("_stable_intervals", "_robust")
        if info["worst"] == "min" and fam_rob in simple and bool(np.all(simple[fam_rob])):
            continue  # the stiffest stable spring is the range end everywhere: nothing to map
        metrics[k] = (v, info)

    files: dict[str, bytes] = {}
    figures: list[tuple[str, str]] = []

    # ---- maps over pairs of axes -------------------------------------------------------------
    k = len(paths)
    pair_axes = list(range(min(k, _MAX_PAIR_AXES)))
    pairs = [(a, b) for ii, a in enumerate(pair_axes) for b in pair_axes[ii + 1:]]
    for a, b in pairs:
        # x = axis b? keep the first-listed axis on x
        nx, ny = shape[a], shape[b]
        cells = axis_idx[a] * ny + axis_idx[b]  # index (ix, iy) -> ix*ny + iy
        others = [paths[j] for j in range(k) if j not in (a, b)]
        agg_note = f" — aggregated over {', '.join(others)}" if others else ""
        frac = _aggregate(cells, nx * ny, robust.astype(float), "mean").reshape(nx, ny).T
        name = f"robust_{_safe(paths[a])}__{_safe(paths[b])}.png"
        title = ("fraction of robust designs" if others else "robust designs (1 = robust)") + agg_note
        files[name] = _heatmap(frac, values[a], values[b], _axis_label(paths[a]), _axis_label(paths[b]),
                               title, "fraction robust", vmin=0.0, vmax=1.0, cmap="RdYlGn", fmt="{:.2f}")
        figures.append((name, f"{title} ({paths[a]} × {paths[b]})"))
        panels = []
        for mk, (v, info) in metrics.items():
            grid = _aggregate(cells, nx * ny, v * info["factor"], info["worst"]).reshape(nx, ny).T
            if np.all(np.isnan(grid)):
                continue
            wc = f"worst case ({info['worst']})" if others else ""
            panels.append({"grid": grid, "title": _wrap(info["title"] + (f" — {wc}" if wc else "")),
                           "cbar_label": f"{mk} [{info['unit']}]", "cmap": info["cmap"],
                           "log": info.get("log", False), "fmt": "{:.3g}"})
        if panels:
            name = f"metrics_{_safe(paths[a])}__{_safe(paths[b])}.png"
            sup = f"key metrics over {paths[a]} × {paths[b]}" + (
                f" (worst case over {', '.join(others)})" if others else "")
            files[name] = _heatmap_panels(panels, values[a], values[b], _axis_label(paths[a]),
                                          _axis_label(paths[b]), sup)
            figures.append((name, sup + ": " + ", ".join(metrics)))

    # ---- 1-D profiles --------------------------------------------------------------------------
    if k == 1:
        x = values[0]
        cells = axis_idx[0]
        series = [("fraction robust", _aggregate(cells, x.size, robust.astype(float), "mean"))]
        for mk, (v, info) in metrics.items():
            series.append((f"{mk}\n[{info['unit']}]", _aggregate(cells, x.size, v * info["factor"], info["worst"])))
        name = f"profile_{_safe(paths[0])}.png"
        files[name] = _profile(x, series, _axis_label(paths[0]), scales[0] == "log", f"sweep over {paths[0]}")
        figures.append((name, f"robustness and key metrics against {paths[0]}"))

    # ---- tables ----------------------------------------------------------------------------------
    table_metrics = [c for c in _TABLE_METRICS if c in metrics] + [c for c in metrics if c.endswith("_lightest_stable_inertia")]
    md = _summary_md(sweep_dir, m, n, missing, paths, values, scales, shape, axis_idx, robust, used,
                     simple, metrics, table_metrics, figures, files)
    files["summary.md"] = md.encode("utf-8")

    try:
        for rel, data in files.items():
            write_atomic(out / rel, data)
    except OSError as e:
        raise ConfigError(str(out), f"cannot write the report: {e.strerror or e}") from None
    return out


def _axis_table(j, paths, values, axis_idx, robust, metrics, table_metrics):
    """Rows: (value, n, frac robust, {metric: (min, max)})."""
    nv = values[j].size
    cells = axis_idx[j]
    counts = np.bincount(cells, minlength=nv)
    frac = _aggregate(cells, nv, robust.astype(float), "mean")
    stats = {}
    for mk in table_metrics:
        v, info = metrics[mk]
        stats[mk] = (_aggregate(cells, nv, v, "min"), _aggregate(cells, nv, v, "max"))
    return counts, frac, stats


def value_runs(vals, ok, digits: int = 4) -> str:
    """Human-readable runs of consecutive axis values where ok, e.g. '1.5 … 4.4, 9.4 … 20'."""
    runs, i, n = [], 0, len(vals)
    while i < n:
        if ok[i]:
            j = i
            while j + 1 < n and ok[j + 1]:
                j += 1
            runs.append(f"{vals[i]:.{digits}g}" if i == j else f"{vals[i]:.{digits}g} … {vals[j]:.{digits}g}")
            i = j + 1
        else:
            i += 1
    return ", ".join(runs) if runs else "none"


def _display_path(p) -> str:
    """A path as shown in reports: relative to the working directory when it lies below it,
    otherwise only its last two components (reports get committed and shared: no machine paths)."""
    import os

    p = os.path.abspath(str(p))
    rel = os.path.relpath(p, os.getcwd())
    if not rel.startswith(".."):
        return rel
    parts = p.rstrip(os.sep).split(os.sep)
    return os.path.join("…", *parts[-2:])


def _summary_md(sweep_dir, m, n, missing, paths, values, scales, shape, axis_idx, robust, used, simple,
                metrics, table_metrics, figures, files) -> str:
    L = []
    L.append("# exotune sweep report")
    L.append("")
    L.append(f"- sweep directory: `{_display_path(sweep_dir)}`")
    L.append(f"- spec hash: `{m.get('spec_hash')}`; exotune {m.get('exotune_version')}; status: {m.get('status')}")
    samp = m.get("sampling", {})
    if samp.get("sample") is not None:
        L.append(f"- designs: {n} of {m.get('n_points')} — a uniform random sample (seed {samp.get('seed')}) "
                 f"of a {' × '.join(map(str, shape))} = {m.get('grid_points')}-point grid")
    else:
        L.append(f"- designs: {n} of {m.get('n_points')} (full grid {' × '.join(map(str, shape))})")
    if missing:
        L.append(f"- **partial sweep**: {len(missing)} chunk(s) missing; the tables cover the finished chunks only")
    if m.get("base_source"):
        L.append(f"- base design: `{_display_path(m['base_source'])}`")
    if m.get("model"):
        L.append(f"- model: {m['model']}")
    L.append("- gains in torque units (SPEC §4); frequencies in Hz; ∞ = unbounded (no crossover, never reached); "
             "— = undefined or no data")
    L.append("")
    L.append("## Axes")
    L.append("")
    L.append("| axis | unit | values | range | scale |")
    L.append("|---|---|---|---|---|")
    for p, v, s in zip(paths, values, scales):
        L.append(f"| `{p}` | {AXIS_UNITS.get(p, '?')} | {v.size} | {v.min():.4g} … {v.max():.4g} | {s} |")
    L.append("")
    L.append("## Robustness")
    L.append("")
    L.append("A design is **robust** when all of these hold: " + ", ".join(f"`{c}`" for c in used) + ".")
    L.append("Family verdicts (`*_robust`) require the whole configured range to be stable and the analysis "
             "to be conclusive.")
    L.append("")
    nrob = int(robust.sum())
    L.append(f"Robust designs: **{nrob} of {n}** ({100.0 * nrob / max(n, 1):.1f} %).")
    L.append("")
    L.append("| criterion | designs failing | fraction failing |")
    L.append("|---|---|---|")
    for c in used:
        fail = int((~np.asarray(simple[c], bool)).sum())
        L.append(f"| `{c}` | {fail} | {fail / max(n, 1):.3f} |")
    inconc = [c for c in simple if c.endswith("_conclusive")]
    if inconc:
        bad = np.zeros(n, bool)
        for c in inconc:
            bad |= ~np.asarray(simple[c], bool)
        L.append("")
        L.append(f"Inconclusive analyses (any `*_conclusive` false, counted as not robust): {int(bad.sum())}.")
    if metrics:
        L.append("")
        L.append("Key metrics over all designs (min … max):")
        L.append("")
        L.append("| metric | unit | min | max | min over robust designs |")
        L.append("|---|---|---|---|---|")
        for mk, (v, info) in metrics.items():
            f = info["factor"]
            vr = v[robust]
            L.append(
                f"| `{mk}` | {info['unit']} | {_fmt(np.nanmin(v) * f if np.any(~np.isnan(v)) else np.nan)} | "
                f"{_fmt(np.nanmax(v) * f if np.any(~np.isnan(v)) else np.nan)} | "
                f"{_fmt(np.nanmin(vr) * f if vr.size and np.any(~np.isnan(vr)) else np.nan)} |"
            )
        L.append("")
        L.append("Derived metrics: *lightest stable inertia* = lower end of the stable interval containing the "
                 "family's upper inertia (∞: the heavy end itself is unstable); *stiffest stable spring* = upper "
                 "end of the stable interval containing the family's lower stiffness (0: the soft end is unstable).")

    # ---- per axis --------------------------------------------------------------------------
    L.append("")
    L.append("## Per axis")
    for j, p in enumerate(paths):
        counts, frac, stats = _axis_table(j, paths, values, axis_idx, robust, metrics, table_metrics)
        others = [q for q in paths if q != p]
        unit = AXIS_UNITS.get(p, "?")
        L.append("")
        L.append(f"### `{p}` [{unit}]")
        L.append("")
        agg = f" (each row aggregates over {', '.join(f'`{q}`' for q in others)})" if others else ""
        seen = counts > 0
        L.append(f"Robust designs exist for {p} ∈ {{{value_runs(values[j], seen & (frac > 0))}}}; every design is "
                 f"robust for {p} ∈ {{{value_runs(values[j], seen & (frac >= 1.0))}}}{agg}.")
        L.append("")
        head = ["value", "designs", "fraction robust"]
        csv_head = [f"{p} [{unit}]", "designs", "fraction_robust"]
        for mk in table_metrics:
            info = metrics[mk][1]
            head += [f"{mk} min [{info['unit']}]", f"{mk} max [{info['unit']}]"]
            csv_head += [f"{mk}_min [{info['unit']}]", f"{mk}_max [{info['unit']}]"]
        L.append("| " + " | ".join(head) + " |")
        L.append("|" + "---|" * len(head))
        csv = [",".join(f'"{h}"' for h in csv_head)]
        for iv, val in enumerate(values[j]):
            row = [f"{val:.4g}", str(int(counts[iv])), _fmt(frac[iv], 3)]
            crow = [repr(float(val)), str(int(counts[iv])), "" if np.isnan(frac[iv]) else repr(float(frac[iv]))]
            for mk in table_metrics:
                f = metrics[mk][1]["factor"]
                lo, hi = stats[mk][0][iv] * f, stats[mk][1][iv] * f
                row += [_fmt(lo), _fmt(hi)]
                crow += ["" if np.isnan(lo) else repr(float(lo)), "" if np.isnan(hi) else repr(float(hi))]
            L.append("| " + " | ".join(row) + " |")
            csv.append(",".join(crow))
        files[f"axis_{_safe(p)}.csv"] = ("\n".join(csv) + "\n").encode("utf-8")

    # ---- best design -----------------------------------------------------------------------
    if "design.amplification" in paths and robust.any():
        j = paths.index("design.amplification")
        a = values[j][axis_idx[j]]
        cand = np.flatnonzero(robust)
        best = cand[np.argmax(a[cand])]
        L.append("")
        L.append("## Robust design with the largest amplification")
        L.append("")
        L.append("| " + " | ".join(f"`{p}`" for p in paths) + " | " + " | ".join(f"`{mk}` [{metrics[mk][1]['unit']}]" for mk in table_metrics) + " |")
        L.append("|" + "---|" * (len(paths) + len(table_metrics)))
        row = [f"{values[jj][axis_idx[jj][best]]:.4g}" for jj in range(len(paths))]
        row += [_fmt(metrics[mk][0][best] * metrics[mk][1]["factor"]) for mk in table_metrics]
        L.append("| " + " | ".join(row) + " |")

    L.append("")
    L.append("## Figures")
    L.append("")
    if len(paths) > _MAX_PAIR_AXES:
        L.append(f"(maps cover the pairs of the first {_MAX_PAIR_AXES} axes)")
        L.append("")
    for name, caption in figures:
        L.append(f"- [{name}]({name}): {caption}")
    L.append("")
    L.append("Per-axis tables as CSV: " + ", ".join(f"[axis_{_safe(p)}.csv](axis_{_safe(p)}.csv)" for p in paths) + ".")
    L.append("")
    return "\n".join(L)
