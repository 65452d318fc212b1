"""The paper's example design (examples/paper.yaml) with implementation changes, and the controller
file ``exotune export`` writes for it: the shared starting point of the sampled-data and
simulation tests."""

from __future__ import annotations

import copy
from pathlib import Path

from exotune.config import design_from_mapping, load_design

PAPER = Path(__file__).resolve().parent.parent / "examples" / "paper.yaml"


def paper_design(humans=None, environment=None, **implementation):
    """examples/paper.yaml with ``implementation`` keys replaced (``sample_rate_hz=1000.0``, …) and,
    when given, other ``humans`` and ``environment`` lists."""
    raw = copy.deepcopy(load_design(PAPER).raw)
    raw["implementation"].update(implementation)
    if humans is not None:
        raw["humans"] = humans
    if environment is not None:
        raw["environment"] = environment
    return design_from_mapping(raw)


def paper_controller(sample_rate_hz: float = 1000.0, **implementation) -> dict:
    """The controller file of :func:`paper_design` exported at ``sample_rate_hz`` [Hz]."""
    from exotune.controllerfile import build_export

    return build_export(paper_design(sample_rate_hz=sample_rate_hz, **implementation), sample_rate_hz)
