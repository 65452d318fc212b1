"""Analysis plots of one design (``exotune analyze DESIGN.yaml --plots DIR``).

:func:`write_analysis_plots` draws, from a scalar :class:`~exotune.config.DesignConfig` and the
dict of :func:`exotune.analysis.analyze_design`:

``bode_compliances.png``
    Bode magnitude and phase of C5 = Δ01/Δ00 (environment side, cuff free), C7 = Δ10/Δ00
    (operator side) [dB re 1 rad/(N·m)] and of the amplification C6/C5 [dB re 1], with the exact
    delay and the implemented filters. The passive phase band [−180°, 0°] is shaded and the
    non-passive bands of C7 (``passivity.nonpassive_band_hz``) are highlighted.
``nyquist_humans.png``
    One panel per human family: Nyquist curves of L(jω) = Z_h(jω)·C7(jω) (Δ = Δ00 (1 + L), so the
    critical point is −1) for the range ends, each critical value and a value inside each stable
    interval. The view is a fixed linear window around −1; the curves continue outside it.
``dob_loop.png`` (only with a DOB)
    The paper's Fig. DOBtune: L_dob = Q e^{−jωT}/(1 − Q), the delay-distorted closed loop
    L/(1 + L) and the original Q, with the gain crossover, the phase crossover and the margins.
``amplification.png``
    |C6/C5| and its phase at the configured delay T and at a larger delay max(2T, T + 2 ms) (the
    paper's Fig. amplification), with the DC level α, the −3 dB bandwidth and the minimum-phase
    and output-locked-stability verdicts of each.

Every figure is rendered in memory (``matplotlib.figure.Figure`` + the Agg canvas; pyplot and the
global backend are never touched) before anything is written; only then is ``out_dir`` created and
each PNG written atomically. A failure while rendering writes nothing and creates nothing.
"""

from __future__ import annotations

import dataclasses
import io
import math
import os
from pathlib import Path

import numpy as np

__all__ = ["write_analysis_plots", "render_analysis_plots"]

F_MIN_HZ = 0.1
F_MAX_HZ = 2000.0
N_GRID = 2400
DPI = 110
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
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize, dpi=DPI)
    FigureCanvasAgg(fig)
    return fig


def _png(fig) -> bytes:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=DPI)
    return buf.getvalue()


def _finite(x) -> bool:
    try:
        return x is not None and math.isfinite(float(x))
    except (TypeError, ValueError):
        return False


def _critical_freqs_hz(result: dict) -> list[float]:
    """Frequencies worth resolving exactly on the plot grids (crossings, band edges, margins)."""
    out = []
    for h in result.get("humans") or []:
        out += [c.get("frequency_hz") for c in h.get("critical") or []]
    for band in (result.get("passivity") or {}).get("nonpassive_band_hz") or []:
        out += list(band)
    dob = result.get("dob") or {}
    out.append(dob.get("crossover_hz"))
    out.append((result.get("amplification") or {}).get("bandwidth_hz"))
    return [float(f) for f in out if _finite(f) and float(f) > 0]


def _freq_grid(result: dict, fmin=F_MIN_HZ, fmax=F_MAX_HZ, n=N_GRID) -> np.ndarray:
    """Dense log grid [Hz] plus clusters of points around the critical frequencies."""
    f = np.geomspace(fmin, fmax, n)
    extra = [fc * (1.0 + d) for fc in _critical_freqs_hz(result) for d in np.linspace(-0.02, 0.02, 21)]
    extra = np.asarray([x for x in extra if fmin <= x <= fmax], dtype=float)
    return np.unique(np.concatenate([f, extra]))


def _qp_response(qp, w: np.ndarray) -> np.ndarray:
    val, _ = qp.eval(np.zeros(w.size, dtype=int), w, deriv=False)
    return val


def _rational_response(r, w: np.ndarray) -> np.ndarray:
    num = np.asarray(r.num, dtype=float).reshape(-1)
    den = np.asarray(r.den, dtype=float).reshape(-1)
    s = 1j * w
    return np.polyval(num[::-1], s) / np.polyval(den[::-1], s)


def _phase_deg(H: np.ndarray) -> np.ndarray:
    """Continuous phase [deg], anchored so that the lowest-frequency value lies in (−180°, 180°]."""
    ph = np.unwrap(np.angle(H))
    return np.degrees(ph - 2 * np.pi * np.round((ph[0] - np.angle(H[0])) / (2 * np.pi)))


def _db(H) -> np.ndarray:
    with np.errstate(divide="ignore"):
        return 20.0 * np.log10(np.abs(H))


def _fmt_s(t: float) -> str:
    return f"{t * 1e3:.3g} ms"


def _design_label(cfg, result: dict) -> str:
    alpha = float(np.asarray(cfg.design.amplification))
    T = float(np.asarray(cfg.implementation.delay_s))
    name = os.path.basename(cfg.source) if getattr(cfg, "source", None) else "design"
    return f"{name}: α = {alpha:.4g}, T = {_fmt_s(T)}, structure '{result.get('structure', cfg.implementation.structure)}'"


def _controller(cfg, implementation=None):
    from ..model.controller import build_controller

    return build_controller(cfg.plant, cfg.design, implementation or cfg.implementation)


def _mark_bands(ax, bands, label=True):
    for i, (a, b) in enumerate(bands):
        b = b if _finite(b) else F_MAX_HZ
        ax.axvspan(a, b, color=NONPASSIVE_COLOR, alpha=0.12, lw=0, label="C7 non-passive band" if (label and i == 0) else None)


# ----------------------------------------------------------------------------------------------
# 1. Bode of the compliances
# ----------------------------------------------------------------------------------------------
def _fig_bode_compliances(cfg, result: dict) -> bytes:
    from ..analysis.core import amplification_qps, char_terms

    cs, _ds = _controller(cfg)
    ct = char_terms(cfg.plant, cs, 1)
    num, den = amplification_qps(cfg.plant, cs, 1)
    f = _freq_grid(result)
    w = 2 * np.pi * f
    d00 = _qp_response(ct.qp("00"), w)
    C5 = _qp_response(ct.qp("01"), w) / d00
    C7 = _qp_response(ct.qp("10"), w) / d00
    A = _qp_response(num, w) / _qp_response(den, w)
    bands = (result.get("passivity") or {}).get("nonpassive_band_hz") or []
    excess = (result.get("passivity") or {}).get("max_phase_excess_deg")

    fig = _new_figure((8.5, 9.5))
    ax1, ax2, ax3 = fig.subplots(3, 1, sharex=True, gridspec_kw={"height_ratios": [1.3, 0.8, 1.3]})
    ax1.semilogx(f, _db(C5), color="tab:blue", label="C5 = θ_j/τ_env (cuff free)")
    ax1.semilogx(f, _db(C7), color="tab:orange", label="C7 = θ_h/τ_h (operator side)")
    ax1.set_ylabel("|C| [dB re 1 rad/(N·m)]")
    ax2.semilogx(f, _db(A), color="tab:purple", label="C6/C5 (amplification)")
    alpha = float(np.asarray(cfg.design.amplification))
    ax2.axhline(20 * np.log10(alpha), color="tab:purple", ls=":", lw=0.9, label=f"α = {alpha:.4g}")
    ax2.set_ylabel("|C6/C5| [dB re 1]")
    ax3.axhspan(-180.0, 0.0, color=PASSIVE_COLOR, alpha=0.10, lw=0, label="passive phase band [−180°, 0°]")
    ax3.semilogx(f, _phase_deg(C5), color="tab:blue", label="∠C5")
    ax3.semilogx(f, _phase_deg(C7), color="tab:orange", label="∠C7")
    ax3.semilogx(f, _phase_deg(A), color="tab:purple", label="∠C6/C5")
    ax3.set_ylabel("phase [deg]")
    ax3.set_xlabel("frequency [Hz]")
    ax3.set_yticks(np.arange(-360, 361, 90))
    lo_ph = min(np.min(_phase_deg(C5)), np.min(_phase_deg(C7)), np.min(_phase_deg(A)))
    hi_ph = max(np.max(_phase_deg(C5)), np.max(_phase_deg(C7)), np.max(_phase_deg(A)))
    ax3.set_ylim(max(lo_ph, -400) - 15, min(hi_ph, 400) + 15)
    for ax in (ax1, ax2, ax3):
        _mark_bands(ax, bands, label=(ax is ax3))
        for h in result.get("humans") or []:
            for c in h.get("critical") or []:
                if _finite(c.get("frequency_hz")) and c["frequency_hz"] > 0:
                    ax.axvline(c["frequency_hz"], color="k", ls="--", lw=0.7, alpha=0.5)
        ax.grid(True, which="both", alpha=0.25)
        ax.legend(loc="best", fontsize=8)
    ax3.set_xlim(f[0], f[-1])
    crit_txt = "; ".join(
        f"{h['kind']} {_SYMBOL.get(h['parameter'], h['parameter'])} = {c['value']:.4g} {h['unit']} at {c['frequency_hz']:.4g} Hz"
        for h in result.get("humans") or []
        for c in h.get("critical") or []
    )
    ex = f"max phase excess of C7: {excess:.3g}°" if _finite(excess) else ""
    fig.suptitle("Compliances with delay and filters — " + _design_label(cfg, result), fontsize=10)
    foot = ex + (("; dashed lines: human stability boundaries (" + crit_txt + ")") if crit_txt else "")
    fig.text(0.5, 0.01, foot, ha="center", va="bottom", fontsize=7.5, wrap=True)
    fig.subplots_adjust(left=0.11, right=0.97, top=0.95, bottom=0.08, hspace=0.1)
    return _png(fig)


# ----------------------------------------------------------------------------------------------
# 2. Nyquist of the human loops
# ----------------------------------------------------------------------------------------------
def _interior(a: float, b: float, frac: float) -> float:
    if a > 0 and b > 0:
        return a * (b / a) ** frac
    return a + (b - a) * frac


def _nyquist_values(h: dict) -> list[tuple[float, str]]:
    """3–5 (value, role) of the ranged parameter: criticals, inside each stable interval, ends."""
    lo, hi = (float(x) for x in h["range"])
    crit = [float(c["value"]) for c in h.get("critical") or [] if _finite(c.get("value"))]
    cset = set(crit)
    inside = []
    for a, b in h.get("stable_intervals") or []:
        a, b = float(a), float(b)
        if a in cset or (a > lo and b >= hi):
            inside.append(_interior(a, b, 0.08))
        elif b in cset or b < hi:
            inside.append(_interior(b, a, 0.08))
        else:
            inside.append(_interior(a, b, 0.5))
    cands = [(v, "critical") for v in crit[:3]] + [(v, "stable") for v in inside] + [(lo, "end"), (hi, "end")]
    out: list[tuple[float, str]] = []
    for v, role in cands:
        if all(abs(v - u) > 1e-6 * max(abs(u), abs(v), 1e-300) for u, _ in out):
            out.append((v, role))
    if len(out) < 3:
        out.append((_interior(lo, hi, 0.5), "mid"))
    out = out[:5]
    return sorted(out, key=lambda t: t[0])


def _is_stable(v: float, h: dict) -> bool:
    return any(float(a) * (1 - 1e-12) <= v <= float(b) * (1 + 1e-12) for a, b in h.get("stable_intervals") or [])


def _neg_real_crossings(L: np.ndarray) -> np.ndarray:
    """Points where L crosses the negative real axis (linear interpolation between samples)."""
    im = L.imag
    i = np.nonzero((np.sign(im[:-1]) * np.sign(im[1:]) < 0) & np.isfinite(im[:-1]) & np.isfinite(im[1:]))[0]
    t = im[i] / (im[i] - im[i + 1])
    x = L.real[i] + t * (L.real[i + 1] - L.real[i])
    return x[x < 0]


def _nyq_extent(L: np.ndarray) -> float:
    """Largest |Im L| of the curve where it lies left of the origin inside the window (where
    the encirclements of −1 are decided); used to zoom the imaginary axis of flat curves."""
    m = (L.real > NYQ_XLIM[0]) & (L.real < -0.1) & (np.abs(L.imag) <= NYQ_YMAX)
    return float(np.max(np.abs(L.imag[m]))) if m.any() else 0.0


def _fig_nyquist_humans(cfg, result: dict) -> bytes:
    from matplotlib import colormaps

    from ..analysis.core import char_terms
    from ..model.humans import family_split

    humans = result["humans"]
    cs, _ds = _controller(cfg)
    ct = char_terms(cfg.plant, cs, 1)
    f = np.unique(np.concatenate([np.geomspace(1e-2, 1e4, 6000), _freq_grid(result, 1e-2, 1e4, 10)]))
    w = 2 * np.pi * f
    d00 = _qp_response(ct.qp("00"), w)
    C7 = _qp_response(ct.qp("10"), w) / d00

    n = len(humans)
    ncol = min(n, 2)
    nrow = int(math.ceil(n / ncol))
    fig = _new_figure((6.2 * ncol, 5.6 * nrow + 0.8))
    axes = np.atleast_1d(fig.subplots(nrow, ncol, squeeze=False)).ravel()
    cmap = colormaps["viridis"]
    for ax, h in zip(axes, humans):
        kind, param = h["kind"], h["parameter"]
        fixed = {k: float(v) for k, v in (h.get("fixed") or {}).items() if _finite(v)}
        eta = fixed.pop("eta", 0.0)
        z0, phi, factor = family_split(kind, param, fixed, eta)
        s = 1j * w
        z0v = z0[0] + z0[1] * s + z0[2] * s**2
        phiv = (phi[0] + phi[1] * s + phi[2] * s**2) * factor
        vals = _nyquist_values(h)
        ax.axhline(0, color="0.6", lw=0.6)
        ax.axvline(0, color="0.6", lw=0.6)
        ax.plot([-1], [0], marker="+", color="red", ms=14, mew=2, ls="none", label="−1 (critical point)", zorder=5)
        sym = _SYMBOL.get(param, param)
        crossing_labelled = False
        ymax = 0.0
        for j, (v, role) in enumerate(vals):
            L = (z0v + v * phiv) * C7
            col = cmap(0.1 + 0.8 * j / max(len(vals) - 1, 1))
            if role == "critical":
                state = "critical"
            else:
                state = "stable" if _is_stable(v, h) else "UNSTABLE"
            ls = "-" if state != "UNSTABLE" else "--"
            ymax = max(ymax, _nyq_extent(L))
            inview = np.any((L.real > NYQ_XLIM[0]) & (L.real < NYQ_XLIM[1]) & (np.abs(L.imag) < NYQ_YMAX))
            ax.plot(L.real, L.imag, color=col, ls=ls, lw=1.3,
                    label=f"{sym} = {v:.4g} {h['unit']} ({state})" + ("" if inview else " — outside the view"))
            ax.plot(L.real, -L.imag, color=col, ls=ls, lw=0.7, alpha=0.35)  # ω < 0 (mirror image)
            x = _neg_real_crossings(L)
            x = x[(x > NYQ_XLIM[0]) & (x < NYQ_XLIM[1])]
            if x.size:
                ax.plot(x, np.zeros_like(x), marker="o", mfc="none", color=col, ms=6, ls="none",
                        label="crossings of the negative real axis" if not crossing_labelled else None)
                crossing_labelled = True
        for c in h.get("critical") or []:
            if not (_finite(c.get("value")) and _finite(c.get("frequency_hz"))):
                continue
            wc = 2 * np.pi * float(c["frequency_hz"])
            sc = 1j * wc
            Lc = (z0[0] + z0[1] * sc + z0[2] * sc**2 + float(c["value"]) * (phi[0] + phi[1] * sc + phi[2] * sc**2) * factor) * (
                _qp_response(ct.qp("10"), np.array([wc])) / _qp_response(ct.qp("00"), np.array([wc]))
            )[0]
            ax.plot([Lc.real], [Lc.imag], marker="x", color="red", ms=9, mew=1.8, ls="none")
            ax.annotate(f"{sym} = {c['value']:.4g}: L = −1 at {c['frequency_hz']:.4g} Hz", (Lc.real, Lc.imag),
                        xytext=(8, 12), textcoords="offset points", fontsize=7.5, color="red")
        yh = min(max(1.3 * ymax, NYQ_YMIN), NYQ_YMAX)
        ax.set_xlim(*NYQ_XLIM)
        ax.set_ylim(-yh, yh)
        ax.grid(True, alpha=0.25)
        ax.set_xlabel("Re L(jω) [1]")
        ax.set_ylabel("Im L(jω) [1]")
        zdesc = {
            "spring": "Z = k + b s",
            "mass": "Z = m s² + b s",
            "msd": "Z = m s² + b s + k",
            "complex_stiffness": "Z = k (1 + jη sign ω)",
        }.get(kind, kind)
        fx = ", ".join(f"{_SYMBOL.get(k, k) if k != 'eta' else 'η'} = {v:.4g}" for k, v in {**fixed, **({"eta": eta} if kind == "complex_stiffness" else {})}.items() if k != param)
        iv = ", ".join(f"[{a:.4g}, {b:.4g}]" for a, b in h.get("stable_intervals") or []) or "none"
        ax.set_title(f"{kind}: {zdesc}  ({fx})\n{sym} ∈ [{h['range'][0]:.4g}, {h['range'][1]:.4g}] {h['unit']}; stable on {iv}",
                     fontsize=8.5)
        ax.legend(loc="lower left", fontsize=7)
    for ax in axes[n:]:
        ax.set_visible(False)
    fig.suptitle("Coupled loop L(jω) = Z_h(jω)·C7(jω), Δ = Δ00·(1 + L) — " + _design_label(cfg, result), fontsize=10)
    fig.text(0.5, 0.005,
             f"Linear view limited to Re L ∈ [{NYQ_XLIM[0]:g}, {NYQ_XLIM[1]:g}] and |Im L| ≤ {NYQ_YMAX:g} around −1, "
             "the imaginary axis zoomed further where the curves left of the origin are flat (axes not to equal scale); "
             "curves continue outside the view.\nBold: ω > 0 (0.01 Hz – 10 kHz); faint: ω < 0 (mirror image). "
             "Dashed: unstable values; verdicts from the exact stable intervals; ○ crossings of the negative real axis, × L = −1.",
             ha="center", va="bottom", fontsize=7.5, wrap=True)
    fig.subplots_adjust(left=0.08, right=0.98, top=0.9, bottom=0.08, wspace=0.2, hspace=0.3)
    return _png(fig)


# ----------------------------------------------------------------------------------------------
# 3. DOB loop (paper Fig. DOBtune)
# ----------------------------------------------------------------------------------------------
def _fig_dob_loop(cfg, result: dict) -> bytes:
    cs, _ds = _controller(cfg)
    T = float(np.asarray(cfg.implementation.delay_s))
    f = _freq_grid(result)
    w = 2 * np.pi * f
    Q = _rational_response(cs.dob_q, w)
    with np.errstate(divide="ignore", invalid="ignore"):
        L = Q * np.exp(-1j * w * T) / (1.0 - Q)
        CL = L / (1.0 + L)
    phL = _phase_deg(L)
    dob = result.get("dob") or {}

    fig = _new_figure((8.5, 8.0))
    ax1, ax2 = fig.subplots(2, 1, sharex=True)
    ax1.semilogx(f, _db(L), color="tab:blue", label="L_dob = Q·e^(−jωT)/(1 − Q) (open loop)")
    ax1.semilogx(f, _db(CL), color="tab:red", label="L/(1 + L) (Q distorted by the delay)")
    ax1.semilogx(f, _db(Q), color="0.4", ls="--", label="Q (original)")
    ax1.axhline(0, color="k", lw=0.7)
    ax1.set_ylabel("magnitude [dB re 1]")
    ax2.semilogx(f, phL, color="tab:blue", label="∠L_dob")
    ax2.semilogx(f, _phase_deg(CL), color="tab:red", label="∠L/(1 + L)")
    ax2.semilogx(f, _phase_deg(Q), color="0.4", ls="--", label="∠Q")
    ax2.set_ylabel("phase [deg]")
    ax2.set_xlabel("frequency [Hz]")
    for k in range(-5, 1):
        if phL.min() - 30 < -180 + 360 * k < 30:
            ax2.axhline(-180 + 360 * k, color="k", lw=0.6, ls=":")
    ax2.set_ylim(max(phL.min(), -900) - 20, 20)
    # gain crossover (from the analysis) and the phase crossover with the largest |L| on the grid
    fc = dob.get("crossover_hz")
    if _finite(fc):
        wc = 2 * np.pi * float(fc)
        Qc = _rational_response(cs.dob_q, np.array([wc]))[0]
        Lc = Qc * np.exp(-1j * wc * T) / (1 - Qc)
        phc = np.interp(fc, f, phL)
        for ax in (ax1, ax2):
            ax.axvline(fc, color="tab:green", ls="--", lw=0.9)
        ax1.plot([fc], [_db(Lc)], "o", color="tab:green", label=f"gain crossover {fc:.4g} Hz")
        pm = dob.get("phase_margin_deg")
        target = -180.0 + 360.0 * np.round((phc + 180.0) / 360.0)
        ax2.annotate("", xy=(fc, phc), xytext=(fc, target), arrowprops=dict(arrowstyle="<->", color="tab:green"))
        if _finite(pm):
            ax2.text(fc / 1.08, 0.5 * (phc + target), f"PM = {pm:.3g}° ", color="tab:green", fontsize=8, va="center", ha="right")
    k = np.floor((phL + 180.0) / 360.0)
    idx = np.nonzero(k[1:] != k[:-1])[0]
    if idx.size:
        j = idx[np.argmax(np.abs(L[idx]))]
        f180 = f[j]
        mag180 = _db(L[j])
        for ax in (ax1, ax2):
            ax.axvline(f180, color="tab:orange", ls="--", lw=0.9)
        ax1.annotate("", xy=(f180, mag180), xytext=(f180, 0.0), arrowprops=dict(arrowstyle="<->", color="tab:orange"))
        gm = dob.get("gain_margin_db")
        ax1.plot([f180], [mag180], "s", color="tab:orange", label=f"phase crossover ≈ {f180:.4g} Hz")
        ax2.plot([f180], [phL[j]], "s", color="tab:orange")
        if _finite(gm):
            ax1.text(f180 * 1.08, 0.5 * mag180, f"GM = {gm:.3g} dB", color="tab:orange", fontsize=8, va="center")
    lines = [f"modelled delay T = {_fmt_s(T)}"]
    if _finite(dob.get("gain_margin_db")):
        lines.append(f"gain margin {dob['gain_margin_db']:.4g} dB")
    else:
        lines.append(f"gain margin {dob.get('gain_margin_db')} (no phase crossover)")
    if _finite(dob.get("phase_margin_deg")):
        lines.append(f"phase margin {dob['phase_margin_deg']:.4g}° at {dob.get('crossover_hz', float('nan')):.4g} Hz")
    if _finite(dob.get("delay_margin_s")):
        lines.append(f"delay margin {_fmt_s(dob['delay_margin_s'])} (extra, on top of T)")
    ax1.text(0.02, 0.04, "\n".join(lines), transform=ax1.transAxes, fontsize=8.5, va="bottom",
             bbox=dict(boxstyle="round", fc="white", ec="0.6", alpha=0.9))
    lo_db = np.nanmin(np.where(np.isfinite(_db(Q)), _db(Q), np.nan))
    hi_db = np.nanmax(np.where(np.isfinite(_db(L)), _db(L), np.nan))
    ax1.set_ylim(max(lo_db, -80) - 5, min(hi_db, 80) + 5)
    for ax in (ax1, ax2):
        ax.grid(True, which="both", alpha=0.25)
        ax.legend(loc="upper right" if ax is ax1 else "lower left", fontsize=8)
    ax2.set_xlim(f[0], f[-1])
    q = cfg.implementation.dob
    fig.suptitle(
        f"DOB loop (paper Fig. DOBtune): Q at {float(np.asarray(q.cutoff_hz)):.4g} Hz, ζ_q = {float(np.asarray(q.damping)):.3g} — "
        + _design_label(cfg, result),
        fontsize=10,
    )
    fig.subplots_adjust(left=0.1, right=0.97, top=0.94, bottom=0.07, hspace=0.08)
    return _png(fig)


# ----------------------------------------------------------------------------------------------
# 4. Amplification at two delays (paper Fig. amplification)
# ----------------------------------------------------------------------------------------------
def second_delay(T: float) -> float:
    """The larger comparison delay of ``amplification.png``: max(2T, T + 2 ms)."""
    return max(2.0 * T, T + 2e-3)


def _fig_amplification(cfg, result: dict) -> bytes:
    from ..analysis.core import amplification, amplification_qps

    T = float(np.asarray(cfg.implementation.delay_s))
    T2 = second_delay(T)
    f = _freq_grid(result)
    w = 2 * np.pi * f
    amp_res = result.get("amplification") or {}
    alpha = float(np.asarray(cfg.design.amplification))

    fig = _new_figure((8.5, 8.0))
    ax1, ax2 = fig.subplots(2, 1, sharex=True)
    styles = [("tab:blue", "-"), ("tab:red", "--")]
    for (Td, (col, ls)) in zip((T, T2), styles):
        impl = dataclasses.replace(cfg.implementation, delay_s=Td)
        cs, _ds = _controller(cfg, impl)
        num, den = amplification_qps(cfg.plant, cs, 1)
        A = _qp_response(num, w) / _qp_response(den, w)
        if Td == T:
            mp, bw, locked = amp_res.get("minimum_phase"), amp_res.get("bandwidth_hz"), result.get("locked_stable")
        else:
            a2 = amplification(cfg.plant, cs, 1)
            mp, bw, locked = bool(a2["minimum_phase"][0]), float(a2["bandwidth_hz"][0]), bool(a2["locked_stable"][0])
        tag = f"T = {_fmt_s(Td)}" + (" (configured)" if Td == T else "")
        mp_txt = "minimum phase" if mp else "NON-minimum phase"
        lk_txt = "" if locked is None else ("; output-locked stable" if locked else "; output-locked UNSTABLE")
        bw_txt = f"; −3 dB at {bw:.3g} Hz" if _finite(bw) else "; −3 dB not reached"
        ax1.semilogx(f, _db(A), color=col, ls=ls, label=f"|C6/C5|, {tag}: {mp_txt}{lk_txt}{bw_txt}")
        ax2.semilogx(f, _phase_deg(A), color=col, ls=ls, label=f"∠C6/C5, {tag}")
        if _finite(bw) and F_MIN_HZ <= bw <= F_MAX_HZ:
            for ax in (ax1, ax2):
                ax.axvline(bw, color=col, ls=":", lw=0.9)
            ax1.plot([bw], [20 * np.log10(alpha) - 3.0103], "o", color=col)
    dc = amp_res.get("dc")
    ax1.axhline(20 * np.log10(alpha), color="k", lw=0.8, ls="-.",
                label=f"DC level α = {alpha:.4g} ({20 * np.log10(alpha):.3g} dB)" + (f"; analysed DC {dc:.4g}" if _finite(dc) else ""))
    ax1.axhline(20 * np.log10(alpha) - 3.0103, color="0.5", lw=0.8, ls=":", label="α − 3 dB")
    ax1.set_ylabel("|C6/C5| [dB re 1]")
    ax2.set_ylabel("phase [deg]")
    ax2.set_xlabel("frequency [Hz]")
    for ax in (ax1, ax2):
        ax.grid(True, which="both", alpha=0.25)
        ax.legend(loc="lower left", fontsize=7.5)
    ax2.set_xlim(f[0], f[-1])
    fig.suptitle("Amplification C6/C5 = −τ_env/τ_h (output locked) at two delays — " + _design_label(cfg, result), fontsize=10)
    fig.text(0.5, 0.005, "Second delay = max(2T, T + 2 ms); minimum-phase and output-locked verdicts by exact RHP counts "
             "of the numerator and denominator quasi-polynomials.", ha="center", va="bottom", fontsize=7.5)
    fig.subplots_adjust(left=0.1, right=0.97, top=0.94, bottom=0.08, hspace=0.08)
    return _png(fig)


# ----------------------------------------------------------------------------------------------
# driver
# ----------------------------------------------------------------------------------------------
def render_analysis_plots(cfg, result: dict) -> dict[str, bytes]:
    """Render every figure to PNG bytes (nothing written). Keys are the file names."""
    out: dict[str, bytes] = {}
    out["bode_compliances.png"] = _fig_bode_compliances(cfg, result)
    if result.get("humans"):
        out["nyquist_humans.png"] = _fig_nyquist_humans(cfg, result)
    if cfg.implementation.dob is not None:
        out["dob_loop.png"] = _fig_dob_loop(cfg, result)
    out["amplification.png"] = _fig_amplification(cfg, result)
    return out


def write_analysis_plots(cfg, result: dict, out_dir) -> list[Path]:
    """Render the analysis figures of one design and write them as PNGs into ``out_dir``.

    All figures are rendered in memory first; ``out_dir`` is created (if needed) only after
    every figure succeeded, and each file is written atomically. ``nyquist_humans.png`` is
    skipped when the design has no human family, ``dob_loop.png`` when it has no DOB.
    If writing fails part-way, the files written by this call are removed again (and
    ``out_dir`` too when this call created it and it is left empty). Returns the written paths.
    """
    from ..jsonio import write_atomic

    files = render_analysis_plots(cfg, result)
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
