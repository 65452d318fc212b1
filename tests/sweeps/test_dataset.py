"""exotune.sweeps.dataset: reading a sweep back (verified manifest, finished chunks in row order,
partial sweeps) on a small sweep of the paper design."""

import shutil
from pathlib import Path

import numpy as np
import pyarrow as pa
import pytest

from exotune.errors import ConfigError
from exotune.sweeps import load_manifest, run_sweep
from exotune.sweeps.dataset import load_results, read_tables, verified_manifest

ROOT = Path(__file__).resolve().parents[2]
PAPER = str(ROOT / "examples" / "paper.yaml")
AXES = {"design.amplification": [2.0, 8.0], "implementation.delay_s": [0.0, 0.002]}


@pytest.fixture(scope="module")
def sweep(tmp_path_factory):
    out = tmp_path_factory.mktemp("sweep") / "out"
    run_sweep({"base": PAPER, "axes": AXES, "chunk_size": 3}, out, workers=1, progress=False)
    return out


def test_load_results_rows_in_grid_order(sweep):
    df = load_results(sweep)
    assert list(df.columns[:3]) == ["point_index", "design.amplification", "implementation.delay_s"]
    assert df["point_index"].tolist() == [0, 1, 2, 3]
    assert df["design.amplification"].tolist() == [2.0, 2.0, 8.0, 8.0]
    assert df["implementation.delay_s"].tolist() == [0.0, 0.002, 0.0, 0.002]
    # interval columns as lists of [lo, hi] (analyze_batch's format)
    iv = df["human0_mass_stable_intervals"].iloc[0]
    assert isinstance(iv, list) and all(len(p) == 2 and p[0] <= p[1] for p in iv)
    # the gains by the paper's formulas: K̂2 = α − 1
    assert np.allclose(df["K2_hat"], df["design.amplification"] - 1.0)


def test_columns_and_raw_nested(sweep):
    df = load_results(sweep, columns=["point_index", "free_stable"])
    assert list(df.columns) == ["point_index", "free_stable"] and df["free_stable"].dtype == bool
    raw = load_results(sweep, columns=["human0_mass_stable_intervals"], nested="raw")
    assert not isinstance(raw["human0_mass_stable_intervals"].iloc[0], list)


def test_read_tables_and_verified_manifest(sweep):
    m, table, missing = read_tables(str(sweep))
    assert isinstance(table, pa.Table) and table.num_rows == 4 and missing == []
    assert m["status"] == "complete" and [c["status"] for c in m["chunks"]] == ["done", "done"]
    assert verified_manifest(sweep)["spec_hash"] == m["spec_hash"]


def test_a_missing_chunk_makes_the_sweep_partial(sweep, tmp_path):
    copy = tmp_path / "copy"
    shutil.copytree(sweep, copy)
    (copy / "chunks" / "part-000001.parquet").unlink()
    with pytest.raises(ConfigError) as ei:
        load_results(copy)
    assert ei.value.field == str(copy) and "incomplete (1 of 2 chunks missing)" in ei.value.reason
    assert ei.value.reason.endswith("rerun `exotune sweep` with the same spec to compute chunk 1")
    # the sweep was complete: with a chunk file gone it no longer says so
    m = verified_manifest(copy)
    assert m["status"] == "incomplete" and [c["status"] for c in m["chunks"]] == ["done", "pending"]
    assert load_manifest(copy)["status"] == "incomplete"
    df = load_results(copy, allow_partial=True)
    assert df["point_index"].tolist() == [0, 1, 2]
    (copy / "chunks" / "part-000000.parquet").unlink()
    empty = load_results(copy, columns=["point_index"], allow_partial=True)
    assert list(empty.columns) == ["point_index"] and len(empty) == 0


def test_a_changed_chunk_is_refused_naming_it(sweep, tmp_path):
    copy = tmp_path / "copy"
    shutil.copytree(sweep, copy)
    p = copy / "chunks" / "part-000000.parquet"
    p.write_bytes(p.read_bytes()[:-20] + b"\0" * 20)
    with pytest.raises(ConfigError) as ei:
        load_results(copy)
    assert "part-000000.parquet" in str(ei.value)


def test_not_a_sweep_directory(tmp_path):
    with pytest.raises(ConfigError, match="not a sweep directory"):
        load_results(tmp_path)


@pytest.mark.parametrize("how", ["directory", "files"])
def test_a_sweep_whose_chunk_files_are_all_gone_is_incomplete_naming_them(sweep, tmp_path, monkeypatch, how):
    """``report`` after ``DIR/chunks`` was deleted said "-o: the sweep has no results yet (no chunk
    finished)" — no -o given (the directory was named ``out``, the keyword's name) and the manifest
    listing its done chunks. It is an incomplete sweep, as one that lost some chunk files is: the
    manifest records it, the report refuses it naming the missing chunks and how to compute them."""
    from exotune.api import report
    from exotune.sweeps.dataset import check_results_left

    monkeypatch.chdir(tmp_path)
    shutil.copytree(sweep, "out")
    if how == "directory":
        shutil.rmtree(Path("out") / "chunks")
    else:
        for p in (Path("out") / "chunks").iterdir():
            p.unlink()
    for _ in range(2):  # the second time from the reconciled manifest (every chunk pending, status incomplete)
        with pytest.raises(ConfigError) as ei:
            report("out")
        assert ei.value.field == "out" and ei.value.in_file  # a directory, never read as the option -o
        assert ei.value.reason.startswith("the sweep is incomplete (2 of 2 chunks missing: chunks 0, 1"
                                          + ("; the directory out/chunks is gone)" if how == "directory" else ")"))
        assert "rerun `exotune sweep` with the same spec and -o out to compute them" in ei.value.reason
        m = load_manifest("out")
        assert m["status"] == "incomplete" and [c["status"] for c in m["chunks"]] == ["pending", "pending"]
    assert not (Path("out") / "report").exists()
    check_results_left(sweep)  # chunks on disk: nothing to say
    run_sweep({"base": PAPER, "axes": AXES, "chunk_size": 3}, "out", workers=1, progress=False)  # resumes
    assert report("out").directory == Path("out") / "report"


def test_a_sweep_that_never_finished_a_chunk_is_left_to_the_reader(sweep, tmp_path):
    """No chunk ever finished (status interrupted, none done): not "incomplete"; the report says
    the sweep has no results yet, naming the directory (the command line names it as typed, never
    as the option -o, whose keyword ``out`` a directory may be named: test_hostile_inputs)."""
    from exotune.api import report
    from exotune.sweeps.manifest import write_manifest

    copy = tmp_path / "copy"
    shutil.copytree(sweep, copy)
    shutil.rmtree(copy / "chunks")
    m = load_manifest(copy)
    m["status"] = "interrupted"
    for c in m["chunks"]:
        c.update(status="pending", sha256=None, spec_hash=None)
    write_manifest(str(copy), m)
    with pytest.raises(ConfigError, match="no results yet") as ei:
        report(copy)
    assert ei.value.field == str(copy)
