"""Stability maps and summary tables of a sweep (``exotune report DIR``, docs/sweep-spec.md).

:func:`make_report` reads a sweep directory (:mod:`exotune.sweeps`) and writes, into ``OUT``
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
    one panel per key metric over the same pair, sliced at the base design's value of every other
    axis along which the design runs into instability (some of its values have no robust design),
    worst case over the remaining axes: DOB delay margin
    (min), phase and gain margins (min), max phase excess of C7 (max), amplification bandwidth
    (min), the lightest stable inertia of each mass family (max) and the stiffest stable spring of
    each spring-like family (min, only when some design is not robust for that family).
``profile_<path>.png``
    with a single axis: robustness and the key metrics against the axis.

Definitions
-----------
* robust = ``free_stable`` ∧ every ``human*_robust`` ∧ every environment verdict
  (``env*_stable`` for locked/free environments, ``env*_robust`` for spring/mass environment
  ranges); a sweep with ``sampled: true`` also requires its sampled-data verdicts
  (``sampled_free_stable``, ``sampled_locked_stable``, every ``sampled_*_robust``). Inconclusive analyses already count as not robust (``*_robust`` requires conclusive).
* lightest stable inertia of a mass family with inertia range [lo, hi]: the lower end of the stable
  interval that contains hi (∞ when hi itself is unstable: no inertia near the heavy end is stable).
* stiffest stable spring of a spring/complex-stiffness family with range [lo, hi]: the upper end of
  the stable interval that contains lo (0 when lo itself is unstable).
* ∞ in a heatmap (no DOB gain crossover, bandwidth never reached, nothing stable) is drawn in the
  colour of the colour bar's "over" arrow; NaN (undefined, e.g. no DOB) is left blank (grey).

Every file is rendered in memory first; the set is written all or none (staged in a temporary
directory next to ``OUT``, then renamed: a full disk leaves no partial report); matplotlib uses
Agg. ``OUT`` (or ``DIR/report``) and the files in it must not be symbolic links.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np

from ..errors import ConfigError
from ..jsonio import write_outputs
from .sweep import heatmap, heatmap_panels, profile_figure
from ..sweeps.dataset import read_tables, verified_manifest
from ..sweeps.manifest import refuse_link
from ..sweeps.result import SweepReport
from ..sweeps.metrics import AXIS_UNITS, MAX_PAIR_AXES, METRICS, TABLE_METRICS, aggregate, derived_metrics, robust_mask
from ..sweeps.summary import safe_name, summary_md

__all__ = ["make_report"]


def _wrap(text: str, width: int = 48) -> str:
    import textwrap

    return "\n".join(textwrap.wrap(text, width))


def _axis_label(path: str) -> str:
    return f"{path} [{AXIS_UNITS.get(path, '?')}]"


def make_report(sweep_dir, out_dir=None) -> SweepReport:
    """Write stability maps and summary tables of a sweep.

    The files (``summary.md``, ``axis_<path>.csv``, ``robust_<a>__<b>.png``,
    ``metrics_<a>__<b>.png``, ``profile_<path>.png``) are described in the module docstring; each
    is rendered in memory and then written atomically. A partial sweep is reported as such.

    Parameters
    ----------
    sweep_dir : str or os.PathLike
        A sweep directory written by :func:`~exotune.sweeps.run.run_sweep`.
    out_dir : str or os.PathLike, optional
        Where to write the report (default ``sweep_dir/report``).

    Returns
    -------
    SweepReport
        The output directory (``directory``), the files written and the maps among them;
        ``to_text()`` is the line ``exotune report`` prints.

    Raises
    ------
    ConfigError
        Not a sweep directory, a damaged manifest or chunk, no finished chunk, or an unwritable
        output.

    References
    ----------
    docs/sweep-spec.md#report.
    """
    sweep_dir = os.fspath(sweep_dir)
    out = Path(out_dir) if out_dir is not None else Path(sweep_dir) / "report"
    refuse_link(str(out), "a report directory")
    if out.exists() and not out.is_dir():
        raise ConfigError(str(out), "exists and is not a directory")
    m = verified_manifest(sweep_dir)
    d = _read_sweep(sweep_dir, m)
    files: dict[str, bytes] = {}
    figures: list[tuple[str, str]] = []
    _pair_maps(d, files, figures)
    if len(d["paths"]) == 1:
        _profile(d, files, figures)

    metrics = d["metrics"]
    table_metrics = [c for c in TABLE_METRICS if c in metrics] + [c for c in metrics if c.endswith("_lightest_stable_inertia")]
    md = summary_md(sweep_dir, m, d["n"], d["missing"], d["paths"], d["values"], d["scales"], d["shape"],
                    d["axis_idx"], d["robust"], d["used"], d["simple"], metrics, table_metrics, figures, files)
    files["summary.md"] = md.encode("utf-8")

    for rel in files:
        refuse_link(str(out / rel), "a report directory")
    try:
        write_outputs(dirs={out: files})  # all or none: staged in a temporary directory, then renamed
    except OSError as e:
        raise ConfigError(str(out), f"cannot write the report: {e.strerror or e}") from None
    return SweepReport(out, tuple(files), tuple(name for name, _ in figures), tuple(d["missing"]),
                       sweep_dir)


def _read_sweep(sweep_dir: str, m: dict) -> dict:
    """The columns a report needs, the robust mask, each row's (sorted) axis indices and the key
    metrics, as a mapping (``paths``, ``values``, ``scales``, ``shape``, ``n``, ``missing``,
    ``simple``, ``robust``, ``used``, ``axis_idx``, ``metrics``)."""
    col_names = [c[0] for c in (m.get("columns") or [])]
    if not col_names:
        raise ConfigError(sweep_dir, "the sweep has no results yet (no chunk finished); run `exotune sweep` first")
    paths = [a["path"] for a in m["axes"]]
    values = [np.asarray(m["spec"]["axes"][p]["values"], dtype=float) for p in paths]
    scales = [m["spec"]["axes"][p].get("scale", "list") for p in paths]
    shape = tuple(v.size for v in values)

    want = {"point_index", "free_stable", *paths, *METRICS, "amplification_dc"}
    want |= {c for c in col_names if re.match(r"^(sampled_)?(human|env)\d+_.+_(robust|stable|conclusive|stable_intervals)$", c)}
    want |= {"sampled_free_stable", "sampled_locked_stable", "schedule_robust", "sampled_schedule_robust"} & set(col_names)
    want |= {c for c in col_names if c.endswith("_conclusive")}
    want |= {f"schedule_worst_{c}" for c in METRICS} & set(col_names)
    cols = [c for c in col_names if c in want]
    _, table, missing = read_tables(sweep_dir, cols, allow_partial=True, manifest=m)
    if table is None:
        raise ConfigError(sweep_dir, "the sweep has no results yet (no chunk finished); run `exotune sweep` first")
    simple = {c: table.column(c).to_numpy() for c in cols if "intervals" not in c}
    robust, used = robust_mask({c: simple[c] for c in simple if c in ("free_stable", "sampled_free_stable", "sampled_locked_stable",
                                                                       "schedule_robust", "sampled_schedule_robust")
                                or re.match(r"^(sampled_)?(human|env)\d+_.+_(robust|stable)$", c)})
    gidx = np.asarray(simple["point_index"], dtype=np.int64)
    axis_idx = list(np.unravel_index(gidx, shape))
    # maps, ranges and tables go by value: an axis listed out of order is sorted here
    for j, v in enumerate(values):
        order = np.argsort(v, kind="stable")
        rank = np.empty_like(order)
        rank[order] = np.arange(order.size)
        axis_idx[j], values[j] = rank[axis_idx[j]], v[order]
    return {"paths": paths, "values": values, "scales": scales, "shape": shape, "n": table.num_rows,
            "missing": missing, "simple": simple, "robust": robust, "used": used, "axis_idx": tuple(axis_idx),
            "metrics": _key_metrics(table, m, simple), "base": (m.get("spec") or {}).get("base")}


def _base_value(base, path: str):
    """The base design's value of a dotted ``path`` (None when absent or not a number)."""
    node = base
    for k in path.split("."):
        if not isinstance(node, dict) or k not in node:
            return None
        node = node[k]
    return float(node) if isinstance(node, (int, float)) and not isinstance(node, bool) else None


def _slices(d: dict, others: list[int]) -> dict[int, int]:
    """{axis: value index} of the other axes a metrics map is sliced at: an axis along which the
    design runs into instability (some of its values have no robust design, others have) is held
    at the value nearest the base design's — the worst case over it would be that of the unstable
    values in every cell — the others stay aggregated (worst case)."""
    out = {}
    for j in others:
        n = d["shape"][j]
        frac = aggregate(d["axis_idx"][j], n, d["robust"].astype(float), "mean")
        b = _base_value(d.get("base"), d["paths"][j])
        if b is None or not (np.any(frac == 0.0) and np.any(frac > 0.0)):
            continue
        out[j] = int(np.argmin(np.abs(d["values"][j] - b)))
    return out


def _key_metrics(table, m: dict, simple: dict) -> dict[str, tuple[np.ndarray, dict]]:
    """{column: (values, info)} of the metrics the report maps: the :data:`METRICS` columns that
    are defined somewhere, then the derived family metrics (the stiffest stable spring only where
    some design is not robust for its family). With a gain schedule swept, a metric is its worst
    over the main controller and the entries (``schedule_worst_*``, docs/sweep-spec.md#gain-schedule)."""
    metrics: dict[str, tuple[np.ndarray, dict]] = {}
    for c, (title, unit, factor, worst, cmap) in METRICS.items():
        if f"schedule_worst_{c}" in simple:
            c_src, title = f"schedule_worst_{c}", f"{title}, worst over the gain schedule"
        else:
            c_src = c
        if c_src in simple:
            v = np.asarray(simple[c_src], dtype=float)
            if np.all(np.isnan(v)):
                continue
            metrics[c] = (v, {"title": title, "unit": unit, "factor": factor, "worst": worst, "cmap": cmap, "log": False,
                              "column": c_src})
    derived = derived_metrics(table, m)
    for k, (v, info) in derived.items():
        fam_rob = info["family"].replace("_stable_intervals", "_robust")
        if info["worst"] == "min" and fam_rob in simple and bool(np.all(simple[fam_rob])):
            continue  # the stiffest stable spring is the range end everywhere: nothing to map
        metrics[k] = (v, info)
    return metrics


def _pair_maps(d: dict, files: dict, figures: list) -> None:
    """The robust-fraction heatmap and the key-metric panels over every pair of the first
    :data:`MAX_PAIR_AXES` axes, into ``files`` (name → PNG) and ``figures`` (name, caption)."""
    paths, values, shape, axis_idx = d["paths"], d["values"], d["shape"], d["axis_idx"]
    robust, metrics = d["robust"], d["metrics"]
    k = len(paths)
    pair_axes = list(range(min(k, MAX_PAIR_AXES)))
    pairs = [(a, b) for ii, a in enumerate(pair_axes) for b in pair_axes[ii + 1:]]
    for a, b in pairs:
        # x = axis b? keep the first-listed axis on x
        nx, ny = shape[a], shape[b]
        cells = axis_idx[a] * ny + axis_idx[b]  # index (ix, iy) -> ix*ny + iy
        others = [paths[j] for j in range(k) if j not in (a, b)]
        agg_note = f" — aggregated over {', '.join(others)}" if others else ""
        frac = aggregate(cells, nx * ny, robust.astype(float), "mean").reshape(nx, ny).T
        name = f"robust_{safe_name(paths[a])}__{safe_name(paths[b])}.png"
        title = ("fraction of robust designs" if others else "robust designs (1 = robust)") + agg_note
        files[name] = heatmap(frac, values[a], values[b], _axis_label(paths[a]), _axis_label(paths[b]),
                              title, "fraction robust", vmin=0.0, vmax=1.0, cmap="RdYlGn", fmt="{:.2f}")
        figures.append((name, f"{title} ({paths[a]} × {paths[b]})"))
        panels = []
        sl = _slices(d, [j for j in range(k) if j not in (a, b)])
        rows = np.ones(robust.size, dtype=bool)
        for j, i in sl.items():
            rows &= d["axis_idx"][j] == i
        rest = [paths[j] for j in range(k) if j not in (a, b) and j not in sl]
        for mk, (v, info) in metrics.items():
            grid = aggregate(cells[rows], nx * ny, (v * info["factor"])[rows], info["worst"]).reshape(nx, ny).T
            if np.all(np.isnan(grid)):
                continue
            wc = f"worst case ({info['worst']})" if rest else ""
            panels.append({"grid": grid, "title": _wrap(info["title"] + (f" — {wc}" if wc else "")),
                           "cbar_label": f"{mk} [{info['unit']}]", "cmap": info["cmap"],
                           "log": info.get("log", False), "fmt": "{:.3g}"})
        if panels:
            name = f"metrics_{safe_name(paths[a])}__{safe_name(paths[b])}.png"
            at = [f"{paths[j]} = {values[j][i]:.6g} (the base design's; it runs into instability)" for j, i in sl.items()]
            sup = f"key metrics over {paths[a]} × {paths[b]}" + (f" at {', '.join(at)}" if at else "") + (
                f" (worst case over {', '.join(rest)})" if rest else "")
            files[name] = heatmap_panels(panels, values[a], values[b], _axis_label(paths[a]),
                                         _axis_label(paths[b]), sup)
            figures.append((name, sup + ": " + ", ".join(metrics)))


def _profile(d: dict, files: dict, figures: list) -> None:
    """With a single axis: robustness and the key metrics against it (one figure)."""
    paths, metrics = d["paths"], d["metrics"]
    x = d["values"][0]
    cells = d["axis_idx"][0]
    series = [("fraction robust", aggregate(cells, x.size, d["robust"].astype(float), "mean"))]
    for mk, (v, info) in metrics.items():
        series.append((f"{mk}\n[{info['unit']}]", aggregate(cells, x.size, v * info["factor"], info["worst"])))
    name = f"profile_{safe_name(paths[0])}.png"
    files[name] = profile_figure(x, series, _axis_label(paths[0]), d["scales"][0] == "log", f"sweep over {paths[0]}")
    figures.append((name, f"robustness and key metrics against {paths[0]}"))
