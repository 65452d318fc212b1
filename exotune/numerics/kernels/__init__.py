"""Compiled (numba) kernels with the numpy implementation as reference and fallback.

One module per kernel family:

- :mod:`.common`: numba (optional: ``AVAILABLE``), the per-task work budgets and the inlined
  scalar primitives (Δ(jω) and its derivative, the interval acceptance rule, the stack);
- :mod:`.phase`: the argument-principle count (adaptive phase sums, the whole count pipeline);
- :mod:`.leaves`: adaptive frequency sets of two tracked quasi-polynomials;
- :mod:`.pair`: scalar functions of a pair (values, Illinois roots, golden-section maxima, the
  crossing classification and sub-sampling of leaves);
- :mod:`.bounds`: frequency tail bounds and batched polynomial products;
- :mod:`.ripple`: the frozen delay-ripple frame of the operator compliance C7 and the samples of
  C7 built on it, one pass per design (passivity);
- :mod:`.latency`: the latency margin of every design of a batch (the sweep column);
- :mod:`.shiftloop`: the linear recursion of a simulated run with a long delay line;
- :mod:`.eig`: eigenvalues of stacks of small real matrices (the sampled-data loops) and the
  matching of two spectra; reference: LAPACK (``numpy.linalg.eigvals``);
- :mod:`.loopmat`: the assembly of the sampled-data loop matrices on a stack; reference: the
  numpy operations of :meth:`exotune.sampled.batch.BatchLoops.matrices`;
- :mod:`.expm`: matrix exponentials of stacks of small matrices (the zero-order holds);
  reference: ``scipy.linalg.expm``;
- :mod:`.rigid`: the exact deflation of the rigid-body eigenvalue z = 1 of stacks of ungrounded
  sampled-data loop matrices; reference: the numpy code of :mod:`exotune.sampled.rigid`.

Which engine runs is decided in one place, :mod:`exotune.numerics.engine`. The kernels are
compiled with ``cache=True``: numba keys each cached kernel on its own module's file only, so after
editing :mod:`.common` (or :mod:`.bounds`, or :mod:`.eig`, whose ``balance`` :mod:`.expm` and
:mod:`.rigid` call) delete this package's ``__pycache__`` (or touch the
modules that use it) to recompile the kernels that inline it.
"""

from .bounds import family_wmax, omega_max, pmul_rows
from .common import AVAILABLE, GEO_SPLIT_RATIO, MAX_GROUP_EVALS, MAX_TASK_EVALS, MAX_TASK_LEAVES
from .leaves import leaves2
from .pair import classify_leaves, golden_max, pair_roots, pair_values, refine_crossings, subsample_brackets
from .phase import count_tasks, phase_sums
from .ripple import c7_samples, ripple_frame

__all__ = [
    "AVAILABLE",
    "MAX_TASK_EVALS",
    "MAX_TASK_LEAVES",
    "MAX_GROUP_EVALS",
    "GEO_SPLIT_RATIO",
    "phase_sums",
    "count_tasks",
    "leaves2",
    "pair_values",
    "pair_roots",
    "refine_crossings",
    "golden_max",
    "classify_leaves",
    "subsample_brackets",
    "family_wmax",
    "omega_max",
    "pmul_rows",
    "ripple_frame",
    "c7_samples",
]
