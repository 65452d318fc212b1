"""``exotune simulate`` (SPEC §8): nonlinear time-domain runs of the runtime controller on the plant.

The controller is the exported runtime controller (:class:`exotune.runtime.Runtime`, from a
controller file or exported in memory from a design file at its sample rate), stepped once per
sample exactly as the real-time runtime would. Its command is applied through a zero-order hold
after the file's total latency T = (d + f)·T_s (d whole samples; for the fraction f of each period
the previous command is still applied). The plant is the physical model of SPEC §2 with the
nonlinearities a real joint has, integrated by fixed-step RK4 (``substeps`` per sample):

    J_m θ̈_m + B_m θ̇_m + F_c tanh(θ̇_m/ε) = τ_s + sat(τ_m)          (Coulomb friction, saturation)
    τ_s = K_s · dz(θ_j − θ_m)                                          (backlash: dead zone of width b)
    J_j θ̈_j = τ_c − τ_s   (θ_j ≡ 0 when the output is locked)
    m θ̈_h + b_h θ̇_h + k_h θ_h = −τ_c + τ_h(t)                         (human, muscle torque τ_h)
    τ_c = K_c (θ_h − θ_j)

Scenarios (:data:`SCENARIOS`): ``locked-output`` (output locked, the human pushes a step: the
delivered amplification (τ_c − τ_s)/τ_c → α), ``dob-friction`` (the same with Coulomb friction on
the motor, run with and without the DOB), ``light-mass`` (free output, a light human mass and an
initial push: does the cuff oscillation decay?), ``saturation`` (the locked-output push large
enough to saturate the motor). Without nonlinearities the sampled trajectory equals the exact
sampled-data model of :mod:`exotune.sampled` (tested), so every departure is the nonlinearity's.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass, replace

import numpy as np

from .controllerfile.runtime import Runtime

__all__ = ["Nonlinearities", "Scenario", "SCENARIOS", "simulate", "run_scenario", "format_simulation"]


@dataclass(frozen=True)
class Nonlinearities:
    coulomb_nm: float = 0.0  # F_c [N·m], motor-side Coulomb friction
    friction_eps_rad_s: float = 1e-3  # ε [rad/s] of the tanh friction model
    backlash_rad: float = 0.0  # total dead-zone width b [rad] in the SEA spring
    saturation_nm: float = math.inf  # motor torque limit [N·m]


@dataclass(frozen=True)
class Scenario:
    name: str
    description: str
    locked: bool
    human: dict  # inertia / damping / stiffness of the human
    push_nm: float  # muscle torque step τ_h [N·m]
    push_at_s: float
    duration_s: float
    theta_h0: float = 0.0  # initial human position [rad] (a push on the cuff spring)
    nonlinear: Nonlinearities = Nonlinearities()
    compare_without_dob: bool = False
    push_hz: float = 0.0  # > 0: the muscle torque is push_nm·sin(2π push_hz t) after push_at_s


SCENARIOS = {
    "locked-output": Scenario("locked-output", "output locked; the human (0.5 kg·m², 2 N·m·s/rad) pushes a 5 N·m step",
                              True, {"inertia": 0.5, "damping": 2.0}, 5.0, 0.05, 2.0),
    "dob-friction": Scenario("dob-friction", "free output; the human (0.5 kg·m²) moves the joint with a 3 N·m, 0.5 Hz "
                             "torque against 2 N·m Coulomb friction on the motor; friction sensitivity with and "
                             "without the DOB", False, {"inertia": 0.5, "damping": 2.0}, 3.0, 0.0, 4.0,
                             nonlinear=Nonlinearities(coulomb_nm=2.0), compare_without_dob=True, push_hz=0.5),
    "light-mass": Scenario("light-mass", "free output; a light human mass (default 5e-3 kg·m²) released from a "
                           "0.01 rad cuff deflection", False, {"inertia": 5e-3}, 0.0, 0.0, 1.5, theta_h0=0.01),
    "saturation": Scenario("saturation", "locked output; a 20 N·m push with the motor limited to 40 N·m (the "
                           "runtime clamps its command and feeds the clamped value to the DOB: no windup)",
                           True, {"inertia": 0.5, "damping": 2.0}, 20.0, 0.05, 2.0,
                           nonlinear=Nonlinearities(saturation_nm=40.0)),
}


def _deadzone(x: float, b: float) -> float:
    if b <= 0:
        return x
    h = 0.5 * b
    return x - h if x > h else (x + h if x < -h else 0.0)


def simulate(doc: dict, scenario: Scenario, substeps: int = 20, without_dob: bool = False) -> dict:
    """Run ``scenario`` with the controller file ``doc``; returns time series (per sample) and
    the plant parameters used."""
    if without_dob:
        doc = copy.deepcopy(doc)
        doc["controller"]["filters"] = [f for f in doc["controller"]["filters"] if not f["name"].startswith("dob_")]
    p = {k: v["value"] for k, v in doc["plant"].items()}
    Jm, Bm, Ks, Jj, Kc = (p[k] for k in ("motor_inertia", "motor_damping", "sea_stiffness", "joint_inertia",
                                         "cuff_stiffness"))
    fs = float(doc["sample_rate_hz"]["value"])
    Ts = 1.0 / fs
    q = float(doc["delay_s"]["value"]) * fs
    d = int(math.floor(q + 1e-9))
    f = q - d if q - d > 1e-9 else 0.0
    nl = scenario.nonlinear
    hm = float(scenario.human.get("inertia", 0.0))
    hb = float(scenario.human.get("damping", 0.0))
    hk = float(scenario.human.get("stiffness", 0.0))
    if hm <= 0:
        raise ValueError("simulate: the human needs an inertia > 0")
    locked = scenario.locked

    def tau_s_of(x):
        return Ks * _deadzone((0.0 if locked else x[2]) - x[0], nl.backlash_rad)

    def deriv(x, tm, th_push):
        # x = [θ_m, ω_m, θ_j, ω_j, θ_h, ω_h]
        ts = tau_s_of(x)
        thj = 0.0 if locked else x[2]
        tc = Kc * (x[4] - thj)
        fr = nl.coulomb_nm * math.tanh(x[1] / nl.friction_eps_rad_s) if nl.coulomb_nm else 0.0
        dx = np.empty(6)
        dx[0] = x[1]
        dx[1] = (ts + tm - Bm * x[1] - fr) / Jm
        dx[2] = 0.0 if locked else x[3]
        dx[3] = 0.0 if locked else (tc - ts) / Jj
        dx[4] = x[5]
        dx[5] = (-tc - hb * x[5] - hk * x[4] + th_push) / hm
        return dx

    def rk4(x, tm, th, h, n):
        for _ in range(n):
            k1 = deriv(x, tm, th)
            k2 = deriv(x + 0.5 * h * k1, tm, th)
            k3 = deriv(x + 0.5 * h * k2, tm, th)
            k4 = deriv(x + h * k3, tm, th)
            x = x + (h / 6.0) * (k1 + 2 * k2 + 2 * k3 + k4)
        return x

    rt = Runtime(doc, limit_nm=nl.saturation_nm if math.isfinite(nl.saturation_nm) else None)
    n = int(round(scenario.duration_s * fs))
    x = np.zeros(6)
    x[4] = scenario.theta_h0
    past = [0.0] * (d + 1)  # τ_cmd[k−1], …, τ_cmd[k−d−1]
    sat = nl.saturation_nm
    rec = {k: np.empty(n) for k in ("t", "theta_m", "omega_m", "theta_j", "theta_h", "tau_s", "tau_c", "tau_cmd",
                                    "tau_m", "push")}
    n1 = max(1, int(round(substeps * f))) if f > 0 else 0
    n0 = substeps - n1
    for k in range(n):
        t = k * Ts
        thj = 0.0 if locked else x[2]
        ts = tau_s_of(x)
        tc = Kc * (x[4] - thj)
        y = {"theta_m": x[0], "omega_m": x[1], "tau_s": ts, "dtau_s": Ks * ((0.0 if locked else x[3]) - x[1]),
             "tau_c": tc}
        u = rt.step(y)
        cur = u if d == 0 else past[d - 1]
        old = past[d]
        push = 0.0
        if t >= scenario.push_at_s:
            push = scenario.push_nm * (math.sin(2 * math.pi * scenario.push_hz * (t - scenario.push_at_s))
                                       if scenario.push_hz > 0 else 1.0)
        clip = lambda v: max(-sat, min(sat, v))  # noqa: E731
        rec["t"][k], rec["theta_m"][k], rec["omega_m"][k], rec["theta_j"][k] = t, x[0], x[1], thj
        rec["theta_h"][k], rec["tau_s"][k], rec["tau_c"][k], rec["tau_cmd"][k] = x[4], ts, tc, u
        rec["tau_m"][k], rec["push"][k] = clip(cur), push
        # the first f·T_s still applies τ_cmd[k−d−1], the rest τ_cmd[k−d]
        if n1:
            x = rk4(x, clip(old), push, f * Ts / n1, n1)
        x = rk4(x, clip(cur), push, (1.0 - f) * Ts / n0, n0)
        past = [u] + past[:-1]
        if not np.all(np.isfinite(x)) or np.max(np.abs(x)) > 1e6:
            for key in rec:
                rec[key] = rec[key][: k + 1]
            break
    return {"series": rec, "sample_rate_hz": fs, "delay_samples": q, "locked": locked}


GROWTH = 5.0  # a late torque peak this many times the mid-run peak (and well above the push) diverges


def _growing(s: dict, sc: Scenario) -> bool:
    """An unstable loop that has not yet reached the 1e6 state bound: the spring or cuff torque
    peak over the last fifth of the run is > GROWTH × its peak over the middle fifth, and more than
    10 × the push (torques, not positions: a free output may drift as a rigid body). A run whose
    push starts after the middle window is judged on the 1e6 bound only."""
    n = s["t"].size
    if n < 50 or sc.push_at_s > 0.4 * float(s["t"][-1]):
        return False
    mid, late = slice(int(0.4 * n), int(0.6 * n)), slice(int(0.8 * n), n)
    for key in ("tau_s", "tau_c"):
        a = np.abs(s[key])
        m, lt = float(np.max(a[mid])), float(np.max(a[late]))
        if lt > GROWTH * m and lt > 10.0 * max(abs(sc.push_nm), 1.0):
            return True
    return False


def _summary(sim: dict, sc: Scenario, alpha: float) -> dict:
    s = sim["series"]
    t = s["t"]
    n = t.size
    out = {"samples": int(n), "duration_s": {"value": float(t[-1]) if n else 0.0, "unit": "s"},
           "diverged": bool(n < int(round(sc.duration_s * sim["sample_rate_hz"]))) or _growing(s, sc)}
    tail = slice(int(0.8 * n), n)
    if sc.locked and n:
        tc = float(np.mean(s["tau_c"][tail]))
        ts = float(np.mean(s["tau_s"][tail]))
        ratio = (tc - ts) / tc if tc != 0 else math.nan
        out["steady_cuff_torque"] = {"value": tc, "unit": "N·m"}
        out["steady_output_torque"] = {"value": tc - ts, "unit": "N·m (τ_c − τ_s on the locked output)"}
        out["delivered_amplification"] = {"value": ratio, "unit": "1", "design_alpha": alpha}
        out["amplification_error"] = {"value": (ratio - alpha) / alpha if math.isfinite(ratio) else math.nan,
                                      "unit": "1 (relative)"}
    w = s["theta_h"] - s["theta_j"]
    a0 = float(np.max(np.abs(w[: max(1, n // 5)]))) if n else 0.0
    if not sc.locked and sc.push_nm == 0 and n:
        w_ac = w[tail] - np.mean(w[tail])
        out["cuff_oscillation_start_rad"] = {"value": a0, "unit": "rad"}
        out["cuff_oscillation_end_rad"] = {"value": float(np.max(np.abs(w_ac))), "unit": "rad"}
        out["oscillation_decays"] = bool(np.max(np.abs(w_ac)) < 0.1 * a0)
    out["peak_motor_torque"] = {"value": float(np.max(np.abs(s["tau_m"]))) if n else 0.0, "unit": "N·m"}
    out["peak_command"] = {"value": float(np.max(np.abs(s["tau_cmd"]))) if n else 0.0, "unit": "N·m"}
    return out


def run_scenario(doc: dict, name: "str | Scenario", human_inertia: float | None = None, substeps: int = 20) -> dict:
    """Run a scenario (a name of :data:`SCENARIOS` or a :class:`Scenario`; optionally with another
    human inertia) and summarize it."""
    if isinstance(name, Scenario):
        sc = name
    elif name in SCENARIOS:
        sc = SCENARIOS[name]
    else:
        raise ValueError(f"unknown scenario {name!r} (known: {', '.join(SCENARIOS)})")
    if human_inertia is not None:
        sc = replace(sc, human={**sc.human, "inertia": float(human_inertia)})
    alpha = float(doc["design"]["amplification"]["value"])
    sim = simulate(doc, sc, substeps=substeps)
    rep = {"scenario": sc.name, "description": sc.description, "human": sc.human,
           "nonlinearities": {"coulomb_nm": sc.nonlinear.coulomb_nm, "backlash_rad": sc.nonlinear.backlash_rad,
                              "saturation_nm": sc.nonlinear.saturation_nm,
                              "units": {"coulomb_nm": "N·m", "backlash_rad": "rad", "saturation_nm": "N·m"}},
           "sample_rate_hz": sim["sample_rate_hz"], "delay_samples": sim["delay_samples"],
           "summary": _summary(sim, sc, alpha), "runs": {"with_controller_file": sim}}
    if sc.compare_without_dob and any(f["name"].startswith("dob_") for f in doc["controller"]["filters"]):
        # friction sensitivity: the joint trajectory with friction against the same controller's
        # frictionless one, with the file's controller (DOB) and with its DOB filters removed
        clean = replace(sc, nonlinear=Nonlinearities())
        sens = {}
        for label, wo in (("with_dob", False), ("without_dob", True)):
            fr = sim if not wo else simulate(doc, sc, substeps=substeps, without_dob=True)
            ref = simulate(doc, clean, substeps=substeps, without_dob=wo)
            a, b = fr["series"]["theta_j"], ref["series"]["theta_j"]
            m = min(a.size, b.size)
            sens[label] = {"value": float(np.sqrt(np.mean((a[:m] - b[:m]) ** 2)) / max(np.sqrt(np.mean(b[:m] ** 2)), 1e-300)),
                           "unit": "1 (RMS joint-angle change due to friction / RMS joint angle)"}
            if wo:
                rep["summary_without_dob"] = _summary(fr, sc, alpha)
                rep["runs"]["without_dob"] = fr
        rep["friction_sensitivity"] = sens
    return rep


def format_simulation(rep: dict) -> str:
    def line(k, v):
        if isinstance(v, dict) and "value" in v:
            return f"  {k}: {v['value']:.6g} {v['unit']}"
        return f"  {k}: {v}"

    out = [f"exotune simulate — {rep['scenario']}: {rep['description']}",
           f"  sample rate {rep['sample_rate_hz']:g} Hz, delay {rep['delay_samples']:.4g} samples"]
    out += [line(k, v) for k, v in rep["summary"].items()]
    for k, v in rep.get("friction_sensitivity", {}).items():
        out.append(f"  friction sensitivity {k.replace('_', ' ')}: {v['value']:.4g} {v['unit']}")
    if "summary_without_dob" in rep:
        out.append("  without the DOB:")
        out += ["  " + line(k, v) for k, v in rep["summary_without_dob"].items()]
    return "\n".join(out)


def plot_simulation(rep: dict) -> dict[str, bytes]:
    """PNG figures of the runs (time series of torques and the cuff deflection)."""
    import io

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axs = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    for label, sim in rep["runs"].items():
        s = sim["series"]
        axs[0].plot(s["t"], s["tau_c"], label=f"τ_c [{label}]")
        axs[0].plot(s["t"], s["tau_c"] - s["tau_s"], "--", label=f"τ_c − τ_s [{label}]")
        axs[1].plot(s["t"], s["theta_h"] - s["theta_j"], label=f"θ_h − θ_j [{label}]")
    axs[0].set_ylabel("torque [N·m]")
    axs[1].set_ylabel("cuff deflection [rad]")
    axs[1].set_xlabel("time [s]")
    for a in axs:
        a.grid(True, alpha=0.3)
        a.legend(fontsize=7)
    fig.suptitle(f"exotune simulate: {rep['scenario']}")
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    plt.close(fig)
    return {f"simulate_{rep['scenario']}.png": buf.getvalue()}


def load_for_simulation(path, sample_rate_hz: float | None = None) -> dict:
    """A controller file as is, or a design file exported in memory at ``sample_rate_hz`` (or at
    its own ``implementation.sample_rate_hz``)."""
    from .config.design import read_yaml
    from .errors import ConfigError
    from .controllerfile.export import build_export, design_at_rate, load_controller

    raw = read_yaml(path)
    if isinstance(raw, dict) and "schema" in raw:
        if sample_rate_hz is not None:
            raise ConfigError("--sample-rate-hz", "a controller file carries the sample rate it was certified at; "
                              "the option applies to design files only")
        return load_controller(path)
    fs = sample_rate_hz
    if fs is None and isinstance(raw, dict) and isinstance(raw.get("implementation"), dict):
        fs = raw["implementation"].get("sample_rate_hz")
    if fs is None:
        raise ConfigError("--sample-rate-hz", "a design file needs a sample rate to be simulated (give "
                          "--sample-rate-hz or implementation.sample_rate_hz, or simulate an exported controller file)")
    cfg = design_at_rate(raw, fs, str(path))
    fs = float(cfg.implementation.sample_rate_hz)
    return build_export(cfg, fs, source=str(path))
