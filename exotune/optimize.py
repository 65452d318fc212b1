"""``exotune optimize SPEC.yaml -o DESIGN.yaml`` (SPEC §7): the best design under robust-stability,
passivity, DOB-margin and bandwidth constraints.

Spec (YAML)::

    base: paper.yaml                     # design file (relative to the spec) or inline mapping
    objective: amplification             # see OBJECTIVES (default: amplification, maximized)
    free:                                # dotted paths (as sweep axes) with bounds
      design.amplification: [1.5, 40.0]
      design.zeta_hat: {lo: 0.3, hi: 1.2, scale: lin}
    constraints:                         # all optional; robust/free_stable/locked_stable default true
      robust: true                       # every human family stable over its whole range
      max_phase_excess_deg: 10.0         # passivity of C7
      dob_phase_margin_deg: 30.0
      dob_gain_margin_db: 6.0
      dob_delay_margin_s: 0.001
      amplification_bandwidth_hz: 2.0
      nominal_passive: true              # the nominal C7 is passive (default false)
    seed: 0                              # (the command line's --seed wins)
    budget: 3000                         # designs evaluated by the global search (default 3000)

Method. Every evaluation is the exact vectorized analysis of :func:`exotune.analysis.analyze_batch`
(whole populations in one call). Global stage: ``scipy.optimize.differential_evolution``
(vectorized, seeded → deterministic) on the free parameters (log coordinates for ``scale: log``,
the default for bounds spanning more than a decade) minimizing a penalty: infeasible designs
score 1 + their total normalized violation (the robust constraint's violation is the unstable
log-fraction of each family's range, so the search has a slope to follow), feasible designs
−objective (normalized to [0, 1] over the bounds). Final stage when the objective is itself a free
parameter (α, felt inertia): the feasibility boundary along that parameter is located by
bisection (batches of 33 points, 4 rounds), other parameters held. The constraints violated just
past the optimum are reported as *active*. With ``pareto`` requested, the non-dominated designs of
every evaluated point — objective vs robust fraction (the smallest, over the human families, of the
stable log-fraction of the range), all other constraints met — are written as CSV.

The search is a heuristic over a non-convex, non-smooth set (SPEC §7): the result is a feasible
design that is verified exactly, not a certificate of global optimality.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field

import numpy as np

from .errors import ConfigError

__all__ = ["OBJECTIVES", "CONSTRAINTS", "OptimizeSpec", "load_optimize_spec", "evaluate", "optimize", "format_optimize"]

#: objective name → (what: a dotted parameter path or an analyze_batch column, sense, unit)
OBJECTIVES = {
    "amplification": ("design.amplification", "max", "1"),
    "felt_inertia": ("design.felt_inertia", "min", "kg·m²"),
    # SPEC §7 "felt compliance": the operator feels C7 ≈ 1/(Ĵ_m/α s² + B̂_m/α s) at low frequency, so
    # the most compliant (lightest-feeling) exoskeleton has the smallest felt inertia
    "felt_compliance": ("design.felt_inertia", "min", "kg·m² (felt inertia, minimized)"),
    "amplification_bandwidth_hz": ("amplification_bandwidth_hz", "max", "Hz"),
    "dob_delay_margin_s": ("dob_delay_margin_s", "max", "s"),
    "passivity_max_phase_excess_deg": ("passivity_max_phase_excess_deg", "min", "deg"),
}
#: bound constraints: name → (column, ">=" | "<=", unit)
CONSTRAINTS = {
    "max_phase_excess_deg": ("passivity_max_phase_excess_deg", "<=", "deg"),
    "dob_phase_margin_deg": ("dob_phase_margin_deg", ">=", "deg"),
    "dob_gain_margin_db": ("dob_gain_margin_db", ">=", "dB"),
    "dob_delay_margin_s": ("dob_delay_margin_s", ">=", "s"),
    "amplification_bandwidth_hz": ("amplification_bandwidth_hz", ">=", "Hz"),
}
_BOOL = ("robust", "free_stable", "locked_stable", "nominal_passive")
_BOOL_DEFAULT = {"robust": True, "free_stable": True, "locked_stable": True, "nominal_passive": False}
_KEYS = ("base", "objective", "free", "constraints", "seed", "budget")


@dataclass(frozen=True)
class OptimizeSpec:
    cfg: object  # DesignConfig of the base
    free: dict  # path → (lo, hi, "log"|"lin")
    objective: str
    constraints: dict  # name → bound (float) or bool
    seed: int = 0
    budget: int = 3000
    source: str | None = None
    raw: dict = field(default_factory=dict)


def _num(field_: str, v) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(float(v)):
        raise ConfigError(field_, f"expected a finite number, got {v!r}")
    return float(v)


def load_optimize_spec(spec, seed: int | None = None) -> OptimizeSpec:
    """Read and validate an optimization spec (path or mapping); every problem is a ConfigError."""
    from .config.design import OVERRIDABLE, batch_config, read_yaml
    from .sweep.engine import load_base

    if isinstance(spec, (str, os.PathLike)):
        mapping = read_yaml(os.fspath(spec))
        root, source = os.path.dirname(os.path.abspath(os.fspath(spec))), os.fspath(spec)
    elif isinstance(spec, dict):
        mapping, root, source = spec, os.getcwd(), None
    else:
        raise ConfigError("<spec>", f"expected a spec file path or a mapping, got {type(spec).__name__}")
    if not isinstance(mapping, dict):
        raise ConfigError(source or "<spec>", "expected a mapping at the top level")
    for k in mapping:
        if k not in _KEYS:
            raise ConfigError(str(k), f"unknown key in an optimization spec (allowed: {', '.join(_KEYS)})")
    if "base" not in mapping:
        raise ConfigError("base", "required key is missing (a design file path or an inline design mapping)")
    cfg, _ = load_base(mapping["base"], root)
    objective = mapping.get("objective", "amplification")
    if not isinstance(objective, str) or objective not in OBJECTIVES:
        raise ConfigError("objective", f"unknown objective {objective!r} (known: {', '.join(OBJECTIVES)})")
    free_in = mapping.get("free")
    if not isinstance(free_in, dict) or not free_in:
        raise ConfigError("free", "required: a mapping of dotted parameter paths to bounds [lo, hi]")
    free = {}
    for path, b in free_in.items():
        f = f"free.{path}"
        if path not in OVERRIDABLE:
            raise ConfigError(f, "unknown or non-overridable parameter (the paths of sweep axes)")
        scale = None
        if isinstance(b, dict):
            extra = set(b) - {"lo", "hi", "scale"}
            if extra:
                raise ConfigError(f"{f}.{sorted(extra)[0]}", "unknown key (allowed: lo, hi, scale)")
            if "lo" not in b or "hi" not in b:
                raise ConfigError(f, "needs lo and hi")
            lo, hi, scale = _num(f"{f}.lo", b["lo"]), _num(f"{f}.hi", b["hi"]), b.get("scale")
            if scale not in (None, "lin", "log"):
                raise ConfigError(f"{f}.scale", f"expected lin or log, got {scale!r}")
        elif isinstance(b, (list, tuple)) and len(b) == 2:
            lo, hi = _num(f"{f}[0]", b[0]), _num(f"{f}[1]", b[1])
        else:
            raise ConfigError(f, f"expected bounds [lo, hi] or {{lo, hi, scale}}, got {b!r}")
        if not lo < hi:
            raise ConfigError(f, f"lower bound {lo:g} must be below the upper bound {hi:g}")
        try:
            batch_config(cfg, {path: np.array([lo, hi])})
        except ConfigError as e:
            raise ConfigError(f, e.reason) from None
        if scale == "log" and lo <= 0:
            raise ConfigError(f"{f}.scale", "log scale needs a positive lower bound")
        if scale is None:
            scale = "log" if lo > 0 and hi / lo > 10 else "lin"
        free[path] = (lo, hi, scale)
    what = OBJECTIVES[objective][0]
    if what.startswith(("design.", "plant.", "implementation.")) and what not in free:
        raise ConfigError("objective", f"{objective} is the parameter {what}: list it under free with its bounds")
    cons_in = mapping.get("constraints")
    cons_in = {} if cons_in is None else cons_in  # an empty `constraints:` key: the defaults
    if not isinstance(cons_in, dict):
        raise ConfigError("constraints", f"expected a mapping of constraint names to bounds, got {cons_in!r}")
    cons = dict(_BOOL_DEFAULT)
    for k, v in cons_in.items():
        if k in _BOOL:
            if not isinstance(v, bool):
                raise ConfigError(f"constraints.{k}", f"expected true or false, got {v!r}")
            cons[k] = v
        elif k in CONSTRAINTS:
            cons[k] = _num(f"constraints.{k}", v)
            if k == "max_phase_excess_deg" and cons[k] < 0:
                raise ConfigError(f"constraints.{k}", f"must be >= 0 (the phase excess is never negative), got {v!r}")
        else:
            raise ConfigError(f"constraints.{k}", f"unknown constraint (known: {', '.join(_BOOL + tuple(CONSTRAINTS))})")
    if cons["robust"] and not cfg.humans:
        raise ConfigError("constraints.robust", "the base design has no human families to be robust against")
    s = mapping.get("seed", 0) if seed is None else seed
    if isinstance(s, bool) or not isinstance(s, int) or s < 0:
        raise ConfigError("seed", f"expected a non-negative integer, got {s!r}")
    budget = mapping.get("budget", 3000)
    if isinstance(budget, bool) or not isinstance(budget, int) or budget < 50:
        raise ConfigError("budget", f"expected an integer ≥ 50, got {budget!r}")
    raw = {"objective": objective, "free": {p: list(v) for p, v in free.items()}, "constraints": cons,
           "seed": s, "budget": budget}
    return OptimizeSpec(cfg, free, objective, cons, s, budget, source, raw)


# --------------------------------------------------------------------------------------------
# evaluation of a population
# --------------------------------------------------------------------------------------------
def _log_fraction(ivs, lo, hi) -> float:
    if hi <= lo:
        return 1.0 if ivs else 0.0
    f = (lambda x: math.log(x)) if lo > 0 else (lambda x: x)
    return sum(f(b) - f(a) for a, b in ivs) / (f(hi) - f(lo))


def evaluate(spec: OptimizeSpec, X: np.ndarray) -> dict:
    """Analyse the designs of the rows of X (columns in ``spec.free`` order, natural units)."""
    from .analysis.core import analyze_batch
    from .config.design import batch_config

    X = np.atleast_2d(np.asarray(X, float))
    paths = list(spec.free)
    cols = analyze_batch(batch_config(spec.cfg, {p: X[:, j] for j, p in enumerate(paths)}))
    n = X.shape[0]
    viol = np.zeros(n)
    broken = {}
    frac = np.ones(n)
    fam_keys = [k[: -len("_robust")] for k in cols if k.startswith("human") and k.endswith("_robust")]
    for i, key in enumerate(fam_keys):
        fam = spec.cfg.humans[i]
        fr = np.array([_log_fraction(iv, fam.lo, fam.hi) for iv in cols[key + "_stable_intervals"]])
        fr = np.where(np.asarray(cols[key + "_robust"], bool), 1.0, np.minimum(fr, 1.0 - 1e-9))
        frac = np.minimum(frac, fr)
    if spec.constraints["robust"]:
        v = 1.0 - frac
        viol += v
        broken["robust"] = v > 0
    for name, col in (("free_stable", "free_stable"), ("locked_stable", "locked_stable")):
        if spec.constraints[name]:
            bad = ~np.asarray(cols[col], bool)
            viol += bad
            broken[name] = bad
    for k in (k for k in cols if k.startswith("env") and k.endswith("_stable")):
        if spec.constraints["locked_stable"]:
            bad = ~np.asarray(cols[k], bool)
            viol += bad
            broken[k] = bad
    for name, (col, op, _unit) in CONSTRAINTS.items():
        if name not in spec.constraints:
            continue
        b = spec.constraints[name]
        val = np.asarray(cols[col], float)
        val = np.where(np.isnan(val), -np.inf if op == ">=" else np.inf, val)
        gap = (b - val) if op == ">=" else (val - b)
        v = np.clip(gap / max(abs(b), 1e-12), 0.0, 10.0)
        v = np.where(np.isfinite(v), v, 10.0)
        viol += v
        broken[name] = gap > 0
    if spec.constraints["nominal_passive"]:
        short, b_over_kc = _nominal_shortage(spec, X)
        v = np.clip(short / b_over_kc, 0.0, 10.0)
        viol += v
        broken["nominal_passive"] = short > 0
    what, sense, _ = OBJECTIVES[spec.objective]
    obj = X[:, paths.index(what)] if what in paths else np.asarray(cols[what], float)
    return {"X": X, "columns": cols, "violation": viol, "feasible": viol == 0, "broken": broken,
            "objective": obj, "robust_fraction": frac}


def _nominal_shortage(spec, X):
    """Closed-form nominal passivity shortage of the rows of X (:func:`exotune.kyp.nominal_shortage`)
    and its normalization B̂_m/(Ĵ_m K_c) (the shortage when ζ̂ = 0)."""
    from .config.design import batch_config
    from .analysis.kyp import nominal_shortage

    c = batch_config(spec.cfg, {p: X[:, j] for j, p in enumerate(spec.free)})
    d, pl = c.design, c.plant
    short = nominal_shortage(d.amplification, d.felt_inertia, d.felt_damping, pl.K_c, d.zeta_hat)
    b_over_kc = np.asarray(d.felt_damping, float) / np.asarray(d.felt_inertia, float) / np.asarray(pl.K_c, float)
    return np.broadcast_to(short, X.shape[:1]), np.broadcast_to(b_over_kc, X.shape[:1])


def _to_unit(spec, X):
    U = np.empty_like(X)
    for j, (lo, hi, sc) in enumerate(spec.free.values()):
        U[:, j] = (np.log(X[:, j] / lo) / math.log(hi / lo)) if sc == "log" else (X[:, j] - lo) / (hi - lo)
    return U


def _from_unit(spec, U):
    X = np.empty_like(U, dtype=float)
    for j, (lo, hi, sc) in enumerate(spec.free.values()):
        u = np.clip(U[:, j], 0.0, 1.0)
        X[:, j] = lo * (hi / lo) ** u if sc == "log" else lo + u * (hi - lo)
    return X


def _score(spec, ev) -> np.ndarray:
    what, sense, _ = OBJECTIVES[spec.objective]
    o = ev["objective"]
    if what in spec.free:
        lo, hi, _sc = spec.free[what]
        on = (o - lo) / (hi - lo)
    else:
        fin = np.isfinite(o)
        scale = max(float(np.nanmax(np.abs(o[fin]))) if fin.any() else 1.0, 1e-12)
        on = np.where(fin, o / scale, -np.inf if sense == "max" else np.inf)
    on = on if sense == "max" else -on
    on = np.nan_to_num(on, nan=-1e3, neginf=-1e3, posinf=1e3)
    return np.where(ev["feasible"], -on, 1.0 + 1e3 + ev["violation"])


def optimize(spec: OptimizeSpec, pareto: bool = False) -> dict:
    """Run the search of the module docstring; returns the result (JSON-ready apart from arrays)."""
    import scipy.optimize

    paths = list(spec.free)
    D = len(paths)
    seen = []

    def f(U):  # U: (D, S) in unit coordinates
        X = _from_unit(spec, np.asarray(U).T)
        ev = evaluate(spec, X)
        seen.append(ev)
        return _score(spec, ev)

    popsize = max(5, int(round(min(60, spec.budget / 20) / max(D, 1))))
    S = popsize * D
    maxiter = max(1, spec.budget // S - 1)
    res = scipy.optimize.differential_evolution(
        f, [(0.0, 1.0)] * D, vectorized=True, updating="deferred", seed=spec.seed, popsize=popsize,
        maxiter=maxiter, polish=False, tol=1e-6, init="latinhypercube")
    allX = np.vstack([e["X"] for e in seen])
    allS = np.concatenate([_score(spec, e) for e in seen])
    feas = np.concatenate([e["feasible"] for e in seen])
    evaluated = int(allX.shape[0])
    if not feas.any():
        best = int(np.argmin(allS))
        ev = evaluate(spec, allX[best:best + 1])
        return {"feasible": False, "evaluated": evaluated, "x": dict(zip(paths, allX[best].tolist())),
                "broken": sorted(k for k, v in ev["broken"].items() if v[0]), "spec": spec.raw}
    best = int(np.argmin(np.where(feas, allS, np.inf)))
    x = allX[best].copy()
    active = []
    what, sense, unit = OBJECTIVES[spec.objective]
    if what in spec.free:
        j = paths.index(what)
        lo, hi, sc = spec.free[what]
        a, b = x[j], (hi if sense == "max" else lo)
        last_bad = None
        for _ in range(4):  # bracket the feasibility boundary along the objective parameter
            ts = np.linspace(0.0, 1.0, 33)
            vals = a * (b / a) ** ts if sc == "log" else a + ts * (b - a)
            Xl = np.repeat(x[None, :], ts.size, axis=0)
            Xl[:, j] = vals
            ev = evaluate(spec, Xl)
            seen.append(ev)
            evaluated += ts.size
            ok = ev["feasible"]
            if ok.all():
                a = vals[-1]
                break
            k = int(np.argmin(ok))  # first infeasible
            if k == 0:
                break
            a, b = vals[k - 1], vals[k]
            last_bad = {n: bool(v[k]) for n, v in ev["broken"].items()}
        x[j] = a
        if last_bad is not None:
            active = sorted(n for n, v in last_bad.items() if v)
        else:
            active = [f"bound {what} ≤ {hi:g}" if sense == "max" else f"bound {what} ≥ {lo:g}"]
    final = evaluate(spec, x[None, :])
    assert bool(final["feasible"][0]), "the optimum must be feasible"
    near = []
    for name, (col, op, _u) in CONSTRAINTS.items():
        if name in spec.constraints:
            b = spec.constraints[name]
            v = float(np.asarray(final["columns"][col])[0])
            slack = (v - b) if op == ">=" else (b - v)
            if slack / max(abs(b), 1e-12) < 0.01:
                near.append(name)
    out = {
        "feasible": True,
        "objective": {"name": spec.objective, "sense": sense, "value": float(final["objective"][0]), "unit": unit},
        "x": dict(zip(paths, x.tolist())),
        "active_constraints": active,
        "near_binding": near,
        "evaluated": evaluated,
        "de_message": str(res.message),
        "metrics": _metrics(final["columns"]),
        "robust_fraction": float(final["robust_fraction"][0]),
        "spec": spec.raw,
    }
    if not active:
        out["note"] = "no constraint is binding along the objective (metric objective): local optimum of the search"
    from .analysis.core import kyp_certificates
    from .config.design import design_from_mapping

    opt_cfg = design_from_mapping(optimized_design_mapping(spec, out))
    if spec.cfg.implementation.sample_rate_hz is not None:
        # the search is continuous-time (exact delay); with a sample rate, check the optimum's
        # sampled-data loop too and say where sampling breaks what the search accepted
        from .analysis.core import analyze_design

        rep = analyze_design(opt_cfg)
        out["sampled_data_warnings"] = [w for w in rep.get("warnings", []) if "sampled-data" in w]
        certs = rep["passivity"]["kyp"]
    else:
        certs = kyp_certificates(opt_cfg)
    # the convex sub-problem (SPEC §7): KYP certificates of the optimum's rational C7 models (cvxpy)
    out["passivity_certificates"] = certs
    nom = certs.get("nominal") or {}
    if spec.constraints["nominal_passive"] and nom.get("passive") is not True:
        out["certificate_warning"] = ("the KYP certificate does not confirm the closed-form nominal passivity of the "
                                      f"optimum: {nom.get('reason', certs.get('error'))}")
    if pareto:
        out["pareto"] = _pareto(spec, seen)
    return out


def _metrics(cols) -> dict:
    g = lambda k: float(np.asarray(cols[k])[0])  # noqa: E731
    return {
        "passivity_max_phase_excess_deg": {"value": g("passivity_max_phase_excess_deg"), "unit": "deg"},
        "dob_phase_margin_deg": {"value": g("dob_phase_margin_deg"), "unit": "deg"},
        "dob_gain_margin_db": {"value": g("dob_gain_margin_db"), "unit": "dB"},
        "dob_delay_margin_s": {"value": g("dob_delay_margin_s"), "unit": "s"},
        "amplification_bandwidth_hz": {"value": g("amplification_bandwidth_hz"), "unit": "Hz"},
        "human_stable_intervals": {k: cols[k][0] for k in cols if k.startswith("human") and k.endswith("_stable_intervals")},
    }


def _pareto(spec, seen) -> list[dict]:
    """Non-dominated (objective, robust fraction) among designs meeting every other constraint."""
    what, sense, _ = OBJECTIVES[spec.objective]
    rows = []
    for ev in seen:
        other = np.ones(ev["X"].shape[0], bool)
        for n, v in ev["broken"].items():
            if n != "robust":
                other &= ~v
        for i in np.nonzero(other)[0]:
            o = float(ev["objective"][i])
            if math.isfinite(o):
                rows.append((o if sense == "max" else -o, float(ev["robust_fraction"][i]), ev["X"][i]))
    rows.sort(key=lambda r: (-r[0], -r[1]))
    front, best_r = [], -1.0
    for o, r, x in rows:
        if r > best_r:
            front.append({"objective": o if sense == "max" else -o, "robust_fraction": r,
                          **dict(zip(spec.free, x.tolist()))})
            best_r = r
    return front


def optimized_design_mapping(spec: OptimizeSpec, result: dict) -> dict:
    """The base design mapping with the optimized values written in."""
    import copy

    raw = copy.deepcopy(spec.cfg.raw)
    for path, v in result["x"].items():
        node = raw
        keys = path.split(".")
        for k in keys[:-1]:
            node = node[k]
        node[keys[-1]] = float(v)
    return raw


def format_optimize(r: dict) -> str:
    if not r["feasible"]:
        return ("NO FEASIBLE DESIGN found in the bounds after "
                f"{r['evaluated']} exact analyses; the best one breaks: {', '.join(r['broken'])}")
    o = r["objective"]
    lines = [f"optimum ({r['evaluated']} designs analysed exactly): {o['name']} = {o['value']:.6g} {o['unit']} ({o['sense']}imized)"]
    lines += [f"  {p} = {v:.6g}" for p, v in r["x"].items()]
    lines.append("  active constraints (broken just past the optimum): " + (", ".join(r["active_constraints"]) or "none"))
    if r.get("near_binding"):
        lines.append("  within 1 % of their bound: " + ", ".join(r["near_binding"]))
    for k, m in r["metrics"].items():
        if k == "human_stable_intervals":
            for fk, iv in m.items():
                lines.append(f"  {fk}: {iv}")
        else:
            lines.append(f"  {k}: {m['value']:.6g} {m['unit']}")
    from .analysis.kyp import format_certificates

    lines += format_certificates(r.get("passivity_certificates"))
    if r.get("certificate_warning"):
        lines.append("  WARNING: " + r["certificate_warning"])
    for w in r.get("sampled_data_warnings", []):
        lines.append("  WARNING: " + w + " (the search itself is continuous-time: tighten the human ranges or the "
                     "delay, then export and certify)")
    if "pareto" in r:
        lines.append(f"  Pareto front (objective vs robust fraction): {len(r['pareto'])} designs")
    return "\n".join(lines)


def run_optimize(spec_file, out, seed: int | None = None, pareto_csv=None) -> dict:
    """``exotune optimize``: load, search, write the optimized design file (validated, atomically)
    and, on request, the Pareto front as CSV. Raises ConfigError for bad input; an infeasible
    problem writes nothing and returns the result (``feasible`` false)."""
    import yaml

    from .config.design import design_from_mapping
    from .jsonio import write_atomic

    spec = load_optimize_spec(spec_file, seed=seed)
    r = optimize(spec, pareto=pareto_csv is not None)
    if not r["feasible"]:
        return r
    mapping = optimized_design_mapping(spec, r)
    design_from_mapping(mapping)  # the written file must load
    o = r["objective"]
    head = (f"# exotune optimize: {o['name']} = {o['value']:.6g} {o['unit']} ({o['sense']}imized), "
            f"active: {', '.join(r['active_constraints']) or 'none'}; seed {spec.seed}\n")
    write_atomic(out, head + yaml.safe_dump(mapping, sort_keys=False, allow_unicode=True))
    if pareto_csv is not None:
        cols = ["objective", "robust_fraction", *spec.free]
        text = ",".join(cols) + "\n" + "".join(",".join(repr(float(row[c])) for c in cols) + "\n" for row in r["pareto"])
        write_atomic(pareto_csv, text)
    return r
