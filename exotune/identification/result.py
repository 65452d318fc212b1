"""The typed result of ``exotune identify``: the plant parameters with their standard errors, the
fit of each equation, and the design-file sections they give.

References
----------
docs/identification.md; docs/design-file.md#uncertainty-optional-the-unit-of-the-plant-uncertainty-margin.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..record import Result

__all__ = ["ParameterEstimate", "EquationFit", "PlantEstimate", "UNCERTAINTY_SIGMAS"]

UNCERTAINTY_SIGMAS = 3.0  # the uncertainty section's relative range: this many standard errors


@dataclass(frozen=True)
class ParameterEstimate:
    """One plant parameter: ``key`` (design-file name), ``symbol``, ``value`` and ``std_error``
    in ``unit`` (from the covariance of its equation's estimate, docs/identification.md#standard-errors)."""

    key: str
    symbol: str
    value: float
    std_error: float
    unit: str
    fixed: bool = False

    @property
    def relative_std_error(self) -> float:
        return abs(self.std_error / self.value) if self.value != 0 else math.inf

    def to_dict(self) -> dict:
        return {"value": self.value, "std_error": self.std_error, "unit": self.unit,
                "relative_std_error": self.relative_std_error, "fixed": self.fixed}


@dataclass(frozen=True)
class EquationFit:
    """One regression: its ``equation`` (text), the parameters it gave, the sensor offset it
    absorbed [``offset_unit``], its coefficient of determination ``r2`` [–] and the RMS residual
    [``residual_unit``], and the ``covariance`` of its parameters' estimates (rows and columns in
    the order of ``parameters``, each in the product of their units)."""

    equation: str
    parameters: tuple[str, ...]
    offset: float
    offset_unit: str
    r2: float
    rms_residual: float
    residual_unit: str
    covariance: tuple[tuple[float, ...], ...] = ()

    def to_dict(self) -> dict:
        return {"equation": self.equation, "parameters": list(self.parameters),
                "offset": {"value": self.offset, "unit": self.offset_unit}, "r2": self.r2,
                "rms_residual": {"value": self.rms_residual, "unit": self.residual_unit},
                "covariance": [list(row) for row in self.covariance]}


@dataclass(frozen=True)
class PlantEstimate(Result):
    """``exotune identify``: the plant parameters the log determines (``parameters``, design-file
    keys), the fit of each equation, and what was used: ``samples`` at ``sample_rate_hz`` [Hz]
    after the filter's transient, the state-variable filter's corner ``filter_hz`` [Hz] and the
    residual's correlation length ``correlation_s`` [s] the standard errors account for.
    ``missing`` names the parameters the log's columns cannot determine, with the columns they
    need; ``not_identified`` those whose equation could not identify them (no excitation, or
    within 5 SE of zero); ``delay``: a held command's delay (given or estimated) with the motor
    equation's RMS residuals. The covariance is per equation (:attr:`EquationFit.covariance`; :meth:`covariance`
    assembles it): the equations are solved separately and their cross-covariances are not
    estimated. ``notes``: remarks that are not warnings (a given sample rate the time column
    contradicts: the rate given is used, as documented)."""

    parameters: tuple[ParameterEstimate, ...]
    fits: tuple[EquationFit, ...]
    sample_rate_hz: float
    samples: int
    filter_hz: float
    correlation_s: float
    missing: tuple[tuple[str, str], ...] = ()
    source: str = "<log>"
    rate_source: str = "t"
    not_identified: tuple[tuple[str, str], ...] = ()
    delay: dict | None = None
    warnings: tuple[str, ...] = ()
    model_errors: tuple = ()
    validation: object = None  # a Validation (exotune.identification.validresult), from validate_plant
    notes: tuple[str, ...] = ()  # what the report notes besides (a given rate the time column contradicts)

    def __getitem__(self, key: str) -> ParameterEstimate:
        for p in self.parameters:
            if p.key == key:
                return p
        raise KeyError(key)

    def covariance(self) -> tuple[list[str], np.ndarray]:
        """The parameters' keys and their covariance matrix (block-diagonal by equation).

        Returns
        -------
        keys : list of str
            The parameters' keys.
        covariance : numpy.ndarray
            Their covariance (n, n), in the products of their SI units.
        """
        keys = [p.key for p in self.parameters]
        C = np.zeros((len(keys), len(keys)))
        for f in self.fits:
            idx = [keys.index(k) for k in f.parameters]
            C[np.ix_(idx, idx)] = np.asarray(f.covariance, float).reshape(len(idx), len(idx))
        return keys, C

    @property
    def physical(self) -> bool:
        """Every estimate positive (a negative inertia, damping or stiffness is not a plant;
        Coulomb friction may be 0: not below −3 standard errors).

        Returns
        -------
        bool
            Whether the estimate is physical.
        """
        return all(p.value > (-UNCERTAINTY_SIGMAS * p.std_error if p.key == "coulomb_friction" else 0)
                   for p in self.parameters)

    @property
    def complete(self) -> bool:
        """Every parameter the log's columns allow identified, and physical (exit code 0).

        Returns
        -------
        bool
            Whether the identification is complete.
        """
        return self.physical and not self.not_identified

    def model_error(self, key: str):
        """The largest model error found for ``key`` (a ``ModelError``: the fitting log's
        diagnostics, and the validation's when there is one), or None.

        Parameters
        ----------
        key : str
            A parameter's key (``motor_inertia``, …).

        Returns
        -------
        ModelError or None
            The model error of largest relative size, None when none was found.
        """
        found = list(self.model_errors) + (list(self.validation.model_errors) if self.validation is not None else [])
        found = [m for m in found if m.key == key and m.relative > 0]
        return max(found, key=lambda m: m.relative) if found else None

    def uncertainty(self) -> dict:
        """Per design-file parameter: ``(relative range, what dominates)`` — the larger of
        :data:`UNCERTAINTY_SIGMAS` standard errors and the model error measured
        (:meth:`model_error`), capped below 1; what dominates is "3 SE" or the model error's source.

        Returns
        -------
        dict
            Design-file key → (relative range [–], what dominates).
        """
        out = {}
        for p in self.parameters:
            if p.key == "coulomb_friction":  # not a design-file parameter
                continue
            stat = UNCERTAINTY_SIGMAS * p.relative_std_error
            m = None if p.fixed else self.model_error(p.key)
            rng, why = (m.relative, m.source) if m is not None and m.relative > stat else (stat, f"{UNCERTAINTY_SIGMAS:g} SE")
            out[p.key] = (min(0.99, rng), why)
        return out

    def design_sections(self) -> dict:
        """``{"plant": …, "uncertainty": …}`` for a design file: the estimates, and as relative
        range of each the larger of the :data:`UNCERTAINTY_SIGMAS`-standard-error band and the
        model error measured (:meth:`uncertainty`; capped below 1).

        Returns
        -------
        dict
            The ``plant`` (values, SI units) and ``uncertainty`` (relative ranges [–]) sections.
        """
        ps = [p for p in self.parameters if p.key != "coulomb_friction"]  # not a design-file parameter
        unc = self.uncertainty()
        return {"plant": {p.key: float(p.value) for p in ps}, "uncertainty": {p.key: float(unc[p.key][0]) for p in ps}}

    def to_dict(self) -> dict:
        """The ``exotune identify --json`` object.

        Returns
        -------
        dict
            The estimates with their standard errors and units, the fits, the delay, the uncertainty,
            the warnings, the model errors, the validation and the method.
        """
        return {
            "source": self.source,
            "sample_rate_hz": self.sample_rate_hz,
            "sample_rate_from": "the time column" if self.rate_source == "t" else "given",
            "samples": self.samples,
            "filter_hz": self.filter_hz,
            "correlation_s": self.correlation_s,
            "parameters": {p.key: p.to_dict() for p in self.parameters},
            "fits": [f.to_dict() for f in self.fits],
            "not_identified": {k: why for k, why in self.missing + self.not_identified},
            "physical": self.physical,
            "complete": self.complete,
            "delay": self.delay,
            "uncertainty_sigmas": UNCERTAINTY_SIGMAS,
            "uncertainty": {k: {"relative": v, "dominated_by": why} for k, (v, why) in self.uncertainty().items()},
            "warnings": list(self.warnings) + (list(self.validation.warnings) if self.validation is not None else []),
            "notes": list(self.notes),
            "model_errors": {m.key: m.to_dict() for m in self.model_errors},
            "validation": self.validation.to_dict() if self.validation is not None else None,
            "method": ("least squares on the plant equations (docs/method.md#physical-model), every signal through "
                       "the state-variable filter ω³/(s + ω)³ and its s-, s²-multiples (first-order hold), a sensor "
                       "offset and the filters' start-up transients per equation (a held command filtered exactly and by "
                       "the hold's sinc² factor); covariance: least-squares sandwich with the residual's "
                       "autocovariance over the correlation length, plus the discretization bound"),
        }

    def to_text(self) -> str:
        """The text report of ``exotune identify``.

        Returns
        -------
        str
            The report.
        """
        lines = [f"exotune identify — {self.source}: {self.samples} samples at {self.sample_rate_hz:g} Hz"
                 f"{' (given)' if self.rate_source != 't' else ''}, "
                 f"filter {self.filter_hz:g} Hz, standard errors for residuals correlated over {self.correlation_s:.3g} s"]
        lines += [f"  note: {n}" for n in self.notes]
        for p in self.parameters:
            lines.append(f"  {p.key} ({p.symbol}): {p.value:.6g} {p.unit} (fixed)" if p.fixed else
                         f"  {p.key} ({p.symbol}): {p.value:.6g} ± {p.std_error:.3g} {p.unit} "
                         f"({100 * p.relative_std_error:.2g} %)")
        if self.delay is not None:
            d = self.delay
            how = "estimated: the smallest motor-equation residual" if d["estimated"] else "given"
            if not math.isfinite(d["rms_residual"]):  # the motor equation could not be fitted at all
                lines.append(f"  delay: {d['samples']} samples ({d['seconds']:.6g} s, {how}); the motor-equation residual "
                             "could not be computed (the log does not excite the motor equation), so the delay is "
                             "not checked")
            else:
                without = d["rms_residual_without_delay"]
                lines.append(f"  delay: {d['samples']} samples ({d['seconds']:.6g} s, {how}), RMS residual "
                             f"{d['rms_residual']:.3g} N·m (without delay "
                             + (f"{without:.3g} N·m" if math.isfinite(without) else "not computed")
                             + "".join(f", {k} samples {v:.3g} N·m" for k, v in d.get("rms_residual_neighbours", {}).items())
                             + ")")
        for f in self.fits:
            lines.append(f"  fit {f.equation}: R² {f.r2:.6f}, RMS residual {f.rms_residual:.3g} {f.residual_unit}, "
                         f"offset {f.offset:.3g} {f.offset_unit}" + ("" if f.parameters else " (every parameter fixed)"))
        for k, why in self.missing + self.not_identified:
            lines.append(f"  {k}: not identified ({why})")
        for w in self.warnings:
            lines.append(f"  warning: {w}")
        if self.validation is not None:
            lines.append(self.validation.to_text())
        lines += [f"  uncertainty {k}: ±{100 * v:.3g} % ({why})" for k, (v, why) in self.uncertainty().items()]
        if not self.physical:
            bad = ", ".join(p.key for p in self.parameters if p.value <= 0 and p.key != "coulomb_friction")
            lines.append(f"  NOT A PLANT: {bad} ≤ 0 (too little excitation, or the log's signs or units differ from "
                         "docs/identification.md)")
        from ..errors import printable

        return printable("\n".join(lines), keep="\n")  # the log's file names quoted: their control characters escaped
