"""exotune.config."""
