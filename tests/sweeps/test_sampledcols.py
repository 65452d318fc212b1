"""exotune.sweeps.sampledcols: the sweep's sampled-data columns of a small batch against the
point-wise sampled-data loop (exotune.sampled.loop), and the refusals of the spec key."""

import copy
import math
from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest

from exotune.config import batch_config, design_from_mapping, design_row
from exotune.model.controller import build_controller
from exotune.sampled.loop import default_prewarp, sampled_stable
from exotune.sweeps.sampledcols import sampled_columns, sampled_refusal

from paper_design import paper_design

FS = 1000.0


@pytest.fixture(scope="module")
def base():
    return paper_design(humans=[{"kind": "mass", "inertia": [0.05, 1.0]},
                                {"kind": "complex_stiffness", "stiffness": [10.0, 1000.0], "eta": 0.2}],
                        environment=[{"kind": "locked"}], sample_rate_hz=FS)


def _stable(cfg, human=None, env="free", extra=0.0):
    impl = cfg.implementation if not extra else replace(cfg.implementation,
                                                        delay_s=float(cfg.implementation.delay_s) + extra)
    cs, _ = build_controller(cfg.plant, cfg.design, impl)
    return sampled_stable(cfg.plant, cs, FS, human, env, prewarp=default_prewarp(impl))[0]


def test_refusals(base):
    assert sampled_refusal(base) is None
    raw = copy.deepcopy(base.raw)
    raw["implementation"]["sample_rate_hz"] = None
    assert sampled_refusal(design_from_mapping(raw)).startswith("needs a sample rate")
    raw = copy.deepcopy(base.raw)
    raw["humans"] = [{"kind": "msd", "inertia": [0.1, 0.2], "stiffness": [10.0, 20.0], "damping": 1.0}]
    assert sampled_refusal(design_from_mapping(raw)).startswith("humans[0] is a box")


def test_columns_agree_with_the_pointwise_loop(base):
    b = batch_config(base, {"design.amplification": np.array([4.0, 8.0])})
    cols = sampled_columns(b, SimpleNamespace(n=2, latency_margin_s=None))
    assert set(cols) == {"sampled_free_stable", "sampled_locked_stable", "sampled_human0_mass_robust",
                         "sampled_human0_mass_stable_intervals", "sampled_human0_mass_critical",
                         "sampled_human0_mass_critical_spectral_radius", "sampled_latency_margin_samples"}
    for i in range(2):
        cfg = design_row(b, i)
        assert cols["sampled_free_stable"][i] == _stable(cfg)
        assert cols["sampled_locked_stable"][i] == _stable(cfg, env="locked")
        assert cols["sampled_human0_mass_stable_intervals"][i] == [[0.05, 1.0]]
        assert bool(cols["sampled_human0_mass_robust"][i])
        crit = cols["sampled_human0_mass_critical"][i]
        assert 0.05 <= crit <= 1.0 and cols["sampled_human0_mass_critical_spectral_radius"][i] < 1.0
        # the latency margin [samples]: every probe loop stable just below it, one unstable just above
        extra = cols["sampled_latency_margin_samples"][i] / FS
        assert 0 < extra < math.inf
        probes = [(None, "free"), (None, "locked")] + [({"inertia": m, "damping": 0.0}, "free") for m in (0.05, 1.0, crit)]
        assert all(_stable(cfg, h, e, extra * 0.999) for h, e in probes)
        assert not all(_stable(cfg, h, e, extra * 1.001) for h, e in probes)


def test_an_unstable_family_has_no_margin(base):
    raw = copy.deepcopy(base.raw)
    raw["humans"] = [{"kind": "mass", "inertia": [0.001, 1.0]}]  # unstable below ~5.5e-3 kg·m² at 1 kHz
    cfg = design_from_mapping(raw)
    cols = sampled_columns(batch_config(cfg, {}), SimpleNamespace(n=1, latency_margin_s=None))
    ((lo, hi),) = cols["sampled_human0_mass_stable_intervals"][0]
    assert hi == 1.0 and not _stable(cfg, {"inertia": lo * 0.999, "damping": 0.0})
    assert _stable(cfg, {"inertia": lo * 1.001, "damping": 0.0})
    assert not cols["sampled_human0_mass_robust"][0] and cols["sampled_latency_margin_samples"][0] == 0.0
