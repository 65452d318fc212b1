"""The rounding bound of a float32 controller (docs/controller-file.md#precision): how far the
output of the float32 realization, run in float32 arithmetic, can be from the float64 controller
of the file (its ``sos`` in exact arithmetic) for inputs of stated amplitude, from the zero state,
over a stated horizon.

Two parts, each a rigorous first-order bound (terms of order 2⁻⁴⁸ neglected):

* **arithmetic**: every operation of the float32 step is a rounding point j (the inputs'
  conversion to float32 included); its error is at most u·|v_j| (u = 2⁻²⁴, round to nearest: half
  an ulp), |v_j| is at most Σ_i A_i ‖h_{i→j}‖₁ (the ℓ1 norm over the horizon of the exact system
  from input i to the value at j, A_i the amplitude of input i), and it reaches τ_cmd through the
  realization's own dynamics: ‖g_j‖₁ over the horizon. The bound is Σ_j ‖g_j‖₁ · u · max|v_j|:
  the roundoff noise gain of each rounding point times the half-ulp of the signal there.
* **coefficients**: the float32 coefficients against the float64 sos (both exact arithmetic):
  Σ_i A_i ‖h32_i − h64_i‖₁.

Everything comes from :func:`exotune.controllerfile.precision.linearize`: the step as executed.
With a DOB the controller has integral action (1/(1 − Q) has a pole at z = 1), so its open-loop
gains grow with the horizon; in the loop the plant bounds them.
"""

from __future__ import annotations

from typing import Mapping

import numpy as np

from ..sampled import Measured, assemble
from .model import Controller, ControllerFile, as_controller_file
from .precision import linearize
from .schema import SIGNAL_UNITS
from .sos import sos_ss

__all__ = ["UNIT_ROUNDOFF", "DEFAULT_AMPLITUDES", "DEFAULT_HORIZON_S", "roundoff_bound", "impulse_l1"]

UNIT_ROUNDOFF = 2.0 ** -24  # float32, round to nearest: |fl(x) − x| ≤ u·|x|
# stated input amplitudes [signal units] of the report: a strength-amplification joint
DEFAULT_AMPLITUDES = {"theta_m": 1.0, "omega_m": 10.0, "tau_s": 100.0, "dtau_s": 10000.0, "tau_c": 50.0}
DEFAULT_HORIZON_S = 0.1


def impulse_l1(A, B, C, D, n: int, squares: bool = False):
    """Σ_{k<n} |h[k]| of the impulse responses h[0] = D, h[k] = C A^{k−1} B (one column per input);
    with ``squares`` also Σ_{k<n} h[k]² (the H2 norm squared over the horizon).

    Parameters
    ----------
    A, B, C, D : numpy.ndarray
        A discrete state space.
    n : int
        The horizon [samples].
    squares : bool, optional
        Also return the sums of squares.

    Returns
    -------
    numpy.ndarray or tuple of numpy.ndarray
        Σ|h[k]| (outputs × inputs), and Σh[k]² with ``squares``.
    """
    h = np.atleast_2d(D).astype(float)
    acc, sq = np.abs(h), h * h
    X = np.array(B, dtype=float)
    for _ in range(1, n):
        h = C @ X
        acc += np.abs(h)
        if squares:
            sq += h * h
        X = A @ X
    return (acc, sq) if squares else acc


def _float64_controller(controller: Controller):
    static = np.array([controller.gain(s) for s in Measured], dtype=float)
    blocks = [(sos_ss(f.sos), f.input) for f in controller.filters]
    return assemble(static, blocks, 1.0, 0.0)


def _difference_l1(L: dict, c64, n: int) -> np.ndarray:
    """Σ_{k<n} |h32[k] − h64[k]| per input: the realization's exact impulse responses against the
    float64 sos controller's, as one system (block diagonal, output difference)."""
    n32, n64 = L["A"].shape[0], c64.Ac.shape[0]
    A = np.zeros((n32 + n64, n32 + n64))
    A[:n32, :n32], A[n32:, n32:] = L["A"], c64.Ac
    B = np.vstack([L["B"], c64.Bc])
    C = np.hstack([L["C"], -c64.Cc])
    return impulse_l1(A, B, C, L["D"] - c64.Dc, n)[0]


def roundoff_bound(doc: ControllerFile | dict, amplitudes: Mapping[str, float] | None = None,
                   horizon_samples: int | None = None, controller: Controller | Mapping | None = None) -> dict:
    """The rounding bound [N·m] of the file's float32 controller (``controller``: another of its
    controllers, e.g. a gain-schedule entry's), for inputs |y_i| ≤ ``amplitudes`` (default
    :data:`DEFAULT_AMPLITUDES`) over ``horizon_samples`` (default :data:`DEFAULT_HORIZON_S` at
    the file's rate) from the zero state.

    Parameters
    ----------
    doc : ControllerFile or dict
        The validated float32 controller file.
    amplitudes : Mapping or None, optional
        Largest |input| per signal (θ_m [rad], θ̇_m [rad/s], τ_s [N·m], τ̇_s [N·m/s], τ_c [N·m]);
        None for :data:`DEFAULT_AMPLITUDES`.
    horizon_samples : int or None, optional
        The horizon [samples]; None for :data:`DEFAULT_HORIZON_S` at the file's rate.
    controller : Controller or Mapping or None, optional
        The controller (with its realization); None for the file's nominal one.

    Returns
    -------
    dict
        ``arithmetic`` and ``coefficients`` and ``total`` ({value, unit: N·m}), ``by_location``
        (per filter section: rounding points and their share, largest first), the amplitudes,
        the horizon and the method.
    """
    cf = as_controller_file(doc)
    c = Controller.of(controller) if controller is not None else cf.controller
    fs = float(cf.sample_rate_hz)
    amp = dict(DEFAULT_AMPLITUDES if amplitudes is None else amplitudes)
    a = np.array([float(amp[s]) for s in Measured])
    n = int(horizon_samples) if horizon_samples is not None else max(1, int(round(DEFAULT_HORIZON_S * fs)))
    L = linearize(c.realization)
    ns, m = L["states"], len(Measured)
    V = L["V"]
    # ℓ1 over the horizon from each input to the value at each rounding point (exact system)
    vl1 = impulse_l1(L["A"], L["B"], V[:, :ns], V[:, ns:ns + m], n)
    vmax = vl1 @ a
    # ℓ1 over the horizon from each rounding point to τ_cmd (its error enters at step 0)
    gl1, gl2 = impulse_l1(L["A"], L["E"], L["C"], L["F"], n, squares=True)
    per_point = gl1[0] * UNIT_ROUNDOFF * vmax
    # the statistical size: independent errors uniform in ±u·max|v_j| (variance (u·max|v_j|)²/3)
    rms = float(np.sqrt(np.sum(gl2[0] * (UNIT_ROUNDOFF * vmax) ** 2 / 3.0)))
    coef = float(_difference_l1(L, _float64_controller(c), n) @ a)
    groups: dict[str, list] = {}
    for lab, b in zip(L["labels"], per_point):
        g = groups.setdefault(lab, [0, 0.0])
        g[0] += 1
        g[1] += float(b)
    arith = float(np.sum(per_point))
    by = [{"where": k, "points": v[0], "bound": {"value": v[1], "unit": "N·m"}}
          for k, v in sorted(groups.items(), key=lambda kv: -kv[1][1])]
    return {
        "precision": "float32",
        "form": c.realization.form,
        "input_amplitudes": {s: {"value": float(amp[s]), "unit": SIGNAL_UNITS[s]} for s in Measured},
        "horizon": {"samples": n, "seconds": n / fs},
        "unit_roundoff": UNIT_ROUNDOFF,
        "arithmetic": {"value": arith, "unit": "N·m"},
        "coefficients": {"value": coef, "unit": "N·m"},
        "total": {"value": arith + coef, "unit": "N·m"},
        "arithmetic_rms_estimate": {"value": rms, "unit": "N·m"},
        "rounding_points": int(L["points"]),
        "by_location": by,
        "method": ("|tau_cmd(float32 realization, float32 arithmetic) - tau_cmd(float64 sos, exact)| from the zero "
                   "state for inputs within the amplitudes over the horizon: arithmetic = sum over rounding points of "
                   "(l1 gain point -> tau_cmd) * 2^-24 * (l1 bound of the value there); coefficients = l1 of the "
                   "difference of the two controllers' impulse responses times the amplitudes; first order; "
                   "arithmetic_rms_estimate: H2 gains with independent uniform errors (typical size, not a bound)"),
    }
