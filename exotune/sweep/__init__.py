"""exotune.sweep."""
