"""Discretization of controller blocks to cascades of second-order sections (scipy ``sos``):
the prewarped bilinear transform (:func:`tustin_sos`) and the state space of a cascade as the
runtime runs it (:func:`sos_ss`, direct form II transposed). Implemented in
:mod:`exotune.sampled.sos` (shared with the sweep's sampled-data columns), re-exported here.
"""

from __future__ import annotations

from ..sampled.sos import sos_ss, tustin_sos

__all__ = ["tustin_sos", "sos_ss"]
