"""The numbers drawn by ``exotune analyze --plots`` (:mod:`exotune.plots.analysis` only draws them).

Frequency responses of one design with its exact delay and implemented filters, on a log grid
that resolves the analysis' critical frequencies: the compliances C5 = Δ01/Δ00 and C7 = Δ10/Δ00 and
the amplification C6/C5 (:func:`compliance_responses`), the coupled human loops
L(jω) = Z_h(jω)·C7(jω) (:func:`human_loops`), the disturbance-observer loop
L_dob = Q e^{−jωT}/(1 − Q) (:func:`dob_loop`) and the amplification at two delays
(:func:`amplification_at_delays`).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

__all__ = [
    "F_MIN_HZ",
    "F_MAX_HZ",
    "N_GRID",
    "finite",
    "freq_grid_hz",
    "phase_deg",
    "db",
    "second_delay",
    "compliance_responses",
    "nyquist_values",
    "box_edge_families",
    "human_loops",
    "dob_loop",
    "amplification_at_delays",
]

F_MIN_HZ = 0.1
F_MAX_HZ = 2000.0
N_GRID = 2400


def finite(x) -> bool:
    """True for a finite number (None, strings and NaN/inf are not).

    Parameters
    ----------
    x : object
        Any value.

    Returns
    -------
    bool
    """
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
    return [float(f) for f in out if finite(f) and float(f) > 0]


def freq_grid_hz(result: dict, fmin=F_MIN_HZ, fmax=F_MAX_HZ, n=N_GRID) -> np.ndarray:
    """Dense log grid of frequencies with clusters of points around the critical frequencies.

    Parameters
    ----------
    result : dict
        The result of :func:`exotune.analysis.analyze_design` (its critical frequencies, band
        edges, DOB crossover and bandwidth are resolved by ±2 % clusters of 21 points).
    fmin, fmax : float
        Range [Hz].
    n : int
        Points of the log grid.

    Returns
    -------
    numpy.ndarray
        Sorted unique frequencies [Hz].

    References
    ----------
    docs/cli.md#analyze.
    """
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


def phase_deg(H: np.ndarray) -> np.ndarray:
    """Continuous phase [deg] of a response, anchored so that the first value lies in (−180°, 180°].

    Parameters
    ----------
    H : ndarray of complex
        A frequency response on an increasing frequency grid.

    Returns
    -------
    ndarray
        Its unwrapped phase [deg].
    """
    ph = np.unwrap(np.angle(H))
    return np.degrees(ph - 2 * np.pi * np.round((ph[0] - np.angle(H[0])) / (2 * np.pi)))


def db(H) -> np.ndarray:
    """20 log10 |H| (−inf at 0, without a warning).

    Parameters
    ----------
    H : array_like of complex
        A frequency response.

    Returns
    -------
    ndarray
        Its magnitude [dB].
    """
    with np.errstate(divide="ignore"):
        return 20.0 * np.log10(np.abs(H))


def second_delay(T: float) -> float:
    """The larger comparison delay of ``amplification.png``: max(2T, T + 2 ms).

    Parameters
    ----------
    T : float
        The design's delay [s].

    Returns
    -------
    float
        The comparison delay [s] (paper Fig. 5 compares the amplification at two delays).
    """
    return max(2.0 * T, T + 2e-3)


def _controller(cfg, implementation=None):
    from ..model.controller import build_controller

    return build_controller(cfg.plant, cfg.design, implementation or cfg.implementation)


def compliance_responses(cfg, result: dict) -> dict:
    """C5, C7 and C6/C5 of a design with its delay and filters.

    Parameters
    ----------
    cfg : exotune.config.design.DesignConfig
        One design.
    result : dict
        Its :func:`exotune.analysis.analyze_design` result (for the frequency grid).

    Returns
    -------
    dict
        ``f`` [Hz] and the complex responses ``C5`` = Δ01/Δ00 (cuff free), ``C7`` = Δ10/Δ00
        (operator side) [rad/(N·m)] and ``A`` = C6/C5 (amplification) [1].

    References
    ----------
    Paper §II (the model), §II-D (amplification); docs/cli.md#analyze.
    """
    from .charfun import amplification_qps, char_terms

    cs, _ds = _controller(cfg)
    ct = char_terms(cfg.plant, cs, 1)
    num, den = amplification_qps(cfg.plant, cs, 1)
    f = freq_grid_hz(result)
    w = 2 * np.pi * f
    d00 = _qp_response(ct.qp("00"), w)
    C5 = _qp_response(ct.qp("01"), w) / d00
    C7 = _qp_response(ct.qp("10"), w) / d00
    A = _qp_response(num, w) / _qp_response(den, w)
    return {"f": f, "C5": C5, "C7": C7, "A": A}


def _interior(a: float, b: float, frac: float) -> float:
    if a > 0 and b > 0:
        return a * (b / a) ** frac
    return a + (b - a) * frac


def nyquist_values(h: dict) -> list[tuple[float, str]]:
    """3–5 (value, role) of a family's ranged parameter: criticals, inside each stable interval, ends.

    Parameters
    ----------
    h : dict
        One entry of ``result["humans"]`` (range, critical values, stable intervals).

    Returns
    -------
    list of (float, str)
        Sorted values with their role ``"critical"``, ``"stable"``, ``"end"`` or ``"mid"``.

    References
    ----------
    docs/cli.md#analyze.
    """
    lo, hi = (float(x) for x in h["range"])
    crit = [float(c["value"]) for c in h.get("critical") or [] if finite(c.get("value"))]
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


def box_edge_families(h: dict) -> list[dict]:
    """The edges of an msd box family as one-parameter family entries (a plain family: itself).

    Parameters
    ----------
    h : dict
        One entry of ``result["humans"]``; a box has ``box`` and ``edges`` (each edge: ``parameter``,
        ``range``, ``at`` — the other ranged parameters at a corner — and ``stable_intervals``).

    Returns
    -------
    list of dict
        Per edge: ``kind``, ``parameter``, ``unit``, ``range``, ``stable_intervals``, ``critical``
        (none: the edges carry no boundary list), ``fixed`` (the family's fixed parameters and the
        edge's corner values) and ``edge``: ``{"index", "count", "at"}``; ``[h]`` for a family
        that is not a box.

    References
    ----------
    Paper §IV (coupled stability); docs/method.md (msd boxes: the Edge Theorem); docs/cli.md#analyze.
    """
    from ..model.humans import PARAM_UNITS

    edges = h.get("edges") or []
    if not (h.get("box") and edges):
        return [h]
    return [{"kind": h["kind"], "parameter": e["parameter"], "unit": PARAM_UNITS[e["parameter"]],
             "range": e["range"], "stable_intervals": e["stable_intervals"], "critical": [],
             "fixed": {**(h.get("fixed") or {}), **e["at"]},
             "edge": {"index": k, "count": len(edges), "at": dict(e["at"])}}
            for k, e in enumerate(edges)]


def _family_loop(h: dict, ct, w: np.ndarray, C7: np.ndarray) -> dict:
    """The Nyquist curves and critical points of one one-parameter family (see :func:`human_loops`)."""
    from ..model.humans import family_split

    kind, param = h["kind"], h["parameter"]
    fixed = {k: float(v) for k, v in (h.get("fixed") or {}).items() if finite(v)}
    eta = fixed.pop("eta", 0.0)
    z0, phi, factor = family_split(kind, param, fixed, eta)
    s = 1j * w
    z0v = z0[0] + z0[1] * s + z0[2] * s**2
    phiv = (phi[0] + phi[1] * s + phi[2] * s**2) * factor
    curves = []
    for v, role in nyquist_values(h):
        L = (z0v + v * phiv) * C7
        if role == "critical":
            state = "critical"
        else:
            state = "stable" if _is_stable(v, h) else "UNSTABLE"
        curves.append((v, role, state, L, _neg_real_crossings(L)))
    crit = []
    for c in h.get("critical") or []:
        if not (finite(c.get("value")) and finite(c.get("frequency_hz"))):
            continue
        wc = 2 * np.pi * float(c["frequency_hz"])
        sc = 1j * wc
        Lc = (z0[0] + z0[1] * sc + z0[2] * sc**2 + float(c["value"]) * (phi[0] + phi[1] * sc + phi[2] * sc**2) * factor) * (
            _qp_response(ct.qp("10"), np.array([wc])) / _qp_response(ct.qp("00"), np.array([wc]))
        )[0]
        crit.append((c, Lc))
    return {"h": h, "fixed": fixed, "eta": eta, "curves": curves, "critical": crit, "edge": h.get("edge")}


def human_loops(cfg, result: dict) -> list[dict]:
    """The coupled loops L(jω) = Z_h(jω)·C7(jω) of every human family (Δ = Δ00 (1 + L)).

    Parameters
    ----------
    cfg : exotune.config.design.DesignConfig
        One design.
    result : dict
        Its :func:`exotune.analysis.analyze_design` result (``humans`` with their intervals).

    Returns
    -------
    list of dict
        Per one-parameter family — an msd box contributes one entry per edge
        (:func:`box_edge_families`): ``h`` (its result entry, or the edge's), ``fixed`` (the other
        parameters), ``eta``, ``edge`` (None, or the edge's index, count and corner values),
        ``curves`` — a list of ``(value, role, state, L, crossings)`` for the values of
        :func:`nyquist_values` on 0.01 Hz – 10 kHz (``state`` "critical", "stable" or "UNSTABLE"
        from the exact stable intervals; ``crossings`` the negative-real-axis crossings) — and
        ``critical``: ``(entry, L(jω_c))`` at each critical value and frequency.

    References
    ----------
    Paper §IV (coupled stability); docs/cli.md#analyze.
    """
    from .charfun import char_terms

    cs, _ds = _controller(cfg)
    ct = char_terms(cfg.plant, cs, 1)
    f = np.unique(np.concatenate([np.geomspace(1e-2, 1e4, 6000), freq_grid_hz(result, 1e-2, 1e4, 10)]))
    w = 2 * np.pi * f
    d00 = _qp_response(ct.qp("00"), w)
    C7 = _qp_response(ct.qp("10"), w) / d00
    return [_family_loop(fh, ct, w, C7) for h in result["humans"] for fh in box_edge_families(h)]


def dob_loop(cfg, result: dict) -> dict:
    """The disturbance-observer loop of a design with its delay (the paper's Fig. 4).

    Parameters
    ----------
    cfg : exotune.config.design.DesignConfig
        One design with a DOB.
    result : dict
        Its :func:`exotune.analysis.analyze_design` result (``dob`` margins).

    Returns
    -------
    dict
        ``f`` [Hz], ``T`` [s], the complex ``Q``, ``L`` = Q e^{−jωT}/(1 − Q) and ``CL`` = L/(1 + L),
        ``phL`` (continuous phase of L [deg]); ``crossover``: ``(f_c, L(jω_c), phase at f_c, nearest
        −180° + k·360°)`` at the analysed gain crossover, or None; ``phase_crossover``: the grid
        index of the −180° crossing with the largest |L|, or None.

    References
    ----------
    Paper §III (DOB tuning, Fig. 4); docs/cli.md#analyze.
    """
    cs, _ds = _controller(cfg)
    T = float(np.asarray(cfg.implementation.delay_s))
    f = freq_grid_hz(result)
    w = 2 * np.pi * f
    Q = _rational_response(cs.dob_q, w)
    with np.errstate(divide="ignore", invalid="ignore"):
        L = Q * np.exp(-1j * w * T) / (1.0 - Q)
        CL = L / (1.0 + L)
    phL = phase_deg(L)
    dob = result.get("dob") or {}
    crossover = None
    fc = dob.get("crossover_hz")
    if finite(fc):
        wc = 2 * np.pi * float(fc)
        Qc = _rational_response(cs.dob_q, np.array([wc]))[0]
        Lc = Qc * np.exp(-1j * wc * T) / (1 - Qc)
        phc = np.interp(fc, f, phL)
        target = -180.0 + 360.0 * np.round((phc + 180.0) / 360.0)
        crossover = (fc, Lc, phc, target)
    k = np.floor((phL + 180.0) / 360.0)
    idx = np.nonzero(k[1:] != k[:-1])[0]
    phase_crossover = int(idx[np.argmax(np.abs(L[idx]))]) if idx.size else None
    return {"f": f, "T": T, "Q": Q, "L": L, "CL": CL, "phL": phL, "crossover": crossover,
            "phase_crossover": phase_crossover}


def amplification_at_delays(cfg, result: dict) -> tuple[np.ndarray, list[dict]]:
    """C6/C5 at the configured delay T and at :func:`second_delay` (the paper's Fig. 5).

    Parameters
    ----------
    cfg : exotune.config.design.DesignConfig
        One design.
    result : dict
        Its :func:`exotune.analysis.analyze_design` result (the verdicts at T).

    Returns
    -------
    (numpy.ndarray, list of dict)
        Frequencies [Hz] and, per delay, ``T``, ``configured``, the complex response ``A`` and the
        ``minimum_phase``, ``bandwidth_hz`` and ``locked_stable`` verdicts.

    References
    ----------
    Paper §II-D; docs/cli.md#analyze.
    """
    from .amplification_ratio import amplification
    from .charfun import amplification_qps

    T = float(np.asarray(cfg.implementation.delay_s))
    T2 = second_delay(T)
    f = freq_grid_hz(result)
    w = 2 * np.pi * f
    amp_res = result.get("amplification") or {}
    out = []
    for Td in (T, T2):
        impl = dataclasses.replace(cfg.implementation, delay_s=Td)
        cs, _ds = _controller(cfg, impl)
        num, den = amplification_qps(cfg.plant, cs, 1)
        A = _qp_response(num, w) / _qp_response(den, w)
        if Td == T:
            mp, bw, locked = amp_res.get("minimum_phase"), amp_res.get("bandwidth_hz"), result.get("locked_stable")
            if amp_res.get("conclusive") is False:  # the root count did not decide: unknown, not "non-minimum"
                mp = None
        else:
            a2 = amplification(cfg.plant, cs, 1)
            mp, bw, locked = bool(a2["minimum_phase"][0]), float(a2["bandwidth_hz"][0]), bool(a2["locked_stable"][0])
            if not bool(a2["conclusive"][0]):
                mp = None
        out.append({"T": Td, "configured": Td == T, "A": A, "minimum_phase": mp, "bandwidth_hz": bw,
                    "locked_stable": locked})
    return f, out
