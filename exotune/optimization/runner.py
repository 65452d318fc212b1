"""``exotune optimize``: load the spec, search, write the optimized design file and the Pareto front.

References
----------
docs/optimize-spec.md#result.
"""

from __future__ import annotations

import math

from .result import OptimizeResult
from .search import optimize
from .spec import load_optimize_spec, optimized_design_mapping

__all__ = ["run_optimize", "pareto_header"]


def pareto_header(spec) -> list[str]:
    """The column names of the ``--pareto`` CSV, each ``name [unit]``: the objective under its
    name in the spec, ``robust_fraction``, then each free parameter's dotted path (SI units,
    joint-reflected; ``1`` for a dimensionless number, as in the files exotune writes).

    Parameters
    ----------
    spec : OptimizeSpec
        The problem (:func:`~exotune.optimization.spec.load_optimize_spec`).

    Returns
    -------
    list of str
        One name per column, in the rows' order.

    References
    ----------
    docs/optimize-spec.md#result.

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> pareto_header(SimpleNamespace(objective="felt_inertia", free={"design.felt_inertia": (0.1, 1.0, "lin")}))
    ['felt_inertia [kg·m²]', 'robust_fraction [1]', 'design.felt_inertia [kg·m²]']
    """
    from ..units import path_unit
    from .spec import OBJECTIVES

    unit = OBJECTIVES[spec.objective][2].split(" (")[0]  # "kg·m² (felt inertia, minimized)": the unit
    return [f"{spec.objective} [{unit}]", "robust_fraction [1]", *(f"{p} [{path_unit(p)}]" for p in spec.free)]


def run_optimize(spec_file, out, seed: int | None = None, pareto_csv=None) -> OptimizeResult:
    """``exotune optimize``: load, search, write the optimized design file (validated) and, on
    request, the Pareto front as CSV: both or neither (:func:`exotune.jsonio.write_outputs`). An output that cannot be
    created is refused before the search (:func:`exotune.jsonio.check_outputs`).

    Parameters
    ----------
    spec_file : str, os.PathLike or dict
        The optimization spec.
    out : str or os.PathLike
        Design file to write (only when a feasible design is found).
    seed : int, optional
        Overrides the spec's seed.
    pareto_csv : str or os.PathLike, optional
        Where to write the Pareto front.

    Returns
    -------
    OptimizeResult
        The report of :func:`optimize` (``to_dict()``) with ``feasible``, the objective value and
        the written file (``feasible`` false: nothing written, ``path`` None).

    Raises
    ------
    ConfigError
        For bad input, or an output that cannot be written (``<path>: cannot write output:
        <reason>``; nothing is written then).

    References
    ----------
    docs/optimize-spec.md.
    """
    import yaml

    from ..config import design_from_mapping
    from ..jsonio import check_outputs, write_outputs

    spec = load_optimize_spec(spec_file, seed=seed)
    check_outputs([spec_file], outputs={"`out`": out, "`pareto_csv`": pareto_csv})  # refused before the search
    r = optimize(spec, pareto=pareto_csv is not None)
    if not r["feasible"]:
        return OptimizeResult.from_report(r, out)
    mapping = optimized_design_mapping(spec, r)
    design_from_mapping(mapping)  # the written file must load
    o = r["objective"]
    lm = r["latency_margin"]
    ms = lambda v: "unbounded" if v is None or not math.isfinite(v) else f"{v * 1e3:.6g} ms"  # noqa: E731
    unit = "–" if o["unit"] == "1" else o["unit"]
    head = (f"# exotune optimize: {o['name']} = {o['value']:.6g} {unit} ({o['sense']}imized), "
            f"active: {', '.join(r['active_constraints']) or 'none'}; latency margin {ms(lm['achieved_s'])} "
            f"(required {ms(lm['required_s'])}); seed {spec.seed}\n")
    files = {out: head + yaml.safe_dump(mapping, sort_keys=False, allow_unicode=True)}
    if pareto_csv is not None:
        cols = ["objective", "robust_fraction", *spec.free]
        files[pareto_csv] = ",".join(pareto_header(spec)) + "\n" + "".join(
            ",".join(repr(float(row[c])) for c in cols) + "\n" for row in r["pareto"])
    write_outputs(files)  # the design and the front: both or neither
    return OptimizeResult.from_report(r, out)
