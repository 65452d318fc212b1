"""Several logs identified together (issue 26 item 6): their equations' rows are stacked, each log
filtered, delayed and offset on its own — never across a log boundary. Logs simulated
independently of exotune (tests/identification/simulated_logs.py)."""

from __future__ import annotations

import numpy as np
import pytest
import yaml
from click.testing import CliRunner

import exotune
from exotune.cli import cli
from exotune.errors import ConfigError
from exotune.identification import identify_plant, log_from_columns
from identification.simulated_logs import TRUE, held_logs

FS = 1000.0


def _csv(path, cols):
    names = list(cols)
    path.write_text(",".join(names) + "\n" + "".join(",".join(repr(float(x)) for x in r) + "\n"
                                                      for r in zip(*(cols[n] for n in names))))
    return path


def test_stacked_logs_give_the_plant_exactly_and_never_cross_a_boundary():
    """Two noise-free logs of different lengths, the second with re-zeroed torque sensors (offsets
    of 3 and −2 N·m) and starting in motion: identified together, the plant to 2e-7; the same
    samples concatenated into one log (a jump in state and offset at the seam) are far off."""
    a = held_logs(1, FS, 5.0, noise=False, seed0=11)[0]
    b = held_logs(1, FS, 7.0, noise=False, seed0=12)[0]
    b = {k: v[1500:] for k, v in b.items()}  # in motion at its first sample
    b["tau_s"] = b["tau_s"] + 3.0
    b["tau_c"] = b["tau_c"] - 2.0
    logs = [log_from_columns(a, "a", delay_s=1e-3), log_from_columns(b, "b", delay_s=1e-3)]
    r = identify_plant(logs)
    for k, v in TRUE.items():
        assert r[k].value == pytest.approx(v, rel=2e-7), k
    assert r.source == "a + b" and max(lg.samples for lg in logs) < r.samples < sum(lg.samples for lg in logs)
    joined = {k: np.concatenate([a[k], b[k] if k != "t" else a["t"][-1] + 1 / FS + b["t"] - b["t"][0]]) for k in a}
    one = identify_plant(log_from_columns(joined, delay_s=1e-3))
    got = {p.key: p.value for p in one.parameters}
    assert max(abs(got[k] / v - 1) if k in got else np.inf for k, v in TRUE.items()) > 1e-3


def test_stacking_two_noisy_logs_shrinks_the_standard_errors():
    a, b = held_logs(2, FS, 8.0, seed0=21)
    la, lb = log_from_columns(a, "a", delay_s=1e-3), log_from_columns(b, "b", delay_s=1e-3)
    both, only = identify_plant([la, lb]), identify_plant(la)
    for k, v in TRUE.items():
        assert abs(both[k].value - v) < 4 * both[k].std_error, k
        assert 0.55 < both[k].std_error / only[k].std_error < 0.9, (k, both[k].std_error / only[k].std_error)
    # the delay is one for all logs, estimated on all of them
    auto = identify_plant([log_from_columns(a, "a", delay_s="auto"), log_from_columns(b, "b", delay_s="auto")])
    assert auto.delay["samples"] == 1 and auto.delay["estimated"]


def test_logs_that_cannot_be_stacked_are_refused():
    a, b = held_logs(2, FS, 3.0, seed0=31)
    la = log_from_columns(a, "a", delay_s=1e-3)
    no_cuff = {k: v for k, v in b.items() if k not in ("tau_c", "theta_h")}
    with pytest.raises(ConfigError) as e:
        identify_plant([la, log_from_columns(no_cuff, "b", delay_s=1e-3)])
    assert e.value.field == "b" and "same columns" in str(e.value)
    faster = dict(b, t=b["t"] / 2)
    with pytest.raises(ConfigError) as e:
        identify_plant([la, log_from_columns(faster, "b", delay_s=5e-4)])
    assert e.value.field == "b" and "one rate" in str(e.value)


def test_cli_and_api_take_several_logs(tmp_path):
    a, b = held_logs(2, FS, 6.0, seed0=41)
    pa, pb = _csv(tmp_path / "a.csv", a), _csv(tmp_path / "b.csv", b)
    out = tmp_path / "plant.yaml"
    res = CliRunner().invoke(cli, ["identify", str(pa), str(pb), "--delay-s", "0.001", "-o", str(out)])
    assert res.exit_code == 0, res.output
    assert res.output.startswith(f"exotune identify — {pa} + {pb}:")
    sec = yaml.safe_load(out.read_text())
    assert sec["plant"]["motor_inertia"] == pytest.approx(TRUE["motor_inertia"], rel=1e-3)
    api = exotune.identify([str(pa), str(pb)], delay_s=1e-3)
    assert api["sea_stiffness"].value == sec["plant"]["sea_stiffness"]
    maps = exotune.identify([a, b], delay_s=1e-3)
    assert maps["sea_stiffness"].value == pytest.approx(api["sea_stiffness"].value, rel=1e-9)
    res = CliRunner().invoke(cli, ["identify", str(pa), str(pb), "--delay-s", "0.001", "--folds", "2"])
    assert res.exit_code == 2 and res.output.startswith("exotune: error: --folds"), res.output
