"""exotune.model."""
