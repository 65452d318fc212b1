"""Sweeps (docs/sweep-spec.md): grid/sampling arithmetic, strict spec validation, chunked Parquet output that
agrees with analyze_batch, identical results for every backend (in-process, local processes,
Dask), kill -9 and resume, refusal of a different spec, and reporting of failing chunks."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml
from click.testing import CliRunner
from hypothesis import given
from hypothesis import strategies as st

from exotune import __version__
from exotune.analysis import analyze_batch
from exotune.cli import cli
from exotune.config import batch_config, load_design
from exotune.errors import ConfigError
from exotune.sweeps import SweepError, SweepProgress, load_manifest, load_results, load_spec, run_sweep

ROOT = Path(__file__).resolve().parents[2]
PAPER = ROOT / "examples" / "paper.yaml"

AMP = [2.0, 8.0, 20.0]
DELAYS = [0.0, 0.002, 0.004]


def write_spec(tmp: Path, axes=None, chunk_size=2, name="spec.yaml", base=None) -> Path:
    spec = {
        "base": str(PAPER) if base is None else base,
        "axes": axes if axes is not None else {
            "design.amplification": AMP,
            "implementation.delay_s": {"start": 0.0, "stop": 0.004, "num": 3},
        },
        "chunk_size": chunk_size,
    }
    p = tmp / name
    p.write_text(yaml.safe_dump(spec, sort_keys=False), encoding="utf-8")
    return p


def assert_frames_equal(a: pd.DataFrame, b: pd.DataFrame) -> None:
    assert list(a.columns) == list(b.columns)
    assert len(a) == len(b)
    for c in a.columns:
        x, y = a[c].tolist(), b[c].tolist()
        assert json.dumps(x, default=str) == json.dumps(y, default=str), c


@pytest.fixture(scope="module")
def ref(tmp_path_factory):
    """Uninterrupted in-process run of the 3 × 3 spec with chunk_size 2 (5 chunks)."""
    d = tmp_path_factory.mktemp("ref")
    spec = write_spec(d)
    out = d / "out"
    manifest = run_sweep(spec, out, workers=1, progress=False).to_dict()
    return spec, out, manifest, load_results(out)


# --------------------------------------------------------------------------------------------
# output format and agreement with analyze_batch
# --------------------------------------------------------------------------------------------
def test_run_sweep_returns_the_sweep_on_disk(ref):
    """run_sweep's SweepResult is the sweep as written: its manifest is manifest.json and its
    table() the Parquet rows load_results reads."""
    from exotune.sweeps import SweepResult

    spec, out, m, df = ref
    on_disk = SweepResult.from_directory(out)
    assert json.loads(json.dumps(m)) == json.loads((out / "manifest.json").read_text()) == on_disk.to_dict()
    assert on_disk.status == "complete" and on_disk.points_total == len(df) == on_disk.table().num_rows


def test_layout_columns_and_manifest(ref):
    spec, out, m, df = ref
    assert len(df) == 9
    files = sorted(os.listdir(out / "chunks"))
    assert files == [f"part-{i:06d}.parquet" for i in range(5)]
    for c in ("point_index", "design.amplification", "implementation.delay_s", "free_stable",
              "human0_mass_robust", "human0_mass_stable_intervals", "human1_spring_robust",
              "passivity_max_phase_excess_deg", "passivity_nonpassive_band_hz", "dob_phase_margin_deg",
              "dob_gain_margin_db", "dob_delay_margin_s", "amplification_dc", "amplification_bandwidth_hz",
              "K1", "B1", "K2", "B2", "K2_hat", "B2_hat"):
        assert c in df.columns, c
    assert df["point_index"].tolist() == list(range(9))
    # C order: the last axis varies fastest
    assert df["design.amplification"].tolist() == [a for a in AMP for _ in DELAYS]
    assert np.allclose(df["implementation.delay_s"], DELAYS * 3)
    assert df["free_stable"].dtype == bool and df["dob_delay_margin_s"].dtype == float
    assert all(isinstance(iv, list) and all(len(x) == 2 for x in iv) for iv in df["human0_mass_stable_intervals"])

    mm = load_manifest(out)
    assert mm == json.loads((out / "manifest.json").read_text())
    assert m["spec_hash"] == mm["spec_hash"] and len(mm["spec_hash"]) == 64
    assert mm["exotune_version"] == __version__
    assert mm["n_points"] == 9 and mm["chunk_size"] == 2 and mm["n_chunks"] == 5 and mm["status"] == "complete"
    assert [c["status"] for c in mm["chunks"]] == ["done"] * 5
    assert [c["rows"] for c in mm["chunks"]] == [2, 2, 2, 2, 1]
    assert all(c["seconds"] > 0 for c in mm["chunks"])
    assert mm["timings"]["designs_per_s_last_run"] > 0 and mm["runs"][-1]["points_computed"] == 9
    assert mm["spec"]["base"]["plant"]["sea_stiffness"] == 1180.0
    assert mm["spec"]["axes"]["implementation.delay_s"]["values"] == [0.0, 0.002, 0.004]
    assert mm["created"] and mm["updated"]
    assert mm["model"].startswith("continuous-time") and "sample_rate_hz" not in mm["model"]
    # Arrow types are fixed (not inferred per chunk)
    types = dict(map(tuple, mm["columns"]))
    assert types["human0_mass_stable_intervals"] == "list<list<double>>"
    assert types["human1_spring_critical"] == "list<list<double>>"
    assert types["free_rigid_body_roots"] == "int64" and types["point_index"] == "int64"


def test_values_agree_with_analyze_batch(ref):
    _, _, _, df = ref
    cfg = load_design(PAPER)
    a = np.repeat(AMP, 3)
    t = np.tile(DELAYS, 3)
    direct = analyze_batch(batch_config(cfg, {"design.amplification": a, "implementation.delay_s": t}),
                           latency=True).to_columns()
    assert set(direct) <= set(df.columns) and "latency_margin_s" in direct
    for k, v in direct.items():
        if isinstance(v, np.ndarray) and v.dtype == bool:
            assert df[k].tolist() == v.tolist(), k
        elif isinstance(v, np.ndarray):
            np.testing.assert_allclose(df[k].to_numpy(float), v.astype(float), rtol=1e-9, atol=1e-12, err_msg=k)
        else:
            got = df[k].tolist()
            assert [len(r) for r in got] == [len(r) for r in v], k
            for gr, vr in zip(got, v):
                np.testing.assert_allclose(np.asarray(gr, float).reshape(-1), np.asarray(vr, float).reshape(-1),
                                           rtol=1e-9, err_msg=k)


def test_local_processes_identical(ref, tmp_path):
    spec, _, _, df = ref
    m = run_sweep(spec, tmp_path / "p2", workers=2, progress=False).to_dict()
    assert m["runs"][-1]["backend"] == "local-processes" and m["runs"][-1]["workers"] == 2
    assert_frames_equal(load_results(tmp_path / "p2"), df)


def test_dask_localcluster_identical(ref, tmp_path):
    distributed = pytest.importorskip("distributed")
    spec, _, _, df = ref
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster:
        m = run_sweep(spec, tmp_path / "dk", dask_address=cluster.scheduler_address, progress=False).to_dict()
    assert m["runs"][-1]["backend"] == "dask"
    assert sorted(os.listdir(tmp_path / "dk" / "chunks")) == [f"part-{i:06d}.parquet" for i in range(5)]
    assert_frames_equal(load_results(tmp_path / "dk"), df)


def test_rerun_complete_is_noop_and_cli(ref, tmp_path):
    spec, out, _, df = ref
    before = {f: os.stat(out / "chunks" / f).st_mtime_ns for f in os.listdir(out / "chunks")}
    m = run_sweep(spec, out, workers=1, progress=False).to_dict()
    assert m["runs"][-1]["chunks_skipped"] == 5 and m["runs"][-1]["chunks_computed"] == 0
    assert before == {f: os.stat(out / "chunks" / f).st_mtime_ns for f in os.listdir(out / "chunks")}
    # the CLI on the same directory: resumes (nothing to do), exit 0
    res = CliRunner().invoke(cli, ["sweep", str(spec), "-o", str(out), "--workers", "1"])
    assert res.exit_code == 0, res.output
    assert_frames_equal(load_results(out), df)
    lines = res.stderr.replace("\r", "\n").splitlines()
    assert lines[0] == "exotune sweep: 9 designs in 5 chunks of 2 (in-process); resuming: 5 of 5 chunks already done"
    assert lines[-1].startswith("exotune sweep: complete — 0 designs computed in ") and lines[-1].endswith(str(out))
    # the library prints nothing; a function given as ``progress`` receives the same lines
    got = []
    run_sweep(spec, out, workers=1, progress=got.append)
    assert got[0] == lines[0] and got[1].startswith("exotune sweep: complete — 0 designs") and len(got) == 2
    with pytest.raises(TypeError, match="progress must be"):
        run_sweep(spec, out, workers=1, progress=True)


# --------------------------------------------------------------------------------------------
# kill -9 and resume
# --------------------------------------------------------------------------------------------
def test_kill_and_resume_matches_uninterrupted(tmp_path):
    axes = {"design.amplification": [2.0, 4.0, 8.0, 20.0], "implementation.delay_s": [0.0, 0.001, 0.003]}
    spec = write_spec(tmp_path, axes=axes, chunk_size=1)
    killed, clean = tmp_path / "killed", tmp_path / "clean"
    code = (
        "import sys; from exotune.sweeps import run_sweep; "
        f"run_sweep({str(spec)!r}, {str(killed)!r}, workers=1, progress=False)"
    )
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    proc = subprocess.Popen([sys.executable, "-c", code], env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            d = killed / "chunks"
            if d.is_dir() and any(n.startswith("part-") for n in os.listdir(d)):
                break
            if proc.poll() is not None:
                pytest.fail(f"sweep subprocess ended early: {proc.communicate()}")
            time.sleep(0.01)
        else:
            pytest.fail("no chunk file appeared")
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait(10)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    done_before = sorted(n for n in os.listdir(killed / "chunks") if n.startswith("part-"))
    assert 1 <= len(done_before) < 12, done_before
    assert load_manifest(killed)["status"] == "running"  # killed mid-run
    with pytest.raises(ConfigError, match="incomplete"):
        load_results(killed)

    m = run_sweep(spec, killed, workers=1, progress=False).to_dict()
    assert m["status"] == "complete"
    assert m["runs"][-1]["chunks_skipped"] >= len(done_before)
    assert m["runs"][-1]["chunks_computed"] == 12 - m["runs"][-1]["chunks_skipped"]
    assert not [n for n in os.listdir(killed / "chunks") if n.startswith(".tmp-")]
    run_sweep(spec, clean, workers=1, progress=False)
    assert_frames_equal(load_results(killed), load_results(clean))


def _children(pid: int) -> list[int]:
    return [int(x) for x in subprocess.run(["pgrep", "-P", str(pid)], capture_output=True, text=True).stdout.split()]


def _big_sweep_process(tmp_path, num=300, ctrl_c=False, until="chunks"):
    """A local-process sweep long enough to be signalled while its workers run (``num`` × ``num``
    designs), returned once both workers have written a chunk (``until="chunks"``) or once they
    are started (``"workers"``: they may still be importing). ``ctrl_c``: in a session of its own,
    with Python's Ctrl-C handler (a test runner's worker may have SIGINT ignored, which its
    children inherit), so that ``os.killpg(pid, SIGINT)`` is a Ctrl-C in a terminal: the sweep and
    its workers receive it."""
    axes = {"design.amplification": {"start": 1.5, "stop": 20.0, "num": num, "scale": "log"},
            "implementation.delay_s": {"start": 0.0, "stop": 0.004, "num": num}}
    spec = write_spec(tmp_path, axes=axes, chunk_size=500)
    out = tmp_path / "out"
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    args = ["sweep", str(spec), "-o", str(out), "--workers", "2"]
    if ctrl_c:
        code = ("import signal, sys; signal.signal(signal.SIGINT, signal.default_int_handler); "
                f"from exotune.cli import main; main({args!r})")
        cmd = [sys.executable, "-c", code]
    else:
        cmd = [sys.executable, "-m", "exotune"] + args
    proc = subprocess.Popen(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=ctrl_c)
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:  # wait until both workers have written a chunk (or are started)
        d = out / "chunks"
        if until == "workers" and len(_children(proc.pid)) >= 2:
            break
        if d.is_dir() and sum(n.startswith("part-") for n in os.listdir(d)) >= 2:
            break
        if proc.poll() is not None:
            pytest.fail(f"sweep ended early: {proc.communicate()}")
        time.sleep(0.02)
    else:
        proc.kill()
        pytest.fail("no chunk file appeared")
    return proc, out, _children(proc.pid)


def _all_gone(pids, timeout=15.0) -> bool:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        alive = []
        for p in pids:
            try:
                os.kill(p, 0)
                with open(f"/proc/{p}/stat") as f:  # a zombie awaiting its (dead) parent counts as gone
                    if f.read().split(") ", 1)[1].startswith("Z"):
                        continue
                alive.append(p)
            except (ProcessLookupError, FileNotFoundError):
                pass
        if not alive:
            return True
        time.sleep(0.1)
    return False


@pytest.mark.skipif(not sys.platform.startswith("linux") or not os.path.isdir("/proc"), reason="Linux process table")
def test_workers_die_with_a_killed_sweep(tmp_path):
    """kill -9 of ``exotune sweep`` used to leave its worker processes blocked for ever (~200 MB
    each); they now end with their parent."""
    proc, out, kids = _big_sweep_process(tmp_path)
    try:
        assert kids, "the sweep has no worker processes"
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait(10)
        assert _all_gone(kids), "worker processes outlived the killed sweep"
    finally:
        for p in kids:
            with __import__("contextlib").suppress(ProcessLookupError):
                os.kill(p, signal.SIGKILL)


@pytest.mark.skipif(not sys.platform.startswith("linux") or not os.path.isdir("/proc"), reason="Linux process table")
def test_sigterm_interrupts_the_sweep_cleanly(tmp_path):
    """``kill PID`` ends the sweep like Ctrl-C: exit 143, the manifest says "interrupted", the
    workers end, and rerunning the command completes the dataset. The sweep is the 100 × 100 one of
    the Ctrl-C test (20 chunks): long enough to be signalled while both workers run, and the rerun
    that completes it computes at most 18 chunks instead of the 300 × 300 sweep's 178."""
    proc, out, kids = _big_sweep_process(tmp_path, num=100)
    os.kill(proc.pid, signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 143, err[-2000:]
    assert "rerun the same command" in err and "Traceback" not in err
    assert load_manifest(out)["status"] == "interrupted"
    assert _all_gone(kids)
    m = run_sweep(tmp_path / "spec.yaml", out, workers=1, progress=False).to_dict()
    assert m["status"] == "complete" and m["runs"][-1]["chunks_skipped"] >= 2


@pytest.mark.skipif(not sys.platform.startswith("linux") or not os.path.isdir("/proc"), reason="Linux process table")
def test_ctrl_c_interrupts_the_sweep_like_sigterm(tmp_path):
    """Ctrl-C used to end the sweep with click's "Aborted!" and exit 1, leaving the manifest
    "running" at times; it now stops it as SIGTERM does: the workers end at once, the finished
    chunks are kept, the manifest says "interrupted", one line says how to resume, exit 130; and
    rerunning the command completes the dataset."""
    proc, out, kids = _big_sweep_process(tmp_path, num=100, ctrl_c=True)
    try:
        os.killpg(proc.pid, signal.SIGINT)  # a terminal's Ctrl-C: the sweep and its workers
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 130, err[-2000:]
    assert "Traceback" not in err and "Aborted" not in err and "KeyboardInterrupt" not in err, err[-2000:]
    last = err.strip().splitlines()[-1]
    assert last.startswith("exotune sweep: interrupted (Ctrl-C): ") and last.endswith("rerun the same command to resume")
    m = load_manifest(out)
    done = sum(c["status"] == "done" for c in m["chunks"])
    assert m["status"] == "interrupted" and f"{done} of 20 chunks done" in last and done >= 2
    assert not any(c["status"] == "failed" for c in m["chunks"])  # the workers' chunks in progress did not fail
    assert _all_gone(kids, timeout=5.0)
    res = subprocess.run([sys.executable, "-m", "exotune", "sweep", str(tmp_path / "spec.yaml"), "-o", str(out),
                          "--workers", "2"], capture_output=True, text=True, timeout=300,
                         env=dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", "")))
    assert res.returncode == 0, res.stderr[-2000:]
    m = load_manifest(out)
    assert m["status"] == "complete" and m["runs"][-1]["chunks_skipped"] >= done
    assert len(load_results(out)) == 100 * 100


@pytest.mark.skipif(not sys.platform.startswith("linux") or not os.path.isdir("/proc"), reason="Linux process table")
def test_ctrl_c_while_the_workers_start_prints_no_traceback(tmp_path):
    """A Ctrl-C that reached a worker still importing exotune (before it ignores SIGINT) ended it
    with a KeyboardInterrupt traceback. The workers start with SIGINT blocked: whenever Ctrl-C
    comes, the sweep alone handles it."""
    proc, out, kids = _big_sweep_process(tmp_path, num=100, ctrl_c=True, until="workers")
    try:
        time.sleep(0.5)  # the workers are starting up (importing)
        os.killpg(proc.pid, signal.SIGINT)
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 130, err[-2000:]
    assert "Traceback" not in err and "KeyboardInterrupt" not in err, err[-2000:]
    assert err.strip().splitlines()[-1].endswith("rerun the same command to resume")
    assert load_manifest(out)["status"] == "interrupted"
    assert _all_gone(kids, timeout=5.0)


def test_an_interrupted_in_process_sweep_exits_130_and_resumes(tmp_path, monkeypatch):
    """A KeyboardInterrupt while a chunk is computed (``--workers 1``): exit 130 (not click's
    "Aborted!", exit 1), the finished chunks recorded, the manifest "interrupted", the line saying
    how to resume; the same command then completes the sweep."""
    from exotune.sweeps import backends

    spec = write_spec(tmp_path)
    out = tmp_path / "out"
    real = backends.chunk_task

    def interrupted_at_chunk_2(spec_, h, i, out_dir):
        if i == 2:
            raise KeyboardInterrupt
        return real(spec_, h, i, out_dir)

    monkeypatch.setattr(backends, "chunk_task", interrupted_at_chunk_2)
    res = CliRunner().invoke(cli, ["sweep", str(spec), "-o", str(out), "--workers", "1"])
    assert res.exit_code == 130, res.output
    assert "Aborted" not in res.output
    assert res.stderr.strip().splitlines()[-1] == (
        f"exotune sweep: interrupted (Ctrl-C): 2 of 5 chunks done, kept in {out} (manifest status: interrupted); "
        "rerun the same command to resume")
    m = load_manifest(out)
    assert m["status"] == "interrupted" and [c["status"] for c in m["chunks"]] == ["done"] * 2 + ["pending"] * 3
    assert m["runs"][-1]["finished"] is not None
    monkeypatch.setattr(backends, "chunk_task", real)
    res = CliRunner().invoke(cli, ["sweep", str(spec), "-o", str(out), "--workers", "1"])
    assert res.exit_code == 0, res.output
    m = load_manifest(out)
    assert m["status"] == "complete" and m["runs"][-1]["chunks_skipped"] == 2 and m["runs"][-1]["chunks_computed"] == 3


# --------------------------------------------------------------------------------------------
# refusals and bad specs
# --------------------------------------------------------------------------------------------
def test_different_spec_refused(ref, tmp_path):
    _, out, _, _ = ref
    other = write_spec(tmp_path, axes={"design.amplification": [2.0, 3.0]})
    before = (out / "manifest.json").read_text()
    with pytest.raises(ConfigError, match="holds a sweep of a different spec") as e:
        run_sweep(other, out, workers=1, progress=False)
    assert "use a new directory" in str(e.value) and "axes" in str(e.value)
    # same spec, other chunk size: different layout, also refused
    spec = write_spec(tmp_path, chunk_size=3, name="spec3.yaml")
    with pytest.raises(ConfigError, match="different spec"):
        run_sweep(spec, out, workers=1, progress=False)
    # --sample on a full-grid directory
    with pytest.raises(ConfigError, match="different spec"):
        run_sweep(ref[0], out, workers=1, sample=3, seed=1, progress=False)
    assert (out / "manifest.json").read_text() == before
    # the CLI: exit 2, one line
    res = CliRunner().invoke(cli, ["sweep", str(other), "-o", str(out), "--workers", "1"])
    assert res.exit_code == 2
    assert res.stderr.strip().startswith("exotune: error: ") and "different spec" in res.stderr
    assert len(res.stderr.strip().splitlines()) == 1


BAD = [
    ({"axes": {"design.amplification": [2.0]}}, "base"),
    ({"base": "PAPER", "axes": {"design.amplification": [2.0]}, "extra": 1}, "extra"),
    ({"base": "PAPER"}, "axes"),
    ({"base": "PAPER", "axes": {}}, "axes"),
    ({"base": "PAPER", "axes": [1, 2]}, "axes"),
    ({"base": "PAPER", "axes": {"design.amplification": []}}, "axes.design.amplification"),
    ({"base": "PAPER", "axes": {"design.amplification": [2.0, "x"]}}, "axes.design.amplification[1]"),
    ({"base": "PAPER", "axes": {"design.amplification": [2.0, True]}}, "axes.design.amplification[1]"),
    ({"base": "PAPER", "axes": {"design.amplification": [2.0, 2.0]}}, "axes.design.amplification[1]"),
    ({"base": "PAPER", "axes": {"design.amplification": [0.5, 2.0]}}, "axes.design.amplification"),
    ({"base": "PAPER", "axes": {"design.amplification": 3.0}}, "axes.design.amplification"),
    ({"base": "PAPER", "axes": {"design.amplification": {"start": 2, "stop": 3, "num": 0}}}, "axes.design.amplification.num"),
    ({"base": "PAPER", "axes": {"design.amplification": {"start": 2, "stop": 3, "num": 2.5}}}, "axes.design.amplification.num"),
    ({"base": "PAPER", "axes": {"design.amplification": {"start": 2, "num": 3}}}, "axes.design.amplification.stop"),
    ({"base": "PAPER", "axes": {"design.amplification": {"start": 2, "stop": 3, "num": 3, "step": 1}}},
     "axes.design.amplification.step"),
    ({"base": "PAPER", "axes": {"design.amplification": {"start": 2, "stop": 3, "num": 3, "scale": "cubic"}}},
     "axes.design.amplification.scale"),
    ({"base": "PAPER", "axes": {"implementation.delay_s": {"start": 0.0, "stop": 0.005, "num": 3, "scale": "log"}}},
     "axes.implementation.delay_s.start"),
    ({"base": "PAPER", "axes": {"design.zeta": {"start": 0.5, "stop": -1.0, "num": 3, "scale": "log"}}},
     "axes.design.zeta.stop"),
    ({"base": "PAPER", "axes": {"design.bogus": [1.0]}}, "axes.design.bogus"),
    ({"base": "PAPER", "axes": {"humans[0].inertia": [1.0]}}, "axes.humans[0].inertia"),
    ({"base": "PAPER", "axes": {"design.amplification": [2.0]}, "chunk_size": 0}, "chunk_size"),
    ({"base": "PAPER", "axes": {"design.amplification": [2.0]}, "chunk_size": "big"}, "chunk_size"),
    ({"base": "nonexistent.yaml", "axes": {"design.amplification": [2.0]}}, "base"),
    ({"base": {"plant": {}}, "axes": {"design.amplification": [2.0]}}, "base.plant"),
    # found by fuzzing (session 6): each used to traceback, exhaust memory or fail every chunk
    ({"base": "PAPER", "axes": {"design.zeta": [10**400]}}, "axes.design.zeta[0]"),
    ({"base": "PAPER", "axes": {"design.zeta": {"start": 0.5, "stop": 10**400, "num": 3}}}, "axes.design.zeta.stop"),
    ({"base": "PAPER", "axes": {"design.zeta": {"start": 0.5, "stop": 2.0, "num": 10**23}}}, "axes.design.zeta.num"),
    ({"base": "PAPER", "axes": {"design.zeta": {"start": 0.5, "stop": 2.0, "num": 100_001}}}, "axes.design.zeta.num"),
    ({"base": "PAPER", "axes": {"design.amplification": {"start": 1.0, "stop": 1.0000000000000004, "num": 5}}},
     "axes.design.amplification"),
    ({"base": "PAPER", "axes": {"design.amplification": [2.0]}, "verify_points": 10**12}, "verify_points"),
    ({"base": "NOGV", "axes": {"design.zeta": [0.5, 0.7]}}, "base.implementation.gv_filter"),
    ({"base": "DISCRETE", "axes": {"implementation.delay_s": [0.001, 2.0]}}, "axes.implementation.delay_s"),
]


def _variant_base(kind: str):
    raw = yaml.safe_load(PAPER.read_text())
    if kind == "NOGV":
        del raw["implementation"]["gv_filter"]
    else:
        raw["implementation"]["sample_rate_hz"] = 1000.0
    return raw


@pytest.mark.parametrize("spec,field", BAD, ids=[f for _, f in BAD])
def test_bad_spec_names_the_field(tmp_path, spec, field):
    spec = {k: (str(PAPER) if v == "PAPER" else _variant_base(v) if v in ("NOGV", "DISCRETE") else v)
            for k, v in spec.items()}
    p = tmp_path / "bad.yaml"
    p.write_text(yaml.safe_dump(spec), encoding="utf-8")
    out = tmp_path / "out"
    with pytest.raises(ConfigError) as e:
        run_sweep(p, out, workers=1, progress=False)
    assert e.value.field.startswith(field), (e.value.field, str(e.value))
    assert not out.exists()  # nothing half-written


def test_bad_options_and_cli_exit_code(tmp_path):
    spec = write_spec(tmp_path)
    for kw, field in (({"sample": 10, "seed": 1}, "sample"), ({"seed": 3}, "seed"),
                      ({"sample": 2, "seed": -1}, "seed"), ({"workers": 0}, "workers")):
        with pytest.raises(ConfigError) as e:
            run_sweep(spec, tmp_path / "o", progress=False, **kw)
        assert e.value.field == field
    assert not (tmp_path / "o").exists()
    bad = tmp_path / "bad.yaml"
    bad.write_text(f"base: {PAPER}\naxes:\n  design.amplification: {{start: 0.5, stop: 2.0, num: 3}}\n")
    res = CliRunner().invoke(cli, ["sweep", str(bad), "-o", str(tmp_path / "o")])
    assert res.exit_code == 2
    assert res.stderr.startswith("exotune: error: axes.design.amplification: ")
    assert "Traceback" not in res.output and not (tmp_path / "o").exists()
    dup = tmp_path / "dup.yaml"
    dup.write_text(f"base: {PAPER}\naxes:\n  design.zeta: [0.5]\n  design.zeta: [0.6]\n")
    with pytest.raises(ConfigError):
        load_spec(dup)


def test_axis_expansion_and_inline_base(tmp_path):
    base = yaml.safe_load(PAPER.read_text())
    plan = load_spec({"base": base, "axes": {
        "design.amplification": {"start": 2.0, "stop": 20.0, "num": 4, "scale": "log"},
        "implementation.gv_filter.cutoff_hz": {"start": 20.0, "stop": 200.0, "num": 1},
        "design.zeta_hat": [0.9, 0.5]}})
    np.testing.assert_allclose(plan.values[0], [2.0, 2.0 * 10 ** (1 / 3), 2.0 * 10 ** (2 / 3), 20.0])
    assert plan.values[1].tolist() == [20.0] and plan.values[2].tolist() == [0.9, 0.5]
    assert plan.shape == (4, 1, 2) and plan.n_points == 8 and plan.chunk_size == 10000 and plan.n_chunks == 1
    # a file base and the same inline base hash identically (content, not path)
    p1 = load_spec({"base": str(PAPER), "axes": {"design.zeta": [0.5]}})
    p2 = load_spec({"base": base, "axes": {"design.zeta": [0.5]}})
    assert p1.hash == p2.hash
    assert load_spec({"base": base, "axes": {"design.zeta": [0.5]}}, sample=1, seed=0).hash != p1.hash


# --------------------------------------------------------------------------------------------
# sampling
# --------------------------------------------------------------------------------------------
def test_sampling_deterministic_uniform_without_replacement():
    base = str(PAPER)
    axes = {"design.amplification": {"start": 1.5, "stop": 20.0, "num": 7},
            "design.zeta": {"start": 0.3, "stop": 1.2, "num": 11},
            "implementation.delay_s": {"start": 0.0, "stop": 0.004, "num": 13}}
    total = 7 * 11 * 13

    def idx(sample, seed, chunk_size=None):
        plan = load_spec({"base": base, "axes": axes}, sample=sample, seed=seed, chunk_size=chunk_size)
        return plan, plan.grid_index(np.arange(plan.n_points))

    _, a = idx(200, 1)
    _, b = idx(200, 1)
    _, c = idx(200, 2)
    assert np.array_equal(a, b)
    assert not np.array_equal(a, c)
    assert len(set(a.tolist())) == 200 and a.min() >= 0 and a.max() < total
    # the first rows of a larger sample are the same points (prefix property of the permutation)
    _, d = idx(500, 1)
    assert np.array_equal(d[:200], a)
    # sample == grid size: a permutation of the whole grid
    _, full = idx(total, 5)
    assert sorted(full.tolist()) == list(range(total)) and not np.array_equal(full, np.arange(total))
    # chunks are generated independently: any chunk equals the slice of the whole
    plan, whole = idx(500, 1, chunk_size=37)
    from exotune.sweeps.plan import chunk_points

    g, vals = chunk_points(plan, 5)
    assert np.array_equal(g, whole[5 * 37: 6 * 37])
    ia, iz, it = np.unravel_index(g, plan.shape)
    assert np.array_equal(vals["design.zeta"], plan.values[1][iz])
    # no seed with --sample means seed 0 (recorded, so the same command resumes)
    p0 = load_spec({"base": base, "axes": axes}, sample=5)
    assert p0.seed == 0 and p0.spec["seed"] == 0
    # huge grids: index arithmetic only
    big = {f"design.{k}": {"start": 1.0, "stop": 2.0, "num": 1000} for k in ("amplification", "zeta", "zeta_hat")}
    pb = load_spec({"base": base, "axes": big}, sample=10**6, seed=3)
    gi = pb.grid_index(np.arange(10**6 - 1000, 10**6))
    assert gi.max() < 10**9 and len(set(gi.tolist())) == 1000


def test_sampled_sweep_rows(tmp_path):
    spec = write_spec(tmp_path, chunk_size=2)
    m = run_sweep(spec, tmp_path / "s", workers=1, sample=3, seed=7, progress=False).to_dict()
    assert m["n_points"] == 3 and m["sampling"]["seed"] == 7 and m["n_chunks"] == 2
    df = load_results(tmp_path / "s")
    plan = load_spec(spec, sample=3, seed=7)
    g = plan.grid_index(np.arange(3))
    assert df["point_index"].tolist() == g.tolist()
    ia, it = np.unravel_index(g, (3, 3))
    assert df["design.amplification"].tolist() == [AMP[i] for i in ia]
    assert np.allclose(df["implementation.delay_s"], [DELAYS[i] for i in it])


# --------------------------------------------------------------------------------------------
# failing chunks
# --------------------------------------------------------------------------------------------
def test_failing_chunk_reported_and_retried(ref, tmp_path, monkeypatch, capsys):
    import exotune.sweeps.compute as sw

    spec, _, _, df = ref
    real = sw.analyze_batch

    def flaky(cfg, *a, **k):
        hit = (np.asarray(cfg.implementation.delay_s) >= 0.002) & (np.asarray(cfg.design.amplification) == 8.0)
        if np.any(hit):  # grid points 4, 5 = (α 8, T 2 and 4 ms): every design of chunk 2 fails
            raise RuntimeError("boom in chunk")
        return real(cfg, *a, **k)

    monkeypatch.setattr(sw, "analyze_batch", flaky)
    out = tmp_path / "f"

    class Record(SweepProgress):
        def __init__(self):
            self.messages, self.done = [], 0

        def message(self, kind, text):
            self.messages.append((kind, text))

        def advance(self, n):
            self.done += n

    rec = Record()
    with pytest.raises(SweepError, match="1 of 5 chunks failed") as e:
        run_sweep(spec, out, workers=1, progress=rec)
    assert e.value.failed == [2]  # rows 4, 5 = (8, 0.002), (8, 0.004)
    assert e.value.exit_code == 1
    failed = [t for k, t in rec.messages if k == "chunk_failed"]
    assert len(failed) == 1 and failed[0].startswith("exotune: chunk 2 failed: ") and "boom in chunk" in failed[0]
    assert [k for k, _ in rec.messages] == ["start", "chunk_failed"] and rec.done == 9
    assert capsys.readouterr().err == ""  # the library itself never writes to the terminal
    m = load_manifest(out)
    assert m["status"] == "failed"
    assert [c["status"] for c in m["chunks"]] == ["done", "done", "failed", "done", "done"]
    assert "RuntimeError: boom in chunk" in m["chunks"][2]["error"]
    assert sorted(os.listdir(out / "chunks")) == [f"part-{i:06d}.parquet" for i in (0, 1, 3, 4)]
    # the CLI exits non-zero without a traceback
    res = CliRunner().invoke(cli, ["sweep", str(spec), "-o", str(out), "--workers", "1"])
    assert res.exit_code == 1 and "chunks failed" in res.stderr and "Traceback" not in res.output
    # fixed: rerunning computes only the failed chunk and matches the uninterrupted run
    monkeypatch.setattr(sw, "analyze_batch", real)
    m = run_sweep(spec, out, workers=1, progress=False).to_dict()
    assert m["status"] == "complete" and m["runs"][-1]["chunks_computed"] == 1
    assert_frames_equal(load_results(out), df)


def test_verify_points_option(tmp_path):
    """`verify_points: N` in a sweep spec checks every family's intervals with exact counts and
    stores the number of mismatches per design (0 for a correct analysis)."""
    import yaml

    from exotune.sweeps import load_results, run_sweep

    spec = tmp_path / "spec.yaml"
    spec.write_text(yaml.safe_dump({
        "base": str(Path(__file__).resolve().parents[2] / "examples" / "paper.yaml"),
        "axes": {"design.amplification": [2.0, 8.0, 16.0]},
        "verify_points": 12,
    }))
    run_sweep(str(spec), str(tmp_path / "out"), workers=1, progress=False)
    df = load_results(str(tmp_path / "out"))
    cols = [c for c in df.columns if c.endswith("_verification_mismatches")]
    assert len(cols) == 3
    assert (df[cols].to_numpy() == 0).all()


def test_sweep_with_a_box_family(tmp_path):
    """A design with an msd box family sweeps to Parquet (robust flag; per-edge details are only in
    the single-design report)."""
    import yaml

    from exotune.sweeps import load_results, run_sweep

    base = yaml.safe_load((Path(__file__).resolve().parents[2] / "examples" / "paper.yaml").read_text())
    base["humans"] = [{"kind": "msd", "inertia": [0.002, 0.15], "damping": [0.01, 2.0], "stiffness": [2.0, 300.0]}]
    spec = tmp_path / "spec.yaml"
    spec.write_text(yaml.safe_dump({"base": base, "axes": {"design.amplification": [2.0, 8.0]}}))
    run_sweep(str(spec), str(tmp_path / "out"), workers=1, progress=False)
    df = load_results(str(tmp_path / "out"))
    assert "human0_msd_robust" in df.columns and not any(c.endswith("_edges") for c in df.columns)
    assert not df["human0_msd_robust"].any()  # 2 g·m² on the cuff destabilizes these designs



@given(st.lists(st.lists(st.lists(st.floats(allow_nan=False, width=64), max_size=3), max_size=4), max_size=6))
def test_nested_list_column_equals_pyarrow_conversion(rows):
    """The flat-offset construction of interval columns is the same Arrow array as pyarrow's own
    conversion of the nested Python lists (values, empties, inf)."""
    import pyarrow as pa

    from exotune.sweeps.store import nested_float_lists

    ref = pa.array(rows, type=pa.list_(pa.list_(pa.float64())))
    assert nested_float_lists(rows).equals(ref)



def test_manifest_says_a_sample_rate_is_not_simulated(tmp_path):
    """A base design with sample_rate_hz: the sweep is still the continuous analysis and says so
    (manifest ``model`` and the report's summary)."""
    from exotune.plots.sweep_report import make_report

    base = yaml.safe_load(PAPER.read_text())
    base["implementation"]["sample_rate_hz"] = 1000.0
    spec = write_spec(tmp_path, axes={"design.amplification": [4.0, 8.0]}, base=base)
    out = tmp_path / "out"
    run_sweep(spec, out, workers=1, progress=False)
    m = load_manifest(out)
    assert "sample_rate_hz = 1000 Hz" in m["model"] and "exotune analyze" in m["model"]
    make_report(out, tmp_path / "rep")
    assert "sample_rate_hz = 1000 Hz" in (tmp_path / "rep" / "summary.md").read_text()


@given(st.lists(st.floats(allow_nan=True, allow_infinity=True), min_size=0, max_size=40),
       st.integers(min_value=1, max_value=3))
def test_numpy_to_arrow_matches_pa_array(xs, step):
    """The buffer-built columns (no pandas import in the workers) equal pyarrow's own conversion,
    for float (NaN kept as a value), int64 and bool columns, strided inputs included."""
    import pyarrow as pa

    from exotune.sweeps.store import np_arrow

    f = np.array(xs, dtype=float)[::step]
    ints = np.arange(f.size, dtype=np.int64)[::-1] * 7 - 3
    bools = np.isfinite(f) & (np.nan_to_num(f) > 0)
    for v, kind, typ in ((f, "f", pa.float64()), (ints, "i", pa.int64()), (bools, "b", pa.bool_())):
        got = np_arrow(v, kind)
        want = pa.array(v, type=typ)
        assert got.type == want.type and len(got) == len(want) == v.size
        assert got.null_count == 0
        if kind == "f":
            np.testing.assert_array_equal(got.to_numpy(zero_copy_only=False), v)  # NaN == NaN here
        else:
            assert got.equals(want)


def test_chunk_task_does_not_import_pandas(tmp_path):
    """A worker's chunk (analysis, Arrow table, Parquet) never imports pandas (~1 s of start-up)."""
    spec = tmp_path / "s.yaml"
    spec.write_text(yaml.safe_dump({"base": str(PAPER), "axes": {"design.amplification": [2.0, 4.0]}}))
    code = ("import sys; from exotune.sweeps import load_spec; from exotune.sweeps.compute import chunk_task; "
            "p = load_spec(sys.argv[1]); "
            "r = chunk_task(p.spec, p.hash, 0, None); assert r['error'] is None and r['rows'] == 2, r; "
            "print('pandas' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code, str(spec)], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "False"


def _set_manifest(key, value):
    def mod(d: Path):
        m = json.loads((d / "manifest.json").read_text())
        m[key] = value
        (d / "manifest.json").write_text(json.dumps(m))
    return mod


def _corrupt_first_chunk(d: Path):
    first = sorted((d / "chunks").iterdir())[0]
    first.write_bytes(first.read_bytes()[:100])


@pytest.mark.parametrize("damage,field", [
    (_set_manifest("chunks", "x"), "chunks"),
    (_set_manifest("spec", None), "spec"),
    (_set_manifest("n_points", "many"), "n_points"),
    (_set_manifest("chunks", [{"index": 0}]), "chunks[0]"),
    (_set_manifest("chunks", [{"index": 0, "file": "../../etc/passwd", "status": "done"}]), "chunks[0].file"),
    (_corrupt_first_chunk, "part-000000.parquet"),
], ids=["chunks-str", "spec-null", "n_points-str", "chunk-entry", "chunk-outside", "chunk-truncated"])
def test_damaged_sweep_directory_is_an_input_error(ref, tmp_path, damage, field):
    """A manifest or chunk damaged by hand: `report` exits 2 naming the field or file (it was a
    TypeError traceback — found by fuzzing); a truncated chunk is recomputed by rerunning `sweep`."""
    import shutil

    spec, out, _, df = ref
    d = tmp_path / "d"
    shutil.copytree(out, d)
    damage(d)
    res = CliRunner().invoke(cli, ["report", str(d), "-o", str(tmp_path / "rep")])
    assert res.exit_code == 2, (res.exit_code, res.output, res.exception)
    assert "Traceback" not in res.output and field in res.output
    if field.endswith(".parquet"):  # resume recomputes the damaged chunk: the dataset is whole again
        res = CliRunner().invoke(cli, ["sweep", str(spec), "-o", str(d), "--workers", "1"])
        assert res.exit_code == 0, res.output
        assert_frames_equal(load_results(d), df)


def test_a_file_named_chunks_in_the_output_directory_is_named(tmp_path):
    """``sweep -o out`` with a file ``out/chunks`` said "-o: cannot create the output directory:
    File exists" (the directory named like the keyword, the path in the way not named). The file
    is named, before any work; nothing is written."""
    out = tmp_path / "out"
    out.mkdir()
    (out / "chunks").write_text("x")
    spec = {"base": str(PAPER), "axes": {"design.amplification": [2.0]}}
    with pytest.raises(ConfigError) as ei:
        run_sweep(spec, out, workers=1, progress=False)
    assert ei.value.field == str(out / "chunks")
    assert ei.value.reason.startswith("exists and is not a directory")
    assert sorted(os.listdir(out)) == ["chunks"] and (out / "chunks").read_text() == "x"
    res = CliRunner().invoke(cli, ["sweep", str(write_spec(tmp_path, axes={"design.amplification": [2.0]})),
                                   "-o", str(out), "--workers", "1"])
    assert res.exit_code == 2 and res.stderr.startswith(f"exotune: error: {out / 'chunks'}: exists and is not a "
                                                        "directory"), res.stderr
    assert sorted(os.listdir(out)) == ["chunks"]


def test_numpy_values_are_accepted_in_a_spec_and_as_keywords(tmp_path):
    """numpy scalars (and a 1-d array or tuple of axis values) are taken where Python numbers are."""
    spec = {"base": str(PAPER), "axes": {"design.amplification": np.array([2.0, 8.0]),
                                         "implementation.delay_s": (np.float64(0.0), 0.002)},
            "chunk_size": np.int64(2), "sampled": np.False_, "plant_margin": np.False_}
    r = run_sweep(spec, tmp_path / "a", workers=np.int8(1), sample=np.int64(3), seed=np.uint32(1), progress=False)
    assert r.status == "complete" and r.to_dict()["spec"]["axes"]["design.amplification"]["values"] == [2.0, 8.0]
    assert r.table().num_rows == 3
