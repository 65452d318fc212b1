"""exotune.analysis."""
