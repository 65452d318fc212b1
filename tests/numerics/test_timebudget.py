"""The time budget of export and certify (exotune.numerics.timebudget): refused before starting
when even the base work exceeds it, stopped when it runs over, one-line errors, nothing written."""

from __future__ import annotations

import time
from pathlib import Path

import pytest
from click.testing import CliRunner

from exotune.cli import cli
from exotune.errors import ConfigError
from exotune.numerics.timebudget import (DEFAULT_TIME_BUDGET_S, active_budget, check_budget_option, check_time,
                                         refuse_if_over, time_budget)

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


@pytest.mark.parametrize("bad", ["abc", "0", "-1", "nan", "inf"])
def test_option_is_validated(bad):
    with pytest.raises(ConfigError) as e:
        check_budget_option(bad)
    assert e.value.field == "time_budget_s"


def test_option_default_and_value():
    assert check_budget_option(None) == DEFAULT_TIME_BUDGET_S == 600.0
    assert check_budget_option("12.5") == 12.5


def test_check_time_raises_only_after_the_deadline_and_only_inside():
    check_time()  # outside any budget: nothing
    assert active_budget() is None
    with time_budget(60.0, "working", "do less"):
        check_time()
        assert active_budget() == (60.0, "working", "do less", "; nothing was written")
    with time_budget(1e-6, "working", "do less", writes=False):
        time.sleep(0.01)
        with pytest.raises(ConfigError) as e:
            check_time()
    assert "working exceeded the time budget of 1e-06 s" in e.value.reason and "written" not in e.value.reason
    assert active_budget() is None


def test_refuse_if_over_names_the_work():
    with pytest.raises(ConfigError) as e:
        refuse_if_over(10**9, 50, 1.0, "exporting at 1e+06 Hz", "lower the rate")
    assert "10" in e.value.reason and "50-state" in e.value.reason and "time budget of 1 s" in e.value.reason
    assert refuse_if_over(1, 4, 10.0, "x", "y") < 10.0


def test_refuse_if_over_prints_a_small_estimate_in_significant_digits(monkeypatch):
    """``--time-budget-s 1e-9`` read "about 0 s on this machine, over the time budget": the
    estimate was rounded to whole seconds. It now keeps two significant digits."""
    import re

    import exotune.numerics.timebudget as tb

    monkeypatch.setattr(tb, "eig_seconds", lambda n, repeats=3: 1.2e-5)
    with pytest.raises(ConfigError) as e:
        refuse_if_over(194, 18, 1e-9, "exporting at 1000 Hz", "lower the rate")
    assert "about 0.0023 s on this machine, over the time budget of 1e-09 s" in e.value.reason, e.value.reason
    m = re.search(r"about (\S+) s on this machine", e.value.reason)
    assert float(m.group(1)) > 0
    with pytest.raises(ConfigError) as e:
        refuse_if_over(10**6, 18, 5.0, "exporting at 1000 Hz", "lower the rate")
    assert "about 12 s on this machine, over the time budget of 5 s" in e.value.reason


def _run(args):
    res = CliRunner().invoke(cli, args)
    assert res.exception is None or isinstance(res.exception, SystemExit), repr(res.exception)
    return res


def test_export_over_budget_is_stopped_and_writes_nothing(tmp_path, monkeypatch):
    import exotune.numerics.timebudget as tb

    monkeypatch.setattr(tb, "eig_seconds", lambda n, repeats=3: 0.0)  # the pre-check passes: the run is stopped
    out = tmp_path / "c.yaml"
    t = time.perf_counter()
    res = _run(["export", str(EXAMPLES / "scheduled.yaml"), "--sample-rate-hz", "50000", "-o", str(out),
                "--time-budget-s", "1"])
    assert res.exit_code == 2 and not out.exists() and list(tmp_path.iterdir()) == []
    assert res.output.startswith("exotune: error: --time-budget-s: exporting at 50000 Hz exceeded the time budget")
    assert len(res.output.strip().splitlines()) == 1 and "Traceback" not in res.output
    assert res.output.rstrip().endswith("or raise --time-budget-s); nothing was written")
    assert time.perf_counter() - t < 30


def test_export_whose_base_work_exceeds_the_budget_is_refused_before_it_starts(tmp_path):
    out = tmp_path / "c.yaml"
    res = _run(["export", str(EXAMPLES / "scheduled.yaml"), "--sample-rate-hz", "200000", "-o", str(out),
                "--time-budget-s", "0.05"])
    assert res.exit_code == 2 and not out.exists()
    assert "eigenvalue problems of a" in res.output and "-state loop matrix" in res.output


def test_certify_over_budget_is_stopped(tmp_path):
    out = tmp_path / "c.yaml"
    assert _run(["export", "--allow-uncertified", str(EXAMPLES / "paper.yaml"), "--sample-rate-hz", "1000", "-o", str(out)]).exit_code == 0
    res = _run(["certify", str(out), "--time-budget-s", "0.01"])
    assert res.exit_code == 2 and "--time-budget-s: certifying c.yaml" in res.output
    assert _run(["certify", str(out)]).exit_code in (0, 1)  # the default budget is ample at 1 kHz


def test_eig_seconds_times_a_huge_loop_at_the_probe_size_and_scales_by_the_cube(monkeypatch):
    """Three eigenvalue problems of a 4 018-state loop (a file padded with 2 000 filter sections)
    took 100 s just to estimate certify's cost; the estimate now times EIG_PROBE states."""
    import numpy as np

    import exotune.numerics.timebudget as tb

    sizes = []
    monkeypatch.setattr(tb.np.linalg, "eigvals", lambda a: sizes.append(a.shape[0]) or np.zeros(a.shape[0]))
    monkeypatch.setattr(tb.time, "perf_counter", iter(np.arange(100.0)).__next__)  # every timing: 1 s
    assert tb.eig_seconds(4 * tb.EIG_PROBE) == pytest.approx(64.0)
    assert max(sizes) == tb.EIG_PROBE
    sizes.clear()
    monkeypatch.setattr(tb.time, "perf_counter", iter(np.arange(100.0)).__next__)
    assert tb.eig_seconds(10) == pytest.approx(1.0) and sizes == [10, 10, 10]
