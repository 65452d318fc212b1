"""One model from optimize to certify (docs/method.md#one-model-of-record): with a sample rate,
analyze, optimize and export decide with certify's own analysis of the controller export writes,
and the template pipeline init → optimize → export → certify closes."""

from __future__ import annotations

import json

import pytest
import yaml
from click.testing import CliRunner

import exotune
from exotune.cli import cli
from exotune.controllerfile import load_controller
from exotune.starter import write_templates


def run(*args):
    return CliRunner().invoke(cli, [str(a) for a in args])


@pytest.fixture(scope="module")
def template(tmp_path_factory):
    d = tmp_path_factory.mktemp("template")
    write_templates(d)
    return d


def _variant(template, tmp_path, name: str, **impl) -> object:
    raw = yaml.safe_load((template / "design.yaml").read_text())
    raw["implementation"].update(impl)
    p = tmp_path / name
    p.write_text(yaml.safe_dump(raw))
    return p


def test_template_pipeline_closes(template):
    """`exotune init`, `optimize optimize.yaml -o best.yaml`, `export best.yaml -o c.yaml` (the
    design's own rate) and `certify c.yaml` all exit 0; the margin asked of optimize travels."""
    best, ctl = template / "best.yaml", template / "c.yaml"
    res = run("optimize", template / "optimize.yaml", "-o", best, "--json")
    assert res.exit_code == 0, res.output
    r = json.loads(res.stdout)
    assert r["sampled_data"]["certifiable"] is True
    lm = r["latency_margin"]
    assert lm["required_s"] == pytest.approx(1e-3) and lm["achieved_s"] >= 1e-3 and lm["met"] is True
    assert lm["continuous_s"] > lm["achieved_s"]  # the zero-order hold costs margin
    design = yaml.safe_load(best.read_text())
    assert design["requirements"]["latency_margin_s"] == pytest.approx(1e-3)
    res = run("export", best, "-o", ctl)
    assert res.exit_code == 0, res.output
    assert res.stdout.index("sampled-data latency margin") < res.stdout.index("continuous")
    doc = load_controller(ctl)
    assert doc["sample_rate_hz"]["value"] == 1000.0 and doc["requirements"]["latency_margin_s"] == pytest.approx(1e-3)
    assert "optimize" in doc["requirements"]["source"] and "uncertified" not in doc["provenance"]
    res = run("certify", ctl, "--json")
    assert res.exit_code == 0, res.output
    cert = json.loads(res.stdout)
    assert cert["certified"] is True
    # one implementation: the optimizer's sampled-data margin is certify's, to the last bits
    assert cert["latency_margin"]["extra_delay_s"] == pytest.approx(lm["achieved_s"], rel=1e-12)


def test_analyze_with_a_rate_gives_certifys_verdicts_first(template, tmp_path):
    """analyze's margin of record and exact family intervals are certify's on the exported file;
    the continuous margin stays beside it, labelled, and is larger by about half a sample."""
    r = exotune.analyze(template / "design.yaml")
    v = r.sampled
    assert v is not None and v.certifiable and v.robust
    c = exotune.export(template / "design.yaml", out=tmp_path / "c.yaml")
    cert = exotune.certify(c).to_dict()
    assert cert["certified"]
    assert r.latency_margin_s == pytest.approx(cert["latency_margin"]["extra_delay_s"], rel=1e-12)
    for h, k in zip(v.analysis["humans"], cert["sampled"]["humans"]):
        assert h.get("stable_intervals") == k.get("stable_intervals")
    gap = (r.continuous_latency_margin_s - r.latency_margin_s) * 1000.0
    assert 0.3 < gap < 0.6  # samples: the zero-order hold's half sample
    d = r.to_dict()
    assert d["margins"]["model_of_record"] == "sampled-data at 1000 Hz"
    assert d["margins"]["latency"]["extra_delay_s"] == r.latency_margin_s
    assert d["margins"]["latency_continuous"]["model"].startswith("continuous")
    text = r.to_text()
    assert text.index("Sampled-data verdicts of record") < text.index("Continuous-time analysis")
    assert "overstates the sampled-data runtime's" in text


@pytest.mark.parametrize("delay,dob", [(0.0, True), (0.0015, True), (0.002, False), (0.0, False)],
                         ids=["no-delay", "fractional", "whole-no-dob", "no-delay-no-dob"])
def test_export_decides_as_certify(template, tmp_path, delay, dob):
    """export → certify round trip over delays 0, fractional and whole samples, with and without
    the DOB: export's decision (written, or refused naming the problems) is certify's verdict on
    the file, and its predicted sampled-data analysis is certify's."""
    impl = {"delay_s": delay}
    if not dob:
        impl["dob"] = None
    src = _variant(template, tmp_path, "d.yaml", **impl)
    ctl = tmp_path / "c.yaml"
    refused = run("export", src, "-o", ctl)
    res = run("export", src, "-o", ctl, "--allow-uncertified")
    assert res.exit_code == 0, res.output
    doc = load_controller(ctl)
    cert = exotune.certify(ctl)
    would_fail = bool(doc["provenance"].get("uncertified"))
    assert cert.certified is not would_fail
    assert refused.exit_code == (1 if would_fail else 0), refused.output
    if would_fail:
        assert "not written" in refused.output and doc["provenance"]["allow_uncertified"] is True
        assert list(cert.reasons)[: len(doc["provenance"]["uncertified"])] == doc["provenance"]["uncertified"]
    assert doc["predicted"]["sampled"]["humans"] == cert.to_dict()["sampled"]["humans"]
    assert (doc["predicted"]["sampled_latency_margin"]["extra_delay_s"]
            == pytest.approx(cert.to_dict()["latency_margin"]["extra_delay_s"], rel=1e-12))


def test_refused_export_writes_nothing_and_names_both_numbers(template, tmp_path):
    src = template / "design.yaml"
    ctl = tmp_path / "c.yaml"
    res = run("export", src, "-o", ctl, "--require-latency-margin-s", "0.01")
    assert res.exit_code == 1 and not ctl.exists()
    line = res.output.strip()
    assert line.count("\n") == 0 and "< required 10 ms" in line and "--allow-uncertified" in line


def test_requirement_asked_of_optimize_reaches_certify(template, tmp_path):
    """A margin asked of optimize at 2 kHz (0.8 ms) is written into the design, exported into the
    file and checked by certify (not the default of one sample period)."""
    base = _variant(template, tmp_path, "d2k.yaml", sample_rate_hz=2000.0)
    spec = tmp_path / "opt.yaml"
    spec.write_text(yaml.safe_dump({"base": str(base), "objective": "amplification",
                                    "free": {"design.amplification": [1.5, 40.0]},
                                    "constraints": {"latency_margin_s": 0.0008, "amplification_bandwidth_hz": 3.0},
                                    "budget": 200, "seed": 1}))
    best, ctl = tmp_path / "best.yaml", tmp_path / "c.yaml"
    assert run("optimize", spec, "-o", best).exit_code == 0
    assert yaml.safe_load(best.read_text())["requirements"]["latency_margin_s"] == 0.0008
    res = run("export", best, "-o", ctl)
    assert res.exit_code == 0, res.output
    assert load_controller(ctl)["requirements"]["latency_margin_s"] == 0.0008
    cert = exotune.certify(ctl).to_dict()
    assert cert["certified"] and cert["latency_margin"]["required_s"] == 0.0008
    assert cert["latency_margin"]["extra_delay_s"] >= 0.0008


@pytest.mark.parametrize("rate,delay,seed", [(500.0, 0.001, 0), (2000.0, 0.0015, 3)], ids=["500Hz-half-sample", "2kHz-3-samples"])
def test_optimum_certifies_over_seeds_and_rates(tmp_path, rate, delay, seed):
    """The shipped pipeline spec (studies/pipeline.yaml) at other rates, delays and seeds: the
    returned design certifies with the margin it was asked for (one sample period by default),
    through export and certify as a user runs them."""
    from pathlib import Path

    spec = yaml.safe_load((Path(__file__).resolve().parents[1] / "studies" / "pipeline.yaml").read_text())
    spec["base"]["implementation"].update(sample_rate_hz=rate, delay_s=delay)
    spec.update(budget=300, seed=seed)
    p = tmp_path / "opt.yaml"
    p.write_text(yaml.safe_dump(spec))
    best, ctl = tmp_path / "best.yaml", tmp_path / "c.yaml"
    res = run("optimize", p, "-o", best, "--json")
    assert res.exit_code == 0, res.output
    r = json.loads(res.stdout)
    assert r["sampled_data"]["certifiable"] and r["latency_margin"]["required_s"] == pytest.approx(1.0 / rate)
    assert run("export", best, "-o", ctl).exit_code == 0
    cert = exotune.certify(ctl).to_dict()
    assert cert["certified"], cert["problems"]
    assert cert["latency_margin"]["extra_delay_s"] >= 1.0 / rate


def test_analyze_holds_the_design_to_its_requirements_section(template, tmp_path):
    """A design's own requirements (here 10 ms, far above its 1.7 ms) decide analyze's verdict of
    record, as they will decide export and certify."""
    raw = yaml.safe_load((template / "design.yaml").read_text())
    raw["requirements"] = {"latency_margin_s": 0.01, "source": "test"}
    p = tmp_path / "req.yaml"
    p.write_text(yaml.safe_dump(raw))
    r = exotune.analyze(p)
    assert not r.sampled.certifiable and r.sampled.robust
    assert r.sampled.required_latency_margin_s == 0.01
    assert any("< required 10 ms" in x for x in r.sampled.problems)
    assert r.to_dict()["margins"]["latency"]["met"] is False
    res = run("export", p, "-o", tmp_path / "c.yaml")
    assert res.exit_code == 1 and "< required 10 ms" in res.output
