"""Frequency responses of a single design for figures and notebooks (docs/api.md).

Figures never compute: the numbers they draw come from here.
"""

from __future__ import annotations

import numpy as np

from ..model.controller import build_controller
from .charfun import char_terms
from .operator_passivity import c7_response

__all__ = ["c7_frequency_response"]


def c7_frequency_response(cfg, f_hz=None) -> tuple[np.ndarray, np.ndarray]:
    """The operator-side compliance C7(j2πf) of a design with its implementation (delay, filters,
    DOB): the human's view of the exoskeleton, whose phase decides passivity.

    Parameters
    ----------
    cfg : DesignConfig
        One design (:func:`exotune.load_design`).
    f_hz : array_like, optional
        Frequencies [Hz]; default 800 log-spaced points from 0.01 Hz to 1 kHz.

    Returns
    -------
    (numpy.ndarray, numpy.ndarray)
        The frequencies [Hz] and C7 [rad/(N·m)] (complex).

    References
    ----------
    Paper Table II (C7) and Fig. 5; docs/method.md#analyses-and-metrics.

    Examples
    --------
    >>> import exotune
    >>> f, H = c7_frequency_response(exotune.load_design("examples/paper.yaml"), [1.0, 10.0])
    >>> H.shape
    (2,)
    """
    f = np.geomspace(0.01, 1000.0, 800) if f_hz is None else np.asarray(f_hz, dtype=float).ravel()
    cs, _ = build_controller(cfg.plant, cfg.design, cfg.implementation)
    ct = char_terms(cfg.plant, cs, 1)
    return f, c7_response(ct, (2.0 * np.pi * f)[None, :])[0]
