"""Study (c): cuff stiffness K_c × lightest stable human inertia (for several amplifications).

    python studies/cuff_inertia.py [--workers N] [--data DIR] [--results DIR] [--resume]

Sweep: studies/cuff_inertia.yaml (base studies/cuff_inertia_base.yaml: paper hardware, one pure
inertia family from 1e-4 to 1 kg·m²). The lightest stable inertia is the lower end of the exact
stable interval that contains the upper end (1 kg·m²) of the family — no grid of trial inertias.
Outputs in results/cuff_inertia/: the generic report plus
  lightest_inertia_vs_cuff_stiffness.png   curves per α, log-log, with the realistic forearm band
  lightest_inertia_vs_cuff_stiffness.csv   the numbers (and all stable intervals)
  study.md
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from _common import plt, run_study, save_png, write_study_md

from exotune.jsonio import write_atomic

NAME = "cuff_inertia"


def lightest(intervals, lo: float, hi: float) -> float:
    """Lower end of the stable interval containing hi (inf when hi is unstable)."""
    if intervals and intervals[-1][1] >= hi * (1 - 1e-9):
        return float(intervals[-1][0])
    return float("inf")


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

    fig, ax = p.subplots(figsize=(8, 5.6))
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
    fig.tight_layout()
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
             "`lightest_inertia_vs_cuff_stiffness.csv`.")
    write_study_md(out, L, manifest)


if __name__ == "__main__":
    run_study(NAME, "cuff_inertia.yaml", __doc__, extra)
