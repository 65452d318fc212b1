"""exotune.sampled."""
