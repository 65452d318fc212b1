"""The ``exotune`` command line (SPEC §8).

Commands implemented here: ``design`` (double compliance shaping, paper §IV / SPEC §4), ``sea``
(analysis of a plain SEA compliance-shaping controller, paper §II-B), and thin wrappers around
``analyze`` (:mod:`exotune.analysis`, :mod:`exotune.plots`), ``sweep`` (:mod:`exotune.sweep`) and
``report`` (:mod:`exotune.report`), which are imported lazily.

Error contract (SPEC §8): every input problem (:class:`~exotune.errors.ConfigError` or
:class:`ValueError`) is printed as one line ``exotune: error: <field>: <reason>`` on stderr with
exit code 2 and no traceback. Outputs (plots) are produced completely before anything is written,
and each file is written atomically, so a failing run leaves nothing behind.

Conventions of the printed numbers: gains in torque units (SPEC §4), frequencies of poles and
zeros in rad/s with natural frequencies in Hz, JSON infinities as the strings "inf"/"-inf" and
undefined values as null (:mod:`exotune.jsonio`).
"""

from __future__ import annotations

import json
import math
import os
import shutil
import tempfile

import click

from .version import __version__
from .errors import ConfigError

__all__ = ["main", "cli", "design_report", "sea_report", "format_design", "format_sea"]

TF_INFO = {
    "C4": ("θ_j/τ_s", "closed-loop SEA compliance (paper eq. motspring)", "rad/(N·m)"),
    "C5": ("θ_j/τ_j", "joint (virtual motor) compliance (paper eq. total_compliance)", "rad/(N·m)"),
    "C5_hat": ("θ_j/τ_j", "desired virtual motor compliance 1/(Ĵ_m s² + B̂_m s) (paper §III)", "rad/(N·m)"),
    "C7_nominal": (
        "θ_h/τ_c",
        "nominal operator-side compliance (paper eq. nominal_C7, middle term 2ζ̂√(αK_c/Ĵ_m)·s per SPEC §4 erratum)",
        "rad/(N·m)",
    ),
    "G_v": ("τ_3/τ̂_m", "cuff-path compensator G_v(s) (paper §III, SPEC §3; improper, filtered in the implementation)", "1"),
}
APPROX_TOL = 0.1
GAIN_CONVENTION_NOTE = (
    "torque units (SPEC §4): K2, B2 multiply the spring torque τ_s and K2_hat, B2_hat the cuff torque "
    "τ_c, so K2, K2_hat are dimensionless and B2, B2_hat are in s; the paper's eq. (extracted) gives K2, "
    "B2 as spring-deflection gains, which are K_s times larger"
)


# ---------------------------------------------------------------------------------------------
# Numerical helpers (ascending-coefficient polynomials, exotune.poly convention)
# ---------------------------------------------------------------------------------------------
def _flat(c):
    import numpy as np

    return np.asarray(c, dtype=float).reshape(-1)


def _trim(c):
    """Drop exactly-zero highest-order coefficients (ascending order)."""
    import numpy as np

    c = _flat(c)
    nz = np.flatnonzero(c)
    return c[: nz[-1] + 1] if nz.size else c[:1] * 0.0


def _minimal(num, den):
    """Cancel the common exact roots at s = 0 (structural, e.g. G_v with K̃1 = 0; SPEC §4)."""
    from .numerics.poly import strip_common_low_zeros

    _, (n, d) = strip_common_low_zeros(_flat(num)[None, :], _flat(den)[None, :])
    return _trim(n[0]), _trim(d[0])


def _roots(c):
    """Roots of an ascending-coefficient polynomial (np.roots wants descending order)."""
    import numpy as np

    c = _trim(c)
    if c.size <= 1:
        return np.zeros(0, dtype=complex)
    r = np.roots(c[::-1]).astype(complex)
    return r[np.lexsort((r.imag, np.abs(r)))]


def _root_entries(roots):
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


def _eval(num, den, w):
    from .numerics.poly import pval

    s = 1j * w
    return pval(_flat(num), s) / pval(_flat(den), s)


def _grid(*polys, per_decade=400, span=3.0):
    """Log grid of ω [rad/s] covering every non-zero root magnitude ± ``span`` decades."""
    import numpy as np

    mags = []
    for p in polys:
        r = np.abs(_roots(p))
        mags.extend(r[r > 0].tolist())
    if mags:
        lo, hi = math.log10(min(mags)) - span, math.log10(max(mags)) + span
    else:
        lo, hi = -2.0, 4.0
    return np.logspace(lo, hi, int((hi - lo) * per_decade) + 1)


def _phase_limit(num, den, at_infinity: bool) -> float:
    """Exact phase [deg] of num(jω)/den(jω) as ω → ∞ (or → 0+), modulo 360°."""
    import numpy as np

    n, d = _trim(num), _trim(den)
    if at_infinity:
        i, j = n.size - 1, d.size - 1
    else:
        i, j = int(np.flatnonzero(n)[0]), int(np.flatnonzero(d)[0])
    return math.degrees(math.atan2(0.0, n[i] / d[j])) + 90.0 * (i - j)


def _phase_extremum(num, den, sign: int = +1):
    """Max (sign=+1) or min (sign=−1) over ω > 0 of the continuous phase of num(jω)/den(jω).

    A dense log grid locates the extremum, ``minimize_scalar`` (bounded, on log ω) refines it. When
    the extremum is a limit (ω → 0 or ω → ∞) the exact limit phase is returned with 0 or inf Hz.
    Returns (phase_deg, frequency_hz).
    """
    import numpy as np
    from scipy.optimize import minimize_scalar

    w = _grid(num, den)
    H = _eval(num, den, w)
    ph = np.degrees(np.unwrap(np.angle(H)))
    i = int(np.argmax(sign * ph))
    if i == len(w) - 1 or i == 0:
        at_inf = i == len(w) - 1
        lim = _phase_limit(num, den, at_inf)
        lim += 360.0 * round((ph[i] - lim) / 360.0)
        return lim, (math.inf if at_inf else 0.0)
    ref_H, ref_ph = H[i], ph[i]

    def f(x):
        h = _eval(num, den, np.array([math.exp(x)]))[0]
        return -sign * (ref_ph + math.degrees(np.angle(h / ref_H)))

    res = minimize_scalar(f, bounds=(math.log(w[i - 1]), math.log(w[i + 1])), method="bounded", options={"xatol": 1e-12})
    refined = -sign * float(res.fun)  # f = −sign·phase
    if sign * refined >= sign * ph[i]:
        return refined, math.exp(res.x) / (2 * math.pi)
    return float(ph[i]), w[i] / (2 * math.pi)


def _resonance(num, den):
    """Largest interior peak of |H(jω)| (ω > 0): (frequency_hz, peak) or (None, None).

    Candidates: the imaginary parts of the poles and the local maxima of a dense log grid; each
    is refined with ``minimize_scalar`` (bounded, on log ω) and kept only if it is a true local
    maximum. The divergence of |H| at ω → 0 from a pole at s = 0 is not a resonance.
    """
    import numpy as np
    from scipy.optimize import minimize_scalar

    w = _grid(num, den)
    mag = np.abs(_eval(num, den, w))
    brackets = []
    for i in range(1, len(w) - 1):
        if mag[i] >= mag[i - 1] and mag[i] >= mag[i + 1] and (mag[i] > mag[i - 1] or mag[i] > mag[i + 1]):
            brackets.append((w[i - 1], w[i + 1]))
    for p in _roots(den):
        if p.imag > 0:
            d = min(0.5, max(0.02, 2.0 * abs(p.real) / abs(p)))
            brackets.append((p.imag * (1 - d), p.imag * (1 + d)))

    def negmag(x):
        return -float(np.abs(_eval(num, den, np.array([math.exp(x)]))[0]))

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
    n, d = _minimal(num, den)
    sym, text, unit = TF_INFO[name]
    return {
        "transfer": sym,
        "description": text,
        "units": unit,
        "num_ascending": n.tolist(),
        "den_ascending": d.tolist(),
        "poles": _root_entries(_roots(d)),
        "zeros": _root_entries(_roots(n)),
    }


def _approximation(tfs):
    """Frequency [Hz] below which |C5(jω)/Ĉ5(jω) − 1| < 0.1 (paper §III, SPEC §4)."""
    import numpy as np
    from scipy.optimize import brentq

    C5, C5h = tfs["C5"], tfs["C5_hat"]
    num = np.convolve(_flat(C5.num)[::-1], _flat(C5h.den)[::-1])[::-1]
    den = np.convolve(_flat(C5.den)[::-1], _flat(C5h.num)[::-1])[::-1]
    num, den = _minimal(num, den)
    w = _grid(num, den, span=4.0)

    def err(x):
        return np.abs(_eval(num, den, np.atleast_1d(x)) - 1.0) - APPROX_TOL

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
def design_report(cfg) -> dict:
    """Everything ``exotune design`` prints, as a dict (SPEC §4, §8): gains with units, the
    compliance shape, poles/zeros of the nominal transfer functions, warnings and the validity of
    the low-frequency approximation Ĉ5 ≈ C5."""
    from .model.shaping import GAIN_UNITS_TORQUE, SHAPE_UNITS, double_compliance_shaping, nominal_transfer_functions

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
    return {
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
            "nominal: zero delay, no filters, no DOB (SPEC §4); poles and zeros in rad/s "
            "(re, im), natural_frequency_hz = |p|/2π, damping_ratio = −re/|p| (null for a root at 0); "
            "num_ascending/den_ascending are coefficients in ascending powers of s after cancelling "
            "common exact roots at s = 0"
        ),
        "approximation": {
            "criterion": "|C5(jω)/Ĉ5(jω) − 1| < 0.1",
            "valid_below_hz": _approximation(tfs),
            "J_m_hat_over_J_j": ratio,
        },
        "approximation_units": {"valid_below_hz": "Hz", "J_m_hat_over_J_j": "1"},
        "warnings": list(ds.warnings),
    }


def _g(x, digits=6) -> str:
    if x is None:
        return "—"
    if isinstance(x, str):
        return x
    if isinstance(x, float) and math.isinf(x):
        return "∞" if x > 0 else "−∞"
    if isinstance(x, float) and math.isnan(x):
        return "—"
    return f"{x:.{digits}g}"


def _fmt_roots(entries) -> list[str]:
    lines = []
    for r in entries:
        if r["im"] < 0:
            continue
        if r["im"] > 0:
            z = f"{_g(r['re'], 5)} ± {_g(r['im'], 5)}j"
        else:
            z = f"{_g(r['re'], 5)}"
        zeta = "" if r["damping_ratio"] is None or (isinstance(r["damping_ratio"], float) and math.isnan(r["damping_ratio"])) else f", ζ = {_g(r['damping_ratio'], 3)}"
        lines.append(f"{z} rad/s (f_n = {_g(r['natural_frequency_hz'], 4)} Hz{zeta})")
    return lines or ["none"]


def format_design(rep: dict) -> str:
    """Readable text for ``exotune design`` (units on every number)."""
    out = []
    src = f" — {rep['source']}" if rep.get("source") else ""
    out.append(f"exotune {rep['exotune_version']} design{src}")
    out.append("Double compliance shaping (paper §IV, SPEC §4).")
    out.append("Gain convention: " + rep["gain_convention_note"] + ".")
    out.append("")
    out.append("Controller gains")
    for k, v in rep["gains"].items():
        out.append(f"  {k:<8} {_g(v):>14}  {rep['units'][k]}")
    out.append("")
    out.append("Compliance shape  C4(s) = (s² + B̃2 s + K̃2) / (K_s (s² + B̃1 s + K̃1)), virtual motor Ĵ_m, B̂_m")
    for k, v in rep["shape"].items():
        out.append(f"  {k:<9} {_g(v):>13}  {rep['shape_units'][k]}")
    out.append("")
    out.append("Nominal transfer functions (zero delay, no filters); poles and zeros in rad/s")
    for name, tf in rep["transfer_functions"].items():
        out.append(f"  {name} = {tf['transfer']} [{tf['units']}]: {tf['description']}")
        for label in ("poles", "zeros"):
            rows = _fmt_roots(tf[label])
            out.append(f"    {label}: {rows[0]}")
            out.extend(f"           {r}" for r in rows[1:])
    out.append("")
    ap = rep["approximation"]
    out.append(
        f"Approximation Ĉ5 ≈ C5: {ap['criterion']} for f < {_g(ap['valid_below_hz'], 4)} Hz "
        f"(Ĵ_m/J_j = {_g(ap['J_m_hat_over_J_j'], 4)})"
    )
    out.append("")
    if rep["warnings"]:
        out.append("Warnings")
        out.extend(f"  - {w}" for w in rep["warnings"])
    else:
        out.append("Warnings: none")
    return "\n".join(out)


def _bode_png(curves, title: str, ylabel: str) -> bytes:
    """One Bode figure (magnitude in dB, phase in deg vs Hz) rendered to PNG bytes (Agg)."""
    import io

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    fig, (ax1, ax2) = plt.subplots(2, 1, sharex=True, figsize=(7, 6))
    try:
        w = _grid(*[p for _, n, d in curves for p in (n, d)], per_decade=150, span=1.5)
        for label, num, den in curves:
            H = _eval(num, den, w)
            f = w / (2 * math.pi)
            ax1.semilogx(f, 20 * np.log10(np.abs(H)), label=label)
            ax2.semilogx(f, np.degrees(np.unwrap(np.angle(H))), label=label)
        ax1.set_ylabel(f"|·| [dB re 1 {ylabel}]")
        ax2.set_ylabel("phase [deg]")
        ax2.set_xlabel("frequency [Hz]")
        ax1.set_title(title)
        for ax in (ax1, ax2):
            ax.grid(True, which="major", alpha=0.3)
        if len(curves) > 1:
            ax1.legend()
        fig.subplots_adjust(left=0.13, right=0.97, top=0.94, bottom=0.09, hspace=0.08)
        buf = io.BytesIO()
        fig.savefig(buf, format="png", dpi=110)
        return buf.getvalue()
    finally:
        plt.close(fig)


def _design_plots(cfg) -> dict[str, bytes]:
    from .model.shaping import double_compliance_shaping, nominal_transfer_functions

    ds = double_compliance_shaping(cfg.plant, cfg.design)
    tfs = nominal_transfer_functions(cfg.plant, cfg.design, ds)
    out = {}
    for name, tf in tfs.items():
        n, d = _minimal(tf.num, tf.den)
        sym, text, unit = TF_INFO[name]
        out[f"bode_{name}.png"] = _bode_png([(name, n, d)], f"{name} = {sym} (nominal)", unit)
    c5 = _minimal(tfs["C5"].num, tfs["C5"].den)
    c5h = _minimal(tfs["C5_hat"].num, tfs["C5_hat"].den)
    out["bode_C5_vs_C5_hat.png"] = _bode_png(
        [("C5", *c5), ("Ĉ5", *c5h)], "C5 vs the virtual motor Ĉ5 (low-frequency approximation)", "rad/(N·m)"
    )
    return out


def _write_files(dest: str, files: dict[str, bytes]) -> None:
    from .jsonio import write_atomic

    try:
        for rel, data in files.items():
            write_atomic(os.path.join(dest, rel), data)
    except OSError as e:
        raise ConfigError(dest, f"cannot write output: {e.strerror or e}") from None


def _staged_dir(dest: str, produce) -> None:
    """Run ``produce(tmpdir)``; only if it succeeds, copy what it wrote into ``dest`` (each
    file atomically). A failing producer leaves ``dest`` untouched (not even created)."""
    tmp = tempfile.mkdtemp(prefix="exotune-stage-")
    try:
        produce(tmp)
        files = {}
        for root, _dirs, names in os.walk(tmp):
            for nm in names:
                full = os.path.join(root, nm)
                with open(full, "rb") as fh:
                    files[os.path.relpath(full, tmp)] = fh.read()
        _write_files(dest, files)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def _dumps(obj) -> str:
    from .jsonio import to_jsonable

    return json.dumps(to_jsonable(obj), indent=2, ensure_ascii=False, allow_nan=False)


# ---------------------------------------------------------------------------------------------
# exotune sea
# ---------------------------------------------------------------------------------------------
def sea_report(cfg) -> dict:
    """Everything ``exotune sea`` prints (paper §II-B): compliance shape, closed-loop stiffness,
    resonance of C5 (paper eq. total_compliance), nominal passivity conditions and the phase
    extremes of C4(jω) (a compliance is passive where its phase is in [−180°, 0°])."""
    import numpy as np

    from .model.plant import Plant
    from .numerics.poly import as_poly, padd, pmul, pscale
    from .model.shaping import (
        GAIN_UNITS_DEFLECTION,
        GAIN_UNITS_TORQUE,
        SHAPE_UNITS,
        sea_passivity_conditions,
        sea_shape_from_gains,
        to_deflection_units,
        to_torque_units,
    )

    plant, gains = cfg.plant, cfg.gains
    sh = sea_shape_from_gains(plant, gains)
    K1t, B1t, K2t, B2t = (float(x) for x in (sh.K1_tilde, sh.B1_tilde, sh.K2_tilde, sh.B2_tilde))
    K_s, J_j = float(plant.K_s), float(plant.J_j)
    num2 = as_poly(K2t, B2t, 1.0)
    den1 = as_poly(K1t, B1t, 1.0)
    c4 = _minimal(num2, pscale(den1, K_s))
    s2 = as_poly(0.0, 0.0, 1.0)
    c5_den_full = padd(pscale(pmul(s2, num2), J_j), pscale(den1, K_s))
    c5 = _minimal(num2, c5_den_full)

    # stiffness = 1/C4(0) = K_s K̃1/K̃2 (after cancelling common roots at 0)
    n0, d0 = c4[0][0], c4[1][0]
    stiffness = math.inf if n0 == 0 else float(d0 / n0)

    poles = _roots(c5[1])
    rigid = bool(c5[1][0] == 0)  # exact pole at s = 0 (K1 = 0): rigid-body mode, not an instability
    nonzero = poles[np.abs(poles) > 0] if rigid else poles
    stable = bool(np.all(nonzero.real < 0))
    res_hz, res_peak = _resonance(*c5)
    max_ph, max_hz = _phase_extremum(*c4, sign=+1)
    min_ph, min_hz = _phase_extremum(*c4, sign=-1)
    cond = sea_passivity_conditions(plant, gains)
    gt, gd = to_torque_units(plant, gains), to_deflection_units(plant, gains)
    notes = []
    if K1t == 0:
        notes.append("K1 = 0: no motor-position feedback, so the closed-loop SEA has zero static stiffness")
    if rigid:
        notes.append("C5 has a pole at s = 0 (rigid-body mode of the free joint, not an instability)")
    if not stable:
        notes.append("C5 has poles with Re ≥ 0 (other than a rigid-body pole at 0): the SEA with the joint inertia is unstable")
    if res_hz is None:
        notes.append("|C5(jω)| has no resonant peak")
    if max_ph > 0:
        notes.append("C4 phase exceeds 0°: the SEA compliance is not passive at those frequencies")
    return {
        "exotune_version": __version__,
        "source": cfg.source,
        "plant": {k: float(v) for k, v in plant.as_dict().items()},
        "plant_units": dict(Plant.UNITS),
        "input_gain_units": gains.units,
        "gains_torque": {k: float(getattr(gt, k)) for k in ("K1", "B1", "K2", "B2")},
        "gains_torque_units": {k: GAIN_UNITS_TORQUE[k] for k in ("K1", "B1", "K2", "B2")},
        "gains_deflection": {k: float(getattr(gd, k)) for k in ("K1", "B1", "K2", "B2")},
        "gains_deflection_units": dict(GAIN_UNITS_DEFLECTION),
        "shape": {"K1_tilde": K1t, "B1_tilde": B1t, "K2_tilde": K2t, "B2_tilde": B2t},
        "shape_units": {k: SHAPE_UNITS[k] for k in ("K1_tilde", "B1_tilde", "K2_tilde", "B2_tilde")},
        "low_frequency_stiffness": stiffness,
        "resonance_hz": res_hz,
        "resonance_peak_compliance": res_peak,
        "c5_poles": _root_entries(poles),
        "c5_stable": stable,
        "c5_rigid_body_mode": rigid,
        "passivity": {
            "passive": all(cond.values()),
            "conditions": cond,
            "failed_conditions": [k for k, ok in cond.items() if not ok],
        },
        "max_phase_deg": max_ph,
        "max_phase_hz": max_hz,
        "min_phase_deg": min_ph,
        "min_phase_hz": min_hz,
        "units": {
            "low_frequency_stiffness": "N·m/rad",
            "resonance_hz": "Hz",
            "resonance_peak_compliance": "rad/(N·m)",
            "c5_poles": "rad/s (natural_frequency_hz in Hz, damping_ratio 1)",
            "max_phase_deg": "deg",
            "max_phase_hz": "Hz",
            "min_phase_deg": "deg",
            "min_phase_hz": "Hz",
        },
        "notes": notes,
    }


def format_sea(rep: dict) -> str:
    """Readable text for ``exotune sea``."""
    out = []
    src = f" — {rep['source']}" if rep.get("source") else ""
    out.append(f"exotune {rep['exotune_version']} sea{src}")
    out.append("SEA compliance shaping (paper §II-B): τ_m = −(K1 + B1 s) θ_m + (K2 + B2 s) τ_s (torque units)")
    out.append("")
    out.append(f"Gains (input given in {rep['input_gain_units']} units)")
    for k in ("K1", "B1", "K2", "B2"):
        out.append(
            f"  {k:<3} {_g(rep['gains_torque'][k]):>13}  {rep['gains_torque_units'][k]:<40}"
            f" = {_g(rep['gains_deflection'][k])} {rep['gains_deflection_units'][k]}"
        )
    out.append("")
    out.append("Compliance shape  C4(s) = (s² + B̃2 s + K̃2) / (K_s (s² + B̃1 s + K̃1))")
    for k, v in rep["shape"].items():
        out.append(f"  {k:<9} {_g(v):>13}  {rep['shape_units'][k]}")
    out.append("")
    st = rep["low_frequency_stiffness"]
    extra = " (K1 = 0: no position feedback, zero static stiffness)" if st == 0 else ""
    out.append(f"Low-frequency stiffness 1/C4(0) = K_s K̃1/K̃2: {_g(st)} N·m/rad{extra}")
    if rep["resonance_hz"] is None:
        out.append("Resonance of C5 = θ_j/τ_j (paper eq. total_compliance): none (no peak of |C5(jω)|)")
    else:
        out.append(
            f"Resonance of C5 = θ_j/τ_j (paper eq. total_compliance): {_g(rep['resonance_hz'], 5)} Hz, "
            f"peak |C5| = {_g(rep['resonance_peak_compliance'], 4)} rad/(N·m)"
        )
    out.append(f"C5 poles ({'stable' if rep['c5_stable'] else 'UNSTABLE'}):")
    out.extend(f"  {r}" for r in _fmt_roots(rep["c5_poles"]))
    p = rep["passivity"]
    out.append("")
    out.append(f"Nominal passivity conditions: {'all hold (passive)' if p['passive'] else 'NOT passive'}")
    for k, ok in p["conditions"].items():
        out.append(f"  [{'ok' if ok else 'FAIL'}] {k}")
    out.append(
        f"Phase of C4(jω): max {_g(rep['max_phase_deg'], 4)} deg at {_g(rep['max_phase_hz'], 4)} Hz, "
        f"min {_g(rep['min_phase_deg'], 4)} deg at {_g(rep['min_phase_hz'], 4)} Hz "
        "(passive compliance: phase within [−180°, 0°])"
    )
    if rep["notes"]:
        out.append("")
        out.append("Notes")
        out.extend(f"  - {n}" for n in rep["notes"])
    return "\n".join(out)


# ---------------------------------------------------------------------------------------------
# click plumbing
# ---------------------------------------------------------------------------------------------
class InputError(click.ClickException):
    """Bad input: printed as one line ``exotune: error: …``, exit code 2 (SPEC §8)."""

    exit_code = 2

    def show(self, file=None) -> None:
        click.echo(f"exotune: error: {self.format_message()}", err=True)


class _Group(click.Group):
    def invoke(self, ctx):
        try:
            return super().invoke(ctx)
        except ConfigError as e:
            raise InputError(str(e)) from None
        except ValueError as e:
            raise InputError(" ".join(str(e).split()) or type(e).__name__) from None
        except OSError as e:  # an unwritable output (a directory, a missing parent, no permission)
            where = e.filename2 if e.filename2 is not None else (e.filename if e.filename is not None else "<file>")
            raise InputError(f"{where}: {e.strerror or e}") from None


@click.group(cls=_Group, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, "--version", prog_name="exotune")
def cli():
    """exotune: robust stability analysis and tuning of strength-amplification exoskeletons
    (double compliance shaping, Thomas, Coholich & Sentis). Gains are in torque units (SPEC §4)."""


@cli.command("design")
@click.argument("design_file", metavar="DESIGN.yaml")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object instead of text.")
@click.option("--plots", "plots_dir", metavar="DIR", default=None, help="Write Bode plots (PNG) of C4, C5, Ĉ5, C7, G_v.")
def design_cmd(design_file, as_json, plots_dir):
    """Gains and nominal transfer functions of a design file (paper §IV, SPEC §4)."""
    from .config.design import load_design

    cfg = load_design(design_file)
    rep = design_report(cfg)
    text = _dumps(rep) if as_json else format_design(rep)
    if plots_dir is not None:
        _write_files(plots_dir, _design_plots(cfg))
    click.echo(text)


@cli.command("sea")
@click.argument("sea_file", metavar="SEA.yaml")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object instead of text.")
def sea_cmd(sea_file, as_json):
    """Analyse a plain SEA compliance-shaping controller (paper §II-B)."""
    from .config.design import load_sea

    rep = sea_report(load_sea(sea_file))
    click.echo(_dumps(rep) if as_json else format_sea(rep))


@cli.command("analyze")
@click.argument("design_file", metavar="DESIGN.yaml")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object instead of text.")
@click.option("--plots", "plots_dir", metavar="DIR", default=None, help="Write the analysis plots to DIR.")
@click.option("--cross-check", "cross_check", is_flag=True,
              help="Also compare the exact verdicts with closed-loop roots of two Padé models (SPEC §5).")
def analyze_cmd(design_file, as_json, plots_dir, cross_check):
    """Stability, passivity, DOB margins and amplification of a design (SPEC §5, §8)."""
    from .config.design import load_design

    cfg = load_design(design_file)  # input errors first, whatever the state of the analysis engine
    from .analysis.core import analyze_design, format_report

    result = analyze_design(cfg)
    if cross_check:
        from .analysis.crosscheck import pade_crosscheck

        result["cross_check"] = pade_crosscheck(cfg)
    text = _dumps(result) if as_json else format_report(result)
    if plots_dir is not None:
        from .plots.analysis import write_analysis_plots

        _staged_dir(plots_dir, lambda tmp: write_analysis_plots(cfg, result, tmp))
    click.echo(text)


@cli.command("sweep")
@click.argument("spec_file", metavar="SPEC.yaml")
@click.option("-o", "--out", "out_dir", required=True, metavar="DIR", help="Output directory (resumable).")
@click.option("--workers", type=click.IntRange(min=1), default=None, help="Local worker processes.")
@click.option("--dask", "dask_address", default=None, metavar="ADDRESS", help="Run on this Dask scheduler.")
@click.option("--sample", type=click.IntRange(min=1), default=None, metavar="N", help="Random sample of N grid points.")
@click.option("--seed", type=int, default=None, metavar="S", help="Seed for --sample.")
@click.option("--chunk-size", type=click.IntRange(min=1), default=None, metavar="N", help="Design points per chunk.")
def sweep_cmd(spec_file, out_dir, workers, dask_address, sample, seed, chunk_size):
    """Vectorized, chunked, resumable parameter sweep (SPEC §6)."""
    from .sweep.engine import run_sweep

    run_sweep(
        spec_file,
        out_dir,
        workers=workers,
        dask_address=dask_address,
        sample=sample,
        seed=seed,
        chunk_size=chunk_size,
        progress=True,
    )


@cli.command("report")
@click.argument("sweep_dir", metavar="DIR")
@click.option("-o", "--out", "out", default=None, metavar="OUT", help="Where to write the report.")
def report_cmd(sweep_dir, out):
    """Stability maps and summary tables of a sweep (SPEC §6)."""
    from .sweep.report import make_report

    make_report(sweep_dir, out)


@cli.command("optimize")
@click.argument("spec_file", metavar="SPEC.yaml")
@click.option("-o", "--out", "out", required=True, metavar="DESIGN.yaml", help="Optimized design file to write.")
@click.option("--seed", type=click.IntRange(min=0), default=None, metavar="S", help="Seed (deterministic per seed).")
@click.option("--pareto", "pareto_csv", default=None, metavar="FILE.csv",
              help="Also write the Pareto front (objective vs robust fraction) as CSV.")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object instead of text.")
@click.pass_context
def optimize_cmd(ctx, spec_file, out, seed, pareto_csv, as_json):
    """Maximize α (or another objective) under robust-stability, passivity, DOB-margin and
    bandwidth constraints (SPEC §7). Exit code 1 when no feasible design exists in the bounds."""
    from .optimize import format_optimize, run_optimize

    r = run_optimize(spec_file, out, seed=seed, pareto_csv=pareto_csv)
    click.echo(_dumps(r) if as_json else format_optimize(r))
    if not r["feasible"]:
        ctx.exit(1)


@cli.command("export")
@click.argument("design_file", metavar="DESIGN.yaml")
@click.option("--sample-rate-hz", "sample_rate_hz", required=True, metavar="F", help="Runtime sample rate [Hz].")
@click.option("-o", "--out", "out", required=True, metavar="CONTROLLER.yaml", help="Controller file to write.")
def export_cmd(design_file, sample_rate_hz, out):
    """Export the discrete-time runtime controller as YAML (SPEC §7)."""
    from .controllerfile.export import export_design

    doc = export_design(design_file, sample_rate_hz, out)
    sa = doc["predicted"]["sampled"]
    n = len(doc["controller"]["filters"])
    click.echo(f"wrote {out}: {doc['sample_rate_hz']['value']:g} Hz, {n} sos filters, "
               f"sampled-data loop free {'stable' if sa['free_stable'] else 'UNSTABLE'}, "
               f"locked {'stable' if sa['locked_stable'] else 'UNSTABLE'}; run `exotune certify {out}`")


@cli.command("certify")
@click.argument("controller_file", metavar="CONTROLLER.yaml")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object instead of text.")
@click.pass_context
def certify_cmd(ctx, controller_file, as_json):
    """Exact sampled-data analysis of an exported controller file (SPEC §7). Exit code 0: certified,
    1: analysed but not certified (the reasons are listed), 2: invalid file."""
    from .controllerfile.certify import certify, format_certify
    from .controllerfile.export import load_controller

    rep = certify(load_controller(controller_file))
    click.echo(_dumps(rep) if as_json else format_certify(rep))
    if not rep["certified"]:
        ctx.exit(1)


@cli.command("simulate")
@click.argument("input_file", metavar="DESIGN.yaml|CONTROLLER.yaml")
@click.option("--scenario", required=True, type=click.Choice(["locked-output", "dob-friction", "light-mass", "saturation"]),
              help="What to run (see README).")
@click.option("--sample-rate-hz", "sample_rate_hz", default=None, metavar="F",
              help="Sample rate for a design file (default: its implementation.sample_rate_hz).")
@click.option("--human-inertia", "human_inertia", type=click.FloatRange(min=0, min_open=True), default=None,
              metavar="KGM2", help="Human inertia [kg·m²] instead of the scenario's.")
@click.option("--joint-angle", "joint_angle", type=float, default=None, metavar="RAD",
              help="Run the gain-schedule entry (plant and controller) nearest this joint angle [rad].")
@click.option("--plots", "plots_dir", metavar="DIR", default=None, help="Write time-series plots (PNG) to DIR.")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object (summary, no time series).")
def simulate_cmd(input_file, scenario, sample_rate_hz, human_inertia, joint_angle, plots_dir, as_json):
    """Nonlinear time-domain run of the runtime controller on the plant (friction, backlash,
    saturation; SPEC §8)."""
    from .simulate import format_simulation, load_for_simulation, plot_simulation, run_scenario

    for name, v in (("--human-inertia", human_inertia), ("--joint-angle", joint_angle)):
        if v is not None and not math.isfinite(v):
            raise ConfigError(name, f"must be a finite number, got {v!r}")
    doc = load_for_simulation(input_file, sample_rate_hz)
    if joint_angle is not None:
        from .controllerfile.export import schedule_entry_doc

        if not doc.get("gain_schedule"):
            raise ConfigError("--joint-angle", "the controller has no gain schedule (no transmission section)")
        e = min(doc["gain_schedule"]["entries"], key=lambda e: abs(e["joint_angle_rad"] - joint_angle))
        doc = schedule_entry_doc(doc, e)
    rep = run_scenario(doc, scenario, human_inertia=human_inertia)
    if plots_dir is not None:
        files = plot_simulation(rep)
        _write_files(plots_dir, files)
    summary = {k: v for k, v in rep.items() if k != "runs"}
    click.echo(_dumps(summary) if as_json else format_simulation(rep))


def main(argv=None) -> None:
    """Console entry point (``exotune = exotune.cli:main``)."""
    cli.main(args=argv, prog_name="exotune")


if __name__ == "__main__":
    main()
