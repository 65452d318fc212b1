"""Numbers of ``exotune design``: gains, compliance shape, poles and zeros of the nominal transfer
functions and the validity of the low-frequency approximation Ĉ5 ≈ C5 (paper §IV).

Also the small toolbox on one rational transfer function num(s)/den(s) (ascending coefficients,
the :mod:`exotune.numerics.poly` convention) shared with :mod:`exotune.analysis.sea` and the
design plots: exact cancellation of common roots at s = 0, sorted roots, frequency responses on a
log grid, the phase extremum and the resonance peak (both refined with ``minimize_scalar``).

Conventions of the numbers: gains in torque units, poles and zeros in rad/s with natural
frequencies in Hz (docs/method.md#controller).
"""

from __future__ import annotations

import math

import numpy as np

from ..version import __version__
from .results import DesignSummary

__all__ = [
    "TF_INFO",
    "APPROX_TOL",
    "GAIN_CONVENTION_NOTE",
    "design_report",
    "design_bode_figures",
    "minimal",
    "poly_roots",
    "root_entries",
    "freq_response",
    "log_grid",
    "bode_curves",
    "phase_extremum",
    "resonance",
    "approximation_limit_hz",
]

TF_INFO = {
    "C4": ("θ_j/τ_s", "closed-loop SEA compliance (paper eq. (8))", "rad/(N·m)"),
    "C5": ("θ_j/τ_j", "joint compliance, the virtual motor (paper eq. (10))", "rad/(N·m)"),
    "C5_hat": ("θ_j/τ_j", "desired virtual motor compliance 1/(Ĵ_m s² + B̂_m s) (paper §II-C, eq. (11))", "rad/(N·m)"),
    "C7_nominal": (
        "θ_h/τ_c",
        "nominal operator-side compliance (paper eq. (16), middle term 2ζ̂√(αK_c/Ĵ_m)·s per docs/method.md#double-compliance-shaping erratum)",
        "rad/(N·m)",
    ),
    "G_v": ("τ_3/τ̂_m", "cuff-path compensator G_v(s) (paper §II-C, eq. (12), docs/method.md#controller; improper, filtered in the implementation)", "1"),
}
APPROX_TOL = 0.1
GAIN_CONVENTION_NOTE = (
    "torque units (docs/method.md#double-compliance-shaping): K2, B2 multiply the spring torque τ_s and K2_hat, B2_hat the cuff torque "
    "τ_c, so K2, K2_hat are dimensionless and B2, B2_hat are in s; the paper's eq. (9) gives K2, "
    "B2 as spring-deflection gains, which are K_s times larger"
)


# ---------------------------------------------------------------------------------------------
# One rational transfer function (ascending-coefficient polynomials, exotune.numerics.poly)
# ---------------------------------------------------------------------------------------------
def _flat(c):
    return np.asarray(c, dtype=float).reshape(-1)


def _trim(c):
    """Drop exactly-zero highest-order coefficients (ascending order)."""
    c = _flat(c)
    nz = np.flatnonzero(c)
    return c[: nz[-1] + 1] if nz.size else c[:1] * 0.0


def minimal(num, den):
    """Cancel the common exact roots at s = 0 of num/den.

    Parameters
    ----------
    num, den : array_like
        Ascending coefficients of the numerator and the denominator.

    Returns
    -------
    tuple of numpy.ndarray
        ``(num, den)`` without their common roots at s = 0 (structural, e.g. G_v with K̃1 = 0),
        exactly-zero highest-order coefficients dropped.

    References
    ----------
    Paper §IV (G_v); docs/method.md#controller.
    """
    from ..numerics.poly import strip_common_low_zeros

    _, (n, d) = strip_common_low_zeros(_flat(num)[None, :], _flat(den)[None, :])
    return _trim(n[0]), _trim(d[0])


def poly_roots(c):
    """Roots of an ascending-coefficient polynomial, sorted by magnitude then imaginary part.

    Parameters
    ----------
    c : array_like
        Ascending coefficients (``np.roots`` wants descending order; this does the reversal).

    Returns
    -------
    numpy.ndarray
        Complex roots (empty for a constant).

    References
    ----------
    docs/method.md#controller.
    """
    c = _trim(c)
    if c.size <= 1:
        return np.zeros(0, dtype=complex)
    r = np.roots(c[::-1]).astype(complex)
    return r[np.lexsort((r.imag, np.abs(r)))]


def root_entries(roots) -> list[dict]:
    """Roots as dicts ``re``, ``im`` [rad/s], ``natural_frequency_hz`` = |r|/2π and
    ``damping_ratio`` = −re/|r| (NaN for a root at 0).

    Parameters
    ----------
    roots : iterable of complex
        Poles or zeros [rad/s].

    Returns
    -------
    list of dict
        One entry per root, in the given order.

    References
    ----------
    docs/method.md#controller.
    """
    out = []
    for r in roots:
        wn = abs(r)
        out.append(
            {
                "re": float(r.real),
                "im": float(r.imag),
                "natural_frequency_hz": wn / (2 * math.pi),
                "damping_ratio": (-r.real / wn) if wn > 0 else float("nan"),
            }
        )
    return out


def freq_response(num, den, w):
    """num(jω)/den(jω) at the angular frequencies ``w`` [rad/s].

    Parameters
    ----------
    num, den : array_like
        Ascending coefficients.
    w : numpy.ndarray
        Angular frequencies [rad/s].

    Returns
    -------
    numpy.ndarray
        Complex response, same shape as ``w``.

    References
    ----------
    docs/method.md#controller.
    """
    from ..numerics.poly import pval

    s = 1j * w
    return pval(_flat(num), s) / pval(_flat(den), s)


def log_grid(*polys, per_decade=400, span=3.0):
    """Log grid of ω [rad/s] covering every non-zero root magnitude of ``polys`` ± ``span`` decades.

    Parameters
    ----------
    *polys : array_like
        Ascending-coefficient polynomials.
    per_decade : int
        Points per decade.
    span : float
        Decades below the smallest and above the largest root magnitude.

    Returns
    -------
    numpy.ndarray
        Angular frequencies [rad/s] (10⁻² … 10⁴ when no polynomial has a non-zero root).

    References
    ----------
    docs/method.md#controller.
    """
    mags = []
    for p in polys:
        r = np.abs(poly_roots(p))
        mags.extend(r[r > 0].tolist())
    if mags:
        lo, hi = math.log10(min(mags)) - span, math.log10(max(mags)) + span
    else:
        lo, hi = -2.0, 4.0
    return np.logspace(lo, hi, int((hi - lo) * per_decade) + 1)


def bode_curves(curves) -> list[tuple]:
    """Bode data of transfer functions on one common grid (for plots).

    Parameters
    ----------
    curves : list of (label, num, den)
        Labelled transfer functions (ascending coefficients).

    Returns
    -------
    list of (label, f_hz, magnitude_db, phase_deg)
        Frequencies [Hz], 20 log10 |H| and the unwrapped phase [deg] of each curve, on a log grid
        covering all their roots ± 1.5 decades.

    References
    ----------
    Paper §IV; docs/method.md#controller.
    """
    w = log_grid(*[p for _, n, d in curves for p in (n, d)], per_decade=150, span=1.5)
    out = []
    for label, num, den in curves:
        H = freq_response(num, den, w)
        f = w / (2 * math.pi)
        out.append((label, f, 20 * np.log10(np.abs(H)), np.degrees(np.unwrap(np.angle(H)))))
    return out


def _phase_limit(num, den, at_infinity: bool) -> float:
    """Exact phase [deg] of num(jω)/den(jω) as ω → ∞ (or → 0+), modulo 360°."""
    n, d = _trim(num), _trim(den)
    if at_infinity:
        i, j = n.size - 1, d.size - 1
    else:
        i, j = int(np.flatnonzero(n)[0]), int(np.flatnonzero(d)[0])
    return math.degrees(math.atan2(0.0, n[i] / d[j])) + 90.0 * (i - j)


def phase_extremum(num, den, sign: int = +1):
    """Max (sign=+1) or min (sign=−1) over ω > 0 of the continuous phase of num(jω)/den(jω).

    A dense log grid locates the extremum, ``minimize_scalar`` (bounded, on log ω) refines it. When
    the extremum is a limit (ω → 0 or ω → ∞) the exact limit phase is returned with 0 or inf Hz.

    Parameters
    ----------
    num, den : array_like
        Ascending coefficients.
    sign : {+1, -1}
        Maximum or minimum.

    Returns
    -------
    tuple of float
        ``(phase_deg, frequency_hz)``.

    References
    ----------
    Paper §IV-A, Fig. 5 (a compliance is passive where its phase is in [−180°, 0°]); docs/method.md#passivity.
    """
    from scipy.optimize import minimize_scalar

    w = log_grid(num, den)
    H = freq_response(num, den, w)
    ph = np.degrees(np.unwrap(np.angle(H)))
    i = int(np.argmax(sign * ph))
    if i == len(w) - 1 or i == 0:
        at_inf = i == len(w) - 1
        lim = _phase_limit(num, den, at_inf)
        lim += 360.0 * round((ph[i] - lim) / 360.0)
        return lim, (math.inf if at_inf else 0.0)
    ref_H, ref_ph = H[i], ph[i]

    def f(x):
        h = freq_response(num, den, np.array([math.exp(x)]))[0]
        return -sign * (ref_ph + math.degrees(np.angle(h / ref_H)))

    res = minimize_scalar(f, bounds=(math.log(w[i - 1]), math.log(w[i + 1])), method="bounded", options={"xatol": 1e-12})
    refined = -sign * float(res.fun)  # f = −sign·phase
    if sign * refined >= sign * ph[i]:
        return refined, math.exp(res.x) / (2 * math.pi)
    return float(ph[i]), w[i] / (2 * math.pi)


def resonance(num, den):
    """Largest interior peak of |H(jω)| (ω > 0).

    Candidates: the imaginary parts of the poles and the local maxima of a dense log grid; each
    is refined with ``minimize_scalar`` (bounded, on log ω) and kept only if it is a true local
    maximum. The divergence of |H| at ω → 0 from a pole at s = 0 is not a resonance.

    Parameters
    ----------
    num, den : array_like
        Ascending coefficients.

    Returns
    -------
    tuple
        ``(frequency_hz, peak)``, or ``(None, None)`` without an interior peak.

    References
    ----------
    Paper eq. (10) (the joint compliance C5, whose resonance this finds); docs/method.md#controller.
    """
    from scipy.optimize import minimize_scalar

    w = log_grid(num, den)
    mag = np.abs(freq_response(num, den, w))
    brackets = []
    for i in range(1, len(w) - 1):
        if mag[i] >= mag[i - 1] and mag[i] >= mag[i + 1] and (mag[i] > mag[i - 1] or mag[i] > mag[i + 1]):
            brackets.append((w[i - 1], w[i + 1]))
    for p in poly_roots(den):
        if p.imag > 0:
            d = min(0.5, max(0.02, 2.0 * abs(p.real) / abs(p)))
            brackets.append((p.imag * (1 - d), p.imag * (1 + d)))

    def negmag(x):
        return -float(np.abs(freq_response(num, den, np.array([math.exp(x)]))[0]))

    best = (None, None)
    for a, b in brackets:
        la, lb = math.log(a), math.log(b)
        res = minimize_scalar(negmag, bounds=(la, lb), method="bounded", options={"xatol": 1e-12})
        x, m = float(res.x), -float(res.fun)
        h = 1e-6
        if not (m >= -negmag(x - h) and m >= -negmag(x + h)):
            continue
        if x - la < 1e-9 or lb - x < 1e-9:
            continue
        if best[1] is None or m > best[1]:
            best = (math.exp(x) / (2 * math.pi), m)
    return best


def _describe_tf(name, num, den):
    n, d = minimal(num, den)
    sym, text, unit = TF_INFO[name]
    return {
        "transfer": sym,
        "description": text,
        "units": unit,
        "num_ascending": n.tolist(),
        "den_ascending": d.tolist(),
        "poles": root_entries(poly_roots(d)),
        "zeros": root_entries(poly_roots(n)),
    }


def approximation_limit_hz(tfs) -> float:
    """Frequency [Hz] below which |C5(jω)/Ĉ5(jω) − 1| < 0.1.

    Parameters
    ----------
    tfs : dict
        Nominal transfer functions of :func:`exotune.model.shaping.nominal_transfer_functions`
        (``C5`` and ``C5_hat`` are used).

    Returns
    -------
    float
        The first crossing (``brentq`` on log ω), ``inf`` when the error stays below the tolerance,
        0 when it never is.

    References
    ----------
    Paper §II-C (the virtual motor approximation); docs/method.md#controller.
    """
    from scipy.optimize import brentq

    C5, C5h = tfs["C5"], tfs["C5_hat"]
    num = np.convolve(_flat(C5.num)[::-1], _flat(C5h.den)[::-1])[::-1]
    den = np.convolve(_flat(C5.den)[::-1], _flat(C5h.num)[::-1])[::-1]
    num, den = minimal(num, den)
    w = log_grid(num, den, span=4.0)

    def err(x):
        return np.abs(freq_response(num, den, np.atleast_1d(x)) - 1.0) - APPROX_TOL

    e = err(w)
    bad = np.flatnonzero(e >= 0)
    if bad.size == 0:
        return math.inf
    i = int(bad[0])
    if i == 0:
        return 0.0
    x = brentq(lambda lx: float(err(math.exp(lx))[0]), math.log(w[i - 1]), math.log(w[i]), xtol=1e-12)
    return math.exp(x) / (2 * math.pi)


# ---------------------------------------------------------------------------------------------
# exotune design
# ---------------------------------------------------------------------------------------------
def design_report(cfg) -> DesignSummary:
    """Everything ``exotune design`` prints, as a typed :class:`~exotune.analysis.results.DesignSummary`.

    Parameters
    ----------
    cfg : exotune.config.design.DesignConfig
        A loaded design file.

    Returns
    -------
    DesignSummary
        Gains with units, the compliance shape, poles/zeros of the nominal transfer functions,
        warnings and the validity of the low-frequency approximation Ĉ5 ≈ C5 (``to_dict()``: the
        ``--json`` object of ``exotune design``).

    References
    ----------
    Paper §IV (double compliance shaping); docs/method.md#controller.
    """
    from ..model.shaping import GAIN_UNITS_TORQUE, SHAPE_UNITS, double_compliance_shaping, nominal_transfer_functions

    ds = double_compliance_shaping(cfg.plant, cfg.design)
    tfs = nominal_transfer_functions(cfg.plant, cfg.design, ds)
    gains = {k: float(v) for k, v in ds.gains.as_dict().items()}
    shape = {
        "K1_tilde": float(ds.shape.K1_tilde),
        "B1_tilde": float(ds.shape.B1_tilde),
        "K2_tilde": float(ds.shape.K2_tilde),
        "B2_tilde": float(ds.shape.B2_tilde),
        "J_m_hat": float(ds.J_m_hat),
        "B_m_hat": float(ds.B_m_hat),
    }
    ratio = float(ds.J_m_hat / cfg.plant.J_j)
    return DesignSummary.from_record({
        "exotune_version": __version__,
        "source": cfg.source,
        "gains": gains,
        "units": dict(GAIN_UNITS_TORQUE),
        "gain_convention": "torque",
        "gain_convention_note": GAIN_CONVENTION_NOTE,
        "shape": shape,
        "shape_units": dict(SHAPE_UNITS),
        "transfer_functions": {name: _describe_tf(name, tf.num, tf.den) for name, tf in tfs.items()},
        "transfer_function_notes": (
            "nominal: zero delay, no filters, no DOB (docs/method.md#double-compliance-shaping); poles and zeros in rad/s "
            "(re, im), natural_frequency_hz = |p|/2π, damping_ratio = −re/|p| (null for a root at 0); "
            "num_ascending/den_ascending are coefficients in ascending powers of s after cancelling "
            "common exact roots at s = 0"
        ),
        "approximation": {
            "criterion": "|C5(jω)/Ĉ5(jω) − 1| < 0.1",
            "valid_below_hz": approximation_limit_hz(tfs),
            "J_m_hat_over_J_j": ratio,
        },
        "approximation_units": {"valid_below_hz": "Hz", "J_m_hat_over_J_j": "1"},
        "warnings": list(ds.warnings),
    }, cfg)


def design_bode_figures(cfg) -> dict[str, tuple]:
    """Bode data of the nominal transfer functions of a design, one entry per figure.

    Parameters
    ----------
    cfg : exotune.config.design.DesignConfig
        A loaded design file.

    Returns
    -------
    dict
        ``{file name: (title, unit, curves)}`` with ``curves`` as returned by :func:`bode_curves`:
        one figure per transfer function (C4, C5, Ĉ5, C7, G_v) and C5 against Ĉ5.

    References
    ----------
    Paper §II-C–§IV; docs/method.md#controller.
    """
    from ..model.shaping import double_compliance_shaping, nominal_transfer_functions

    ds = double_compliance_shaping(cfg.plant, cfg.design)
    tfs = nominal_transfer_functions(cfg.plant, cfg.design, ds)
    out = {}
    for name, tf in tfs.items():
        n, d = minimal(tf.num, tf.den)
        sym, text, unit = TF_INFO[name]
        out[f"bode_{name}.png"] = (f"{name} = {sym} (nominal)", unit, bode_curves([(name, n, d)]))
    c5 = minimal(tfs["C5"].num, tfs["C5"].den)
    c5h = minimal(tfs["C5_hat"].num, tfs["C5_hat"].den)
    out["bode_C5_vs_C5_hat.png"] = (
        "C5 vs the virtual motor Ĉ5 (low-frequency approximation)", "rad/(N·m)",
        bode_curves([("C5", *c5), ("Ĉ5", *c5h)]),
    )
    return out
