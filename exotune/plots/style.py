"""The one style module of every exotune figure: sizes, fonts, dpi, grid, colour maps, physical
names and units of configuration paths (:func:`label`), unit-scaled axes (:func:`unit_axis`),
log/symlog helpers, colour bars without offset text and the PNG renderer.

The implementation sits in :mod:`exotune.sweeps.style` only because the sweep report's figures
(a lower layer) use it too; import it from here.

Examples
--------
>>> from exotune.plots.style import label, scale_of
>>> label("implementation.delay_s"), scale_of("implementation.delay_s")
('total delay T [ms]', 1000.0)
"""

from __future__ import annotations

from ..sweeps.style import (BAD_COLOR, BAD_MEANING, CMAPS, DPI, FIGSIZE, FONTSIZE, GRID, SMALL, Quantity, colorbar,
                            grid, label, log_if_decades, new_figure, plain_formatter, png, quantity, rc, scale_of,
                            short_name, symlog_if_decades, tick_labels, unit_axis)

__all__ = ["DPI", "FIGSIZE", "FONTSIZE", "SMALL", "GRID", "CMAPS", "BAD_COLOR", "BAD_MEANING", "Quantity",
           "quantity", "label", "short_name", "scale_of", "unit_axis", "tick_labels", "log_if_decades",
           "symlog_if_decades", "plain_formatter", "colorbar", "grid", "new_figure", "png", "rc"]
