"""``exotune optimize SPEC.yaml -o DESIGN.yaml``: the best design under robust-stability,
latency-margin, passivity, DOB-margin and amplification constraints.

Spec (YAML)::

    base: paper.yaml                     # design file (relative to the spec) or inline mapping
    objective: amplification             # see OBJECTIVES (default: amplification, maximized)
    free:                                # dotted paths (as sweep axes) with bounds
      design.amplification: [1.5, 40.0]
      design.zeta_hat: {lo: 0.3, hi: 1.2, scale: lin}
    constraints:                         # all optional; robust/free_stable/locked_stable default true
      robust: true                       # every human family stable over its whole range
      latency_margin_s: 0.001            # extra delay tolerated [s] (default below; 0 disables)
      max_phase_excess_deg: 10.0         # passivity of C7
      dob_phase_margin_deg: 30.0         # (the DOB margins need implementation.dob in the base)
      dob_gain_margin_db: 6.0
      dob_delay_margin_s: 0.001
      amplification_bandwidth_hz: 2.0
      amplification_peak_db: 1.0         # max over ω of |C6/C5(jω)| over its DC value [dB]
      nominal_passive: true              # the nominal C7 is passive (default false)
    seed: 0                              # (the command line's --seed wins)
    budget: 3000                         # exact analyses (default 1500 per free parameter, ≥ 3000)

Latency margin by default. A returned design tolerates an extra measured-to-applied delay of one
sample period when the base design sets ``implementation.sample_rate_hz``, else 0.5 ms
(``latency_margin_s: 0`` disables it; the default is 0 when ``robust``, ``free_stable`` or
``locked_stable`` is disabled, since the margin requires them). The result states the margin
required and the one achieved, computed exactly (:func:`exotune.analysis.latency_margin.latency_margin`).
``plant_uncertainty_margin`` is recognized but not available yet (a ConfigError says so).

Method. Every evaluation is the exact vectorized analysis of
:func:`exotune.analysis.analyze_batch` (:mod:`.evaluate`). The latency constraint is imposed
during the search by requiring the delay-sensitive verdicts also at T + m·k/K (K = 3); the
returned design is then checked with the exact margin and, when it falls short (an instability
window between the checked delays), the checked delays are doubled (plus one just past the
shortfall), the best designs evaluated so far are re-evaluated and polished again (at most 3
rounds; the exact value is always reported). The objective ``latency_margin_s`` is estimated by a
ladder of extra delays refined by multisection, and the best few designs are evaluated exactly.

1. Global stage: ``scipy.optimize.differential_evolution`` (vectorized, seeded → deterministic)
   on the free parameters in unit coordinates (log for ``scale: log``, the default for bounds
   spanning more than a decade) minimizing a penalty: infeasible designs score 1 + 10³ + their
   total normalized violation (robust: the unstable log-fraction of each family's range),
   feasible designs −objective (normalized). It spends half of the budget.
2. Local polish (the rest of the budget): when the objective is a free parameter (α, felt
   inertia), a batched pattern search over the other parameters maximizes the feasibility
   boundary along it — coordinate and random directions, Hooke–Jeeves moves along the last
   successful steps and directions scattered around them (the optimum usually lies on a ridge
   where two constraints meet), each improving trial pushed to its own boundary by
   multisection, restarted while it improves; otherwise a batched pattern search (coordinate
   and random directions, step halved down to 10⁻⁵) among feasible designs. On the 4-parameter
   problem of the tests (α, ζ̂, felt inertia and damping; bandwidth and robustness meeting at
   the optimum) five seeds land within 0.15 % of a long reference run at the default budget.
3. The best feasible design *evaluated* is taken back (a better point of a split feasible set
   is never lost), and the boundary along the objective parameter is located by multisection
   keeping the largest feasible point of each bracket.
4. Diagnosis: parameters at their bounds (``at_bounds``); binding constraints — relative slack
   below 10⁻³, or broken by a 10⁻³ perturbation (unit coordinates) of the optimum that improves
   the objective; for an infeasible problem, every broken constraint of the least-violating
   design with its value and the bound it needed (robust: the family and the unstable part of
   its range).

With ``pareto`` requested, the non-dominated designs of every evaluated point — objective vs
robust fraction, all other constraints met — are written as CSV. The search is a heuristic over
a non-convex, non-smooth set: the result is a feasible design verified exactly, not a
certificate of global optimality.

References
----------
docs/optimize-spec.md; paper §IV (coupled stability with the human), §IV-A (passivity), §II-D (amplification).
"""

from ..lazy import attach

__getattr__, __dir__, __all__ = attach(
    __name__,
    {
        "OBJECTIVES": "spec",
        "CONSTRAINTS": "spec",
        "OptimizeSpec": "spec",
        "load_optimize_spec": "spec",
        "optimize": "search",
        "run_optimize": "runner",
        "optimized_design_mapping": "spec",
    },
)
