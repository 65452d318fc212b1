"""Study (c): cuff stiffness K_c × lightest stable human inertia (for several amplifications).

    python studies/cuff_inertia.py [--workers N] [--data DIR] [--results DIR] [--resume]

Sweep: studies/cuff_inertia.yaml (base studies/cuff_inertia_base.yaml: paper hardware, one pure
inertia family from 1e-4 to 1 kg·m²). The lightest stable inertia is the lower end of the exact
stable interval that contains the upper end (1 kg·m²) of the family — no grid of trial inertias.
Outputs in results/cuff_inertia/: the generic report plus
  lightest_inertia_vs_cuff_stiffness.png   curves per α, log-log, with the realistic forearm band
  lightest_inertia_vs_cuff_stiffness.csv   the numbers (and all stable intervals)
  lightest_inertia_map.png                 the same numbers as a K_c × α map (log colour scale)
  robust_forearm_plant.cuff_stiffness__design.amplification.png
                                           robust for every inertia of the forearm band and heavier
                                           (≥ 0.06 kg·m²), alone and with the output locked; it replaces
                                           the report's robust map, which is 0 everywhere because the
                                           family's range starts at 1e-4 kg·m², lighter than the lightest
                                           stable inertia of every design (not a plotting bug)
  study.md
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from _common import plt, replace_report_figure, run_study, save_png, write_study_md

from exotune.jsonio import write_atomic

NAME = "cuff_inertia"


def lightest(intervals, lo: float, hi: float) -> float:
    """Lower end of the stable interval containing hi (inf when hi is unstable)."""
    if intervals and intervals[-1][1] >= hi * (1 - 1e-9):
        return float(intervals[-1][0])
    return float("inf")


FOREARM = 0.06  # kg·m², lower end of the forearm + hand band


def maps(kk, aa, K, A, light, ok, out: Path) -> None:
    """lightest_inertia_map.png and the forearm-band robust map (replacing the report's all-zero
    robust map: every design is unstable somewhere in [1e-4, 1] kg·m², so the family verdict is
    false everywhere — the aggregation is right, the question was not informative)."""
    from exotune.plots.sweep import heatmap

    ix, iy = np.searchsorted(K, kk), np.searchsorted(A, aa)
    g = np.full((A.size, K.size), np.nan)
    g[iy, ix] = np.where(ok, light, np.inf)
    write_atomic(out / "lightest_inertia_map.png",
                 heatmap(g, K, A, "plant.cuff_stiffness [N·m/rad]", "design.amplification [–]",
                         "lightest stable human inertia on the cuff (exact, stable up to 1 kg·m²)",
                         "human0_lightest_stable_inertia [kg·m²]", cmap="magma", log=True, fmt="{:.2g}"))
    r = np.full((A.size, K.size), np.nan)
    r[iy, ix] = (ok & (light <= FOREARM)).astype(float)
    write_atomic(out / "robust_forearm_plant.cuff_stiffness__design.amplification.png",
                 heatmap(r, K, A, "plant.cuff_stiffness [N·m/rad]", "design.amplification [–]",
                         f"robust for every inertia ≥ {FOREARM:g} kg·m² (forearm + hand), alone and locked "
                         "(1 = robust)", "fraction robust", vmin=0.0, vmax=1.0, cmap="RdYlGn", fmt="{:.0f}"))
    replace_report_figure(out, "robust_plant.cuff_stiffness__design.amplification.png",
                          "robust_forearm_plant.cuff_stiffness__design.amplification.png",
                          "that map is 0 everywhere: the family range starts at 1e-4 kg·m², lighter than the lightest "
                          "stable inertia of every design; this one asks for the forearm band and heavier")


def extra(df, manifest, out: Path) -> None:
    p = plt()
    lo, hi = manifest["spec"]["base"]["humans"][0]["inertia"]
    K = np.asarray(manifest["spec"]["axes"]["plant.cuff_stiffness"]["values"])
    A = np.asarray(manifest["spec"]["axes"]["design.amplification"]["values"])
    ivs = df["human0_mass_stable_intervals"].tolist()
    light = np.array([lightest(iv, lo, hi) for iv in ivs])
    kk = df["plant.cuff_stiffness"].to_numpy()
    aa = df["design.amplification"].to_numpy()
    free = df["free_stable"].to_numpy(bool)
    locked = df["locked_stable"].to_numpy(bool)

    maps(kk, aa, K, A, light, free & locked, out)
    fig, ax = p.subplots(figsize=(8, 5.6), layout="constrained")
    ax.axhspan(0.06, 0.15, color="tab:green", alpha=0.15, label="forearm + hand, 0.06–0.15 kg·m² (docs/method.md#physical-model)")
    ax.axhline(1e-3, color="k", lw=0.8, ls=":", label="light objects on the cuff ≈ 10⁻³ kg·m²")
    for a in A:
        sel = aa == a
        order = np.argsort(kk[sel])
        x, y = kk[sel][order], light[sel][order]
        ok = np.isfinite(y) & free[sel][order] & locked[sel][order]
        line, = ax.plot(x[ok], y[ok], "o-", ms=3, label=f"α = {a:g}")
        bad = ~ok
        if bad.any():
            ax.plot(x[bad], np.full(int(bad.sum()), hi), "x", color=line.get_color(), ms=7)
    ax.axhline(lo, color="gray", lw=0.8, ls="--")
    ax.text(K.min(), lo * 1.15, f"lower end of the analysed range ({lo:g} kg·m²): every inertia stable",
            fontsize=7, color="gray")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("cuff stiffness K_c [N·m/rad]")
    ax.set_ylabel("lightest stable human inertia [kg·m²]")
    ax.set_title("Lightest stable pure inertia on the cuff vs cuff stiffness\n"
                 "(exact stable interval containing 1 kg·m²; × = unstable even at 1 kg·m², alone or locked)",
                 fontsize=9)
    ax.grid(True, which="both", alpha=0.25)
    ax.legend(fontsize=8, loc="best")
    save_png(fig, out / "lightest_inertia_vs_cuff_stiffness.png")

    import csv
    import io

    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(["cuff_stiffness [N·m/rad]", "amplification [–]", "lightest_stable_inertia [kg·m²]", "free_stable",
                "locked_stable", "B2_hat [s]", "stable_intervals [kg·m²]"])
    for i in np.lexsort((kk, aa)):
        w.writerow([repr(float(kk[i])), repr(float(aa[i])), repr(float(light[i])), bool(free[i]), bool(locked[i]),
                    repr(float(df["B2_hat"].iloc[i])), json.dumps(ivs[i])])
    write_atomic(out / "lightest_inertia_vs_cuff_stiffness.csv", buf.getvalue())

    base = manifest["spec"]["base"]
    L = ["# Study (c): cuff stiffness × lightest stable human inertia", ""]
    L.append("Regenerate: `studies/run_all.sh` (or `python studies/cuff_inertia.py`). Sweep spec: "
             "`studies/cuff_inertia.yaml`; base `studies/cuff_inertia_base.yaml` = the paper hardware and controller "
             f"settings of `examples/paper.yaml` (T = {base['implementation']['delay_s'] * 1e3:g} ms, DOB "
             f"{base['implementation']['dob']['cutoff_hz']:g} Hz, ζ̂ = {base['design']['zeta_hat']:g}) with one human "
             f"family, a pure inertia over [{lo:g}, {hi:g}] kg·m².")
    L.append("")
    L.append(f"Grid: K_c ∈ [{K.min():g}, {K.max():g}] N·m/rad ({K.size} log-spaced values) × α ∈ "
             f"{{{', '.join(f'{a:g}' for a in A)}}} = {len(df)} designs. The controller gain B̂2 = (2ζ̂√(αK_cĴ_m) − "
             "B̂_m)/K_c is recomputed for every K_c (docs/method.md#double-compliance-shaping). *Lightest stable inertia* = the lower end of the exact "
             "stable interval containing 1 kg·m² (inertias between it and 1 kg·m² are all stable; lighter ones may "
             "destabilise the loop — the paper's \"destabilization by light inertias\").")
    L.append("")
    L.append("| K_c [N·m/rad] | " + " | ".join(f"α = {a:g}" for a in A) + " |")
    L.append("|---|" + "---|" * A.size)
    for k in K[:: max(1, K.size // 10)].tolist() + ([K[-1]] if (K.size - 1) % max(1, K.size // 10) else []):
        cells = []
        for a in A:
            i = np.flatnonzero((kk == k) & (aa == a))
            v = light[i[0]] if i.size else np.nan
            ok = bool(free[i[0]] and locked[i[0]]) if i.size else False
            cells.append(("∞" if np.isinf(v) else f"{v:.3g}") + ("" if ok else " (unstable alone/locked)"))
        L.append(f"| {k:.4g} | " + " | ".join(cells) + " |")
    L.append("")
    L.append(f"Units: kg·m². A value equal to {lo:g} means every inertia in the analysed range is stable; ∞ means "
             "even 1 kg·m² is unstable. The full table (all K_c, every stable interval) is in "
             "`lightest_inertia_vs_cuff_stiffness.csv`; `lightest_inertia_map.png` maps it over K_c × α.")
    L.append("")
    nrob = int(np.sum(free & locked & (light <= FOREARM)))
    L.append(f"The generic report's robust map is 0 in every cell, and that is correct, not a plotting bug: the family "
             f"verdict `human0_mass_robust` asks for stability over the whole range [{lo:g}, {hi:g}] kg·m², and the "
             f"lightest stable inertia of every design ({np.nanmin(light):.3g} kg·m² at best) is heavier than {lo:g}. "
             f"It is replaced by `robust_forearm_plant.cuff_stiffness__design.amplification.png`: stable alone, with the "
             f"output locked and for every inertia from {FOREARM:g} kg·m² (forearm + hand) up to {hi:g} kg·m² — "
             f"{nrob} of {len(light)} designs.")
    write_study_md(out, L, manifest)


if __name__ == "__main__":
    run_study(NAME, "cuff_inertia.yaml", __doc__, extra)
