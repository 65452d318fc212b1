"""Frequency responses of a single design for figures and notebooks (docs/api.md).

Figures never compute: the numbers they draw come from here.
"""

from __future__ import annotations

import numpy as np

from ..model.controller import build_controller
from .charfun import char_terms
from .operator_passivity import c7_response

__all__ = ["c7_frequency_response", "nominal_frequency_responses"]


def _grid(f_hz) -> np.ndarray:
    """The given frequencies [Hz], flat; None: 800 log-spaced points from 0.01 Hz to 1 kHz."""
    return np.geomspace(0.01, 1000.0, 800) if f_hz is None else np.asarray(f_hz, dtype=float).ravel()


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
    f = _grid(f_hz)
    cs, _ = build_controller(cfg.plant, cfg.design, cfg.implementation)
    ct = char_terms(cfg.plant, cs, 1)
    return f, c7_response(ct, (2.0 * np.pi * f)[None, :])[0]


def nominal_frequency_responses(cfg, f_hz=None) -> tuple[np.ndarray, dict]:
    """The nominal C4, C5, Ĉ5, C7 and G_v (zero delay, no filters, no DOB) of a design at
    ``f_hz``, evaluated from their ``control.TransferFunction`` objects.

    Parameters
    ----------
    cfg : DesignConfig
        One design; its implementation (delay, filters, DOB) is not used.
    f_hz : array_like, optional
        Frequencies [Hz]; default the grid of :func:`c7_frequency_response` (0.01 Hz – 1 kHz).

    Returns
    -------
    (numpy.ndarray, dict)
        The frequencies [Hz] and ``{"C4", "C5", "C5_hat", "C7_nominal", "G_v"}`` → complex
        response (compliances in rad/(N·m); G_v in [1]).

    References
    ----------
    Paper §II-B–§II-D; docs/method.md#double-compliance-shaping.
    """
    from ..model.interop import nominal_transfer_functions_control

    f = _grid(f_hz)
    tfs = nominal_transfer_functions_control(cfg)
    return f, {name: np.asarray(tf(2j * np.pi * f)).ravel() for name, tf in tfs.items()}
