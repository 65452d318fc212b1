"""exotune.controllerfile.hysteretic: the hysteretic humans that the sampled-data analysis skips are
checked on the continuous-time loop of the file's design; a family not robust there refuses the
file (export and certify), a hand-tuned file says it could not check them."""

from __future__ import annotations

import copy
from pathlib import Path

import numpy as np
import pytest
import yaml

from exotune.controllerfile.hysteretic import hysteretic_problems

ROOT = Path(__file__).resolve().parents[2]
SKIP = "hysteretic damping is not rational: it has no finite-dimensional sampled-data model"


def _raw(zeta_hat: float) -> dict:
    """The `exotune init` design at 1 kHz with ζ̂ = ``zeta_hat`` and a hysteretic family."""
    from exotune.config import read_yaml

    raw = read_yaml(ROOT / "examples" / "paper.yaml")
    raw["design"]["zeta_hat"] = zeta_hat
    raw["implementation"]["sample_rate_hz"] = 1000.0
    raw["humans"] = [{"kind": "spring", "stiffness": [1.0, 300.0], "damping": 0.0},
                     {"kind": "complex_stiffness", "stiffness": [10.0, 1000.0], "eta": 0.2}]
    raw["environment"] = [{"kind": "locked"}]
    return raw


def _doc(raw: dict) -> dict:
    from exotune.controllerfile import build_export, design_at_rate

    doc = build_export(design_at_rate(raw, 1000.0), 1000.0, analyses=False)
    return yaml.safe_load(yaml.safe_dump(doc, sort_keys=False, allow_unicode=True))


def _skipped_sa() -> dict:
    return {"humans": [{"kind": "spring", "parameter": "stiffness", "unit": "N·m/rad", "range": [1.0, 300.0],
                        "robust": True, "stable_intervals": [[1.0, 300.0]]},
                       {"kind": "complex_stiffness", "parameter": "stiffness", "unit": "N·m/rad",
                        "range": [10.0, 1000.0], "skipped": SKIP}]}


def _member_stable(raw: dict, k: float) -> bool:
    """The continuous verdict of one hysteretic member k(1 + 0.2j), as a single-value family."""
    from exotune.analysis import analyze_batch
    from exotune.config import design_from_mapping

    one = copy.deepcopy(raw)
    one["humans"] = [{"kind": "complex_stiffness", "stiffness": k, "eta": 0.2}]
    fam = analyze_batch(design_from_mapping(one)).humans[0]
    assert fam.conclusive[0]
    return bool(fam.robust[0])


def test_a_hysteretic_family_unstable_in_continuous_time_refuses_the_file():
    raw = _raw(5.0)
    sa = _skipped_sa()
    problems = hysteretic_problems(_doc(raw), sa)
    check = sa["humans"][1]["continuous_check"]
    assert check["checked"] and check["conclusive"] and not check["robust"]
    (lo, hi), = check["stable_intervals"]
    assert lo == 10.0 and 300.0 < hi < 1000.0
    assert len(problems) == 1 and "complex_stiffness stiffness [10, 1000] N·m/rad: not robust" in problems[0]
    # the interval end against member-by-member verdicts
    assert _member_stable(raw, 0.98 * hi) and not _member_stable(raw, 1.02 * hi)
    assert "continuous_check" not in sa["humans"][0]


def test_a_robust_hysteretic_family_is_reported_as_checked_in_continuous_time_only():
    sa = _skipped_sa()
    assert hysteretic_problems(_doc(_raw(0.7)), sa) == []
    check = sa["humans"][1]["continuous_check"]
    assert check["checked"] and check["robust"] and check["stable_intervals"] == [[10.0, 1000.0]]
    assert "not rational" in check["model"]


def test_a_hand_tuned_file_says_its_hysteretic_family_is_not_checked():
    doc = _doc(_raw(5.0))
    doc["provenance"]["hand_tuned"] = True
    sa = _skipped_sa()
    assert hysteretic_problems(doc, sa) == []
    assert sa["humans"][1]["continuous_check"]["checked"] is False
    assert "hand-tuned" in sa["humans"][1]["continuous_check"]["reason"]


def test_export_refuses_and_certify_does_not_certify_it(tmp_path):
    """End to end: export writes nothing unless allowed; the file written anyway is NOT CERTIFIED
    with the hysteretic family named, and its text shows the continuous check."""
    from exotune import api
    from exotune.errors import RunFailed

    src = tmp_path / "d.yaml"
    src.write_text(yaml.safe_dump(_raw(5.0), sort_keys=False, allow_unicode=True))
    out = tmp_path / "c.yaml"
    with np.errstate(all="ignore"):
        with pytest.raises(RunFailed, match="complex_stiffness stiffness"):
            api.export(src, out=out, require_latency_margin_s=0.0)
        assert not out.exists()
        api.export(src, out=out, require_latency_margin_s=0.0, allow_uncertified=True)
        cert = api.certify(out)
    assert not cert.certified
    assert any("complex_stiffness" in p and "continuous-time" in p for p in cert.to_dict()["problems"])
    assert "continuous time, exact delay: NOT robust" in cert.to_text()


def test_a_hysteretic_family_that_tolerates_less_delay_bounds_the_margin_of_record():
    """The sampled-data latency margin covers only the rational loops. With a strongly hysteretic
    family (η = 9.999 over [100, 1e9] N·m/rad) the continuous loop with that human goes unstable at
    less extra delay than the sampled free and locked loops (3.41 ms): the margin of record is that
    family's continuous-time margin, named as critical, the sampled figure kept under ``bound``.
    Checked against the continuous verdicts of the family just below and above the bound."""
    from exotune.analysis import analyze_batch
    from exotune.config import batch_config, design_from_mapping
    from exotune.controllerfile.certify import sampled_decision
    from exotune.numerics.engine import numpy_engine

    raw = _raw(0.7)
    raw["design"].update(amplification=8.0, felt_inertia=0.25, felt_damping=1.0, zeta=0.7)
    raw["humans"] = [{"kind": "spring", "stiffness": [100.0, 300.0], "damping": 0.0},
                     {"kind": "complex_stiffness", "stiffness": [100.0, 1e9], "eta": 9.999}]
    doc = _doc(raw)
    sa, lm, problems = sampled_decision(doc)
    b = lm["bound"]
    assert lm["critical"]["loop"] == "human1_complex_stiffness" and b["loop"] == "human1_complex_stiffness"
    assert lm["extra_delay_s"] < b["sampled_extra_delay_s"]
    assert lm["extra_delay_samples"] == pytest.approx(lm["extra_delay_s"] * 1000.0, rel=1e-12)
    T, dT = 0.001, lm["extra_delay_s"]
    one = copy.deepcopy(raw)
    one["humans"] = [raw["humans"][1]]
    cfg = batch_config(design_from_mapping(one), {"implementation.delay_s": np.array([T + dT * (1 - 1e-3), T + dT * (1 + 1e-3)])})
    with numpy_engine():
        fam = analyze_batch(cfg).humans[0]
    assert fam.robust.tolist() == [True, False]
    # a requirement between the bound and the sampled figure refuses the file
    doc["requirements"] = {"latency_margin_s": 0.5 * (dT + b["sampled_extra_delay_s"])}
    _sa, lm2, problems2 = sampled_decision(doc)
    assert any(p.startswith("latency margin") for p in problems2)
    assert not any(p.startswith("latency margin") for p in problems)


def test_no_bound_when_the_hysteretic_family_tolerates_more():
    """The template-like design: the hysteretic family [10, 1000] N·m/rad, η = 0.2 tolerates more
    delay than the sampled rational loops, so the margin of record is theirs, without ``bound``."""
    from exotune.controllerfile.certify import sampled_decision

    sa, lm, problems = sampled_decision(_doc(_raw(0.7)))
    assert "bound" not in lm and not lm["critical"]["loop"].endswith("complex_stiffness")
    assert sa["humans"][1]["continuous_check"]["robust"] is True


def test_the_batch_of_documents_gives_each_its_own_checks():
    """hysteretic_problems_many runs documents that differ only in overridable numbers (here the
    plant, as gain-schedule entries do) as one batch: each document gets exactly the checks and
    problems that hysteretic_problems gives it alone — a robust and a not-robust design side by side."""
    from exotune.controllerfile.hysteretic import hysteretic_problems_many

    docs = [_doc(_raw(0.7)), _doc(_raw(5.0)), _doc(_raw(0.7))]
    docs[2]["plant"]["motor_inertia"]["value"] *= 1.25
    alone = []
    for d in docs:
        sa = _skipped_sa()
        alone.append((hysteretic_problems(d, sa), sa))
    sas = [_skipped_sa() for _ in docs]
    together = hysteretic_problems_many([(d, sa, "") for d, sa in zip(docs, sas)])
    for (problems, sa), got, sa_b in zip(alone, together, sas):
        assert got == problems
        assert sa_b["humans"][1]["continuous_check"] == sa["humans"][1]["continuous_check"]
    assert not together[0] and together[1]
