"""``run_scenario``: a scenario's runs and what they show (verdict, metrics, the scenario's own
measurements: windup recovery, limit cycle, the DOB's friction estimate)."""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Callable

import numpy as np

from ..controllerfile import ControllerFile, Runtime, as_controller_file
from ..errors import ConfigError
from ..numerics.timebudget import FIELD as TIME_FIELD, active_budget, check_time
from ..options import number_value
from ..units import fmt_num
from .engine import bumpless_start, check_start, simulate, strip_dob
from .load import check_human_inertia, schedule_entry
from .result import SimulationRun
from .scenarios import SCENARIOS, Nonlinearities, Scenario
from .verdict import (FIT_FRACTION, MARGINAL_TOL, MIN_PERIODS, LoopSpectrum, classify, dominant_frequency,
                      envelope_growth, judge, loop_spectrum)

__all__ = ["run_scenario", "check_run_options", "summarize", "scenario_runs", "check_budget", "MAX_SAMPLES",
           "BYTES_PER_SAMPLE"]

CHECK_EVERY = 4096  # samples of the DOB's replay between two looks at the time budget
LIMIT_CYCLE_NM = 1e-3  # a sustained spring-torque swing above this × max(|push|, 1 N·m) is a limit cycle


def _q(value, unit: str, **extra) -> dict:
    return {"value": value, "unit": unit, **extra}


def _judge(sim: dict, sc: Scenario, spectrum: LoopSpectrum | None) -> dict:
    """Verdict of a run from the envelopes of τ_s and τ_c: a live oscillation outranks one that died
    out (the latest death outranks earlier ones); then the faster-growing one decides. The
    envelope's verdict is then weighed against the linearized loop (:func:`~.verdict.judge`)."""
    s = sim["series"]
    lag = int(round(sim["sample_rate_hz"] / sc.push_hz)) if sc.push_hz > 0 else 1
    if s["t"].size < 2 * lag + 16:  # shorter than two push periods: the sample-to-sample change
        lag = 1
    best = None
    for key in ("tau_s", "tau_c"):
        g, died = envelope_growth(s["t"], s[key], lag=lag)
        rank = (died is None, -math.inf if died is None else died, -math.inf if g is None else g)
        if best is None or rank > best[0]:
            best = (rank, key, g, died)
    _, key, g, died = best
    envelope = classify(g, died, False)
    run_s = s["t"].size / sim["sample_rate_hz"]
    verdict, basis = judge(envelope, run_s, spectrum, died is not None, sim["diverged"] is not None)
    j = {"verdict": verdict, "basis": basis, "envelope": envelope, "growth": g, "died": died is not None,
         "died_at": died, "signal": key, "lag": lag}
    j["reason"] = _reason(j, sim, run_s, spectrum)
    return j


def _envelope_words(j: dict) -> str:
    """What the envelope shows, in words."""
    g, sig = j["growth"], j["signal"]
    if j["died"]:
        return f"the oscillation of {sig} decayed to rounding level at t = {j['died_at']:.4g} s"
    if g is None:
        return f"the envelope of {sig} could not be fitted"
    if j["envelope"] == "marginal":
        return f"the oscillation of {sig} is sustained (|{g:.4g}| ≤ {MARGINAL_TOL} 1/s)"
    return f"the oscillation of {sig} {'grows' if g > 0 else 'decays'} at {abs(g):.4g} 1/s"


def _reason(j: dict, sim: dict, run_s: float, sp: LoopSpectrum | None) -> str:
    """Why the run got its verdict, in words: which of the envelope and the eigenvalues decided,
    and the run length against the periods an envelope needs."""
    if j["basis"] == "stopped":
        return f"the run stopped: {sim['diverged']}"
    env = _envelope_words(j)
    needed = sp.needed_run_s if sp is not None else None
    periods = ("" if needed is None else f"{MIN_PERIODS:g} periods of the linearized loop's dominant oscillation at "
               f"{sp.oscillation_hz:.4g} Hz ({MIN_PERIODS:g} × {sp.oscillation_period_s:.4g} s = {needed:.4g} s)")
    short = needed is not None and run_s < needed and not j["died"]
    too_short = f"the run ({run_s:g} s, {sim['series']['t'].size} samples) is shorter than {periods}"
    if j["basis"] == "none":
        return (f"{too_short}: its envelope ({env}) cannot tell growth from decay; a run of at least "
                f"{needed:.4g} s can be judged")
    if j["basis"] == "spectral_radius":
        head = (f"the linearized loop's spectral radius {sp.spectral_radius:.6g} > 1 "
                f"(growth {sp.growth_rate_per_s:.4g} 1/s)")
        if short:
            return f"{head} decides: {too_short}, too short for its envelope ({env}) to be judged"
        return (f"{head} outranks the run's envelope ({env}): where they disagree the eigenvalue verdict wins, "
                "and a loop with an eigenvalue outside the unit circle is never judged decaying")
    return env + (f"; the run of {run_s:g} s lasts at least {periods}" if periods else "")


def _null_reason(j: dict, sim: dict, sp: LoopSpectrum | None) -> str:
    """Why the metrics of a growing or an inconclusive run are not measured (a steady value or a
    peak of such a run is an artefact of its duration)."""
    if sim["diverged"]:
        return sim["diverged"]
    if j["basis"] == "spectral_radius":
        return f"the linearized loop grows (spectral radius {sp.spectral_radius:.6g} > 1)"
    if j["verdict"] == "inconclusive":
        return "the run is too short to be judged (see verdict_reason); its values would be artefacts of its length"
    return _envelope_words(j)


def _tail(n: int) -> slice:
    return slice(int((1.0 - 0.2) * n), n)


def _metrics(sim: dict, sc: Scenario, alpha: float) -> dict:
    s = sim["series"]
    n = s["t"].size
    out = {}
    tail = _tail(n)
    if sc.locked and not math.isfinite(sc.release_at_s):  # (after a release τ_c → 0: see windup_recovery)
        tc = float(np.mean(s["tau_c"][tail]))
        ts = float(np.mean(s["tau_s"][tail]))
        ratio = (tc - ts) / tc if tc != 0 else None
        out["steady_cuff_torque"] = _q(tc, "N·m")
        out["steady_output_torque"] = _q(tc - ts, "N·m (τ_c − τ_s on the locked output)")
        out["delivered_amplification"] = _q(ratio, "1", design_alpha=alpha)
        out["amplification_error"] = _q((ratio - alpha) / alpha if ratio is not None else None, "1 (relative)")
    if not sc.locked and sc.push_nm == 0:
        w = s["theta_h"] - s["theta_j"]
        out["cuff_oscillation_start_rad"] = _q(float(np.max(np.abs(w[: max(1, n // 5)]))), "rad")
        out["cuff_oscillation_end_rad"] = _q(float(np.max(np.abs(w[tail] - np.mean(w[tail])))), "rad")
    out["peak_motor_torque"] = _q(float(np.max(np.abs(s["tau_m"]))), "N·m")
    out["peak_command"] = _q(float(np.max(np.abs(s["tau_cmd"]))), "N·m")
    return out


def summarize(sim: dict, sc: Scenario, alpha: float, rho: "float | LoopSpectrum | None") -> dict:
    """Summary of one run.

    Parameters
    ----------
    sim : dict
        A run (:func:`exotune.simulation.simulate`).
    sc : Scenario
        Its scenario.
    alpha : float
        The design's amplification α.
    rho : LoopSpectrum, float or None
        The linearized sampled-data loop (:func:`~.verdict.loop_spectrum`): its spectral radius
        is reported beside the verdict, and its dominant oscillation sets the run length an
        envelope needs; a bare ρ (float) gives no such length; None: not known.

    Returns
    -------
    dict
        Samples, duration, start, ``verdict`` (growing / decaying / marginal / inconclusive,
        :func:`~.verdict.judge`) with ``verdict_basis`` (``envelope``, ``spectral_radius``,
        ``stopped`` or ``none``) and ``verdict_reason`` (in words), its envelope growth rate, ρ
        and the dominant oscillation, ``diverged`` (verdict growing), ``stopped`` (why a run
        ended early) and the metrics — null, with ``metrics_null_reason``, for a growing or an
        inconclusive run (a steady value or a peak of such a run is an artefact of its duration).

    References
    ----------
    docs/cli.md#simulate.
    """
    s = sim["series"]
    n = s["t"].size
    fs = sim["sample_rate_hz"]
    sp = rho if isinstance(rho, LoopSpectrum) else (None if rho is None else LoopSpectrum(float(rho), fs))
    j = _judge(sim, sc, sp)
    out = {"samples": int(n), "duration_s": _q(float(n / fs), "s"), "start": sim["start"], "verdict": j["verdict"],
           "verdict_basis": j["basis"], "verdict_reason": j["reason"], "diverged": j["verdict"] == "growing",
           "envelope_growth_rate": _q(j["growth"], "1/s", signal=j["signal"], tolerance=MARGINAL_TOL,
                                      fitted_over=f"the last {FIT_FRACTION:.0%} of the run"
                                      + (f" (change over one push period, {j['lag'] / fs:g} s)" if j["lag"] > 1 else "")
                                      + (" (the oscillation decayed to rounding level)" if j["died"] else "")),
           "loop_spectral_radius": _q(None if sp is None else sp.spectral_radius, "1",
                                      growth_rate_per_s=None if sp is None else sp.growth_rate_per_s,
                                      dominant_oscillation_hz=None if sp is None else sp.oscillation_hz,
                                      dominant_oscillation_period_s=None if sp is None else sp.oscillation_period_s,
                                      note="linearized sampled-data loop (nonlinearities off); a run is judged from "
                                           f"its envelope over at least {MIN_PERIODS:g} periods of the dominant "
                                           "oscillation")}
    if sim["diverged"]:
        out["stopped"] = sim["diverged"]
    m = _metrics(sim, sc, alpha)
    if j["verdict"] in ("growing", "inconclusive"):
        m = {k: {**v, "value": None} for k, v in m.items()}
        out["metrics_null_reason"] = f"{j['verdict']} run: {_null_reason(j, sim, sp)}"
    out.update(m)
    return out


def _windup(sim: dict, sc: Scenario, alpha: float) -> dict:
    """Recovery after the push is released: how long the motor stays saturated, the peak command
    and the RMS amplification error (τ_c − τ_s) − α τ_c after the release."""
    s = sim["series"]
    t = s["t"]
    lim = sc.nonlinear.saturation_nm
    after = t >= sc.release_at_s
    sat = np.abs(s["tau_m"]) >= lim * (1 - 1e-12)
    idx = np.flatnonzero(sat & after)
    err = (s["tau_c"] - s["tau_s"]) - alpha * s["tau_c"]
    return {"peak_command": _q(float(np.max(np.abs(s["tau_cmd"]))), "N·m"),
            "saturated_after_release": _q(float(t[idx[-1]] - sc.release_at_s + 1.0 / sim["sample_rate_hz"])
                                          if idx.size else 0.0, "s"),
            "rms_amplification_error_after_release": _q(float(np.sqrt(np.mean(err[after] ** 2))) if after.any()
                                                        else None, "N·m ((τ_c − τ_s) − α τ_c)")}


def _limit_cycle(sim: dict, sc: Scenario, verdict: str, linear: dict) -> dict:
    """A limit cycle: a sustained oscillation (marginal verdict) of the spring torque above
    ``LIMIT_CYCLE_NM`` × max(|push|, 1 N·m) peak to peak that crosses the dead zone (τ_s = 0 or a
    sign change in the last half of the run: the backlash takes part); its frequency is the
    spectral peak of τ_s. ``linear``: the summary of the same run without backlash."""
    s = sim["series"]
    n = s["t"].size
    part = slice(int((1 - FIT_FRACTION) * n), n)
    ts = s["tau_s"][part]
    swing = float(np.ptp(ts)) if ts.size else 0.0
    crosses = bool(ts.size and (np.any(ts == 0.0) or np.any(np.signbit(ts[1:]) != np.signbit(ts[:-1]))))
    present = verdict == "marginal" and crosses and swing > LIMIT_CYCLE_NM * max(abs(sc.push_nm), 1.0)
    return {"present": None if verdict in ("growing", "inconclusive") else bool(present),
            "frequency": _q(dominant_frequency(s["t"][part], ts) if present else None, "Hz"),
            "spring_torque_swing": _q(swing, "N·m peak to peak, last half of the run"),
            "crosses_dead_zone": crosses,
            "without_backlash": {"verdict": linear["verdict"], "envelope_growth_rate": linear["envelope_growth_rate"]},
            "rule": f"sustained (|growth| ≤ {MARGINAL_TOL} 1/s), crossing the dead zone, and a spring-torque swing "
                    f"above {LIMIT_CYCLE_NM:g} × max(|push|, 1 N·m)"}


def dob_estimate(doc: ControllerFile, sim: dict) -> np.ndarray | None:
    """The DOB's friction estimate per sample (the sum of its filters' outputs, which the runtime
    adds to its command), replayed from the run's signals with the runtime's filters."""
    names = set((doc.dob.filters if doc.dob is not None else None) or [])
    if not names:
        return None
    s = sim["series"]
    rt = Runtime(doc)
    if sim["start"].startswith("bumpless"):
        bumpless_start(rt, {k: float(s[k][0]) for k in ("theta_m", "omega_m", "tau_s", "dtau_s", "tau_c")})
    fl = doc.controller.filters
    sensed = [f.name for f in fl if f.input != "tau_cmd"]
    loop = [f.name for f in fl if f.input == "tau_cmd"]
    used = [(s[inp], filt) for name, (inp, filt) in zip(sensed, rt.filters) if name in names]
    used += [(s["tau_cmd"], filt) for name, filt in zip(loop, rt.loop) if name in names]
    est = np.zeros(s["t"].size)
    for k in range(est.size):
        if k % CHECK_EVERY == 0:
            check_time()
        est[k] = sum(filt.step(float(sig[k])) for sig, filt in used)
    return est


BYTES_PER_SAMPLE = 144  # peak memory [B] per sample of each run (measured ≤ 130: 12 float64 series, temporaries)
MAX_SAMPLES = 6_000_000  # per scenario, all its runs together: 144 B × 6e6 ≈ 0.86 GB at most, refused beyond
MIN_SAMPLES = 16  # per run: the envelope's growth rate needs 9 samples at least (envelope_growth)


def scenario_runs(doc: ControllerFile | dict, sc: Scenario) -> tuple[str, ...]:
    """The runs :func:`run_scenario` makes for the scenario ``sc`` with the controller file
    ``doc``, by name, in the order it makes them (each a whole run of the scenario's duration).

    Parameters
    ----------
    doc : ControllerFile or dict
        A validated controller file (whether it has a DOB decides the DOB comparisons).
    sc : Scenario
        The scenario.

    Returns
    -------
    tuple of str
        ``controller``; ``without_clamp`` (a motor limit and a release: windup recovery),
        ``without_backlash`` (backlash: the limit-cycle comparison), ``frictionless``,
        ``without_dob`` and ``frictionless_without_dob`` (a scenario comparing the joint with
        and without the DOB, for a file with DOB filters; the last one records the joint angle
        only).

    Examples
    --------
    >>> from exotune.simulation import SCENARIOS, load_for_simulation
    >>> doc = load_for_simulation("examples/scheduled.yaml")
    >>> scenario_runs(doc, SCENARIOS["saturation"]), len(scenario_runs(doc, SCENARIOS["dob-friction"]))
    (('controller', 'without_clamp'), 4)
    """
    nl = sc.nonlinear
    runs = ["controller"]
    if math.isfinite(nl.saturation_nm) and math.isfinite(sc.release_at_s):
        runs.append("without_clamp")
    if nl.backlash_rad > 0:
        runs.append("without_backlash")
    doc = as_controller_file(doc)
    if sc.compare_without_dob and doc.dob is not None and doc.dob.filters:
        runs += ["frictionless", "without_dob", "frictionless_without_dob"]
    return tuple(runs)


def check_budget(sample_rate_hz: float, duration_s: float, runs: int = 1, scenario: str | None = None) -> None:
    """Refuse, before anything runs, a scenario whose runs together exceed :data:`MAX_SAMPLES`
    samples (their time series would take more than about
    :data:`BYTES_PER_SAMPLE` × :data:`MAX_SAMPLES` bytes; docs/cli.md#simulate), or a run shorter
    than :data:`MIN_SAMPLES` (too short for a verdict: its envelope cannot be fitted, and
    "marginal" would be a claim the run does not support). The samples are counted as a run
    counts them (duration × rate, rounded); the message gives the counts exactly, the scenario's
    runs, and the longest duration accepted at that rate.

    Parameters
    ----------
    sample_rate_hz : float
        The runs' sample rate [Hz].
    duration_s : float
        The length of each run [s].
    runs : int, optional
        How many runs of that length the scenario makes (:func:`scenario_runs`).
    scenario : str, optional
        The scenario's name, for the message.

    Raises
    ------
    exotune.errors.ConfigError
        On ``duration``, when the runs are too long or a run too short.

    Examples
    --------
    >>> check_budget(1000.0, 6.0, runs=4, scenario="dob-friction")
    >>> check_budget(1000.0, 1501.0, runs=4, scenario="dob-friction")
    Traceback (most recent call last):
    ...
    exotune.errors.ConfigError: duration: 1501 s at 1000 Hz is 1501000 samples per run; scenario dob-friction makes 4 runs, 6004000 samples in all, over the limit of 6000000 samples per scenario (at most 1500 s at 1000 Hz for its 4 runs; shorten `duration` or lower the rate)
    >>> check_budget(1000.0, 0.005)
    Traceback (most recent call last):
    ...
    exotune.errors.ConfigError: duration: 0.005 s at 1000 Hz is 5 samples; a verdict needs a run of at least 16 samples (0.016 s at this rate)
    """
    n = sample_rate_hz * duration_s
    if n < MIN_SAMPLES and round(n) < MIN_SAMPLES:  # the run's own count, as below (0.0159999 s at 1 kHz: 16)
        raise ConfigError("duration", f"{fmt_num(duration_s)} s at {fmt_num(sample_rate_hz)} Hz is {round(n)} samples; "
                                      f"a verdict needs a run of at least {MIN_SAMPLES} samples "
                                      f"({fmt_num(MIN_SAMPLES / sample_rate_hz)} s at this rate)")
    runs = max(1, int(runs))
    if not (math.isfinite(n) and round(n) * runs <= MAX_SAMPLES):  # the runs' own count: round(duration × rate)
        exact = n < 1e15  # a float counts exactly here: no 300-digit integer beyond
        count = f"{round(n)}" if exact else f"about {fmt_num(n, 3)}"
        total = f"{round(n) * runs}" if exact else f"about {fmt_num(n * runs, 3)}"
        name = f"scenario {scenario}" if scenario else "the scenario"
        longest = fmt_num((MAX_SAMPLES // runs) / sample_rate_hz)
        raise ConfigError("duration", f"{fmt_num(duration_s)} s at {fmt_num(sample_rate_hz)} Hz is {count} samples per "
                                      f"run; {name} makes {runs} run{'s' if runs > 1 else ''}, {total} samples in "
                                      f"all, over the limit of {MAX_SAMPLES} samples per scenario (at most {longest} s "
                                      f"at {fmt_num(sample_rate_hz)} Hz for its {runs} run{'s' if runs > 1 else ''}; "
                                      "shorten `duration` or lower the rate)")


def check_run_options(name, start: str = "bumpless", human_inertia: float | None = None,
                      duration_s: float | None = None) -> tuple[Scenario, float | None, float | None]:
    """The options of :func:`run_scenario` checked before any work, each refused naming its
    keyword (``scenario``, ``start``, ``human_inertia``, ``duration``; the command line names
    ``--scenario``, …). Numbers must be numbers (a bool or a string is refused).

    Parameters
    ----------
    name : str or Scenario
        A key of :data:`SCENARIOS` or a :class:`Scenario`.
    start : str, optional
        Initial controller state (:func:`~exotune.simulation.engine.check_start`).
    human_inertia : float, optional
        Human inertia [kg·m²] (:func:`~exotune.simulation.load.check_human_inertia`).
    duration_s : float, optional
        Run length [s], > 0.

    Returns
    -------
    tuple
        The scenario, the human inertia and the run length (floats or None).

    Raises
    ------
    exotune.errors.ConfigError
        The first bad option.

    Examples
    --------
    >>> check_run_options("locked-output", duration_s=2)[0].name, check_run_options("backlash", duration_s=2)[2]
    ('locked-output', 2.0)
    """
    if isinstance(name, Scenario):
        sc = name
    elif isinstance(name, str) and name in SCENARIOS:
        sc = SCENARIOS[name]
    else:
        raise ConfigError("scenario", f"unknown scenario {name!r} (known: {', '.join(SCENARIOS)})")
    check_start(start)
    human_inertia = check_human_inertia(human_inertia)
    if duration_s is not None:
        duration_s = number_value("duration", duration_s, positive=True, noun="a number of seconds", strings=False)
    return sc, human_inertia, duration_s


def run_scenario(doc: ControllerFile | dict, name: "str | Scenario", human_inertia: float | None = None,
                 duration_s: float | None = None, start: str = "bumpless",
                 progress: Callable[[float], None] | None = None, joint_angle: float | None = None) -> SimulationRun:
    """Run a scenario and summarize it.

    Parameters
    ----------
    doc : ControllerFile or dict
        A validated controller file.
    name : str or Scenario
        A key of :data:`SCENARIOS` or a :class:`Scenario`.
    human_inertia : float, optional
        Human inertia [kg·m²] instead of the scenario's.
    duration_s : float, optional
        Run length [s] instead of the scenario's.
    start : {"bumpless", "zero"}
        Initial controller state.
    progress : callable, optional
        Called with the completed fraction of the main run.
    joint_angle : float, optional
        Run the gain-schedule entry :func:`~.load.schedule_entry` picks at this joint angle [rad]
        (the nearest; an angle beyond the schedule's is refused) instead of the nominal controller.

    Returns
    -------
    SimulationRun
        ``to_dict()``: ``scenario``, ``description``, ``human``, ``nonlinearities``,
        ``sample_rate_hz``, ``delay_samples``, ``gain_schedule_entry`` (with ``joint_angle``: the
        angle asked for, the entry's angle and ratio), ``summary`` and the scenario's measurements
        (``windup_recovery``, ``limit_cycle``, ``friction_estimate``, ``friction_sensitivity``);
        ``runs``: the time series, keyed ``controller``, ``without_clamp``, ``without_backlash``,
        ``frictionless``, ``without_dob`` (the runs of :func:`scenario_runs` but the last
        frictionless one, which is used for its joint angle only).

    Raises
    ------
    exotune.errors.ConfigError
        A bad option (:func:`check_run_options`), runs too long together or a run too short
        (``duration``, :func:`check_budget`: decided before any run starts), a joint angle the
        file's gain schedule does not cover (``joint_angle``), or a spent time budget
        (``time_budget_s``, within :func:`exotune.numerics.timebudget.time_budget`: the message
        adds the runs finished and where the current one stopped).

    References
    ----------
    Paper §V (the hardware experiments these scenarios reproduce in time-domain simulation);
    docs/cli.md#simulate.
    """
    sc, human_inertia, duration_s = check_run_options(name, start, human_inertia, duration_s)
    entry = None
    if joint_angle is not None:
        entry = schedule_entry(doc, joint_angle)
        doc = as_controller_file(doc).entry_view(entry)
    if human_inertia is not None:
        sc = replace(sc, human={**sc.human, "inertia": human_inertia})
    if duration_s is not None:
        sc = replace(sc, duration_s=duration_s)
    doc = as_controller_file(doc)
    plan = scenario_runs(doc, sc)
    check_budget(float(doc.sample_rate_hz), sc.duration_s, len(plan), sc.name)  # all its runs, before any
    runs = _Runs(doc, sc, start, plan, progress)
    try:
        rep = _report(doc, sc, runs)
    except ConfigError as e:
        if e.field != TIME_FIELD:
            raise
        raise ConfigError(e.field, runs.stopped(e.reason)) from None
    if entry is not None:
        rep["gain_schedule_entry"] = {
            "joint_angle_requested": _q(float(joint_angle), "rad"),
            "joint_angle": _q(float(entry.joint_angle_rad), "rad"), "ratio": _q(float(entry.ratio), "1"),
            "note": "the entry nearest the requested angle, as the runtime picks it: its plant and controller, "
                    "frozen at the entry's angle"}
    return SimulationRun.from_report(rep)


class _Runs:
    """The runs of one scenario (:func:`scenario_runs`), made one after the other: what has been
    done, for the message of a spent time budget."""

    def __init__(self, doc: ControllerFile, sc: Scenario, start: str, plan: tuple, progress):
        self.doc, self.sc, self.start, self.plan, self.progress = doc, sc, start, plan, progress
        self.done, self.current, self.fraction = 0, None, 0.0

    def run(self, label: str, sc: Scenario | None = None, **options) -> dict:
        """The run ``label`` of the plan (``sc``: the scenario changed for it; ``options``:
        :func:`~.engine.simulate`'s)."""
        self.current, self.fraction = label, 0.0
        user = self.progress if label == "controller" else None

        def progress(frac):
            self.fraction = frac
            if user is not None:
                user(frac)

        sim = simulate(self.doc, self.sc if sc is None else sc, start=self.start, progress=progress, **options)
        self.done, self.current = self.done + 1, None
        return sim

    def stopped(self, reason: str) -> str:
        """``reason`` (a spent time budget) with what was done: the runs finished, where the
        current one stopped."""
        budget = active_budget()
        tail = budget[3] if budget is not None else ""
        head = reason[: len(reason) - len(tail)] if tail and reason.endswith(tail) else reason
        where = (f" and stopped the run {self.current} at t = {self.fraction * self.sc.duration_s:.4g} s of "
                 f"{self.sc.duration_s:.6g} s" if self.current is not None else "")
        total = f"{len(self.plan)} run{'s' if len(self.plan) > 1 else ''}"
        return (f"{head}; it had finished {self.done} of the {total} of scenario {self.sc.name} "
                f"({', '.join(self.plan)}){where}{tail}")


def _report(doc: ControllerFile, sc: Scenario, runs: _Runs) -> dict:
    """The report of the scenario ``sc``: its runs (``runs``), their summaries and its own measurements."""
    alpha = float(doc.design.amplification)
    sim = runs.run("controller")
    rho = loop_spectrum(doc, sc.human, sc.locked)
    nl = sc.nonlinear
    rep = {"scenario": sc.name, "description": sc.description, "human": sc.human,
           "nonlinearities": {"coulomb_nm": nl.coulomb_nm, "backlash_rad": nl.backlash_rad,
                              "saturation_nm": nl.saturation_nm,
                              "units": {"coulomb_nm": "N·m", "backlash_rad": "rad", "saturation_nm": "N·m"}},
           "sample_rate_hz": sim["sample_rate_hz"], "delay_samples": sim["delay_samples"], "design_alpha": alpha}
    rep.update(summary=summarize(sim, sc, alpha, rho), runs={"controller": sim})
    verdict = rep["summary"]["verdict"]
    if "without_clamp" in runs.plan:
        free = runs.run("without_clamp", clamp=False)
        rep["runs"]["without_clamp"] = free
        rep["windup_recovery"] = {"release_at": _q(sc.release_at_s, "s"), "with_clamp": _windup(sim, sc, alpha),
                                  "without_clamp": _windup(free, sc, alpha)}
    if "without_backlash" in runs.plan:
        lin = runs.run("without_backlash", replace(sc, nonlinear=replace(nl, backlash_rad=0.0)))
        rep["runs"]["without_backlash"] = lin
        rep["limit_cycle"] = _limit_cycle(sim, sc, verdict, summarize(lin, sc, alpha, rho))
    if nl.coulomb_nm > 0:
        est = dob_estimate(doc, sim)
        if est is not None:
            sim["series"]["friction_estimate"] = est
            fr = sim["series"]["friction"]
            rms = float(np.sqrt(np.mean(fr ** 2)))
            e = float(np.sqrt(np.mean((est - fr) ** 2)))
            rep["friction_estimate"] = {"rms_friction": _q(rms, "N·m"), "rms_error": _q(e, "N·m"),
                                        "relative_error": _q(e / rms if rms > 0 else None, "1"),
                                        "note": "the DOB's estimate (the sum of its filters' outputs) against the "
                                                "true friction F_c·tanh(θ̇_m/ε)"}
    if "without_dob" in runs.plan:
        _friction_sensitivity(doc, sc, sim, rep, alpha, runs)
    return rep


def _friction_sensitivity(doc, sc, sim, rep, alpha, runs: _Runs) -> None:
    """The joint trajectory with friction against the same controller's frictionless one, with
    the file's controller (DOB) and with its DOB filters removed."""
    clean = replace(sc, nonlinear=Nonlinearities())
    sens = {}
    for label, wo in (("with_dob", False), ("without_dob", True)):
        fr = sim if not wo else runs.run("without_dob", without_dob=True)
        # the frictionless run without the DOB is kept for its joint angle only
        ref = runs.run("frictionless" + ("_without_dob" if wo else ""), clean, without_dob=wo,
                       series=("t", "theta_j") if wo else None)
        a, b = fr["series"]["theta_j"], ref["series"]["theta_j"]
        m = min(a.size, b.size)
        sens[label] = _q(float(np.sqrt(np.mean((a[:m] - b[:m]) ** 2)) / max(np.sqrt(np.mean(b[:m] ** 2)), 1e-300)),
                         "1 (RMS joint-angle change due to friction / RMS joint angle)")
        if wo:
            rho = loop_spectrum(strip_dob(doc), sc.human, sc.locked)
            rep["summary_without_dob"] = summarize(fr, sc, alpha, rho)
            rep["runs"]["without_dob"] = fr
        else:
            rep["runs"]["frictionless"] = ref
    rep["friction_sensitivity"] = sens
