"""Latency margin (docs/method.md#latency-margin), checked three independent ways:

1. closed form: Δ(s) = s + a + k e^{−sτ} loses stability at τ* = (π − atan(ω/a))/ω with
   ω = √(k² − a²) (the classic first-order delay loop), for any nominal delay below τ*;
2. the exact argument-principle verdicts of the analysis at T + ΔT(1 ∓ 10⁻⁶) — the margin is the
   first delay at which a verdict changes;
3. closed-loop eigenvalues of the independent state-space reference (tests/reference_model.py,
   Padé delay) of the critical family member, just below and above the margin.
"""

from __future__ import annotations

import copy
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from exotune.analysis.latency import family_latency_margin, qp_latency_margin
from exotune.analysis.latency_margin import latency_margin
from exotune.analysis import analyze_batch
from exotune.config import batch_config, design_from_mapping, read_yaml

from reference_model import coupled_verdict, reference_gains, reference_gc

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
PAPER_MAP = read_yaml(EXAMPLES / "paper.yaml")


def _first_order_margin(a: float, k: float, T: float) -> float:
    w = math.sqrt(k * k - a * a)
    return (math.pi - math.atan2(w, a)) / w - T


# ---------------------------------------------------------------------------------------------
# 1. closed form
# ---------------------------------------------------------------------------------------------
@settings(deadline=None, max_examples=60)
@given(a=st.floats(0.1, 100.0), ratio=st.floats(1.05, 50.0), frac=st.floats(0.0, 0.9))
def test_first_order_loop_closed_form(a, ratio, frac):
    k = a * ratio
    tau_star = _first_order_margin(a, k, 0.0)
    T = frac * tau_star
    dT, w = qp_latency_margin(np.array([a, 1.0]), np.array([k]), T)
    assert dT == pytest.approx(tau_star - T, rel=1e-9, abs=1e-12 * tau_star)
    assert w == pytest.approx(math.sqrt(k * k - a * a), rel=1e-9)


def test_no_crossing_means_infinite_margin():
    # |k| < a: |P0(jω)| = |jω + a| > |k| for every ω, no delay destabilizes (delay-independent stability)
    dT, w = qp_latency_margin(np.array([2.0, 1.0]), np.array([1.5]), 0.01)
    assert dT == math.inf and w is None


@settings(deadline=None, max_examples=25)
@given(a=st.floats(0.5, 20.0), k_lo=st.floats(1.05, 3.0), span=st.floats(1.0, 20.0), frac=st.floats(0.0, 0.5))
def test_family_margin_is_the_dense_member_minimum(a, k_lo, span, frac):
    """Family Δ = (s + a) + p e^{−sτ}, p ∈ [a·k_lo, a·k_lo·span]: the family margin equals the
    minimum of the members' closed-form margins (the largest p is critical), never above it."""
    lo, hi = a * k_lo, a * k_lo * span
    T = frac * _first_order_margin(a, hi, 0.0)
    dT, w, p = family_latency_margin([a, 1.0], [0.0], [0.0], [1.0], lo, hi, T, wmax=10 * hi)
    dense = min(_first_order_margin(a, q, T) for q in np.geomspace(lo, hi, 2001))
    assert dT <= dense * (1 + 1e-9)
    assert dT == pytest.approx(dense, rel=1e-6)
    assert p == pytest.approx(hi, rel=1e-6)


# ---------------------------------------------------------------------------------------------
# 2./3. a design: the analysis verdicts and the reference eigenvalues
# ---------------------------------------------------------------------------------------------
def _robust_mapping() -> dict:
    """The paper's hardware with a mass range the design is robust over (the paper example's
    lightest inertias are not, so its margin is 0)."""
    m = copy.deepcopy(PAPER_MAP)
    m["humans"] = [{"kind": "mass", "inertia": [0.01, 1.0], "damping": 0.0},
                   {"kind": "spring", "stiffness": [1.0, 10000.0], "damping": 0.0}]
    return m


@pytest.fixture(scope="module")
def robust_margin():
    cfg = design_from_mapping(_robust_mapping())
    return cfg, latency_margin(cfg)


def _all_ok(cols: dict, t: int) -> bool:
    keys = [k for k in cols if k == "free_stable" or (k.startswith(("human", "env")) and k.endswith(("_robust", "_stable")))]
    return all(bool(np.asarray(cols[k])[t]) for k in keys)


def test_design_margin_is_where_the_exact_verdicts_change(robust_margin):
    cfg, m = robust_margin
    assert 0 < m.extra_delay_s < math.inf and m.verified is True
    T = cfg.implementation.delay_s
    assert m.delay_s == T
    cols = analyze_batch(batch_config(cfg, {"implementation.delay_s": np.array(
        [T, T + m.extra_delay_s * (1 - 1e-6), T + m.extra_delay_s * (1 + 1e-6)])})).to_columns()
    assert [_all_ok(cols, t) for t in range(3)] == [True, True, False]
    # the design margin is its loops' minimum, the critical loop among them
    assert m.extra_delay_s == min(lp.extra_delay_s for lp in m.loops)
    assert m.critical in m.loops
    d = m.to_dict()
    assert d["units"]["extra_delay_s"] == "s" and d["extra_delay_s"] == m.extra_delay_s


def test_design_margin_against_reference_eigenvalues(robust_margin):
    """The critical member of the critical family (from the margin) is stable just below the
    margin and unstable just above it for the independent state-space model (Padé 12)."""
    cfg, m = robust_margin
    c = m.critical
    assert c.loop.startswith("human0_mass") and c.parameter == "inertia" and c.unit == "kg·m²"
    mp = _robust_mapping()
    p = mp["plant"]
    plant = dict(J_m=p["motor_inertia"], B_m=p["motor_damping"], K_s=p["sea_stiffness"], J_j=p["joint_inertia"],
                 K_c=p["cuff_stiffness"])
    im = mp["implementation"]
    gains = reference_gains(plant, mp["design"])
    gains["Gc"] = reference_gc(plant, mp["design"], im["gv_filter"], im["derivative_filter"])
    human = {"kind": "mass", "inertia": c.value, "damping": 0.0}
    T = float(im["delay_s"])
    below = coupled_verdict(plant, gains, {"T": T + m.extra_delay_s * (1 - 1e-3), "dob": im["dob"]}, human, pade_order=12)
    above = coupled_verdict(plant, gains, {"T": T + m.extra_delay_s * (1 + 1e-3), "dob": im["dob"]}, human, pade_order=12)
    assert below[0] is True and above[0] is False


def test_not_robust_at_nominal_delay_gives_zero():
    cfg = design_from_mapping(PAPER_MAP)  # the paper example: lightest inertias unstable
    m = latency_margin(cfg)
    assert m.extra_delay_s == 0.0
    assert m.critical is not None and m.critical.loop.startswith("human0_mass")
    assert "nominal" in m.note


def test_margin_in_samples_when_a_rate_is_set():
    mp = _robust_mapping()
    mp["implementation"]["sample_rate_hz"] = 1000.0
    cfg = design_from_mapping(mp)
    m = latency_margin(cfg, verify=False)
    assert m.sample_rate_hz == 1000.0
    assert m.extra_delay_samples == pytest.approx(m.extra_delay_s * 1000.0, rel=1e-15)


# ---------------------------------------------------------------------------------------------
# the design file's `uncertainty` section and the analyze report
# ---------------------------------------------------------------------------------------------
def test_uncertainty_section_gives_the_weights():
    from exotune.errors import ConfigError

    mp = _robust_mapping()
    assert design_from_mapping(mp).uncertainty is None  # absent: weight 1 each
    mp["uncertainty"] = {"motor_inertia": 0.1, "cuff_stiffness": 0.2}
    cfg = design_from_mapping(mp)
    assert cfg.uncertainty == {"motor_inertia": 0.1, "motor_damping": 0.0, "sea_stiffness": 0.0,
                               "joint_inertia": 0.0, "cuff_stiffness": 0.2}  # left out: certain
    for bad, field in (({"sea_stiffness": 1.5}, "uncertainty.sea_stiffness"), ({"motor_inertia": -0.1}, "uncertainty.motor_inertia"),
                       ({"motor_inertia": 0.0}, "uncertainty"), ({"motor_inertai": 0.1}, "uncertainty.motor_inertai")):
        mp["uncertainty"] = bad
        with pytest.raises(ConfigError) as e:
            design_from_mapping(mp)
        assert str(e.value).startswith(field)


def test_analyze_reports_both_margins_with_units():
    from exotune.analysis import analyze_with_margins

    mp = _robust_mapping()
    mp["uncertainty"] = {"motor_inertia": 0.1, "motor_damping": 0.3, "sea_stiffness": 0.05, "cuff_stiffness": 0.2}
    rec = analyze_with_margins(design_from_mapping(mp)).to_dict()
    assert list(rec)[0] == "margins"
    lat, pm = rec["margins"]["latency"], rec["margins"]["plant_uncertainty"]
    assert lat["units"]["extra_delay_s"] == "s" and lat["extra_delay_s"] > 0
    assert pm["weights"] == {"J_m": 0.1, "B_m": 0.3, "K_s": 0.05, "J_j": 0.0, "K_c": 0.2}
    assert 0 < pm["lower"] <= pm["upper"] <= pm["lower"] * 1.02
    w = pm["witness"]
    assert w["confirmed"] is True and w["rightmost_root"]["re"] > 0
    # the witness deviates only the uncertain parameters, by at most k·w each
    for sym, dev in w["deviations"].items():
        assert abs(dev) <= w["k"] * pm["weights"][sym] * (1 + 1e-9)


def test_latency_boundaries_agree_with_the_margin(robust_margin):
    """The boundary curves of `analyze --plots` (members' own margins) never dip below the design
    margin, and touch it at the critical member (an end of the critical family here)."""
    from matplotlib.figure import Figure

    from exotune.analysis.latency_margin import latency_boundaries
    from exotune.plots.margins import latency_boundary_figure

    cfg, m = robust_margin
    bs = latency_boundaries(cfg, n=40)
    assert [b.loop for b in bs] == ["human0_mass", "human1_spring"]
    for b in bs:
        assert np.all(np.isfinite(b.extra_delay_s))  # robust: every member stable at T
        assert b.extra_delay_s.min() >= m.extra_delay_s * (1 - 1e-9)
    crit = next(b for b in bs if b.loop == m.critical.loop)
    i = int(np.argmin(np.abs(np.log(crit.values / m.critical.value))))
    assert crit.extra_delay_s[i] == pytest.approx(m.extra_delay_s, rel=1e-6)
    fig = latency_boundary_figure(bs, m.extra_delay_s)
    assert isinstance(fig, Figure) and len(fig.axes[0].lines) == 3


def test_latency_boundaries_mark_members_unstable_at_nominal():
    from exotune.analysis.latency_margin import latency_boundaries

    b = latency_boundaries(design_from_mapping(PAPER_MAP), n=30)[0]  # the paper's light masses
    bad = np.isnan(b.extra_delay_s)
    assert bad.any() and not bad.all()
    assert b.values[bad].max() < b.values[~bad].min()  # the unstable members are the lightest


def test_margin_at_a_high_rate_probes_delays_beyond_the_sampled_model():
    """At 100 kHz, T + ΔT is over 200 samples (the sampled model's delay-state limit): the
    margin is a continuous-time quantity and is computed as such (it used to fail the export)."""
    mp = _robust_mapping()
    mp["implementation"]["sample_rate_hz"] = 100_000.0
    m = latency_margin(design_from_mapping(mp))
    ref = latency_margin(design_from_mapping(_robust_mapping()))
    assert m.verified is True and m.extra_delay_s == pytest.approx(ref.extra_delay_s, rel=1e-9)
    assert m.extra_delay_samples == pytest.approx(m.extra_delay_s * 1e5, rel=1e-12)


def test_margins_are_typed_results_with_their_views():
    """LatencyMargin and PlantMargin are Result types: to_dict/to_json with units, to_text the
    lines of analyze's margins section (str() is the text)."""
    import json

    from exotune.analysis import LatencyMargin, PlantMargin, analyze_with_margins
    from exotune.record import Result

    from exotune.config import load_design

    rec = analyze_with_margins(load_design(EXAMPLES / "scheduled.yaml"), sampled_check=False)
    lm, pm = rec.margins
    assert isinstance(lm, LatencyMargin) and isinstance(pm, PlantMargin)
    assert isinstance(lm, Result) and isinstance(pm, Result)
    assert json.loads(lm.to_json())["extra_delay_s"] == pytest.approx(lm.extra_delay_s)
    assert json.loads(pm.to_json())["units"]["lower"].startswith("1")
    text = str(lm)
    assert text.startswith("Margins:") and "latency margin:" in text and " ms" in text
    assert "plant-uncertainty margin:" in str(pm)


def test_an_infinite_margin_is_checked_by_exact_verdicts_at_extra_delays():
    """A stiff human (1e-9 kg·m², 100 N·m·s/rad: a pole near 1e11 rad/s) hid every crossing from the
    search: "latency margin ∞" was printed for a design unstable at 5 ms of extra delay (free loop
    included, whose margin is 3.85 ms without that human). The infinite claim is now checked at
    extra delays: the margin is unknown (NaN, not verified), never infinite."""
    import math

    import yaml

    from exotune.analysis.latency_margin import latency_margin
    from exotune.config import design_from_mapping

    doc = yaml.safe_load((EXAMPLES / "paper.yaml").read_text())
    doc["humans"][0] = {"kind": "mass", "inertia": 1e-9, "damping": 100.0}
    res = latency_margin(design_from_mapping(doc))
    assert math.isnan(res.extra_delay_s) and res.verified is False and res.critical is None
    assert all(not math.isinf(lp.extra_delay_s) for lp in res.loops)
    assert "the margin is unknown" in res.note
    assert "unknown" in res.to_text()
    doc["implementation"]["delay_s"] = 0.006  # the exact verdict the probes rely on
    from exotune.analysis.batch import analyze_batch

    assert not analyze_batch(design_from_mapping(doc)).loops_ok()[0]


def test_the_sweep_column_checks_an_infinite_margin_too():
    """The same stiff human in a sweep's batch: the `latency_margin_s` column said ∞ for designs a
    few ms of extra delay destabilizes (its batch path had no confirmation). Infinite rows are now
    checked at the same extra delays: unknown (NaN); finite rows are untouched (a batch with the
    paper's human: the column equals the single-design engine's margins)."""
    import yaml

    from exotune.analysis.batch import analyze_batch
    from exotune.config import design_from_mapping

    doc = yaml.safe_load((EXAMPLES / "paper.yaml").read_text())
    doc["humans"][0] = {"kind": "mass", "inertia": 1e-9, "damping": 100.0}
    alphas = np.array([8.0, 4.0, 2.0])
    with np.errstate(all="ignore"):
        res = analyze_batch(batch_config(design_from_mapping(doc), {"design.amplification": alphas}), latency=True)
        assert np.all(res.loops_ok()) and np.all(np.isnan(res.latency_margin_s))
        # the exact verdict behind it: unstable at 6 ms of total delay, for each design
        doc["implementation"]["delay_s"] = 0.006
        later = analyze_batch(batch_config(design_from_mapping(doc), {"design.amplification": alphas}))
    assert not np.any(later.loops_ok())


def test_a_margin_beyond_the_accepted_delays_is_reported_unverified():
    """A design whose free loop tolerates ~2.5 s of extra delay (a 0.13 Hz crossing): the check of
    the margin by exact verdicts at T + ΔT(1 ∓ 10⁻⁶) asked for a 2.5 s delay, beyond the 1 s a
    design accepts, and `analyze` refused the valid design with a range error on
    implementation.delay_s. The margin is now reported, not verified, and the exact verdicts at
    every accepted delay up to 1 s agree that it exceeds them."""
    raw = copy.deepcopy(PAPER_MAP)
    raw["design"].update(amplification=13.00863876773165, felt_damping=0.05247264369604607,
                         felt_inertia=0.07068107898350512, zeta=0.47554670183811043, zeta_hat=0.44853183623891585)
    raw["implementation"].update(delay_s=0.0, derivative_filter={"cutoff_hz": 34.47394369501197},
                                 dob={"cutoff_hz": 16.436125728899455, "damping": 0.4438678071420012},
                                 gv_filter={"cutoff_hz": 432.815549002881, "damping": 0.48285863902734716})
    raw["plant"].update(cuff_stiffness=134.19823653075375, joint_inertia=0.4844523807437293,
                        motor_damping=27.991568014983187, motor_inertia=0.22860956541261207,
                        sea_stiffness=659.0728022511133)
    raw["humans"], raw["environment"] = [], []
    cfg = design_from_mapping(raw)
    m = latency_margin(cfg)
    assert m.extra_delay_s > 1.0 and math.isfinite(m.extra_delay_s)
    assert m.verified is None and "not verified" in m.note
    assert m.critical.loop == "free"
    delays = np.array([0.01, 0.1, 0.3, 0.6, 1.0])
    with np.errstate(all="ignore"):
        cols = analyze_batch(batch_config(cfg, {"implementation.delay_s": delays}))
    assert bool(np.all(cols.loops_ok()))


def test_gain_schedule_entries_searched_as_one_batch_equal_each_entry_alone():
    """schedule_latency_margin runs the crossing search of all entries as one batch; every entry's
    margin (value, critical loop and member, every loop's margin, verification) is the one of the
    entry's design analysed alone."""
    import dataclasses

    import exotune
    from exotune.analysis.latency_margin import schedule_latency_margin

    cfg = exotune.load_design(EXAMPLES / "scheduled.yaml")
    ratios = [float(r) for r in cfg.raw["transmission"]["ratio"]]
    assert len(ratios) > 2
    _, entries = schedule_latency_margin(cfg, latency_margin(cfg))
    assert len(entries) == len(ratios)
    for r, got in zip(ratios, entries):
        alone = latency_margin(dataclasses.replace(cfg, plant=cfg.plant.reflected(r)))
        assert got.verified == alone.verified and got.note == alone.note
        assert got.critical.loop == alone.critical.loop
        assert got.extra_delay_s == pytest.approx(alone.extra_delay_s, rel=1e-12)
        for a, b in zip(got.loops, alone.loops):
            assert a.loop == b.loop
            assert a.extra_delay_s == pytest.approx(b.extra_delay_s, rel=1e-12)
            assert (a.value is None) == (b.value is None)
            if a.value is not None:
                assert a.value == pytest.approx(b.value, rel=1e-12)
    assert len({e.extra_delay_s for e in entries}) > 1  # the entries are different designs
