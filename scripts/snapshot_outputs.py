"""Capture every CLI output of exotune on the shipped examples, for before/after comparisons.

    python scripts/snapshot_outputs.py OUT_DIR [--sweep-points 20000] [--no-sweep]

Writes one file per command (stdout, stderr tail, exit code) into OUT_DIR, plus a digest of the
rows of a benchmark sweep (sorted by design index; the manifest's timings excluded) and of the
report it gives. Provenance fields that change with the date are normalized. Compare two
snapshots with ``diff -r A B``. A refactoring that must not change behaviour shows no difference.
"""

from __future__ import annotations

import argparse
import hashlib
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
EX = ROOT / "examples"

_DATE = re.compile(r"(created|date|generated)(\"?:\s*\"?)[0-9T:\-+.Z ]{10,}")


def _norm(text: str, tmp: str) -> str:
    text = text.replace(tmp, "<TMP>")
    text = _DATE.sub(r"\1\2<DATE>", text)
    return text


def run(out: Path, name: str, args: list[str], tmp: str) -> None:
    p = subprocess.run([sys.executable, "-m", "exotune", *args], capture_output=True, text=True, cwd=ROOT,
                       env={**os.environ, "PYTHONWARNINGS": "ignore"})
    body = f"$ exotune {' '.join(args)}\nexit {p.returncode}\n--- stdout\n{p.stdout}\n--- stderr (last 3 lines)\n"
    body += "\n".join(p.stderr.strip().splitlines()[-3:]) + "\n"
    (out / f"{name}.txt").write_text(_norm(body, tmp))


def file_digest(out: Path, name: str, path: Path, tmp: str) -> None:
    if not path.exists():
        (out / f"{name}.file").write_text("missing\n")
        return
    if path.suffix in (".yaml", ".md", ".csv", ".txt", ".json"):
        text = _norm(path.read_text(), tmp)
        text = re.sub(r"(exotune_version|version): .*", r"\1: <V>", text)
        text = re.sub(r"(input_sha256|input_hash|sha256): .*", r"\1: <H>", text)
        (out / f"{name}.file").write_text(text)
    else:
        (out / f"{name}.file").write_text(hashlib.sha256(path.read_bytes()).hexdigest() + "\n")


def sweep_digest(out: Path, sweep_dir: Path) -> None:
    import pyarrow.parquet as pq

    files = sorted((sweep_dir / "chunks").glob("*.parquet"))
    tables = [pq.read_table(f) for f in files]
    lines = []
    for f, t in zip(files, tables):
        d = t.to_pydict()
        cols = sorted(d)
        lines.append(f"{f.name} rows={t.num_rows} cols={cols}")
        for c in cols:
            h = hashlib.sha256(repr(d[c]).encode()).hexdigest()[:16]
            lines.append(f"  {c} {h}")
    (out / "sweep_rows.txt").write_text("\n".join(lines) + "\n")


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("out")
    ap.add_argument("--sweep-points", type=int, default=20000)
    ap.add_argument("--no-sweep", action="store_true")
    a = ap.parse_args()
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    tmp = tempfile.mkdtemp(prefix="exo-snap-")
    T = Path(tmp)
    try:
        for ex in ("paper", "scheduled"):
            f = str(EX / f"{ex}.yaml")
            run(out, f"design_{ex}", ["design", f], tmp)
            run(out, f"design_{ex}_json", ["design", f, "--json"], tmp)
            run(out, f"analyze_{ex}", ["analyze", f], tmp)
            run(out, f"analyze_{ex}_json", ["analyze", f, "--json"], tmp)
            run(out, f"export_{ex}", ["export", f, "--sample-rate-hz", "1000", "-o", str(T / f"c_{ex}.yaml")], tmp)
            file_digest(out, f"controller_{ex}", T / f"c_{ex}.yaml", tmp)
            run(out, f"certify_{ex}", ["certify", str(T / f"c_{ex}.yaml")], tmp)
            run(out, f"certify_{ex}_json", ["certify", str(T / f"c_{ex}.yaml"), "--json"], tmp)
        run(out, "analyze_paper_crosscheck", ["analyze", str(EX / "paper.yaml"), "--cross-check", "--json"], tmp)
        run(out, "sea", ["sea", str(EX / "sea.yaml")], tmp)
        run(out, "sea_json", ["sea", str(EX / "sea.yaml"), "--json"], tmp)
        for sc in ("locked-output", "dob-friction", "light-mass", "saturation"):
            run(out, f"simulate_{sc}", ["simulate", str(T / "c_paper.yaml"), "--scenario", sc, "--json"], tmp)
        run(out, "simulate_text", ["simulate", str(T / "c_paper.yaml"), "--scenario", "light-mass"], tmp)
        run(out, "optimize", ["optimize", str(ROOT / "studies" / "pipeline.yaml"), "-o", str(T / "opt.yaml"),
                              "--json"], tmp)
        file_digest(out, "optimized_design", T / "opt.yaml", tmp)
        # error paths
        bad = T / "bad.yaml"
        bad.write_text((EX / "paper.yaml").read_text().replace("motor_inertia: 0.44", "motor_inertia: -0.44"))
        run(out, "error_negative", ["analyze", str(bad)], tmp)
        run(out, "error_missing", ["analyze", str(T / "nope.yaml")], tmp)
        if not a.no_sweep:
            spec = T / "sweep.yaml"
            spec.write_text(
                f"base: {EX / 'paper.yaml'}\n"
                "axes:\n"
                "  design.amplification: {start: 2.0, stop: 40.0, num: 20, scale: log}\n"
                "  design.zeta_hat: {start: 0.3, stop: 1.2, num: 10}\n"
                "  implementation.delay_s: {start: 0.0, stop: 0.004, num: 10}\n"
                "  implementation.dob.cutoff_hz: {start: 20.0, stop: 150.0, num: 10, scale: log}\n"
                "chunk_size: 5000\n"
            )
            sd = T / "sweep"
            run(out, "sweep", ["sweep", str(spec), "-o", str(sd), "--sample", str(a.sweep_points), "--seed", "1",
                               "--workers", "2"], tmp)
            sweep_digest(out, sd)
            run(out, "report", ["report", str(sd), "-o", str(T / "report")], tmp)
            for p in sorted((T / "report").glob("*")):
                if p.suffix in (".md", ".csv"):
                    file_digest(out, f"report_{p.name}", p, tmp)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
