"""exotune.numerics.beside: a computation in a forked child gives the serial result; any failure of
the child falls back to the caller; an abandoned child is killed and reaped.

The forking cases run in a fresh interpreter (one thread, its own first-run memory), so that they
do not depend on how the test runner's process was set up.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap

import pytest

from exotune.numerics import beside as B

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

SCRIPT = textwrap.dedent("""
    import json, os, signal, sys
    from exotune.numerics.beside import beside, can_fork

    PARENT = os.getpid()
    out = {"can_fork": can_fork()}

    def where(x):
        return (x * 2, os.getpid() != PARENT)

    # the first run of a key is serial, the second forks
    with beside("k", where, 21) as job:
        out["first"] = [job.forked, *job.result()]
    with beside("k", where, 21) as job:
        out["second"] = [job.forked, *job.result()]

    def fails_in_child():
        if os.getpid() != PARENT:
            raise RuntimeError("child only")
        return "parent"

    beside("f", fails_in_child).result()
    with beside("f", fails_in_child) as job:
        out["child_raises"] = [job.forked, job.result()]

    def killed_in_child():
        if os.getpid() != PARENT:
            os.kill(os.getpid(), signal.SIGKILL)
        return "parent"

    beside("s", killed_in_child).result()
    with beside("s", killed_in_child) as job:
        out["child_killed"] = [job.forked, job.result()]

    def unpicklable():
        return (lambda: None) if os.getpid() != PARENT else "parent"

    beside("u", unpicklable).result()
    with beside("u", unpicklable) as job:
        out["unpicklable"] = [job.forked, job.result()]

    def big():
        return bytes(range(256)) * 40000  # 10 MB: larger than a pipe's buffer

    beside("b", big).result()
    with beside("b", big) as job:
        out["big"] = [job.forked, job.result() == big()]

    def slow():
        import time
        time.sleep(30)

    beside("z", lambda: None).result()
    with beside("z", slow) as job:
        pid = job._pid
    out["reaped"] = None
    if pid is not None:
        try:  # closed without a result: killed and reaped (no zombie left behind)
            os.waitpid(pid, os.WNOHANG)
            out["reaped"] = False
        except ChildProcessError:
            out["reaped"] = True

    import time
    import exotune.numerics.beside as B

    def stalls_in_child():
        if os.getpid() != PARENT:
            time.sleep(30)
        return "parent"

    beside("t", stalls_in_child).result()
    B.STALL_S = 0.5
    t0 = time.monotonic()
    with beside("t", stalls_in_child) as job:
        out["stall"] = [job.forked, job.result(), time.monotonic() - t0 < 10]
    B.STALL_S = 600.0

    def raises_everywhere():
        raise ValueError("bad input")

    beside("e", lambda: None).result()
    try:
        with beside("e", raises_everywhere) as job:
            job.result()
    except ValueError as e:
        out["raises"] = str(e)
    print(json.dumps(out))
""")


def _run(env_extra=None) -> dict:
    env = {k: v for k, v in os.environ.items() if k != "EXOTUNE_SERIAL"}
    env.update(env_extra or {})
    p = subprocess.run([sys.executable, "-c", SCRIPT], capture_output=True, text=True, env=env, cwd=ROOT,
                       timeout=120)
    assert p.returncode == 0, p.stderr
    return json.loads(p.stdout.strip().splitlines()[-1])


def test_forked_child_gives_the_serial_result_and_failures_fall_back():
    out = _run()
    if not out["can_fork"]:
        pytest.skip("no fork or fewer than two usable CPUs here")
    assert out["first"] == [False, 42, False]  # serial, computed in the parent
    assert out["second"] == [True, 42, True]  # forked, computed in the child
    assert out["child_raises"] == [True, "parent"]
    assert out["child_killed"] == [True, "parent"]
    assert out["unpicklable"] == [True, "parent"]
    assert out["big"] == [True, True]
    assert out["reaped"] is True
    assert out["raises"] == "bad input"  # an error in both places propagates from the parent's run
    assert out["stall"] == [True, "parent", True]  # no result in time: killed, computed here


def test_exotune_serial_never_forks():
    out = _run({"EXOTUNE_SERIAL": "1"})
    assert out["can_fork"] is False
    assert out["second"] == [False, 42, False]
    assert out["child_raises"] == [False, "parent"]


def test_can_fork_refuses_a_threaded_process():
    import threading

    stop = threading.Event()
    t = threading.Thread(target=stop.wait)
    t.start()
    try:
        assert B.can_fork() is False
    finally:
        stop.set()
        t.join()


def test_serial_context_never_forks():
    """Inside serial() (a sweep's workers) nothing forks, whatever the process."""
    with B.serial():
        assert B.can_fork() is False
        job = B.beside(("test_serial_context_never_forks", 1), int, "7")
        job.result()
        job2 = B.beside(("test_serial_context_never_forks", 1), int, "8")
        assert job2.forked is False and job2.result() == 8
        job2.close()


def test_result_is_computed_once():
    calls = []

    def fn(x):
        calls.append(x)
        return x + 1

    job = B.beside(("test_result_is_computed_once", id(calls)), fn, 1)
    assert job.forked is False and job.key == ("test_result_is_computed_once", id(calls))  # a first run is serial
    assert job.result() == 2 and job.result() == 2
    assert calls == [1]
    job.close()


def test_one_shot_forks_on_the_first_run():
    """Inside one_shot() (the command line's declaration) a first run may fork already."""
    script = textwrap.dedent("""
        import json, os
        from exotune.numerics.beside import beside, can_fork, one_shot
        PARENT = os.getpid()
        with one_shot():
            with beside("first", lambda: os.getpid() != PARENT) as job:
                out = [can_fork(), job.forked, job.result()]
        with beside("other", lambda: os.getpid() != PARENT) as job:  # outside: serial first run
            out += [job.forked, job.result()]
        print(json.dumps(out))
    """)
    env = {k: v for k, v in os.environ.items() if k != "EXOTUNE_SERIAL"}
    p = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, env=env, cwd=ROOT, timeout=120)
    assert p.returncode == 0, p.stderr
    can, forked, in_child, forked2, in_child2 = json.loads(p.stdout.strip().splitlines()[-1])
    if not can:
        pytest.skip("no fork or fewer than two usable CPUs here")
    assert (forked, in_child, forked2, in_child2) == (True, True, False, False)
