"""exotune.sweeps.backends: Dask address validation, the in-process and local-process backends
computing the same chunks, and Ctrl-C (SIGINT) and SIGTERM stopping a sweep the same way."""

import os
import signal
from pathlib import Path

import pyarrow.parquet as pq
import pytest

from exotune.errors import ConfigError
from exotune.sweeps import backends
from exotune.sweeps.backends import check_dask_address, dispatch, stop_signals
from exotune.sweeps.spec import load_spec
from exotune.sweeps.store import chunk_file

ROOT = Path(__file__).resolve().parents[2]
PAPER = str(ROOT / "examples" / "paper.yaml")


@pytest.mark.parametrize("address, workers, expected", [
    ("local", 3, ("local", 3)),
    ("local:2", 5, ("local", 2)),
    ("tcp://10.0.0.1:8786", None, ("remote", None)),
    ("scheduler.example:8786", None, ("remote", None)),
    ("tls://[::1]:443", None, ("remote", None)),
    ("inproc://anything", None, ("remote", None)),
])
def test_valid_dask_addresses(address, workers, expected):
    assert check_dask_address(address, workers) == expected


def test_local_without_workers_uses_the_cpus():
    assert check_dask_address("local") == ("local", os.cpu_count() or 1)


@pytest.mark.parametrize("address, reason", [
    ("", "expected a scheduler address"),
    (None, "expected a scheduler address"),
    ("local:x", "expected 'local' or 'local:N'"),
    ("local:0", "local:N needs N >= 1, got 0"),
    ("host:0", "port 1 … 65535"),
    ("host:70000", "port 1 … 65535"),
    ("http://host:80", "expected a scheduler address [tcp://]host:port"),
    ("host", "expected a scheduler address"),
])
def test_bad_dask_addresses_name_the_dask_address_keyword(address, reason):
    with pytest.raises(ConfigError) as ei:
        check_dask_address(address)
    assert ei.value.field == "dask_address" and reason in ei.value.reason  # the command line: --dask


def test_dispatch_in_process_calls_back_every_chunk_in_order(monkeypatch, tmp_path):
    calls, records = [], []
    monkeypatch.setattr(backends, "chunk_task",
                        lambda spec, h, i, out: calls.append((h, i, out)) or {"index": i, "rows": 1, "error": None})

    class Plan:
        spec, hash = {"x": 1}, "h"

    dispatch(Plan, str(tmp_path), [2, 0, 1], records.append, "in-process", None, None, 1)
    assert calls == [("h", 2, str(tmp_path)), ("h", 0, str(tmp_path)), ("h", 1, str(tmp_path))]
    assert [r["index"] for r in records] == [2, 0, 1]
    dispatch(Plan, str(tmp_path), [], records.append, "local-processes", None, None, 2)  # nothing to do
    assert len(records) == 3


def test_local_processes_compute_the_same_rows_as_in_process(tmp_path):
    plan = load_spec({"base": PAPER, "axes": {"design.amplification": [2.0, 8.0]}, "chunk_size": 1})
    rows = {}
    for backend in ("in-process", "local-processes"):
        out = tmp_path / backend
        (out / "chunks").mkdir(parents=True)
        records = []
        dispatch(plan, str(out), [0, 1], records.append, backend, None, 1, 1)
        assert sorted(r["index"] for r in records) == [0, 1]
        assert all(r["error"] is None and r["rows"] == 1 for r in records)
        rows[backend] = [pq.read_table(chunk_file(str(out), i)).to_pylist() for i in (0, 1)]
    assert rows["in-process"] == rows["local-processes"]
    assert [r[0]["design.amplification"] for r in rows["in-process"]] == [2.0, 8.0]


def test_sigterm_ends_the_sweep_with_exit_143():
    before = signal.getsignal(signal.SIGTERM)
    with pytest.raises(SystemExit) as ei:
        with stop_signals() as stop:
            os.kill(os.getpid(), signal.SIGTERM)
    assert ei.value.code == 128 + signal.SIGTERM and stop.received == signal.SIGTERM
    assert signal.getsignal(signal.SIGTERM) == before


@pytest.fixture
def default_sigint():
    """Python's own Ctrl-C handler (a test runner's worker may start with SIGINT ignored)."""
    old = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, old)


def test_ctrl_c_stops_the_sweep_like_sigterm_and_a_second_one_is_ignored(default_sigint):
    """Ctrl-C used to reach the sweep as Python's KeyboardInterrupt anywhere, a second one cutting
    the manifest's write short (status left "running", click's "Aborted!", exit 1). The sweep now
    handles SIGINT as it handles SIGTERM: the first one stops it (KeyboardInterrupt, which the
    command line turns into exit 130), later ones are ignored while it records how it ended."""
    before_term = signal.getsignal(signal.SIGTERM)
    with pytest.raises(KeyboardInterrupt):
        with stop_signals() as stop:
            try:
                os.kill(os.getpid(), signal.SIGINT)
            except KeyboardInterrupt:
                os.kill(os.getpid(), signal.SIGINT)  # the second Ctrl-C: ignored
                os.kill(os.getpid(), signal.SIGTERM)  # so is a SIGTERM meanwhile
                raise
    assert stop.received == signal.SIGINT and stop.stopping
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    assert signal.getsignal(signal.SIGTERM) == before_term


def test_hold_ignores_signals_while_a_sweep_records_its_end(default_sigint):
    with stop_signals() as stop:
        stop.hold()
        os.kill(os.getpid(), signal.SIGINT)
        os.kill(os.getpid(), signal.SIGTERM)
    assert stop.received is None


def test_an_ignored_ctrl_c_stays_ignored():
    """A sweep started with SIGINT ignored (a background job of a script) does not take Ctrl-C over."""
    old = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        with stop_signals() as stop:
            assert signal.getsignal(signal.SIGINT) is signal.SIG_IGN
            os.kill(os.getpid(), signal.SIGINT)
        assert stop.received is None
    finally:
        signal.signal(signal.SIGINT, old)
