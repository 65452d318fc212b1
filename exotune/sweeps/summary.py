"""The text of a sweep report: ``summary.md`` (sweep, axes, robustness, per-axis tables, best
design, figures) and the per-axis CSV tables."""

from __future__ import annotations

import re

import numpy as np

from ..units import fmt_num
from .metrics import AXIS_UNITS, MAX_PAIR_AXES, aggregate
from .result import chunk_list

__all__ = ["summary_md", "value_runs", "display_path", "safe_name", "metric_label"]


_UNIT_SUFFIX = {"s": "_s", "ms": "_ms", "deg": "_deg", "dB": "_db", "Hz": "_hz"}


def metric_label(name: str, unit: str) -> str:
    """The name under which a metric column is shown: its unit suffix matches the displayed unit.

    ``dob_delay_margin_s`` shown in ms becomes ``dob_delay_margin_ms``; a name whose suffix
    already matches (or that has none) is unchanged.

    Parameters
    ----------
    name : str
        The results column (SI units, e.g. ``dob_delay_margin_s``).
    unit : str
        The unit the report shows its values in.

    Returns
    -------
    str
        The label for tables and CSV headers.

    References
    ----------
    docs/sweep-spec.md (result columns).
    """
    want = _UNIT_SUFFIX.get(unit)
    for suffix in _UNIT_SUFFIX.values():
        if want and name.endswith(suffix) and suffix != want:
            return name[: -len(suffix)] + want
    return name


def safe_name(path: str) -> str:
    """A dotted parameter path as a file-name component (``axis_<name>.csv``, …).

    Parameters
    ----------
    path : str
        Dotted parameter path.

    Returns
    -------
    str
        The path with every run of other characters than letters, digits, ``_``, ``.`` and ``-``
        replaced by ``_``.
    """
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", path)


def _axis_table(j, paths, values, axis_idx, robust, metrics, table_metrics):
    """Rows: (value, n, frac robust, {metric: (min, max)})."""
    nv = values[j].size
    cells = axis_idx[j]
    counts = np.bincount(cells, minlength=nv)
    frac = aggregate(cells, nv, robust.astype(float), "mean")
    stats = {}
    for mk in table_metrics:
        v, info = metrics[mk]
        stats[mk] = (aggregate(cells, nv, v, "min"), aggregate(cells, nv, v, "max"))
    return counts, frac, stats


def value_runs(vals, ok, digits: int = 4) -> str:
    """Human-readable runs of consecutive axis values where ok, e.g. '1.5 … 4.4, 9.4 … 20'.

    Parameters
    ----------
    vals : sequence of float
        The axis values, in order.
    ok : sequence of bool
        Which values qualify.
    digits : int, optional
        Significant digits.

    Returns
    -------
    str
        The runs, or ``"none"``.
    """
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


def display_path(p) -> str:
    """A path as shown in reports: relative to the working directory when it lies below it,
    otherwise only its last two components (reports get committed and shared: no machine paths).

    Parameters
    ----------
    p : str or os.PathLike
        The path.

    Returns
    -------
    str
        The path as the report shows it (control characters escaped).
    """
    import os

    from ..errors import printable

    p = os.path.abspath(str(p))
    rel = os.path.relpath(p, os.getcwd())
    if not rel.startswith(".."):
        return printable(rel)  # a name's control characters escaped: `cat summary.md` cannot drive the terminal
    parts = p.rstrip(os.sep).split(os.sep)
    return printable(os.path.join("…", *parts[-2:]))


def summary_md(sweep_dir, m, n, missing, paths, values, scales, shape, axis_idx, robust, used, simple,
               metrics, table_metrics, figures, files) -> str:
    """The text of ``summary.md``; adds the per-axis CSV tables to ``files`` (name → bytes).

    Parameters
    ----------
    sweep_dir : str
        The sweep directory.
    m : dict
        Its manifest.
    n : int
        Number of designs read.
    missing : list of int
        Indices of the chunks not finished.
    paths : list of str
        The axes' parameter paths.
    values : list of numpy.ndarray
        Each axis' values (SI units).
    scales : list of str
        Each axis' spacing (``"lin"``, ``"log"``, ``"list"``).
    shape : tuple of int
        The grid's shape.
    axis_idx : list of numpy.ndarray
        Per axis, each row's index into its values.
    robust : numpy.ndarray
        Whether each row is robust (bool).
    used : list of str
        The verdict columns the robust mask combines.
    simple : dict
        The scalar columns read (name → values).
    metrics : dict
        Key metrics: name → (values, info with ``unit`` and ``factor``).
    table_metrics : list of str
        The metrics the tables show.
    figures : list of tuple
        ``(file name, caption)`` of the figures written.
    files : dict
        File name → content, to which the per-axis CSV tables are added.

    Returns
    -------
    str
        The Markdown text.
    """
    L = _head_lines(sweep_dir, m, n, missing, paths, values, scales, shape, schedule_swept="schedule_robust" in used)
    L += _robustness_lines(n, robust, used, simple, metrics)
    L += _per_axis_lines(paths, values, axis_idx, robust, metrics, table_metrics, files)
    L += _best_design_lines(paths, values, axis_idx, robust, metrics, table_metrics)
    L.append("")
    L.append("## Figures")
    L.append("")
    if len(paths) > MAX_PAIR_AXES:
        L.append(f"(maps cover the pairs of the first {MAX_PAIR_AXES} axes)")
        L.append("")
    for name, caption in figures:
        L.append(f"- [{name}]({name}): {caption}")
    L.append("")
    L.append("Per-axis tables as CSV: " + ", ".join(f"[axis_{safe_name(p)}.csv](axis_{safe_name(p)}.csv)" for p in paths) + ".")
    L.append("")
    return "\n".join(L)


def _head_lines(sweep_dir, m, n, missing, paths, values, scales, shape, schedule_swept: bool = False) -> list[str]:
    """The title, the sweep (directory, hash, designs, sampling, base design, its gain schedule,
    model) and the axes."""
    L = []
    L.append("# exotune sweep report")
    L.append("")
    L.append(f"- sweep directory: `{display_path(sweep_dir)}`")
    L.append(f"- spec hash: `{m.get('spec_hash')}`; exotune {m.get('exotune_version')}; status: {m.get('status')}")
    samp = m.get("sampling", {})
    if samp.get("sample") is not None:
        L.append(f"- designs: {n} of {m.get('n_points')} — a uniform random sample (seed {samp.get('seed')}) "
                 f"of a {' × '.join(map(str, shape))} = {m.get('grid_points')}-point grid")
    else:
        L.append(f"- designs: {n} of {m.get('n_points')} (full grid {' × '.join(map(str, shape))})")
    from .manifest import sweep_running

    if missing and sweep_running(sweep_dir, m):
        L.append(f"- **partial report of a sweep still running** (its manifest says running and a run holds the "
                 f"directory's lock): {len(missing)} chunk(s) not finished yet ({chunk_list(missing)} of "
                 f"{len(m.get('chunks', []))}); the tables cover the finished chunks only; run `exotune report` again "
                 "once the sweep has finished")
    elif missing:
        L.append(f"- **partial sweep**: {len(missing)} chunk(s) missing ({chunk_list(missing)} of "
                 f"{len(m.get('chunks', []))}); the tables cover the finished chunks only; rerun `exotune sweep` with "
                 f"the same spec and `-o {display_path(sweep_dir)}` to compute "
                 f"{'it' if len(missing) == 1 else 'them'} (the finished chunks are kept)")
    n_failed = sum(len(c.get("failed_designs") or []) for c in m.get("chunks", []) if c.get("status") == "done")
    if n_failed:
        L.append(f"- **failed designs**: {n_failed} design(s) whose analysis raised have no results (counted as not "
                 "robust); their reasons are in manifest.json (chunks[].failed_designs)")
    if m.get("base_source"):
        L.append(f"- base design: `{display_path(m['base_source'])}`")
    base = (m.get("spec") or {}).get("base")
    if isinstance(base, dict) and base.get("transmission") and schedule_swept:
        tr = base["transmission"]
        L.append(f"- **gain schedule swept**: every design is also analysed at each of the base's "
                 f"{len(tr.get('ratio', []))} joint angles (transmission ratios "
                 f"{', '.join(fmt_num(r) for r in tr.get('ratio', []))}); robust requires every entry "
                 "(`schedule_robust`), and `latency_margin_s` is the smallest of the main controller's and "
                 "the entries' (`latency_margin_main_s`: the main controller's)")
    elif isinstance(base, dict) and base.get("transmission"):
        L.append("- **gain schedule not swept**: the base design has a `transmission` schedule; every column is the "
                 "nominal controller's (transmission ratio 1), the schedule's entries are not analysed, so a design "
                 "robust here may not certify: run `exotune analyze` and `exotune certify` on the design you pick")
    if m.get("model"):
        L.append(f"- model: {m['model']}")
    L.append("- gains in torque units (docs/method.md#double-compliance-shaping); frequencies in Hz; ∞ = unbounded (no crossover, never reached); "
             "— = undefined or no data")
    L.append("")
    L.append("## Axes")
    L.append("")
    L.append("| axis | unit | values | range | scale |")
    L.append("|---|---|---|---|---|")
    for p, v, s in zip(paths, values, scales):
        L.append(f"| `{p}` | {AXIS_UNITS.get(p, '?')} | {v.size} | {v.min():.4g} … {v.max():.4g} | {s} |")
    return L


def _robustness_lines(n, robust, used, simple, metrics) -> list[str]:
    """The definition of a robust design, how often each criterion fails, the key metrics' ranges."""
    L = []
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
                f"| `{metric_label(info.get('column', mk), info['unit'])}` | {info['unit']} | {fmt_num(np.nanmin(v) * f if np.any(~np.isnan(v)) else np.nan, 4)} | "
                f"{fmt_num(np.nanmax(v) * f if np.any(~np.isnan(v)) else np.nan, 4)} | "
                f"{fmt_num(np.nanmin(vr) * f if vr.size and np.any(~np.isnan(vr)) else np.nan, 4)} |"
            )
        L.append("")
        L.append("Derived metrics: *lightest stable inertia* = lower end of the stable interval containing the "
                 "family's upper inertia (∞: the heavy end itself is unstable); *stiffest stable spring* = upper "
                 "end of the stable interval containing the family's lower stiffness (0: the soft end is unstable).")
    return L


def _per_axis_lines(paths, values, axis_idx, robust, metrics, table_metrics, files) -> list[str]:
    """One table per axis (also written as CSV into ``files``): designs, fraction robust and the
    worst-case key metrics per value, with the value ranges where robust designs exist."""
    L = []
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
            lab = metric_label(info.get("column", mk), info["unit"])
            head += [f"{lab} min [{info['unit']}]", f"{lab} max [{info['unit']}]"]
            csv_head += [f"{lab}_min [{info['unit']}]", f"{lab}_max [{info['unit']}]"]
        L.append("| " + " | ".join(head) + " |")
        L.append("|" + "---|" * len(head))
        csv = [",".join(f'"{h}"' for h in csv_head)]
        for iv, val in enumerate(values[j]):
            row = [f"{val:.4g}", str(int(counts[iv])), fmt_num(frac[iv], 3)]
            crow = [repr(float(val)), str(int(counts[iv])), "" if np.isnan(frac[iv]) else repr(float(frac[iv]))]
            for mk in table_metrics:
                f = metrics[mk][1]["factor"]
                lo, hi = stats[mk][0][iv] * f, stats[mk][1][iv] * f
                row += [fmt_num(lo, 4), fmt_num(hi, 4)]
                crow += ["" if np.isnan(lo) else repr(float(lo)), "" if np.isnan(hi) else repr(float(hi))]
            L.append("| " + " | ".join(row) + " |")
            csv.append(",".join(crow))
        files[f"axis_{safe_name(p)}.csv"] = ("\n".join(csv) + "\n").encode("utf-8")
    return L


def _best_design_lines(paths, values, axis_idx, robust, metrics, table_metrics) -> list[str]:
    """The robust design with the largest α, when α is swept and some design is robust."""
    L = []
    if "design.amplification" in paths and robust.any():
        j = paths.index("design.amplification")
        a = values[j][axis_idx[j]]
        cand = np.flatnonzero(robust)
        best = cand[np.argmax(a[cand])]
        L.append("")
        L.append("## Robust design with the largest amplification")
        L.append("")
        L.append("| " + " | ".join(f"`{p}`" for p in paths) + " | " + " | ".join(f"`{metric_label(metrics[mk][1].get('column', mk), metrics[mk][1]['unit'])}` [{metrics[mk][1]['unit']}]" for mk in table_metrics) + " |")
        L.append("|" + "---|" * (len(paths) + len(table_metrics)))
        row = [f"{values[jj][axis_idx[jj][best]]:.4g}" for jj in range(len(paths))]
        row += [fmt_num(metrics[mk][0][best] * metrics[mk][1]["factor"], 4) for mk in table_metrics]
        L.append("| " + " | ".join(row) + " |")
    return L
