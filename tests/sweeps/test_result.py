"""exotune.sweeps.result: SweepResult reads a sweep directory (manifest and chunk rows) and reduces
a column over two axes; SweepReport says what a report wrote. On a hand-made directory."""

import json

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pyarrow as pa  # noqa: E402
import pyarrow.parquet as pq  # noqa: E402
import pytest  # noqa: E402

from exotune.sweeps.result import SweepReport, SweepResult, chunk_list  # noqa: E402

MANIFEST = {"format": "exotune-sweep", "status": "complete", "n_points": 6,
            "axes": [{"path": "design.amplification"}, {"path": "implementation.delay_s"}, {"path": "design.zeta"}]}


@pytest.fixture
def sweep_dir(tmp_path):
    (tmp_path / "manifest.json").write_text(json.dumps(MANIFEST))
    (tmp_path / "chunks").mkdir()
    # α ∈ {2, 8} × T ∈ {0, 0.002} × ζ ∈ {0.5, 0.7} (8 rows over two chunks; ζ is reduced over)
    a = np.repeat([2.0, 8.0], 4)
    t = np.tile(np.repeat([0.0, 0.002], 2), 2)
    z = np.tile([0.5, 0.7], 4)
    free = np.array([1, 1, 1, 0, 1, 0, 0, 0], bool)
    human = np.array([1, 1, 1, 1, 1, 1, 0, 0], bool)
    margin = np.array([4.0, 3.0, 2.0, 1.0, 0.5, np.nan, 0.2, 0.1])
    excess = np.array([0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0])
    cols = {"design.amplification": a, "implementation.delay_s": t, "design.zeta": z, "free_stable": free,
            "human0_mass_robust": human, "latency_margin_s": margin, "passivity_max_phase_excess_deg": excess}
    for i, sl in enumerate((slice(0, 5), slice(5, 8))):
        pq.write_table(pa.table({k: v[sl] for k, v in cols.items()}), tmp_path / "chunks" / f"part-00000{i}.parquet")
    return tmp_path


def test_from_directory(sweep_dir):
    r = SweepResult.from_directory(sweep_dir)
    assert (r.directory, r.status, r.points_total) == (str(sweep_dir), "complete", 6)
    assert r.to_dict() == MANIFEST
    assert json.loads(r.to_text()) == MANIFEST
    t = r.table()
    assert t.num_rows == 8 and t.column("latency_margin_s").to_pylist()[:2] == [4.0, 3.0]  # chunks in order
    assert SweepResult.from_manifest({"points_total": 9}, sweep_dir).points_total == 9
    assert SweepResult.from_manifest({}, sweep_dir).points_total is None


def test_empty_directory_has_an_empty_table(tmp_path):
    assert SweepResult.from_manifest(MANIFEST, tmp_path).table().num_rows == 0


def test_map_data_fraction_robust_over_the_other_axes(sweep_dir):
    grid, xs, ys, xp, yp = SweepResult.from_directory(sweep_dir).map_data()
    assert (xp, yp) == ("design.amplification", "implementation.delay_s")
    assert xs.tolist() == [2.0, 8.0] and ys.tolist() == [0.0, 0.002]
    # robust = free ∧ human: rows 0,1,2 and 4 → cells (α=2,T=0): 2/2, (α=2,T=.002): 1/2, (8,0): 1/2, (8,.002): 0/2
    assert grid.tolist() == [[1.0, 0.5], [0.5, 0.0]]


def test_map_data_worst_case_of_a_column(sweep_dir):
    r = SweepResult.from_directory(sweep_dir)
    grid, *_ = r.map_data("latency_margin_s")  # the minimum, NaN ignored
    assert grid.tolist() == [[3.0, 0.5], [1.0, 0.1]]  # rows: delay, columns: amplification
    grid, *_ = r.map_data("passivity_max_phase_excess_deg")  # passivity excess: the maximum
    assert grid.tolist() == [[1.0, 5.0], [3.0, 7.0]]
    grid, xs, ys, xp, yp = r.map_data("robust", axes=("design.zeta", "design.amplification"))
    assert (xp, yp) == ("design.zeta", "design.amplification") and xs.tolist() == [0.5, 0.7]
    assert grid.tolist() == [[1.0, 0.5], [0.5, 0.0]]  # rows: α, columns: ζ


def test_plot_draws_the_map_into_the_given_ax(sweep_dir):
    fig, ax = plt.subplots()
    out = SweepResult.from_directory(sweep_dir).plot(ax=ax)
    assert out is fig
    assert np.allclose(ax.get_images()[0].get_array(), [[1.0, 0.5], [0.5, 0.0]])
    plt.close(fig)


def test_sweep_report():
    rep = SweepReport("out/report", ("summary.md", "robust_a__b.png"), ("robust_a__b.png",))
    assert rep.to_dict() == {"directory": "out/report", "files": ["summary.md", "robust_a__b.png"],
                             "maps": ["robust_a__b.png"], "missing_chunks": []}
    assert rep.to_text() == "wrote report to out/report (1 map, summary.md)"
    assert SweepReport("r", (), ("a", "b")).to_text() == "wrote report to r (2 maps, summary.md)"


def test_the_report_of_a_partial_sweep_names_the_missing_chunks_and_how_to_compute_them():
    rep = SweepReport("sw/report", ("summary.md",), (), (4, 7), "sw")
    assert rep.to_dict()["missing_chunks"] == [4, 7]
    assert rep.to_text().splitlines() == [
        "wrote report to sw/report (0 maps, summary.md)",
        "partial sweep: chunks 4, 7 missing; the report covers the finished chunks only; rerun `exotune sweep` with "
        "the same spec and -o sw to compute them, then `exotune report` again"]


def test_chunk_list():
    assert chunk_list([4]) == "chunk 4"
    assert chunk_list(range(3)) == "chunks 0, 1, 2"
    assert chunk_list(range(12)) == "chunks 0, 1, 2, 3, 4, 5, 6, 7, 8, 9 …"
