"""exotune.numerics.budgets: the per-task work budgets, shared by the numpy and compiled engines."""

import subprocess
import sys
from pathlib import Path

from exotune.numerics import budgets

ROOT = Path(__file__).resolve().parents[2]


def test_budgets_are_consistent():
    assert isinstance(budgets.MAX_TASK_EVALS, int) and isinstance(budgets.MAX_TASK_LEAVES, int)
    # a task's ~50 evaluations and ~100 leaves fit many times over
    assert budgets.MAX_TASK_EVALS >= 1000 * 50 and budgets.MAX_TASK_LEAVES >= 100 * 100
    # a group of counts shares a budget of several tasks (never less than one task's)
    assert budgets.MAX_GROUP_EVALS > budgets.MAX_TASK_EVALS
    # the geometric split of an interval [a, b] is only used when it differs from the midpoint
    assert budgets.GEO_SPLIT_RATIO > 1.0


def test_compiled_kernels_use_the_same_budgets():
    from exotune.numerics.kernels import common

    for name in budgets.__all__:
        assert getattr(common, name) == getattr(budgets, name), name


def test_importing_the_budgets_does_not_import_numba():
    code = "import sys, exotune.numerics.budgets, exotune.numerics.quasipoly; print('numba' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"
