"""exotune.plots."""
