"""exotune.sweeps.sampledcols: the sweep's sampled-data columns of a small batch against the
point-wise sampled-data loop (exotune.sampled.loop), and the refusals of the spec key."""

import copy
import math
from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from exotune.config import batch_config, design_from_mapping, design_row
from exotune.model.controller import build_controller
from exotune.sampled.loop import default_prewarp, sampled_stable
from exotune.sweeps.sampledcols import sampled_columns, sampled_refusal

from campaign_designs import UNRESOLVED_LIGHT_MASS_1KHZ
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
                         "sampled_human0_mass_stable_intervals", "sampled_human0_mass_unresolved_cells",
                         "sampled_human0_mass_critical", "sampled_human0_mass_critical_spectral_radius",
                         "sampled_latency_margin_samples"}
    for i in range(2):
        cfg = design_row(b, i)
        assert cols["sampled_free_stable"][i] == _stable(cfg)
        assert cols["sampled_locked_stable"][i] == _stable(cfg, env="locked")
        assert cols["sampled_human0_mass_stable_intervals"][i] == [[0.05, 1.0]]
        assert cols["sampled_human0_mass_unresolved_cells"][i] == []
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


@settings(max_examples=200, deadline=None)
@given(st.lists(st.floats(0.0, 100.0), min_size=2, max_size=12, unique=True),
       st.lists(st.tuples(st.floats(0.0, 100.0), st.floats(0.0, 100.0)), max_size=5))
def test_checked_intervals_leave_out_exactly_the_unresolved_cells(ends, raw_cells):
    from exotune.sweeps.sampledcols import checked_intervals

    ends = sorted(ends)
    ivs = [[ends[k], ends[k + 1]] for k in range(0, len(ends) - 1, 2)]
    cells = [sorted(c) for c in raw_cells if c[0] != c[1]]
    out = checked_intervals(ivs, cells)
    assert all(lo < hi for lo, hi in out) and out == sorted(out)
    probes = np.linspace(0.0, 100.0, 2001).tolist() + ends + [x for c in cells for x in c]
    inside = lambda x, ivs_: any(lo <= x <= hi for lo, hi in ivs_)  # noqa: E731
    for x in probes:
        in_cell = any(a < x < b for a, b in cells)
        if inside(x, out):
            assert inside(x, ivs) and not in_cell  # nothing is added, no cell interior is kept
        elif inside(x, ivs) and not in_cell:
            # a checked member is only lost as an end of a cell that left a zero-length part
            assert any(x in (a, b) for a, b in cells)


def test_sweep_intervals_leave_out_the_unresolved_cells():
    """A campaign design whose undamped light-mass family stays within 1e-9 of |z| = 1 over a range
    (members alternate between stable and unstable): the family check leaves cells unresolved, the
    sweep lists them in their column, the family is not robust, and the checked intervals (what the
    derived maps use) hold none of their interiors."""
    from exotune.analysis import analyze_batch
    from exotune.config import batch_config, design_from_mapping
    from exotune.sampled.batch import BatchLoops
    from exotune.sampled.families import family_check, family_loops
    from exotune.sweeps.sampledcols import checked_intervals, sampled_columns

    raw = copy.deepcopy(UNRESOLVED_LIGHT_MASS_1KHZ)

    des = design_from_mapping(raw)
    b = batch_config(des, {"design.amplification": np.array([raw["design"]["amplification"]])})
    cols = sampled_columns(b, analyze_batch(b))
    loop, lo, hi = family_loops(des.humans, des.environment)[0]
    chk = family_check(BatchLoops(b, 1000.0), np.array([0]), loop, lo, hi)
    ivs = cols["sampled_human0_mass_stable_intervals"][0]
    cells = cols["sampled_human0_mass_unresolved_cells"][0]
    assert cells == chk["unresolved"][0] and cells and not bool(cols["sampled_human0_mass_robust"][0])
    assert ivs == chk["stable_intervals"][0]  # certify's listing: the intervals span the cells
    checked = checked_intervals(ivs, cells)
    assert checked != ivs
    for a, c in cells:
        assert not any(x < c and y > a for x, y in checked)
