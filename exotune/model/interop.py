"""python-control and numpy conventions at the library's edge (docs/api.md#python-control).

Inside the kernels polynomials are stored with **ascending** coefficients (``c[k]`` multiplies
``s**k``), which suits batched evaluation. Everything public uses **descending** coefficients like
numpy, scipy.signal, python-control and MATLAB:

* :func:`exotune.numerics.poly.descending` / :func:`~exotune.numerics.poly.ascending` convert one
  coefficient vector; ``Rational.descending()`` and ``Rational.to_control()`` one member of a
  batched transfer function;
* ``Plant.to_control()`` gives the plant as a ``control.StateSpace`` (paper Fig. 2);
* ``ControllerStructure.to_control()`` gives the controller blocks G_θ, G_s, G_c, the DOB filter Q
  and the delay (paper Fig. 3);
* :func:`nominal_transfer_functions_control` gives the nominal C4, C5, Ĉ5, C7 and G_v of a design.

python-control is imported only when a conversion is asked for.
"""

from __future__ import annotations

from ..numerics.poly import ascending, descending

__all__ = ["ascending", "descending", "nominal_transfer_functions_control"]


def nominal_transfer_functions_control(cfg, index: int = 0) -> dict:
    """The nominal transfer functions of a design (zero delay, no filters, no DOB) as
    ``control.TransferFunction`` objects.

    Parameters
    ----------
    cfg : DesignConfig
        A loaded design (:func:`exotune.load_design`).
    index : int
        Which member of a batched design.

    Returns
    -------
    dict
        ``"C4"``, ``"C5"``, ``"C5_hat"``, ``"C7_nominal"`` (compliances, rad/(N·m)) and ``"G_v"`` (–).

    References
    ----------
    Paper §II-B–§II-D, eqs. (8), (10)–(12) and (16); docs/method.md#double-compliance-shaping.

    Examples
    --------
    >>> import exotune
    >>> tfs = nominal_transfer_functions_control(exotune.load_design("examples/paper.yaml"))
    >>> sorted(tfs)
    ['C4', 'C5', 'C5_hat', 'C7_nominal', 'G_v']
    """
    from .shaping import double_compliance_shaping, nominal_transfer_functions

    ds = double_compliance_shaping(cfg.plant, cfg.design)
    tfs = nominal_transfer_functions(cfg.plant, cfg.design, ds)
    return {name: r.to_control(index) for name, r in tfs.items()}
