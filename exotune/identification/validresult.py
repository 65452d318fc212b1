"""The typed results of the identification's validation (``exotune identify --validate``,
``--folds``): the simulated-output fits, the non-parametric frequency responses beside the
identified model's, the residual tests, the model errors they measure and the warnings.

References
----------
docs/identification.md#validation.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..record import Result

__all__ = ["OutputFit", "LocalParameter", "FrequencyResponse", "ResidualTest", "ModelError", "Validation",
           "CONFIDENCE_Z", "MIN_COHERENCE"]

CONFIDENCE_Z = 2.58  # 99 % bounds, as MATLAB's resid
MIN_COHERENCE = 0.9  # the coherent band: coherence γ² at least this


def _floats(a) -> list:
    return [float(x) for x in np.asarray(a, float)]


@dataclass(frozen=True)
class OutputFit:
    """One simulated output: ``output`` simulated from ``inputs`` (text) with the identified
    parameters, compared with its measurement on ``samples`` samples of ``data`` ("held-out log",
    "fold i/K" or "the fitting log"): NRMSE [%] = 100·‖y − ŷ‖/‖y − ȳ‖, fit [%] = 100 − NRMSE."""

    output: str
    inputs: str
    nrmse_percent: float
    samples: int
    data: str

    @property
    def fit_percent(self) -> float:
        return 100.0 - self.nrmse_percent

    def to_dict(self) -> dict:
        return {"output": self.output, "inputs": self.inputs, "nrmse_percent": self.nrmse_percent,
                "fit_percent": self.fit_percent, "samples": self.samples, "data": self.data}


@dataclass(frozen=True)
class LocalParameter:
    """A parameter read off the measured frequency response at each frequency (``values`` with
    standard deviations ``sigma``, in ``unit``) beside the identified ``estimate``;
    ``relative_excess`` is how far the values leave the estimate beyond ``CONFIDENCE_Z``·sigma over
    the coherent band (reached in at least two bins, relative to the estimate), at ``at_hz``."""

    key: str
    symbol: str
    unit: str
    values: np.ndarray
    sigma: np.ndarray
    estimate: float
    relative_excess: float
    at_hz: float

    def to_dict(self) -> dict:
        return {"key": self.key, "symbol": self.symbol, "unit": self.unit, "estimate": self.estimate,
                "relative_excess": self.relative_excess, "at_hz": self.at_hz}


@dataclass(frozen=True)
class FrequencyResponse:
    """The non-parametric estimate of one transfer function (``name``: motor, spring, joint or
    cuff) from ``input_name`` to ``output_name`` [``unit``] at ``frequency_hz``: ``measured``
    (H1, Welch-averaged, by way of the motor torque as instrument), its ``coherence`` γ², its
    relative random error ``relative_error`` (1σ of the magnitude, radians of the phase), the
    identified model's response ``model``, and the parameters read off it (``local``). The
    coherent band is where γ² ≥ :data:`MIN_COHERENCE`."""

    name: str
    input_name: str
    output_name: str
    unit: str
    frequency_hz: np.ndarray
    measured: np.ndarray
    coherence: np.ndarray
    relative_error: np.ndarray
    model: np.ndarray
    local: tuple[LocalParameter, ...]
    averages: int

    @property
    def coherent(self) -> np.ndarray:
        return self.coherence >= MIN_COHERENCE

    def to_dict(self) -> dict:
        return {"name": self.name, "input": self.input_name, "output": self.output_name, "unit": self.unit,
                "averages": self.averages, "coherent_bins": int(np.sum(self.coherent)),
                "local_parameters": [p.to_dict() for p in self.local]}

    def band(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The 99 % band: magnitude low and high, and the phase half-width [rad] (at most π)."""
        m, z = np.abs(self.measured), np.minimum(CONFIDENCE_Z * self.relative_error, math.pi)
        return m * np.exp(-z), m * np.exp(z), z

    def csv_rows(self) -> list[list]:
        """Rows of the CSV view (header first): frequency, measured magnitude and phase, its
        99 % band, coherence, model magnitude and phase."""
        m, mm = np.abs(self.measured), np.abs(self.model)
        z = CONFIDENCE_Z * self.relative_error
        rows = [["transfer", "frequency_hz", "measured_magnitude", "measured_phase_deg", "magnitude_low_99",
                 "magnitude_high_99", "phase_band_99_deg", "coherence", "model_magnitude", "model_phase_deg", "unit"]]
        for i, f in enumerate(self.frequency_hz):
            rows.append([self.name, float(f), float(m[i]), math.degrees(float(np.angle(self.measured[i]))),
                         float(m[i] * math.exp(-z[i])), float(m[i] * math.exp(z[i])), math.degrees(min(float(z[i]), math.pi)),
                         float(self.coherence[i]), float(mm[i]), math.degrees(float(np.angle(self.model[i]))), self.unit])
        return rows


@dataclass(frozen=True)
class ResidualTest:
    """Residual analysis of one simulated output (MATLAB's ``resid``): the normalized
    autocorrelation of the simulation error at ``lags`` (0…M) with the whiteness bound
    ±``auto_bound`` (2.58/√N), and its cross-correlation with the input ``input_name`` at lags
    −M…M (positive: the input leads) with the bound ``cross_bound`` for coloured signals
    (2.58·√(Σ R_ee R_uu)/N, Ljung eq. 16.67). ``peak_lag``: where |cross-correlation| / bound is
    largest."""

    output: str
    input_name: str
    lags: np.ndarray
    autocorrelation: np.ndarray
    auto_bound: float
    cross_lags: np.ndarray
    cross_correlation: np.ndarray
    cross_bound: float
    peak_lag: int

    @property
    def white(self) -> bool:
        return bool(np.mean(np.abs(self.autocorrelation[1:]) > self.auto_bound) <= 0.05)

    @property
    def independent(self) -> bool:
        return bool(np.all(np.abs(self.cross_correlation) <= self.cross_bound))

    def to_dict(self) -> dict:
        return {"output": self.output, "input": self.input_name, "white": self.white, "auto_bound": self.auto_bound,
                "autocorrelation": _floats(self.autocorrelation), "independent": self.independent,
                "cross_bound": self.cross_bound, "cross_lags": [int(x) for x in self.cross_lags],
                "cross_correlation": _floats(self.cross_correlation), "peak_lag": self.peak_lag}


@dataclass(frozen=True)
class ModelError:
    """The model error found for one parameter: a relative range ``relative`` (of the estimate)
    and what measured it (``source``)."""

    key: str
    relative: float
    source: str

    def to_dict(self) -> dict:
        return {"relative": self.relative, "source": self.source}


@dataclass(frozen=True)
class Validation(Result):
    """What ``--validate`` / ``--folds`` found: the simulated-output ``fits`` (on data not fitted
    on, or on the fitting log when ``held_out`` is False), the ``frequency_responses`` of ``data``,
    the ``residual_tests``, the ``model_errors`` (per parameter, the largest) and ``warnings``."""

    data: str
    held_out: bool
    fits: tuple[OutputFit, ...]
    frequency_responses: tuple[FrequencyResponse, ...]
    residual_tests: tuple[ResidualTest, ...]
    model_errors: tuple[ModelError, ...] = ()
    warnings: tuple[str, ...] = ()

    def model_error(self, key: str) -> ModelError | None:
        return next((m for m in self.model_errors if m.key == key), None)

    def to_dict(self) -> dict:
        return {"data": self.data, "held_out": self.held_out, "fits": [f.to_dict() for f in self.fits],
                "frequency_responses": [r.to_dict() for r in self.frequency_responses],
                "residual_tests": [t.to_dict() for t in self.residual_tests],
                "model_errors": {m.key: m.to_dict() for m in self.model_errors}, "warnings": list(self.warnings)}

    def to_csv(self) -> str:
        """The frequency responses as CSV (one row per transfer function and frequency)."""
        rows = [r for i, fr in enumerate(self.frequency_responses) for r in fr.csv_rows()[(1 if i else 0):]]
        return "".join(",".join(x if isinstance(x, str) else repr(float(x)) for x in r) + "\n" for r in rows)

    def to_text(self) -> str:
        from ..text.identify import validation_text

        return validation_text(self)

    def plot(self, ax=None):
        """Bode figures of the frequency responses (:mod:`exotune.plots.identification`)."""
        from ..plots.identification import validation_figures

        return validation_figures(self)
