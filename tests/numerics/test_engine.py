"""The engine switch (exotune.numerics.engine): single-design commands run on the numpy engine and
never compile a kernel; batches use the compiled kernels when numba is there."""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import pytest

from exotune.numerics import engine

ROOT = Path(__file__).resolve().parents[2]


def test_numpy_engine_context_is_scoped():
    before = engine.compiled()
    with engine.numpy_engine():
        assert engine.compiled() is False
        assert engine.resolve_engine(None) == "numpy"
        assert engine.resolve_engine("numba") == "numba"  # an explicit request still wins
    assert engine.compiled() == before


def test_single_design_command_compiles_no_kernel(tmp_path):
    """`exotune analyze` (in-process) leaves every numba dispatcher of every kernel module
    (continuous, latency, passivity and sampled-data kernels alike) without a compiled signature
    when nothing is in numba's cache (an empty ``NUMBA_CACHE_DIR``): single designs never wait on
    the JIT (with a cache, the plant margin's large count batches load the cached kernels:
    :func:`exotune.numerics.engine.cached_engine`)."""
    pytest.importorskip("numba")
    code = (
        "import sys\n"
        "from exotune.cli import main\n"
        "try:\n    main(['analyze', 'examples/scheduled.yaml'])\nexcept SystemExit as e:\n    assert not e.code, e.code\n"
        "import exotune.numerics.kernels as k\n"
        "from numba.core.registry import CPUDispatcher\n"
        "import importlib, pkgutil\n"
        "mods = [importlib.import_module(f'{k.__name__}.{m.name}') for m in pkgutil.iter_modules(k.__path__)]\n"
        "assert len(mods) >= 12, [m.__name__ for m in mods]\n"
        "compiled = [f'{m.__name__}.{a}' for m in mods for a, f in vars(m).items() "
        "if isinstance(f, CPUDispatcher) and f.signatures]\n"
        "print('COMPILED', compiled, file=sys.stderr)\n"
        "assert not compiled, compiled\n"
    )
    p = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=600,
                       env={**__import__("os").environ, "EXOTUNE_NUMPY_ONLY": "", "NUMBA_CACHE_DIR": str(tmp_path)})
    assert p.returncode == 0, p.stderr[-2000:]
    assert "Margins:" in p.stdout


def test_cached_engine_only_for_cached_kernels_and_large_batches(monkeypatch):
    monkeypatch.setattr(engine, "_cache_present", lambda: True)
    monkeypatch.delenv("EXOTUNE_NUMPY_ONLY", raising=False)
    from exotune.numerics import kernels

    assert engine.cached_engine(1e6) == ("numba" if kernels.AVAILABLE else None)
    assert engine.cached_engine(10) is None  # a small batch: not worth loading the kernels
    monkeypatch.setenv("EXOTUNE_NUMPY_ONLY", "1")
    assert engine.cached_engine(1e6) is None
    monkeypatch.delenv("EXOTUNE_NUMPY_ONLY")
    monkeypatch.setattr(engine, "_cache_present", lambda: False)
    assert engine.cached_engine(1e6) is None  # never compiled for a single design


def test_plant_margin_same_on_both_engines(monkeypatch):
    """The plant-uncertainty margin's witness search gives the same bounds and witness whether its
    count batches run on the cached kernels or on numpy."""
    pytest.importorskip("numba")
    import exotune
    from exotune.analysis import plant_uncertainty_margin

    cfg = exotune.load_design(ROOT / "examples" / "scheduled.yaml")
    out = {}
    for name, present in (("numba", True), ("numpy", False)):
        monkeypatch.setattr(engine, "_cache_present", lambda present=present: present)
        with engine.numpy_engine():
            out[name] = plant_uncertainty_margin(cfg, families=["free", "human0_mass"], rel_tol=0.05).to_dict()
    assert out["numba"] == out["numpy"]


def test_kernels_cached_is_false_on_numpy():
    with engine.numpy_engine():
        assert engine.kernels_cached() is False


def test_kernels_cached_follows_numbas_cache_directory(tmp_path):
    """:func:`kernels_cached` (which decides the command line's line about compiling) is False on an
    empty ``NUMBA_CACHE_DIR`` and True once numba has compiled a kernel of the count there: the
    files numba really writes are the ones it looks for. One small kernel is compiled, in a fresh
    interpreter (compiling every kernel takes minutes), and its phase sum checked: the phase of
    1 + jω from 0.1 to 10 rad/s turns by atan(10) − atan(0.1)."""
    pytest.importorskip("numba")
    import os

    code = ("import numpy as np\n"
            "from exotune.numerics import engine\n"
            "from exotune.numerics.kernels.phase import phase_sums\n"
            "print(engine.kernels_cached())\n"
            "tot, res, _n = phase_sums(np.array([[1.0, 1.0]]), np.zeros((1, 1)), np.zeros(1), "
            "np.array([[0.1, 10.0]]), np.ones(1, bool), 0.8, 0.5, 30)\n"
            "print(repr(float(tot[0])), bool(res[0]))\n"
            "print(engine.kernels_cached())\n")
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache"), "EXOTUNE_NUMPY_ONLY": ""}
    r = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=600, env=env)
    assert r.returncode == 0, r.stderr[-1500:]
    before, total, resolved, after = r.stdout.split()
    assert (before, resolved, after) == ("False", "True", "True")
    assert float(total) == pytest.approx(math.atan(10.0) - math.atan(0.1), rel=1e-12)


@pytest.mark.parametrize("command", ["sweep", "optimize"])
def test_a_batch_command_says_once_that_it_compiles(tmp_path, monkeypatch, command):
    """With the compiled engine and nothing in numba's cache, ``sweep`` and ``optimize`` say so in
    one stderr line before any work (here an absent spec file, refused after it); with the cache
    there, they say nothing. (That the cache test sees numba's files: the test above.)"""
    from click.testing import CliRunner

    from exotune.cli import cli

    missing = str(tmp_path / "absent.yaml")
    monkeypatch.setattr(engine, "compiled", lambda: True)
    for cached, times in ((False, 1), (True, 0)):
        monkeypatch.setattr(engine, "kernels_cached", lambda cached=cached: cached)
        res = CliRunner().invoke(cli, [command, missing, "-o", str(tmp_path / "out")])
        assert res.exit_code == 2 and "absent.yaml" in res.output, res.output
        assert res.output.count("compiling the analysis kernels") == times, res.output
    assert not (tmp_path / "out").exists()
