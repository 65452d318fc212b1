"""Numbers of ``exotune design``: gains, compliance shape, poles and zeros of the nominal transfer
functions and the validity of the low-frequency approximation Ĉ5 ≈ C5 (paper §IV).

Every transfer function here is the one rational type :class:`exotune.numerics.poly.Rational` (a
batch of one: its ``minimal()``, ``poles()``, ``zeros()`` and ``at_jw(ω)``, frequencies on
:func:`exotune.numerics.poly.root_grid`); this module adds what the report needs of one: the phase
extremum and the resonance peak (both refined with ``minimize_scalar``), Bode data, the validity of
the approximation, shared with :mod:`exotune.analysis.sea` and the design plots.

Conventions of the numbers: gains in torque units, poles and zeros in rad/s with natural
frequencies in Hz (docs/method.md#controller).
"""

from __future__ import annotations

import math

import numpy as np

from ..numerics.poly import Rational, root_grid, trim_high
from ..version import __version__
from .results import DesignSummary

__all__ = [
    "TF_INFO",
    "APPROX_TOL",
    "GAIN_CONVENTION_NOTE",
    "design_report",
    "design_bode_figures",
    "root_entries",
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


def bode_curves(curves) -> list[tuple]:
    """Bode data of transfer functions on one common grid (for plots).

    Parameters
    ----------
    curves : list of (label, Rational)
        Labelled transfer functions (one row each).

    Returns
    -------
    list of (label, f_hz, magnitude_db, phase_deg)
        Frequencies [Hz], 20 log10 |H| and the unwrapped phase [deg] of each curve, on a log grid
        covering all their roots ± 1.5 decades.

    References
    ----------
    Paper §IV; docs/method.md#controller.
    """
    w = root_grid(*[p for _, tf in curves for p in (tf.num, tf.den)], per_decade=150, span=1.5)
    out = []
    for label, tf in curves:
        H = tf.at_jw(w)
        f = w / (2 * math.pi)
        out.append((label, f, 20 * np.log10(np.abs(H)), np.degrees(np.unwrap(np.angle(H)))))
    return out


def _phase_limit(tf: Rational, at_infinity: bool) -> float:
    """Exact phase [deg] of num(jω)/den(jω) as ω → ∞ (or → 0+), modulo 360°."""
    n, d = trim_high(tf.num), trim_high(tf.den)
    if at_infinity:
        i, j = n.size - 1, d.size - 1
    else:
        i, j = int(np.flatnonzero(n)[0]), int(np.flatnonzero(d)[0])
    return math.degrees(math.atan2(0.0, n[i] / d[j])) + 90.0 * (i - j)


def phase_extremum(tf: Rational, sign: int = +1):
    """Max (sign=+1) or min (sign=−1) over ω > 0 of the continuous phase of num(jω)/den(jω).

    A dense log grid locates the extremum, ``minimize_scalar`` (bounded, on log ω) refines it. When
    the extremum is a limit (ω → 0 or ω → ∞) the exact limit phase is returned with 0 or inf Hz.

    Parameters
    ----------
    tf : Rational
        One transfer function.
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

    w = root_grid(tf.num, tf.den)
    H = tf.at_jw(w)
    ph = np.degrees(np.unwrap(np.angle(H)))
    i = int(np.argmax(sign * ph))
    if i == len(w) - 1 or i == 0:
        at_inf = i == len(w) - 1
        lim = _phase_limit(tf, at_inf)
        lim += 360.0 * round((ph[i] - lim) / 360.0)
        return lim, (math.inf if at_inf else 0.0)
    ref_H, ref_ph = H[i], ph[i]

    def f(x):
        h = tf.at_jw(np.array([math.exp(x)]))[0]
        return -sign * (ref_ph + math.degrees(np.angle(h / ref_H)))

    res = minimize_scalar(f, bounds=(math.log(w[i - 1]), math.log(w[i + 1])), method="bounded", options={"xatol": 1e-12})
    refined = -sign * float(res.fun)  # f = −sign·phase
    if sign * refined >= sign * ph[i]:
        return refined, math.exp(res.x) / (2 * math.pi)
    return float(ph[i]), w[i] / (2 * math.pi)


def resonance(tf: Rational):
    """Largest interior peak of |H(jω)| (ω > 0).

    Candidates: the imaginary parts of the poles and the local maxima of a dense log grid; each
    is refined with ``minimize_scalar`` (bounded, on log ω) and kept only if it is a true local
    maximum. The divergence of |H| at ω → 0 from a pole at s = 0 is not a resonance.

    Parameters
    ----------
    tf : Rational
        One transfer function.

    Returns
    -------
    tuple
        ``(frequency_hz, peak)``, or ``(None, None)`` without an interior peak.

    References
    ----------
    Paper eq. (10) (the joint compliance C5, whose resonance this finds); docs/method.md#controller.
    """
    from scipy.optimize import minimize_scalar

    w = root_grid(tf.num, tf.den)
    mag = np.abs(tf.at_jw(w))
    brackets = []
    for i in range(1, len(w) - 1):
        if mag[i] >= mag[i - 1] and mag[i] >= mag[i + 1] and (mag[i] > mag[i - 1] or mag[i] > mag[i + 1]):
            brackets.append((w[i - 1], w[i + 1]))
    for p in tf.poles():
        if p.imag > 0:
            d = min(0.5, max(0.02, 2.0 * abs(p.real) / abs(p)))
            brackets.append((p.imag * (1 - d), p.imag * (1 + d)))

    def negmag(x):
        return -float(np.abs(tf.at_jw(np.array([math.exp(x)]))[0]))

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


def _describe_tf(name, tf: Rational):
    m = tf.minimal()
    sym, text, unit = TF_INFO[name]
    return {
        "transfer": sym,
        "description": text,
        "units": unit,
        "num_ascending": m.num.tolist(),
        "den_ascending": m.den.tolist(),
        "poles": root_entries(m.poles()),
        "zeros": root_entries(m.zeros()),
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
    flat = lambda c: np.asarray(c, dtype=float).reshape(-1)  # noqa: E731
    num = np.convolve(flat(C5.num)[::-1], flat(C5h.den)[::-1])[::-1]
    den = np.convolve(flat(C5.den)[::-1], flat(C5h.num)[::-1])[::-1]
    ratio = Rational(num, den).minimal()
    w = root_grid(ratio.num, ratio.den, span=4.0)

    def err(x):
        return np.abs(ratio.at_jw(np.atleast_1d(x)) - 1.0) - APPROX_TOL

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
        "transfer_functions": {name: _describe_tf(name, tf) for name, tf in tfs.items()},
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
        sym, text, unit = TF_INFO[name]
        out[f"bode_{name}.png"] = (f"{name} = {sym} (nominal)", unit, bode_curves([(name, tf.minimal())]))
    out["bode_C5_vs_C5_hat.png"] = (
        "C5 vs the virtual motor Ĉ5 (low-frequency approximation)", "rad/(N·m)",
        bode_curves([("C5", tfs["C5"].minimal()), ("Ĉ5", tfs["C5_hat"].minimal())]),
    )
    return out
