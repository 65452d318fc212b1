"""Text of the identification's validation (``exotune identify --validate/--folds``): the
simulated-output fits, the frequency responses' coherent bands and departures, the residual
tests and the warnings (docs/identification.md#validation)."""

from __future__ import annotations

from ..errors import printable
from .numbers import count_text

__all__ = ["validation_text"]


def validation_text(v) -> str:
    """The lines of a :class:`exotune.identification.validresult.Validation`, indented under the
    identify report.

    Parameters
    ----------
    v : Validation
        The validation of a plant estimate.

    Returns
    -------
    str
        The lines, joined.
    """
    lines = [f"  validation on {v.data}" + ("" if v.held_out else " (the fitting log: residual tests and frequency "
                                                                 "responses only; --validate or --folds for held-out fits)")]
    for f in v.fits:
        lines.append(f"    simulated {f.output} from {f.inputs}: NRMSE {f.nrmse_percent:.3g} % (fit {f.fit_percent:.3g} %), "
                     f"{f.samples} samples, {f.data}")
    for r in v.frequency_responses:
        n = int(r.coherent.sum())
        band = (f"{r.frequency_hz[r.coherent].min():.3g}–{r.frequency_hz[r.coherent].max():.3g} Hz" if n else "none")
        parts = ", ".join(f"{p.symbol} {'within its band' if p.relative_excess == 0 else f'departs {100 * p.relative_excess:.2g} % at {p.at_hz:.3g} Hz'}"
                          for p in r.local)
        where = (f"coherent (γ² ≥ 0.9) in {count_text(n, 'bin')}, {band}" if n
                 else "no coherent bin (γ² ≥ 0.9): nothing to compare with the model")
        lines.append(f"    frequency response {r.name} ({r.input_name} → {r.output_name}): {where}"
                     + (f"; {parts}" if parts else ""))
    for t in v.residual_tests:
        lines.append(f"    residuals of {t.output}: {'white' if t.white else 'not white'} (bound ±{t.auto_bound:.2g}), "
                     f"{'independent of' if t.independent else 'correlated with'} {t.input_name} "
                     f"(largest at lag {t.peak_lag} samples, bound ±{t.cross_bound:.2g})")
    lines += [f"  warning: {w}" for w in v.warnings]
    return printable("\n".join(lines), keep="\n")  # the logs' file names quoted: their control characters escaped
