"""The engine switch (exotune.numerics.engine): single-design commands run on the numpy engine and
never compile a kernel; batches use the compiled kernels when numba is there."""

from __future__ import annotations

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


def test_single_design_command_compiles_no_kernel():
    """`exotune analyze` (in-process) leaves every numba dispatcher without a compiled signature."""
    pytest.importorskip("numba")
    code = (
        "import sys\n"
        "from exotune.cli import main\n"
        "try:\n    main(['analyze', 'examples/scheduled.yaml'])\nexcept SystemExit as e:\n    assert not e.code, e.code\n"
        "import exotune.numerics.kernels as k\n"
        "from numba.core.registry import CPUDispatcher\n"
        "mods = [getattr(k, n) for n in ('bounds', 'leaves', 'pair', 'phase', 'common')]\n"
        "compiled = [f'{m.__name__}.{a}' for m in mods for a, f in vars(m).items() "
        "if isinstance(f, CPUDispatcher) and f.signatures]\n"
        "print('COMPILED', compiled, file=sys.stderr)\n"
        "assert not compiled, compiled\n"
    )
    p = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=600,
                       env={**__import__("os").environ, "EXOTUNE_NUMPY_ONLY": ""})
    assert p.returncode == 0, p.stderr[-2000:]
    assert "Margins:" in p.stdout


def test_kernels_cached_is_false_on_numpy():
    with engine.numpy_engine():
        assert engine.kernels_cached() is False


def test_first_batch_run_says_it_compiles(tmp_path):
    """A sweep with an empty numba cache prints one line about compiling, a second one does not."""
    pytest.importorskip("numba")
    import os

    spec = tmp_path / "s.yaml"
    spec.write_text(f"base: {ROOT / 'examples' / 'paper.yaml'}\naxes:\n  design.amplification: [4.0, 8.0]\n")
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache"), "EXOTUNE_NUMPY_ONLY": ""}

    def run(out):
        return subprocess.run([sys.executable, "-m", "exotune", "sweep", str(spec), "-o", str(tmp_path / out)],
                              cwd=tmp_path, capture_output=True, text=True, timeout=900, env=env)

    first = run("a")  # an empty cache directory: numba compiles, the command says so once
    assert first.returncode == 0, first.stderr[-1500:]
    assert first.stderr.count("compiling the analysis kernels") == 1
    second = run("b")
    assert second.returncode == 0 and "compiling the analysis kernels" not in second.stderr
