"""Study (b): DOB cutoff × delay → DOB delay margin (and phase/gain margins, robust stability).

    python studies/dob_delay.py [--workers N] [--data DIR] [--results DIR] [--resume]

Sweep: studies/dob_delay.yaml (base studies/arm.yaml). Outputs in results/dob_delay/: the generic
report plus
  dob_delay_margin_map.png   delay margin [ms] over cutoff × T with 0.5/1/2 ms contours, the DOB
                             loop's unstable region shaded and the robust-stability boundary
  dob_cutoff_limits.csv      for each T: largest cutoff with delay margin ≥ 0.5 / 1 / 2 ms
  study.md
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from _common import plt, robust_of, run_study, runs, save_png, write_study_md

from exotune.jsonio import write_atomic

NAME = "dob_delay"
LEVELS_MS = (0.5, 1.0, 2.0)


def extra(df, manifest, out: Path) -> None:
    from matplotlib.ticker import NullFormatter

    p = plt()
    F = np.asarray(manifest["spec"]["axes"]["implementation.dob.cutoff_hz"]["values"])
    T = np.asarray(manifest["spec"]["axes"]["implementation.delay_s"]["values"])
    i_f = np.searchsorted(F, df["implementation.dob.cutoff_hz"].to_numpy())
    i_t = np.searchsorted(T, df["implementation.delay_s"].to_numpy())

    def grid(v):
        g = np.full((T.size, F.size), np.nan)
        g[i_t, i_f] = v
        return g

    dm = df["dob_delay_margin_s"].to_numpy(float) * 1e3
    pm = df["dob_phase_margin_deg"].to_numpy(float)
    # a DOB loop that is already unstable has no delay margin: exotune reports dob_stable = False
    # and a 0 s margin for it (shown masked here)
    dob_unstable = ~df["dob_stable"].to_numpy(bool)
    dm_valid = np.where(dob_unstable, np.nan, dm)
    robust = robust_of(df)

    fig, axes = p.subplots(1, 2, figsize=(13, 5.4), layout="constrained")
    ax = axes[0]
    G = grid(dm_valid)
    finite = G[np.isfinite(G)]
    from matplotlib.colors import LogNorm

    pos = finite[finite > 0]
    norm = LogNorm(vmin=max(float(pos.min()), 0.05), vmax=float(pos.max())) if pos.size else None
    im = ax.pcolormesh(F, T * 1e3, np.ma.masked_invalid(np.where(G > 0, G, np.nan)), shading="nearest",
                       cmap="viridis", norm=norm)
    fig.colorbar(im, ax=ax, label="DOB delay margin [ms] (extra delay on top of T)")
    cs = ax.contour(F, T * 1e3, np.nan_to_num(G, nan=-1.0), levels=list(LEVELS_MS), colors="w", linewidths=1.2)
    ax.clabel(cs, fmt=lambda v: f"{v:g} ms", fontsize=8)
    U = grid(dob_unstable.astype(float))
    ax.contourf(F, T * 1e3, U, levels=[0.5, 1.5], colors="none", hatches=["xx"])
    ax.contour(F, T * 1e3, U, levels=[0.5], colors="r", linewidths=1.5)
    R = grid(robust.astype(float))
    ax.contour(F, T * 1e3, R, levels=[0.5], colors="orange", linewidths=2.0, linestyles="--")
    ax.set_title("DOB delay margin; hatched/red: DOB loop unstable (PM or GM ≤ 0);\n"
                 "orange dashed: boundary of robust stability (all human families)", fontsize=9)
    ax2 = axes[1]
    G2 = grid(np.where(dob_unstable, np.nan, pm))
    im2 = ax2.pcolormesh(F, T * 1e3, np.ma.masked_invalid(G2), shading="nearest", cmap="magma", vmin=0)
    fig.colorbar(im2, ax=ax2, label="DOB phase margin [deg]")
    cs2 = ax2.contour(F, T * 1e3, np.nan_to_num(G2, nan=-1.0), levels=[30, 45, 60], colors="w", linewidths=1.0)
    ax2.clabel(cs2, fmt=lambda v: f"{v:g}°", fontsize=8)
    ax2.set_title("DOB phase margin (blank: DOB loop unstable)", fontsize=9)
    for a in axes:
        a.set_xscale("log")
        a.set_xticks([10, 20, 50, 100, 200], ["10", "20", "50", "100", "200"])
        a.xaxis.set_minor_formatter(NullFormatter())
        a.set_xlabel("DOB cutoff f_q [Hz]")
        a.set_ylabel("total delay T [ms]")
    save_png(fig, out / "dob_delay_margin_map.png")

    rows = ["delay_ms," + ",".join(f"max_cutoff_hz_margin_ge_{lv:g}ms" for lv in LEVELS_MS)
            + ",max_cutoff_hz_robust,min_cutoff_hz_robust"]
    md = []
    for k, t in enumerate(T):
        line = [f"{t * 1e3:.4g}"]
        cells = []
        for lv in LEVELS_MS:
            ok = G[k] >= lv
            v = F[ok].max() if ok.any() else np.nan
            line.append("" if np.isnan(v) else f"{v:.6g}")
            cells.append("none" if np.isnan(v) else f"{v:.3g}")
        rk = R[k] > 0.5
        line += [f"{F[rk].max():.6g}" if rk.any() else "", f"{F[rk].min():.6g}" if rk.any() else ""]
        cells.append(runs(F, rk))
        rows.append(",".join(line))
        md.append(f"| {t * 1e3:.3g} | " + " | ".join(cells) + " |")
    write_atomic(out / "dob_cutoff_limits.csv", "\n".join(rows) + "\n")

    base = manifest["spec"]["base"]
    L = ["# Study (b): DOB cutoff × delay — DOB delay margin", ""]
    L.append("Regenerate: `studies/run_all.sh` (or `python studies/dob_delay.py`). Sweep spec: `studies/dob_delay.yaml`; "
             f"base design `studies/arm.yaml` (paper hardware, α = {base['design']['amplification']:g}, DOB damping "
             f"ζ_q = {base['implementation']['dob']['damping']:g}, realistic human ranges).")
    L.append("")
    L.append(f"Grid: DOB cutoff f_q ∈ [{F.min():g}, {F.max():g}] Hz ({F.size} log-spaced values) × T ∈ "
             f"[0, {T.max() * 1e3:g}] ms ({T.size} values) = {len(df)} designs. The DOB margins are those of "
             "L_dob(s) = Q(s) e^{−sT}/(1 − Q(s)) (docs/method.md#controller, docs/method.md#analyses-and-metrics); the delay margin is the extra delay on top of T "
             "(minimum over all gain crossovers).")
    L.append("")
    L.append(f"{int(dob_unstable.sum())} designs have an unstable closed DOB loop with their delay "
             "(`dob_stable` false; exotune reports a 0 s delay margin for them; masked in the map). "
             f"{int(robust.sum())} of {len(df)} designs are robustly stable for every human family.")
    L.append("")
    L.append("| T [ms] | " + " | ".join(f"max f_q [Hz] with margin ≥ {lv:g} ms" for lv in LEVELS_MS)
             + " | robust f_q range [Hz] |")
    L.append("|---|" + "---|" * (len(LEVELS_MS) + 1))
    L.extend(md)
    L.append("")
    L.append("Figures: `dob_delay_margin_map.png` (this study), the generic report's `robust_*.png`, "
             "`metrics_*.png` and `summary.md`.")
    write_study_md(out, L, manifest)


if __name__ == "__main__":
    run_study(NAME, "dob_delay.yaml", __doc__, extra)
