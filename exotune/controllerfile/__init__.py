"""exotune.controllerfile."""
