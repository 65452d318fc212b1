"""Typed results of exotune's commands (docs/api.md).

Each command of the command line has a result class here. A result is a frozen dataclass whose
fields are the headline numbers (with their units in the field name or the ``units`` mapping) and
which keeps the full record behind them: :meth:`Result.to_dict` returns exactly the object that
the command prints with ``--json``, :meth:`Result.to_text` the text report, and — where the
command draws figures — ``plot(ax=None)`` returns a matplotlib ``Figure``. Text and figures are
views: they are imported only when asked for.
"""

from __future__ import annotations

import copy
import json
from dataclasses import dataclass, field
from typing import Any, Mapping

__all__ = [
    "Result",
    "DesignSummary",
    "SeaReport",
    "FamilyResult",
    "PassivityResult",
    "DobMargins",
    "Amplification",
    "DesignAnalysis",
    "ControllerFile",
    "Certificate",
    "SweepResult",
    "OptimizeResult",
    "SimulationRun",
]


@dataclass(frozen=True)
class Result:
    """Base of every result: the full record (``to_dict``) and its JSON/text views."""

    record: Mapping[str, Any] = field(repr=False, compare=False)

    def to_dict(self) -> dict:
        """The result as the command's ``--json`` object (a deep copy: editing it changes nothing here)."""
        return copy.deepcopy(dict(self.record))

    def to_json(self) -> str:
        """The command's ``--json`` output (strict JSON: ``Infinity``/``NaN`` as strings)."""
        from .jsonio import dumps

        return dumps(self.to_dict())

    def to_text(self) -> str:  # pragma: no cover - overridden
        return self.to_json()

    def __str__(self) -> str:
        return self.to_text()


def _f(x) -> float | None:
    return None if x is None else float(x)


# ---------------------------------------------------------------------------------------------
# design
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class DesignSummary(Result):
    """``exotune design``: the six gains (torque units, ``units``), the shape, the nominal transfer
    functions and warnings of a design (paper §IV; docs/method.md#double-compliance-shaping)."""

    gains: Mapping[str, float] = field(default_factory=dict)
    units: Mapping[str, str] = field(default_factory=dict)
    approximation_valid_below_hz: float | None = None
    warnings: tuple[str, ...] = ()
    config: Any = field(default=None, repr=False, compare=False)

    @classmethod
    def from_record(cls, rec: dict, config=None) -> "DesignSummary":
        return cls(rec, dict(rec["gains"]), dict(rec["units"]), _f(rec["approximation"]["valid_below_hz"]),
                   tuple(rec["warnings"]), config)

    def transfer_functions(self) -> dict:
        """The nominal C4, C5, Ĉ5, C7 and G_v (zero delay, no filters, no DOB) as
        ``control.TransferFunction`` objects (descending coefficients, as python-control).

        Returns
        -------
        dict
            ``{"C4", "C5", "C5_hat", "C7_nominal", "G_v"}`` → ``control.TransferFunction``
            (compliances in rad/(N·m); G_v dimensionless).

        References
        ----------
        Paper §II-B–§II-D, eqs. (8), (10)–(12) and (16); docs/method.md#double-compliance-shaping.
        """
        from .model.interop import nominal_transfer_functions_control

        return nominal_transfer_functions_control(self.config)

    def to_text(self) -> str:
        from .text.design import format_design

        return format_design(self.to_dict())

    def plot(self, ax=None):
        """Bode magnitude of the nominal transfer functions; returns the matplotlib ``Figure``."""
        import numpy as np

        from .plots.figures import bode_magnitude

        f = np.geomspace(0.01, 1000.0, 800)
        curves = [(name, f, np.asarray(tf(2j * np.pi * f)).ravel()) for name, tf in self.transfer_functions().items()]
        return bode_magnitude(curves, ax=ax, title="nominal transfer functions (design)")


@dataclass(frozen=True)
class SeaReport(Result):
    """``exotune sea``: a plain SEA compliance-shaping controller (paper §II-B) — its gains in both
    conventions, the closed-loop compliance C5's poles and resonance, the passivity conditions."""

    c5_stable: bool | None = None
    passive: bool | None = None
    low_frequency_stiffness: float | None = None
    resonance_hz: float | None = None

    @classmethod
    def from_record(cls, rec: dict) -> "SeaReport":
        return cls(rec, bool(rec["c5_stable"]), bool(rec["passivity"]["passive"]), _f(rec["low_frequency_stiffness"]),
                   _f(rec["resonance_hz"]))

    def to_text(self) -> str:
        from .text.sea import format_sea

        return format_sea(self.to_dict())


# ---------------------------------------------------------------------------------------------
# analysis
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class FamilyResult(Result):
    """One human family or environment: the stable member intervals of its ranged ``parameter``
    (in ``unit``), the robust flag (stable over the whole range) and the critical members."""

    kind: str = ""
    parameter: str | None = None
    unit: str | None = None
    range: tuple[float, float] | None = None
    stable_intervals: tuple[tuple[float, float], ...] = ()
    robust: bool | None = None
    conclusive: bool | None = None

    @classmethod
    def from_record(cls, rec: dict) -> "FamilyResult":
        rng = rec.get("range")
        ivs = rec.get("stable_intervals") or []
        robust = rec.get("robust", rec.get("stable"))
        return cls(rec, rec.get("kind", ""), rec.get("parameter"), rec.get("unit"),
                   None if rng is None else (float(rng[0]), float(rng[1])),
                   tuple((float(a), float(b)) for a, b in ivs if not isinstance(a, (list, dict))),
                   None if robust is None else bool(robust), rec.get("conclusive"))


@dataclass(frozen=True)
class PassivityResult(Result):
    """Passivity of the operator-side compliance C7 (docs/method.md#analyses-and-metrics): the
    maximum phase excess over −90°…90° of s·C7 [deg] and the non-passive bands [Hz]."""

    max_phase_excess_deg: float | None = None
    nonpassive_band_hz: tuple[tuple[float, float], ...] = ()

    @classmethod
    def from_record(cls, rec: dict) -> "PassivityResult":
        bands = rec.get("nonpassive_band_hz") or []
        return cls(rec, _f(rec.get("max_phase_excess_deg")), tuple((float(a), float(b)) for a, b in bands))

    @property
    def passive(self) -> bool:
        return self.max_phase_excess_deg is not None and self.max_phase_excess_deg <= 0.0


@dataclass(frozen=True)
class DobMargins(Result):
    """Margins of the DOB Q-filter loop: gain [dB], phase [deg], delay [s], crossover [Hz]."""

    gain_margin_db: float | None = None
    phase_margin_deg: float | None = None
    delay_margin_s: float | None = None
    crossover_hz: float | None = None
    stable: bool | None = None

    @classmethod
    def from_record(cls, rec: dict) -> "DobMargins":
        return cls(rec, _f(rec.get("gain_margin_db")), _f(rec.get("phase_margin_deg")), _f(rec.get("delay_margin_s")),
                   _f(rec.get("crossover_hz")), rec.get("stable"))


@dataclass(frozen=True)
class Amplification(Result):
    """Delivered amplification |C6/C5|: DC value [–] and −3 dB bandwidth [Hz]."""

    dc: float | None = None
    bandwidth_hz: float | None = None

    @classmethod
    def from_record(cls, rec: dict) -> "Amplification":
        return cls(rec, _f(rec.get("dc")), _f(rec.get("bandwidth_hz")))


@dataclass(frozen=True)
class DesignAnalysis(Result):
    """``exotune analyze``: every verdict and metric of one design (docs/method.md#analyses-and-metrics).

    ``robust`` is true when the cuff-free exoskeleton, every environment and every human family
    are stable over their whole ranges."""

    free_stable: bool | None = None
    humans: tuple[FamilyResult, ...] = ()
    environment: tuple[FamilyResult, ...] = ()
    passivity: PassivityResult | None = None
    dob: DobMargins | None = None
    amplification: Amplification | None = None
    latency_margin_s: float | None = None
    config: Any = field(default=None, repr=False, compare=False)

    @classmethod
    def from_record(cls, rec: dict, config=None) -> "DesignAnalysis":
        lm = (rec.get("margins") or {}).get("latency") or {}
        return cls(
            rec,
            rec.get("free_stable"),
            tuple(FamilyResult.from_record(h) for h in rec.get("humans") or []),
            tuple(FamilyResult.from_record(e) for e in rec.get("environment") or []),
            None if rec.get("passivity") is None else PassivityResult.from_record(rec["passivity"]),
            None if rec.get("dob") is None else DobMargins.from_record(rec["dob"]),
            None if rec.get("amplification") is None else Amplification.from_record(rec["amplification"]),
            _f(lm.get("extra_delay_s")) if lm else None,
            config,
        )

    @property
    def robust(self) -> bool:
        return bool(self.free_stable) and all(bool(x.robust) for x in self.humans + self.environment)

    def to_text(self) -> str:
        from .text.analysis import format_report

        return format_report(self.to_dict())

    def plot(self, ax=None):
        """Bode plot of the operator-side compliance C7 with its non-passive bands shaded and the
        passivity limits drawn; returns the matplotlib ``Figure``."""
        from .analysis.responses import c7_frequency_response
        from .plots.figures import compliance_phase

        f, H = c7_frequency_response(self.config)
        bands = self.passivity.nonpassive_band_hz if self.passivity else ()
        return compliance_phase(f, H, bands, ax=ax, title="operator-side compliance C7 (paper Fig. 5)")


# ---------------------------------------------------------------------------------------------
# controller file
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class ControllerFile(Result):
    """An exported controller file (docs/controller-file.md): its document and where it was written."""

    sample_rate_hz: float | None = None
    path: str | None = None

    @classmethod
    def from_record(cls, doc: dict, path=None) -> "ControllerFile":
        return cls(doc, float(doc["sample_rate_hz"]["value"]), None if path is None else str(path))

    def to_text(self) -> str:
        import yaml

        return yaml.safe_dump(self.to_dict(), sort_keys=False, allow_unicode=True)

    def summary(self) -> str:
        """The one line ``exotune export`` prints: where the file went, its rate, filters,
        sampled-data verdicts and latency margin (:func:`exotune.text.export.format_export`)."""
        from .text.export import format_export

        return format_export(self.to_dict(), self.path)


@dataclass(frozen=True)
class Certificate(Result):
    """``exotune certify``: the exact sampled-data verdicts of a controller file; ``certified`` is
    true only when every check passed (``reasons`` lists the ones that did not)."""

    certified: bool = False
    reasons: tuple[str, ...] = ()

    @classmethod
    def from_record(cls, rec: dict) -> "Certificate":
        return cls(rec, bool(rec["certified"]), tuple(str(r) for r in rec.get("problems") or ()))

    def to_text(self) -> str:
        from .text.certify import format_certify

        return format_certify(self.to_dict())


# ---------------------------------------------------------------------------------------------
# sweep, optimize, simulate
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class SweepResult(Result):
    """A sweep directory (docs/sweep-spec.md): its manifest and the Parquet rows on demand."""

    directory: str = ""
    status: str | None = None
    points_total: int | None = None

    @classmethod
    def from_directory(cls, directory) -> "SweepResult":
        from pathlib import Path

        d = Path(directory)
        man = json.loads((d / "manifest.json").read_text())
        total = man.get("points_total", man.get("n_points"))
        return cls(man, str(d), man.get("status"), None if total is None else int(total))

    def table(self):
        """Every computed row as one ``pyarrow.Table`` (chunks in design-index order)."""
        from pathlib import Path

        import pyarrow as pa
        import pyarrow.parquet as pq

        files = sorted((Path(self.directory) / "chunks").glob("*.parquet"))
        return pa.concat_tables([pq.read_table(f) for f in files]) if files else pa.table({})

    def to_text(self) -> str:
        return json.dumps(self.to_dict(), indent=2)

    def map_data(self, column: str = "robust", axes: tuple[str, str] | None = None):
        """One value per cell of two sweep axes (default: the first two), reduced over the others:
        ``column`` "robust" → the fraction of robust designs; a numeric column → its worst case
        (the minimum; ``passivity_max_phase_excess_deg``: the maximum).

        Returns (grid[iy, ix], x values, y values, x path, y path)."""
        import numpy as np

        from .sweeps.metrics import aggregate, robust_mask

        man_axes = [a["path"] for a in self.to_dict()["axes"]]
        xp, yp = axes or (man_axes[0], man_axes[1] if len(man_axes) > 1 else man_axes[0])
        t = self.table()
        cols = {c: t.column(c).to_numpy(zero_copy_only=False) for c in t.column_names
                if c == "free_stable" or c == column or c.endswith(("_robust", "_stable")) or c in (xp, yp)}
        if column == "robust":
            vals, how = robust_mask(cols)[0].astype(float), "mean"
        else:
            vals, how = np.asarray(cols[column], float), "max" if column.startswith("passivity") else "min"
        xs, ix = np.unique(cols[xp], return_inverse=True)
        ys, iy = np.unique(cols[yp], return_inverse=True)
        grid = aggregate(iy * xs.size + ix, xs.size * ys.size, vals, how).reshape(ys.size, xs.size)
        return grid, xs, ys, xp, yp

    def plot(self, column: str = "robust", axes: tuple[str, str] | None = None, ax=None):
        """A heatmap of :meth:`map_data` (fraction robust or a column's worst case) over two axes;
        returns the matplotlib ``Figure``."""
        from .plots.results import sweep_map

        grid, xs, ys, xp, yp = self.map_data(column, axes)
        what = "fraction of robust designs" if column == "robust" else f"{column} (worst case)"
        return sweep_map(grid, xs, ys, xp, yp, what, "fraction" if column == "robust" else column, ax=ax)


@dataclass(frozen=True)
class OptimizeResult(Result):
    """``exotune optimize``: the best feasible design found (``feasible``), its objective value and
    the written design file (``path``)."""

    feasible: bool = False
    objective_value: float | None = None
    path: str | None = None

    @classmethod
    def from_record(cls, rec: dict, path=None) -> "OptimizeResult":
        obj = rec.get("objective") or {}
        val = obj.get("value") if isinstance(obj, dict) else obj
        return cls(rec, bool(rec["feasible"]), None if val is None else float(val),
                   None if path is None or not rec["feasible"] else str(path))

    def to_text(self) -> str:
        from .optimization import format_optimize

        return format_optimize(self.to_dict())

    def plot(self, ax=None):
        """Where the returned design sits in each free parameter's bounds (parameters at a bound in
        red, the binding constraints in the title), or — when the run kept a Pareto front — the
        front with the design marked. Returns the matplotlib ``Figure``."""
        from .plots.results import optimum_in_bounds, pareto_front

        r = self.to_dict()
        if r.get("pareto") and self.objective_value is not None:
            front = r["pareto"]
            return pareto_front([p["objective"] for p in front], [p["robust_fraction"] for p in front],
                                (self.objective_value, r.get("robust_fraction", 1.0)),
                                objective_label=f"{r['objective']['name']} [{r['objective'].get('unit') or '–'}]", ax=ax)
        rel = r.get("x_relative") or {}
        names = list(rel)
        title = (f"{r['objective']['name']} = {self.objective_value:.6g} {r['objective'].get('unit') or ''}"
                 if self.feasible else "no feasible design: the least-violating one")
        return optimum_in_bounds(names, [rel[n] for n in names], [b["parameter"] for b in r.get("at_bounds", [])],
                                 ", ".join(r.get("active_constraints") or []), title, ax=ax)


@dataclass(frozen=True)
class SimulationRun(Result):
    """``exotune simulate``: the scenario's summary (``to_dict``, no time series) and its runs."""

    scenario: str = ""
    runs: Any = field(default=None, repr=False, compare=False)

    @classmethod
    def from_report(cls, rep: dict) -> "SimulationRun":
        summary = {k: v for k, v in rep.items() if k != "runs"}
        return cls(summary, str(rep.get("scenario", "")), rep.get("runs"))

    def _full(self) -> dict:
        return {**self.to_dict(), "runs": self.runs}

    def to_text(self) -> str:
        from .text.simulate import format_simulation

        return format_simulation(self._full())

    def plot(self, ax=None):
        """The scenario's time series (:func:`exotune.plots.simulate.simulation_figure`): two
        panels, or the first one only into a given ``ax``. Returns the matplotlib ``Figure``."""
        from .plots.simulate import simulation_figure

        return simulation_figure(self._full(), ax=ax)

