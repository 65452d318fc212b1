"""The sweep's exact sampled-data columns (spec key ``sampled: true``, docs/sweep-spec.md#sampled-data-columns):
every design's loop as ``exotune export`` writes it and ``exotune certify`` judges it, batched over
the designs of a chunk (:mod:`exotune.sampled.batch`, :mod:`exotune.sampled.families`).
"""

from __future__ import annotations

import numpy as np

__all__ = ["sampled_columns", "sampled_schedule_columns", "sampled_refusal", "checked_intervals"]


def sampled_refusal(cfg) -> str | None:
    """Why the base design ``cfg`` cannot have sampled-data columns (None: it can).

    Parameters
    ----------
    cfg : DesignConfig
        The sweep's base design.

    Returns
    -------
    str or None
        The reason, or None.
    """
    if not cfg.implementation.sample_rate_hz:
        return ("needs a sample rate: the base design sets no implementation.sample_rate_hz (the sampled-data "
                "loop is the one the runtime runs at that rate)")
    for i, fam in enumerate(cfg.humans):
        if fam.box:
            return (f"humans[{i}] is a box of several uncertain msd parameters: the sampled-data check (as "
                    "`exotune certify`) covers one-parameter families only; fix all but one parameter")
    return None


def checked_intervals(intervals: list, cells: list) -> list:
    """The stable intervals less the interiors of the cells step control could not resolve.

    A family check lists such cells apart from its intervals, as ``exotune certify`` does (which
    refuses a file that has any) and as the sweep's ``…_unresolved_cells`` columns do: the intervals
    span them. Cut out, every member of what remains was checked; the sweep's derived maps (the
    lightest or stiffest stable member of a family) use these. Only families that are not robust
    have such cells.

    Parameters
    ----------
    intervals : list of [lo, hi]
        Disjoint stable intervals, ascending, in the family parameter's unit.
    cells : list of [a, b]
        Unresolved cells (their ends were evaluated; their interiors were not resolved).

    Returns
    -------
    list of [lo, hi]
        The parts of ``intervals`` outside every open cell (a, b), ascending; the cut leaves no
        part of zero length (an interval given as a single member stays, unless a cell holds it).
    """
    out = [[float(lo), float(hi)] for lo, hi in intervals]
    for a, b in sorted((float(a), float(b)) for a, b in cells):
        nxt = []
        for lo, hi in out:
            if b <= lo or a >= hi:  # the open cell (a, b) misses [lo, hi]
                nxt.append([lo, hi])
                continue
            if lo < a:
                nxt.append([lo, a])
            if b < hi:
                nxt.append([b, hi])
        out = nxt
    return out


def sampled_columns(cfg, res) -> dict:
    """The sampled-data columns of a batch of designs ``cfg`` (:func:`exotune.config.batch_config`).

    Parameters
    ----------
    cfg : DesignConfig
        The chunk's batch (its base sets ``implementation.sample_rate_hz``).
    res : BatchAnalysis
        The continuous analysis of the same batch (:func:`~exotune.analysis.analyze_batch`); its
        ``latency_margin_s`` (when computed) only chooses where the sampled margin's bracket starts.

    Returns
    -------
    dict
        ``sampled_free_stable``, ``sampled_locked_stable``; per rational human family
        ``sampled_human{i}_{kind}_robust``, ``…_stable_intervals`` (certify's), ``…_unresolved_cells``
        (the cells step control left unresolved, as certify lists them), ``…_critical``,
        ``…_critical_spectral_radius``; per environment range ``sampled_env{i}_{kind}_robust``
        and ``…_stable_intervals``, ``…_unresolved_cells``; ``sampled_latency_margin_samples``.

    References
    ----------
    docs/sweep-spec.md#sampled-data-columns; docs/controller-file.md#latency-margin.
    """
    from ..numerics.threads import one_blas_thread
    from ..sampled.batch import BatchLoops, Loop
    from ..sampled.families import family_check, family_loops, latency_margin

    @one_blas_thread
    def run():
        n = res.n
        bl = BatchLoops(cfg, float(np.ravel(cfg.implementation.sample_rate_hz)[0]), n)
        des = np.arange(n)
        out = {}
        ok = np.ones(n, bool)
        for name, loop in (("free", Loop("free")), ("locked", Loop("locked", env="locked"))):
            _rho, _eig, stable = bl.spectra(des, loop)
            out[f"sampled_{name}_stable"] = stable
            ok &= stable
        fams = []
        for loop, lo, hi in family_loops(cfg.humans, cfg.environment):
            prefix = f"sampled_{loop.name}"
            chk = family_check(bl, des, loop, lo, hi)
            out[f"{prefix}_robust"] = chk["robust"]
            out[f"{prefix}_stable_intervals"] = chk["stable_intervals"]
            out[f"{prefix}_unresolved_cells"] = chk["unresolved"]
            if prefix.startswith("sampled_human"):
                out[f"{prefix}_critical"] = chk["critical"]
                out[f"{prefix}_critical_spectral_radius"] = chk["critical_radius"]
            ok &= chk["robust"]
            fams.append((loop, lo, hi, chk["critical"]))
        margin = np.zeros(n)
        rows = np.nonzero(ok)[0]
        if rows.size:
            hint = None if res.latency_margin_s is None else np.asarray(res.latency_margin_s, float)[rows]
            margin[rows] = latency_margin(bl, rows, [(lp, lo, hi, c[rows]) for lp, lo, hi, c in fams], hint).extra_delay_s
        out["sampled_latency_margin_samples"] = margin * bl.fs
        return out

    return run()


def sampled_schedule_columns(sched, nominal: dict) -> dict:
    """The sampled-data columns of a gain schedule: every entry's loops sampled at the base's rate
    (:func:`sampled_columns` on the N·E rescheduled designs of ``sched``), reduced per design.

    Parameters
    ----------
    sched : ScheduleBatch
        The continuous analysis of the entries (:func:`exotune.analysis.gain_schedule.analyze_schedule`).
    nominal : dict
        The main controller's sampled-data columns (:func:`sampled_columns` of the same N designs).

    Returns
    -------
    dict
        ``sampled_schedule_robust`` (every entry's sampled loops stable and families robust),
        ``sampled_schedule_failing_entries`` (how many are not), ``sampled_latency_margin_samples``
        (the design's: the smallest of the main controller's and the entries'; NaN when one is
        unknown) and ``sampled_latency_margin_main_samples`` (the main controller's).

    References
    ----------
    docs/sweep-spec.md#gain-schedule; paper §IV (gain scheduling).
    """
    sub = sampled_columns(sched.cfg, sched.analysis)
    e, n = len(sched.ratio), sched.n
    ok = np.asarray(sub["sampled_free_stable"], bool) & np.asarray(sub["sampled_locked_stable"], bool)
    for k, v in sub.items():
        if k.endswith("_robust"):
            ok &= np.asarray(v, bool)
    ok = ok.reshape(e, n)
    main = np.asarray(nominal["sampled_latency_margin_samples"], float)
    m = np.vstack([main, np.asarray(sub["sampled_latency_margin_samples"], float).reshape(e, n)])
    return {"sampled_schedule_robust": ok.all(axis=0), "sampled_schedule_failing_entries": (~ok).sum(axis=0),
            "sampled_latency_margin_samples": np.where(np.isnan(m).any(axis=0), np.nan, m.min(axis=0)),
            "sampled_latency_margin_main_samples": main}
