"""Designs beyond the accepted input ranges, for tests of the engine's own robustness.

Since the input validation refuses physically meaningless magnitudes (docs/design-file.md#input-
limits-and-accepted-ranges), a pathological design cannot come from a design file any more; the
engine must still terminate and never say "stable" wrongly on one. ``unchecked`` builds it from a
valid design by replacing model values directly (no validation)."""

from __future__ import annotations

import dataclasses

import numpy as np

from exotune.model.controller import SecondOrderFilter


def unchecked(cfg, **changes):
    """``cfg`` with ``section__field=value`` replaced without validation (sections: plant, design,
    implementation; a filter given as a mapping ``{cutoff_hz, damping}``); arrays make a batch."""
    sections = {"plant": cfg.plant, "design": cfg.design, "implementation": cfg.implementation}
    for path, v in changes.items():
        sec, key = path.split("__")
        if isinstance(v, dict):
            v = SecondOrderFilter(np.asarray(v["cutoff_hz"], float), np.asarray(v.get("damping", 0.7), float))
        elif not isinstance(v, (int, float)) or isinstance(v, bool):
            v = np.asarray(v, dtype=float)
        else:
            v = float(v)
        sections[sec] = dataclasses.replace(sections[sec], **{key: v})
    return dataclasses.replace(cfg, **sections)
