"""A design file whose plant section is reflected through a transmission ratio by hand (J_m, B_m,
K_s × ratio², paper §IV gain scheduling): the independent reference of the gain-schedule tests."""

from __future__ import annotations

import copy

from exotune.config import design_from_mapping


def by_hand(raw: dict, ratio: float, alpha: float | None = None):
    """The design ``raw`` without its ``transmission`` table, its plant section reflected by
    ``ratio``² by hand (and its amplification set to ``alpha`` when given)."""
    r = copy.deepcopy(raw)
    r.pop("transmission", None)
    if alpha is not None:
        r["design"]["amplification"] = float(alpha)
    for k in ("motor_inertia", "motor_damping", "sea_stiffness"):
        r["plant"][k] = float(r["plant"][k]) * ratio * ratio
    return design_from_mapping(r)
