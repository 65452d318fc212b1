"""Analysis plots of one design (``exotune analyze DESIGN.yaml --plots DIR``).

:func:`write_analysis_plots` draws the typed figure data of one analysed design,
:class:`exotune.analysis.figure_data.AnalysisFigures` (computed by
:func:`exotune.analysis.figure_data.analysis_figures`; this module computes nothing):

``bode_compliances.png``
    Bode magnitude and phase of C5 = Δ01/Δ00 (environment side, cuff free), C7 = Δ10/Δ00
    (operator side) [dB re 1 rad/(N·m)] and of the amplification C6/C5 [dB re 1], with the exact
    delay and the implemented filters. The passive phase band [−180°, 0°] is shaded and the
    non-passive bands of C7 (``passivity.nonpassive_band_hz``) are highlighted.
``nyquist_humans.png``
    One panel per human family (per edge of an msd box): Nyquist curves of L(jω) = Z_h(jω)·C7(jω) (Δ = Δ00 (1 + L), so the
    critical point is −1) for the range ends, each critical value and a value inside each stable
    interval. The view is a fixed linear window around −1; the curves continue outside it.
``dob_loop.png`` (only with a DOB)
    The paper's Fig. 4: L_dob = Q e^{−jωT}/(1 − Q), the delay-distorted closed loop
    L/(1 + L) and the original Q, with the gain crossover, the phase crossover and the margins.
``amplification.png``
    |C6/C5| and its phase at the configured delay T and at a larger delay max(2T, T + 2 ms) (the
    paper's Fig. 5), with the DC level α, the −3 dB bandwidth and the minimum-phase
    and output-locked-stability verdicts of each.
``latency_boundary.png`` (only with human families)
    the stability boundary in the (human parameter × extra delay) plane: each member's first
    destabilizing extra delay, members already unstable at T marked, the design's latency margin
    drawn (docs/method.md#latency-margin).

Every figure is rendered in memory (``matplotlib.figure.Figure`` + the Agg canvas; pyplot and the
global backend are never touched) before anything is written; only then is ``out_dir`` created and
each PNG written atomically. A failure while rendering writes nothing and creates nothing.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..analysis.plot_data import F_MAX_HZ, F_MIN_HZ, db, finite, phase_deg
from ..model.humans import PARAM_UNITS
from . import style

__all__ = ["write_analysis_plots", "render_analysis_plots"]

DPI = style.DPI
NYQ_XLIM = (-5.0, 3.0)  # linear Nyquist window around −1
NYQ_YMAX = 4.0  # |Im L| of the window at most; less when the curves near −1 are flat (see _nyq_ylim)
NYQ_YMIN = 0.5
PASSIVE_COLOR = "tab:green"
NONPASSIVE_COLOR = "tab:red"

_SYMBOL = {"stiffness": "k", "inertia": "m", "damping": "b"}


# ----------------------------------------------------------------------------------------------
# helpers
# ----------------------------------------------------------------------------------------------
def _new_figure(figsize):
    return style.new_figure(figsize, layout=None)


def _png(fig) -> bytes:
    return style.png(fig)


def _fmt_s(t: float) -> str:
    return f"{t * 1e3:.3g} ms"


def _design_label(figs) -> str:
    return f"{figs.name}: α = {figs.amplification:.4g}, T = {_fmt_s(figs.delay_s)}, structure '{figs.structure}'"


def _mark_bands(ax, bands, label=True):
    for i, (a, b) in enumerate(bands):
        b = b if finite(b) else F_MAX_HZ
        ax.axvspan(a, b, color=NONPASSIVE_COLOR, alpha=0.12, lw=0, label="C7 non-passive band" if (label and i == 0) else None)


# ----------------------------------------------------------------------------------------------
# 1. Bode of the compliances
# ----------------------------------------------------------------------------------------------
def _fig_bode_compliances(figs) -> bytes:
    result = figs.result
    r = figs.compliances
    f, C5, C7, A = r.f_hz, r.C5, r.C7, r.A
    bands = (result.get("passivity") or {}).get("nonpassive_band_hz") or []
    excess = (result.get("passivity") or {}).get("max_phase_excess_deg")

    fig = _new_figure((8.5, 9.5))
    ax1, ax2, ax3 = fig.subplots(3, 1, sharex=True, gridspec_kw={"height_ratios": [1.3, 0.8, 1.3]})
    ax1.semilogx(f, db(C5), color="tab:blue", label="C5 = θ_j/τ_env (cuff free)")
    ax1.semilogx(f, db(C7), color="tab:orange", label="C7 = θ_h/τ_h (operator side)")
    ax1.set_ylabel("|C| [dB re 1 rad/(N·m)]")
    ax2.semilogx(f, db(A), color="tab:purple", label="C6/C5 (amplification)")
    alpha = figs.amplification
    ax2.axhline(20 * np.log10(alpha), color="tab:purple", ls=":", lw=0.9, label=f"α = {alpha:.4g}")
    ax2.set_ylabel("|C6/C5| [dB re 1]")
    ax3.axhspan(-180.0, 0.0, color=PASSIVE_COLOR, alpha=0.10, lw=0, label="passive phase band [−180°, 0°]")
    ax3.semilogx(f, phase_deg(C5), color="tab:blue", label="∠C5")
    ax3.semilogx(f, phase_deg(C7), color="tab:orange", label="∠C7")
    ax3.semilogx(f, phase_deg(A), color="tab:purple", label="∠C6/C5")
    ax3.set_ylabel("phase ∠ [deg]")
    ax3.set_xlabel("frequency f [Hz]")
    ax3.set_yticks(np.arange(-360, 361, 90))
    lo_ph = min(np.min(phase_deg(C5)), np.min(phase_deg(C7)), np.min(phase_deg(A)))
    hi_ph = max(np.max(phase_deg(C5)), np.max(phase_deg(C7)), np.max(phase_deg(A)))
    ax3.set_ylim(max(lo_ph, -400) - 15, min(hi_ph, 400) + 15)
    for ax in (ax1, ax2, ax3):
        _mark_bands(ax, bands, label=(ax is ax3))
        for h in result.get("humans") or []:
            for c in h.get("critical") or []:
                if finite(c.get("frequency_hz")) and c["frequency_hz"] > 0:
                    ax.axvline(c["frequency_hz"], color="k", ls="--", lw=0.7, alpha=0.5)
        style.grid(ax)
        ax.legend(loc="best", fontsize=8)
    ax3.set_xlim(f[0], f[-1])
    crit_txt = "; ".join(
        f"{h['kind']} {_SYMBOL.get(h['parameter'], h['parameter'])} = {c['value']:.4g} {h['unit']} at {c['frequency_hz']:.4g} Hz"
        for h in result.get("humans") or []
        for c in h.get("critical") or []
    )
    ex = f"max phase excess of C7: {excess:.3g}°" if finite(excess) else ""
    fig.suptitle("Compliances with delay and filters — " + _design_label(figs), fontsize=10)
    foot = ex + (("; dashed lines: human stability boundaries (" + crit_txt + ")") if crit_txt else "")
    fig.text(0.5, 0.01, foot, ha="center", va="bottom", fontsize=7.5, wrap=True)
    fig.subplots_adjust(left=0.11, right=0.97, top=0.95, bottom=0.08, hspace=0.1)
    return _png(fig)


# ----------------------------------------------------------------------------------------------
# 2. Nyquist of the human loops
# ----------------------------------------------------------------------------------------------
def _nyq_extent(L: np.ndarray) -> float:
    """Largest |Im L| of the curve where it lies left of the origin inside the window (where
    the encirclements of −1 are decided); used to zoom the imaginary axis of flat curves."""
    m = (L.real > NYQ_XLIM[0]) & (L.real < -0.1) & (np.abs(L.imag) <= NYQ_YMAX)
    return float(np.max(np.abs(L.imag[m]))) if m.any() else 0.0


def _fig_nyquist_humans(figs) -> bytes:
    from matplotlib import colormaps

    loops = figs.human_loops
    n = len(loops)
    ncol = min(n, 2)
    nrow = int(math.ceil(n / ncol))
    fig = _new_figure((6.2 * ncol, 5.6 * nrow + 0.8))
    axes = np.atleast_1d(fig.subplots(nrow, ncol, squeeze=False)).ravel()
    cmap = colormaps[style.CMAPS["sequential"]]
    for ax, loop in zip(axes, loops):
        fixed, eta, curves = loop.fixed, loop.eta, loop.curves
        kind, param, unit = loop.kind, loop.parameter, loop.unit
        ax.axhline(0, color="0.6", lw=0.6)
        ax.axvline(0, color="0.6", lw=0.6)
        ax.plot([-1], [0], marker="+", color="red", ms=14, mew=2, ls="none", label="−1 (critical point)", zorder=5)
        sym = _SYMBOL.get(param, param)
        edge = loop.edge
        # an edge of an msd box: every member is named by both (all) its ranged parameters
        at = "".join(f", {_SYMBOL.get(q, q)} = {x:.4g} {PARAM_UNITS.get(q, '')}" for q, x in edge["at"].items()) if edge else ""
        crossing_labelled = False
        ymax = 0.0
        for j, curve in enumerate(curves):
            v, state, L, x = curve.value, curve.state, curve.L, curve.crossings
            col = cmap(0.1 + 0.8 * j / max(len(curves) - 1, 1))
            ls = "-" if state != "UNSTABLE" else "--"
            ymax = max(ymax, _nyq_extent(L))
            inview = np.any((L.real > NYQ_XLIM[0]) & (L.real < NYQ_XLIM[1]) & (np.abs(L.imag) < NYQ_YMAX))
            ax.plot(L.real, L.imag, color=col, ls=ls, lw=1.3,
                    label=f"{sym} = {v:.4g} {unit}{at} ({state})" + ("" if inview else " — outside the view"))
            ax.plot(L.real, -L.imag, color=col, ls=ls, lw=0.7, alpha=0.35)  # ω < 0 (mirror image)
            x = x[(x > NYQ_XLIM[0]) & (x < NYQ_XLIM[1])]
            if x.size:
                ax.plot(x, np.zeros_like(x), marker="o", mfc="none", color=col, ms=6, ls="none",
                        label="crossings of the negative real axis" if not crossing_labelled else None)
                crossing_labelled = True
        for c in loop.critical:
            Lc = c.L
            ax.plot([Lc.real], [Lc.imag], marker="x", color="red", ms=9, mew=1.8, ls="none")
            ax.annotate(f"{sym} = {c.value:.4g}: L = −1 at {c.frequency_hz:.4g} Hz", (Lc.real, Lc.imag),
                        xytext=(8, 12), textcoords="offset points", fontsize=7.5, color="red")
        yh = min(max(1.3 * ymax, NYQ_YMIN), NYQ_YMAX)
        ax.set_xlim(*NYQ_XLIM)
        ax.set_ylim(-yh, yh)
        style.grid(ax, which="major")
        ax.set_xlabel("Re L(jω) [1]")
        ax.set_ylabel("Im L(jω) [1]")
        zdesc = {
            "spring": "Z = k + b s",
            "mass": "Z = m s² + b s",
            "msd": "Z = m s² + b s + k",
            "complex_stiffness": "Z = k (1 + jη sign ω)",
        }.get(kind, kind)
        fx = ", ".join(f"{_SYMBOL.get(k, k) if k != 'eta' else 'η'} = {v:.4g}" for k, v in {**fixed, **({"eta": eta} if kind == "complex_stiffness" else {})}.items() if k != param)
        iv = ", ".join(f"[{a:.4g}, {b:.4g}]" for a, b in loop.stable_intervals)
        iv = f"{iv} {unit}" if iv else "none"
        head = f"{kind} box, edge {edge['index'] + 1} of {edge['count']}" if edge else kind
        ax.set_title(f"{head}: {zdesc}  ({fx})\n{sym} ∈ [{loop.range[0]:.4g}, {loop.range[1]:.4g}] {unit}; stable on {iv}",
                     fontsize=8.5)
        ax.legend(loc="lower left", fontsize=7)
    for ax in axes[n:]:
        ax.set_visible(False)
    fig.suptitle("Coupled loop L(jω) = Z_h(jω)·C7(jω), Δ = Δ00·(1 + L) — " + _design_label(figs), fontsize=10)
    fig.text(0.5, 0.005,
             f"Linear view limited to Re L ∈ [{NYQ_XLIM[0]:g}, {NYQ_XLIM[1]:g}] and |Im L| ≤ {NYQ_YMAX:g} around −1, "
             "the imaginary axis zoomed further where the curves left of the origin are flat (axes not to equal scale); "
             "curves continue outside the view.\nBold: ω > 0 (0.01 Hz – 10 kHz); faint: ω < 0 (mirror image). "
             "Dashed: unstable values; verdicts from the exact stable intervals; ○ crossings of the negative real axis, × L = −1.",
             ha="center", va="bottom", fontsize=7.5, wrap=True)
    fig.subplots_adjust(left=0.08, right=0.98, top=0.9, bottom=0.08, wspace=0.2, hspace=0.3)
    return _png(fig)


# ----------------------------------------------------------------------------------------------
# 3. DOB loop (paper Fig. 4)
# ----------------------------------------------------------------------------------------------
def _fig_dob_loop(figs) -> bytes:
    r = figs.dob
    f, T, Q, L, CL, phL = r.f_hz, r.delay_s, r.Q, r.L, r.CL, r.phase_L_deg
    dob = figs.result.get("dob") or {}

    fig = _new_figure((8.5, 8.0))
    ax1, ax2 = fig.subplots(2, 1, sharex=True)
    ax1.semilogx(f, db(L), color="tab:blue", label="L_dob = Q·e^(−jωT)/(1 − Q) (open loop)")
    ax1.semilogx(f, db(CL), color="tab:red", label="L/(1 + L) (Q distorted by the delay)")
    ax1.semilogx(f, db(Q), color="0.4", ls="--", label="Q (original)")
    ax1.axhline(0, color="k", lw=0.7)
    ax1.set_ylabel("magnitude [dB re 1]")
    ax2.semilogx(f, phL, color="tab:blue", label="∠L_dob")
    ax2.semilogx(f, phase_deg(CL), color="tab:red", label="∠L/(1 + L)")
    ax2.semilogx(f, phase_deg(Q), color="0.4", ls="--", label="∠Q")
    ax2.set_ylabel("phase ∠ [deg]")
    ax2.set_xlabel("frequency f [Hz]")
    for k in range(-5, 1):
        if phL.min() - 30 < -180 + 360 * k < 30:
            ax2.axhline(-180 + 360 * k, color="k", lw=0.6, ls=":")
    ax2.set_ylim(max(phL.min(), -900) - 20, 20)
    # gain crossover (from the analysis) and the phase crossover with the largest |L| on the grid
    if r.crossover is not None:
        fc, Lc, phc, target = r.crossover
        for ax in (ax1, ax2):
            ax.axvline(fc, color="tab:green", ls="--", lw=0.9)
        ax1.plot([fc], [db(Lc)], "o", color="tab:green", label=f"gain crossover {fc:.4g} Hz")
        pm = dob.get("phase_margin_deg")
        ax2.annotate("", xy=(fc, phc), xytext=(fc, target), arrowprops=dict(arrowstyle="<->", color="tab:green"))
        if finite(pm):
            ax2.text(fc / 1.08, 0.5 * (phc + target), f"PM = {pm:.3g}° ", color="tab:green", fontsize=8, va="center", ha="right")
    if r.phase_crossover is not None:
        j = r.phase_crossover
        f180 = f[j]
        mag180 = db(L[j])
        for ax in (ax1, ax2):
            ax.axvline(f180, color="tab:orange", ls="--", lw=0.9)
        ax1.annotate("", xy=(f180, mag180), xytext=(f180, 0.0), arrowprops=dict(arrowstyle="<->", color="tab:orange"))
        gm = dob.get("gain_margin_db")
        ax1.plot([f180], [mag180], "s", color="tab:orange", label=f"phase crossover ≈ {f180:.4g} Hz")
        ax2.plot([f180], [phL[j]], "s", color="tab:orange")
        if finite(gm):
            ax1.text(f180 * 1.08, 0.5 * mag180, f"GM = {gm:.3g} dB", color="tab:orange", fontsize=8, va="center")
    lines = [f"modelled delay T = {_fmt_s(T)}"]
    if finite(dob.get("gain_margin_db")):
        lines.append(f"gain margin {dob['gain_margin_db']:.4g} dB")
    else:
        lines.append(f"gain margin {dob.get('gain_margin_db')} (no phase crossover)")
    if finite(dob.get("phase_margin_deg")):
        lines.append(f"phase margin {dob['phase_margin_deg']:.4g}° at {dob.get('crossover_hz', float('nan')):.4g} Hz")
    if finite(dob.get("delay_margin_s")):
        lines.append(f"delay margin {_fmt_s(dob['delay_margin_s'])} (extra, on top of T)")
    ax1.text(0.02, 0.04, "\n".join(lines), transform=ax1.transAxes, fontsize=8.5, va="bottom",
             bbox=dict(boxstyle="round", fc="white", ec="0.6", alpha=0.9))
    lo_db = np.nanmin(np.where(np.isfinite(db(Q)), db(Q), np.nan))
    hi_db = np.nanmax(np.where(np.isfinite(db(L)), db(L), np.nan))
    ax1.set_ylim(max(lo_db, -80) - 5, min(hi_db, 80) + 5)
    for ax in (ax1, ax2):
        style.grid(ax)
        ax.legend(loc="upper right" if ax is ax1 else "lower left", fontsize=8)
    ax2.set_xlim(f[0], f[-1])
    fig.suptitle(
        f"DOB loop (paper Fig. 4): Q at {r.cutoff_hz:.4g} Hz, ζ_q = {r.damping:.3g} — "
        + _design_label(figs),
        fontsize=10,
    )
    fig.subplots_adjust(left=0.1, right=0.97, top=0.94, bottom=0.07, hspace=0.08)
    return _png(fig)


# ----------------------------------------------------------------------------------------------
# 4. Amplification at two delays (paper Fig. 5)
# ----------------------------------------------------------------------------------------------
def _fig_amplification(figs) -> bytes:
    f, runs = figs.amplification_at_delays.f_hz, figs.amplification_at_delays.runs
    amp_res = figs.result.get("amplification") or {}
    alpha = figs.amplification

    fig = _new_figure((8.5, 8.0))
    ax1, ax2 = fig.subplots(2, 1, sharex=True)
    styles = [("tab:blue", "-"), ("tab:red", "--")]
    for run, (col, ls) in zip(runs, styles):
        A, mp, bw, locked = run.A, run.minimum_phase, run.bandwidth_hz, run.locked_stable
        tag = f"T = {_fmt_s(run.delay_s)}" + (" (configured)" if run.configured else "")
        mp_txt = "minimum phase unknown" if mp is None else ("minimum phase" if mp else "NON-minimum phase")
        lk_txt = "" if locked is None else ("; output-locked stable" if locked else "; output-locked UNSTABLE")
        bw_txt = f"; −3 dB at {bw:.3g} Hz" if finite(bw) else "; −3 dB not reached"
        ax1.semilogx(f, db(A), color=col, ls=ls, label=f"|C6/C5|, {tag}: {mp_txt}{lk_txt}{bw_txt}")
        ax2.semilogx(f, phase_deg(A), color=col, ls=ls, label=f"∠C6/C5, {tag}")
        if finite(bw) and F_MIN_HZ <= bw <= F_MAX_HZ:
            for ax in (ax1, ax2):
                ax.axvline(bw, color=col, ls=":", lw=0.9)
            ax1.plot([bw], [20 * np.log10(alpha) - 3.0103], "o", color=col)
    dc = amp_res.get("dc")
    ax1.axhline(20 * np.log10(alpha), color="k", lw=0.8, ls="-.",
                label=f"DC level α = {alpha:.4g} ({20 * np.log10(alpha):.3g} dB)" + (f"; analysed DC {dc:.4g}" if finite(dc) else ""))
    ax1.axhline(20 * np.log10(alpha) - 3.0103, color="0.5", lw=0.8, ls=":", label="α − 3 dB")
    ax1.set_ylabel("|C6/C5| [dB re 1]")
    ax2.set_ylabel("phase ∠ [deg]")
    ax2.set_xlabel("frequency f [Hz]")
    for ax in (ax1, ax2):
        style.grid(ax)
        ax.legend(loc="lower left", fontsize=7.5)
    ax2.set_xlim(f[0], f[-1])
    fig.suptitle("Amplification C6/C5 = −τ_env/τ_h (output locked) at two delays — " + _design_label(figs), fontsize=10)
    fig.text(0.5, 0.005, "Second delay = max(2T, T + 2 ms); minimum-phase and output-locked verdicts by exact RHP counts "
             "of the numerator and denominator quasi-polynomials.", ha="center", va="bottom", fontsize=7.5)
    fig.subplots_adjust(left=0.1, right=0.97, top=0.94, bottom=0.08, hspace=0.08)
    return _png(fig)


# ----------------------------------------------------------------------------------------------
# driver
# ----------------------------------------------------------------------------------------------
def render_analysis_plots(figs) -> dict[str, bytes]:
    """Render every figure to PNG bytes (nothing written). Keys are the file names.

    Parameters
    ----------
    figs : AnalysisFigures
        The figure data of the analysed design
        (:func:`exotune.analysis.figure_data.analysis_figures`).

    Returns
    -------
    dict of str to bytes
        File name → PNG content: ``bode_compliances.png``, ``amplification.png`` and, where they
        apply, ``nyquist_humans.png``, ``dob_loop.png`` and ``latency_boundary.png``.
    """
    out: dict[str, bytes] = {}
    humans = bool(figs.result.get("humans"))
    out["bode_compliances.png"] = _fig_bode_compliances(figs)
    if humans:
        out["nyquist_humans.png"] = _fig_nyquist_humans(figs)
    if figs.dob is not None:
        out["dob_loop.png"] = _fig_dob_loop(figs)
    out["amplification.png"] = _fig_amplification(figs)
    if humans:
        out["latency_boundary.png"] = _fig_latency_boundary(figs)
    return out


def _fig_latency_boundary(figs) -> bytes:
    """Each human member's first destabilizing extra delay, with the design's latency margin."""
    from .margins import latency_boundary_figure

    return _png(latency_boundary_figure(figs.latency_boundaries, figs.latency_margin_s))


def write_analysis_plots(figs, out_dir) -> list[Path]:
    """Render the analysis figures of one design and write them as PNGs into ``out_dir``.

    All figures are rendered in memory first; ``out_dir`` is created (if needed) only after
    every figure succeeded, and each file is written atomically. ``nyquist_humans.png`` is
    skipped when the design has no human family, ``dob_loop.png`` when it has no DOB.
    If writing fails part-way, the files written by this call are removed again (and
    ``out_dir`` too when this call created it and it is left empty). Returns the written paths.

    Parameters
    ----------
    figs : AnalysisFigures
        The figure data of the analysed design
        (:func:`exotune.analysis.figure_data.analysis_figures`).
    out_dir : str or os.PathLike
        The directory to write into.

    Returns
    -------
    list of pathlib.Path
        The files written.

    Raises
    ------
    OSError
        When the directory or a file cannot be written (after the cleanup).
    """
    from ..jsonio import write_atomic

    files = render_analysis_plots(figs)
    out = Path(out_dir)
    created = not out.exists()
    written: list[Path] = []
    try:
        out.mkdir(parents=True, exist_ok=True)
        for name, data in files.items():
            p = out / name
            write_atomic(p, data)
            written.append(p)
    except BaseException:
        for p in written:
            try:
                p.unlink()
            except OSError:
                pass
        if created:
            try:
                out.rmdir()
            except OSError:
                pass
        raise
    return written
