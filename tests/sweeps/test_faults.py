"""Fault suite of sweeps (issue 16): out of disk space (a small tmpfs in a private mount namespace),
read-only directories and concurrent runs. Each test runs where the environment allows it and is
skipped with the reason where not (SIGKILL and resume: tests/sweep/test_run.py)."""

from __future__ import annotations

import fcntl
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from exotune.errors import ConfigError
from exotune.plots.sweep_report import make_report
from exotune.sweeps import load_manifest, load_results, run_sweep
from exotune.sweeps.dataset import verified_manifest

ROOT = Path(__file__).resolve().parents[2]
PAPER = ROOT / "examples" / "paper.yaml"


def _spec(tmp: Path, chunk_size=1) -> Path:
    p = tmp / "spec.yaml"
    p.write_text(yaml.safe_dump({"base": str(PAPER), "chunk_size": chunk_size, "axes": {
        "design.amplification": [2.0, 4.0, 8.0, 12.0, 20.0],
        "implementation.delay_s": [0.0, 0.001, 0.002, 0.003, 0.004]}}, sort_keys=False))
    return p


def _can_mount_tmpfs(tmp: Path) -> str | None:
    """None when a private mount namespace with a tmpfs works here, else the reason."""
    if shutil.which("unshare") is None:
        return "no unshare(1) on this system"
    probe = tmp / "probe"
    probe.mkdir()
    r = subprocess.run(["unshare", "-rm", "sh", "-c", f"mount -t tmpfs -o size=64k tmpfs {probe}"],
                       capture_output=True, text=True)
    if r.returncode != 0:
        return f"cannot mount a tmpfs in a user/mount namespace ({r.stderr.strip()[:120] or r.returncode})"
    return None


def test_out_of_space_leaves_a_consistent_sweep(tmp_path):
    """ENOSPC half-way: the run ends with one line (exit 1, no traceback); every chunk that made it
    to disk is recognized by `report` and by a resumed run, which completes the dataset exactly."""
    why = _can_mount_tmpfs(tmp_path)
    if why:
        pytest.skip(why)
    spec = _spec(tmp_path)
    mnt, saved = tmp_path / "mnt", tmp_path / "saved"
    mnt.mkdir()
    script = (f"mount -t tmpfs -o size=200k tmpfs {mnt} && "
              f"{sys.executable} -m exotune sweep {spec} -o {mnt}/out --workers 1 2> {tmp_path}/err.txt; "
              f"echo $? > {tmp_path}/rc.txt; cp -a {mnt}/out {saved}; "
              f"{sys.executable} -m exotune report {mnt}/out -o {mnt}/rep 2> {tmp_path}/rep_err.txt; "
              f"echo $? > {tmp_path}/rep_rc.txt; ls -A {mnt} > {tmp_path}/ls.txt")
    subprocess.run(["unshare", "-rm", "sh", "-c", script], check=True, timeout=300)
    rc = int((tmp_path / "rc.txt").read_text())
    err = (tmp_path / "err.txt").read_text()
    assert rc == 1 and "Traceback" not in err, err
    last = err.replace("\r", "\n").strip().splitlines()[-1]
    assert last.startswith("exotune: error: ") and "No space left on device" in last, last
    # the disk is still full: `report -o` fails with one line and leaves no partial report behind
    rep_err = (tmp_path / "rep_err.txt").read_text()
    assert int((tmp_path / "rep_rc.txt").read_text()) == 2 and rep_err.startswith("exotune: error: "), rep_err
    assert (tmp_path / "ls.txt").read_text().split() == ["out"]
    on_disk = sorted(p.name for p in (saved / "chunks").glob("part-*.parquet"))
    assert 0 < len(on_disk) < 25
    m = verified_manifest(saved)  # what `report` sees: every chunk on disk recorded, the run interrupted
    assert [c["file"].split("/")[-1] for c in m["chunks"] if c["status"] == "done"] == on_disk
    assert m["status"] == "interrupted" and load_manifest(saved)["status"] == "interrupted"
    md = (make_report(saved, tmp_path / "rep").directory / "summary.md").read_text(encoding="utf-8")
    assert f"designs: {len(on_disk)} of 25" in md
    m = run_sweep(spec, saved, workers=1, progress=False).to_dict()  # room again: the rest is computed
    assert m["status"] == "complete" and m["runs"][-1]["chunks_computed"] == 25 - len(on_disk)
    run_sweep(spec, tmp_path / "clean", workers=1, progress=False)
    a, b = load_results(saved), load_results(tmp_path / "clean")
    assert json.dumps(a.to_dict("list"), default=str) == json.dumps(b.to_dict("list"), default=str)


@pytest.mark.skipif(hasattr(os, "geteuid") and os.geteuid() == 0,
                    reason="running as root: permissions are not enforced, a read-only directory stays writable")
def test_read_only_directory_is_an_input_error(tmp_path):
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o555)
    try:
        with pytest.raises(ConfigError, match="cannot create the output directory"):
            run_sweep(_spec(tmp_path), ro / "out", workers=1, progress=False)
        assert os.listdir(ro) == []
    finally:
        ro.chmod(0o755)


def test_read_only_mount(tmp_path):
    """A read-only file system (a read-only bind mount: enforced for root too): a sweep into it is
    one line, exit 2, nothing created; `report` of an interrupted sweep on it still reads it (the
    reconciled manifest cannot be recorded there) and writes its report elsewhere."""
    why = _can_mount_tmpfs(tmp_path)
    if why:
        pytest.skip(why)
    spec = _spec(tmp_path, chunk_size=13)
    ro = tmp_path / "ro"
    run_sweep(spec, ro / "done", workers=1, progress=False)
    m = json.loads((ro / "done" / "manifest.json").read_text())
    m["chunks"][1].update(status="pending", sha256=None)
    m["status"] = "running"
    (ro / "done" / "manifest.json").write_text(json.dumps(m))
    text = (ro / "done" / "manifest.json").read_text()
    script = (f"mount --bind {ro} {ro} && mount -o remount,ro,bind {ro} && "
              f"{{ {sys.executable} -m exotune sweep {spec} -o {ro}/new --workers 1 2> {tmp_path}/err.txt; "
              f"echo $? > {tmp_path}/rc.txt; "
              f"{sys.executable} -m exotune report {ro}/done -o {tmp_path}/rep 2> {tmp_path}/rep_err.txt; "
              f"echo $? > {tmp_path}/rep_rc.txt; }}")
    r = subprocess.run(["unshare", "-rm", "sh", "-c", script], capture_output=True, text=True, timeout=300)
    if r.returncode != 0:
        pytest.skip(f"cannot make a read-only bind mount here ({r.stderr.strip()[:120]})")
    err = (tmp_path / "err.txt").read_text()
    assert int((tmp_path / "rc.txt").read_text()) == 2 and err.count("\n") == 1, err
    assert err.startswith("exotune: error: ") and "Traceback" not in err
    assert not (ro / "new").exists()
    assert int((tmp_path / "rep_rc.txt").read_text()) == 0, (tmp_path / "rep_err.txt").read_text()
    md = (tmp_path / "rep" / "summary.md").read_text(encoding="utf-8")
    assert "designs: 25 of 25" in md
    assert (ro / "done" / "manifest.json").read_text() == text


def test_concurrent_run_is_refused(tmp_path):
    """A second run in the same directory while the first holds the lock is refused, writing
    nothing; a report during the run reads without writing the manifest."""
    spec = _spec(tmp_path, chunk_size=25)
    out = tmp_path / "out"
    run_sweep(spec, out, workers=1, progress=False)
    text = (out / "manifest.json").read_text()
    with open(out / ".lock", "a+") as fh:  # the first run, still running
        fcntl.flock(fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        with pytest.raises(ConfigError, match="another exotune sweep is running"):
            run_sweep(spec, out, workers=1, progress=False)
        verified_manifest(out)
    assert (out / "manifest.json").read_text() == text
