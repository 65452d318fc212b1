"""exotune.numerics."""
