"""What ``exotune simulate`` runs from a design file: exactly the runtime sections of a full export
(controller, gain schedule controllers, plant, delay, DOB, golden vectors), without the sampled-data
predictions a written controller file carries."""

from __future__ import annotations

from pathlib import Path

from exotune.config import design_from_mapping
from exotune.controllerfile.export import build_export
from exotune.simulation import load_for_simulation

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
RUNTIME_KEYS = ("schema", "sample_rate_hz", "delay_s", "plant", "design", "gains", "signals", "controller", "dob",
                "transmission", "golden")


def test_in_memory_export_has_the_runtime_sections_of_a_full_export():
    path = EXAMPLES / "scheduled.yaml"
    lite = load_for_simulation(path, 1000.0)
    import yaml

    raw = yaml.safe_load(path.read_text())
    raw["implementation"]["sample_rate_hz"] = 1000.0
    full = build_export(design_from_mapping(raw), 1000.0, source=str(path))
    for k in RUNTIME_KEYS:
        assert lite[k] == full[k], k
    assert lite["predicted"] is None and full["predicted"]["sampled"]["free_stable"] is True
    le, fe = lite["gain_schedule"]["entries"], full["gain_schedule"]["entries"]
    assert len(le) == len(fe) == 5
    for a, b in zip(le, fe):
        assert "predicted_sampled" not in a and "predicted_sampled" in b
        assert a["controller"] == b["controller"] and a["plant"] == b["plant"] and a["gains"] == b["gains"]
