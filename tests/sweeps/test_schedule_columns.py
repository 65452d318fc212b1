"""A sweep of a gain-scheduled base analyses every entry (docs/sweep-spec.md#gain-schedule): its
``schedule_*`` columns and its latency margins agree with ``exotune analyze`` (continuous) and with
``exotune export`` + ``exotune certify`` of the same design (sampled data), design by design."""

from __future__ import annotations

import copy

import numpy as np
import pytest
import yaml

import exotune.api as api
from exotune.analysis import analyze_batch, analyze_design
from exotune.analysis.latency_margin import latency_margin, schedule_latency_margin
from exotune.config import design_from_mapping, read_yaml
from exotune.sweeps import load_results
from exotune.sweeps.metrics import robust_mask

ALPHA = (4.0, 8.0)
DELAY = (0.001, 0.003)


@pytest.fixture(scope="module")
def swept(tmp_path_factory):
    d = tmp_path_factory.mktemp("sched")
    spec = {"base": str(api.__file__).replace("exotune/api.py", "examples/scheduled.yaml"),
            "axes": {"design.amplification": list(ALPHA), "implementation.delay_s": list(DELAY)},
            "sampled": True}
    (d / "spec.yaml").write_text(yaml.safe_dump(spec))
    api.sweep(d / "spec.yaml", d / "out", workers=1)
    df = load_results(d / "out").sort_values("point_index").reset_index(drop=True)
    return d, df


@pytest.fixture(scope="module")
def report_md(swept):
    """``summary.md`` of ``exotune report`` of the sweep (written once for the tests that read it)."""
    d, _ = swept
    api.report(d / "out")
    return (d / "out" / "report" / "summary.md").read_text()


def _analyze(cfg):
    """What ``exotune analyze`` (:func:`exotune.analysis.analyze_with_margins`) reports of the gain
    schedule: its entries (verdicts of :func:`analyze_design`, latency margins of
    :func:`schedule_latency_margin`) and the main controller's continuous latency margin [s] —
    the same calls, without the plant-uncertainty margin (half of the work) that no check here reads."""
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        lm, per_entry = schedule_latency_margin(cfg, latency_margin(cfg, nominal=analyze_batch(cfg)))
        entries = analyze_design(cfg, False).gain_schedule
    assert len(per_entry) == len(entries)
    return [(e.robust, m.extra_delay_s) for e, m in zip(entries, per_entry)], float(lm.extra_delay_s)


def _design(alpha, delay):
    raw = read_yaml("examples/scheduled.yaml")
    raw["design"]["amplification"] = float(alpha)
    raw["implementation"]["delay_s"] = float(delay)
    return raw


def test_continuous_columns_agree_with_analyze(swept):
    _, df = swept
    seen = set()
    for _, row in df.iterrows():
        raw = _design(row["design.amplification"], row["implementation.delay_s"])
        entries, main_margin = _analyze(design_from_mapping(copy.deepcopy(raw)))
        assert bool(row["schedule_robust"]) == all(robust for robust, _ in entries)
        assert int(row["schedule_failing_entries"]) == sum(not robust for robust, _ in entries)
        seen.add(bool(row["schedule_robust"]))
        # the margin of record is the smallest of the main controller's and the entries'
        want = min([main_margin] + [m for _, m in entries])
        assert row["latency_margin_s"] == pytest.approx(want, rel=1e-5, abs=1e-9)
        assert row["latency_margin_s"] <= row["latency_margin_main_s"]
    assert seen == {True, False}  # the grid holds both kinds


def test_sampled_columns_agree_with_certify(swept, tmp_path):
    _, df = swept
    for _, row in df.iterrows():
        raw = _design(row["design.amplification"], row["implementation.delay_s"])
        (tmp_path / "d.yaml").write_text(yaml.safe_dump(raw))
        api.export(tmp_path / "d.yaml", out=tmp_path / "c.yaml", allow_uncertified=True)
        cert = api.certify(tmp_path / "c.yaml").to_dict()
        ok = []
        for e in cert["gain_schedule"]:
            s = e["sampled"]
            ok.append(s["free_stable"] and s["locked_stable"]
                      and all(h["robust"] for h in s["humans"] + s["environment"] if "robust" in h))
        assert bool(row["sampled_schedule_robust"]) == all(ok)
        assert int(row["sampled_schedule_failing_entries"]) == ok.count(False)
        lm = cert["latency_margin"]["extra_delay_samples"]
        assert row["sampled_latency_margin_samples"] == pytest.approx(lm, rel=1e-4, abs=1e-9)


def test_robust_requires_every_entry_and_the_report_says_so(swept, report_md):
    _, df = swept
    cols = {c: df[c].to_numpy() for c in df.columns if c.endswith(("_robust", "_stable"))}
    mask, used = robust_mask(cols)
    assert "schedule_robust" in used and "sampled_schedule_robust" in used
    assert not (mask & ~df["schedule_robust"].to_numpy(bool)).any()
    assert "gain schedule swept" in report_md and "not swept" not in report_md


def test_metric_columns_and_maps_are_the_worst_over_the_schedule(swept, report_md):
    from exotune.analysis.gain_schedule import WORST_METRICS

    _, df = swept
    for col, op in WORST_METRICS.items():
        w, main = df[f"schedule_worst_{col}"].to_numpy(float), df[col].to_numpy(float)
        both = ~np.isnan(w) & ~np.isnan(main)
        assert ((w <= main) if op == ">=" else (w >= main))[both].all(), col
    # the entries' passivity is worse than the main controller's somewhere on this grid
    assert (df["schedule_worst_passivity_max_phase_excess_deg"] > df["passivity_max_phase_excess_deg"]).any()
    assert "`schedule_worst_passivity_max_phase_excess_deg`" in report_md
