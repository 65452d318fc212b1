"""exotune.sampled.check: the sampled-data check of a design against given continuous intervals
(verdicts at log-spaced members, disagreements, the sampled boundary near each interval end)."""

import math

import numpy as np
import pytest

from exotune.model.controller import build_controller
from exotune.sampled.check import CHECK_POINTS, Boundary, Disagreement, SampledFamilyCheck, check_design
from exotune.sampled.loop import default_prewarp, sampled_stable

from paper_design import paper_design

FS = 1000.0


@pytest.fixture(scope="module")
def cfg():
    return paper_design(environment=[{"kind": "locked"}, {"kind": "spring", "stiffness": [10.0, 1000.0]}],
                        sample_rate_hz=FS)


@pytest.fixture(scope="module")
def check(cfg):
    # continuous intervals as given (not computed here): the mass family stable above 0.004 kg·m²
    return check_design(cfg, [[(0.004, 1.0)], [(1.0, 1e4)], None], [None, [(10.0, 1000.0)]], points=12)


def _stable(cfg, human=None, env="free"):
    cs, _ = build_controller(cfg.plant, cfg.design, cfg.implementation)
    return sampled_stable(cfg.plant, cs, FS, human, env, prewarp=default_prewarp(cfg.implementation))[0]


def test_free_and_locked_verdicts(cfg, check):
    assert check.sample_rate_hz == FS and check.free_stable is True and check.locked_stable is True
    assert 0 < check.free_spectral_radius < 1
    assert "zero-order hold" in check.method and "delay as 1 sample (" in check.method  # 1 ms at 1 kHz
    assert "tau_c: 80 Hz, dob: 60 Hz" in check.method  # prewarped at the G_v and Q cutoffs


def test_mass_family_disagreements_are_the_members_where_the_verdicts_differ(cfg, check):
    mass = check.humans[0]
    assert (mass.kind, mass.parameter, mass.points) == ("mass", "inertia", 12)
    vals = np.geomspace(0.001, 1.0, 12)
    sampled = [_stable(cfg, {"inertia": v, "damping": 0.0}) for v in vals]
    assert mass.stable_points == sum(sampled)
    expected = [(v, bool(0.004 <= v <= 1.0), s) for v, s in zip(vals, sampled) if s != (0.004 <= v <= 1.0)]
    assert [(d.value, d.continuous_stable, d.sampled_stable) for d in mass.disagreements] == pytest.approx(expected)
    # the given end 0.004 lies below the sampled boundary: the members between are continuous-stable only
    (b,) = mass.boundaries
    assert b.continuous == 0.004 and b.sampled is not None and b.sampled > 0.004
    assert _stable(cfg, {"inertia": b.sampled * 1.001, "damping": 0.0})
    assert not _stable(cfg, {"inertia": b.sampled * 0.999, "damping": 0.0})
    assert b.unsafe == (0.004, b.sampled)


def test_skipped_and_environment_checks(check):
    assert check.humans[2].skipped.startswith("not rational")
    assert check.humans[1].boundaries == ()  # no interior end given
    (env,) = check.environment  # the locked environment is not a range
    assert (env.kind, env.parameter, env.note) == ("spring", "stiffness", "cuff free, environment at the joint")
    assert env.points == 12


def test_to_dict_views():
    fam = SampledFamilyCheck("mass", "inertia", points=3, stable_points=2,
                             disagreements=(Disagreement(0.002, True, False),),
                             boundaries=(Boundary(0.004, 0.0055, (0.004, 0.0055)), Boundary(9.0, None, None)))
    assert fam.to_dict() == {
        "kind": "mass", "parameter": "inertia", "points": 3, "stable_points": 2,
        "disagreements": [{"value": 0.002, "continuous_stable": True, "sampled_stable": False}],
        "boundaries": [{"continuous": 0.004, "sampled": 0.0055, "sampled_unstable_where_continuous_stable": [0.004, 0.0055]},
                       {"continuous": 9.0, "sampled": None, "sampled_unstable_where_continuous_stable": None}]}
    assert SampledFamilyCheck("complex_stiffness", "stiffness", skipped="why").to_dict() == {
        "kind": "complex_stiffness", "parameter": "stiffness", "skipped": "why"}
    assert CHECK_POINTS >= 10 and math.isfinite(CHECK_POINTS)
