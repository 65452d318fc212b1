"""The typed results of a sweep (its directory, manifest and rows) and of its report (docs/sweep-spec.md).

References
----------
docs/api.md#typed-results; docs/sweep-spec.md.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

from ..errors import printable
from ..record import Record, Result

__all__ = ["SweepResult", "SweepReport", "chunk_list"]


def chunk_list(indices, limit: int = 10) -> str:
    """Chunk indices as a report names them: ``chunk 4``, ``chunks 4, 7, 9``, the first ``limit``
    followed by ``…`` when there are more.

    Parameters
    ----------
    indices : sequence of int
        The chunks (at least one).
    limit : int, optional
        How many are listed.

    Returns
    -------
    str
        The text.
    """
    idx = [int(i) for i in indices]
    text = ", ".join(str(i) for i in idx[:limit]) + (" …" if len(idx) > limit else "")
    return f"chunk{'' if len(idx) == 1 else 's'} {text}"


@dataclass(frozen=True)
class SweepResult(Record):
    """A sweep directory (docs/sweep-spec.md): its manifest (``to_dict()``) and the Parquet rows
    on demand (:meth:`table`)."""

    directory: str = ""
    status: str | None = None
    points_total: int | None = None

    @classmethod
    def from_directory(cls, directory) -> "SweepResult":
        """The sweep written into ``directory`` (its ``manifest.json``).

        Parameters
        ----------
        directory : str or os.PathLike
            The sweep directory.

        Returns
        -------
        SweepResult
            The sweep.
        """
        d = Path(directory)
        return cls.from_manifest(json.loads((d / "manifest.json").read_text()), d)

    @classmethod
    def from_manifest(cls, man: dict, directory) -> "SweepResult":
        """The sweep in ``directory`` whose manifest is ``man``.

        Parameters
        ----------
        man : dict
            The manifest.
        directory : str or os.PathLike
            The sweep directory.

        Returns
        -------
        SweepResult
            The sweep.
        """
        total = man.get("points_total", man.get("n_points"))
        return cls(man, str(directory), man.get("status"), None if total is None else int(total))

    def table(self):
        """Every computed row as one ``pyarrow.Table`` (chunks in design-index order).

        Returns
        -------
        pyarrow.Table
            The rows (an empty table before the first chunk is written).
        """
        import pyarrow as pa
        import pyarrow.parquet as pq

        files = sorted((Path(self.directory) / "chunks").glob("*.parquet"))
        return pa.concat_tables([pq.read_table(f) for f in files]) if files else pa.table({})

    def to_text(self) -> str:
        """The manifest as indented JSON.

        Returns
        -------
        str
            The text.
        """
        return json.dumps(self.to_dict(), indent=2)

    def map_data(self, column: str = "robust", axes: tuple[str, str] | None = None):
        """One value per cell of two sweep axes (default: the first two), reduced over the others:
        ``column`` "robust" → the fraction of robust designs; a numeric column → its worst case
        (the minimum; ``passivity_max_phase_excess_deg``: the maximum).

        Returns (grid[iy, ix], x values, y values, x path, y path).

        Parameters
        ----------
        column : str, optional
            ``"robust"`` or a numeric column of the sweep.
        axes : tuple of str, optional
            The two axes' parameter paths (x, y).

        Returns
        -------
        grid : numpy.ndarray
            One value per cell (ny, nx): the fraction robust [–] or the column's worst case, in its unit.
        xs, ys : numpy.ndarray
            The x and y axis values (SI units), sorted.
        x_path, y_path : str
            The axes' parameter paths.
        """
        import numpy as np

        from .metrics import aggregate, robust_mask

        man_axes = [a["path"] for a in self.to_dict()["axes"]]
        xp, yp = axes or (man_axes[0], man_axes[1] if len(man_axes) > 1 else man_axes[0])
        t = self.table()
        cols = {c: t.column(c).to_numpy(zero_copy_only=False) for c in t.column_names
                if c == "free_stable" or c == column or c.endswith(("_robust", "_stable")) or c in (xp, yp)}
        if column == "robust":
            vals, how = robust_mask(cols)[0].astype(float), "mean"
        else:
            vals, how = np.asarray(cols[column], float), "max" if column.startswith("passivity") else "min"
        xs, ix = np.unique(cols[xp], return_inverse=True)
        ys, iy = np.unique(cols[yp], return_inverse=True)
        grid = aggregate(iy * xs.size + ix, xs.size * ys.size, vals, how).reshape(ys.size, xs.size)
        return grid, xs, ys, xp, yp

    def plot(self, column: str = "robust", axes: tuple[str, str] | None = None, ax=None):
        """A heatmap of :meth:`map_data` (fraction robust or a column's worst case) over two axes;
        returns the matplotlib ``Figure``.

        Parameters
        ----------
        column : str, optional
            ``"robust"`` or a numeric column of the sweep.
        axes : tuple of str, optional
            The two axes' parameter paths (x, y); default the first two.
        ax : matplotlib.axes.Axes, optional
            Where to draw; None for a new figure.

        Returns
        -------
        matplotlib.figure.Figure
            The figure.
        """
        from ..plots.results import sweep_map

        grid, xs, ys, xp, yp = self.map_data(column, axes)
        what = "fraction of robust designs" if column == "robust" else f"{column} (worst case)"
        return sweep_map(grid, xs, ys, xp, yp, what, "fraction" if column == "robust" else column, ax=ax)


@dataclass(frozen=True)
class SweepReport(Result):
    """``exotune report``: where the report of a sweep went (``directory``), the files written
    (``files``: ``summary.md``, the per-axis CSV tables, the PNG maps), the maps among them
    (``maps``, in the order ``summary.md`` lists them) and, for a partial sweep, the chunks not
    finished (``missing_chunks``) of the sweep in ``sweep_dir`` and whether that sweep appears to
    be still running (``running``: its manifest says so and a run holds its lock; None when
    constructed: looked up in ``sweep_dir``)."""

    directory: Path
    files: tuple[str, ...] = ()
    maps: tuple[str, ...] = ()
    missing_chunks: tuple[int, ...] = ()
    sweep_dir: str | None = None
    running: bool | None = None

    def __post_init__(self):
        # a partial report of a sweep still running says so (None: looked up in its directory)
        if self.running is None:
            running = False
            if self.missing_chunks and self.sweep_dir is not None:
                from .manifest import sweep_running

                running = sweep_running(self.sweep_dir)
            object.__setattr__(self, "running", running)

    def to_dict(self) -> dict:
        """The ``exotune report --json`` object.

        Returns
        -------
        dict
            ``directory``, ``files``, ``maps`` and ``missing_chunks`` (empty for a complete sweep).
        """
        return {"directory": str(self.directory), "files": list(self.files), "maps": list(self.maps),
                "missing_chunks": list(self.missing_chunks)}

    def to_text(self) -> str:
        """What ``exotune report`` prints: where the report went and, for a partial sweep, which
        chunks are missing and how to compute them.

        Returns
        -------
        str
            One line, two for a partial sweep.
        """
        n = len(self.maps)
        text = f"wrote report to {self.directory} ({n} map{'' if n == 1 else 's'}, summary.md)"
        if self.missing_chunks and self.running:
            n = len(self.missing_chunks)
            text += (f"\npartial report: the sweep appears to be still running (its manifest says running and a run "
                     f"holds its directory's lock); {chunk_list(self.missing_chunks)} "
                     f"{'is' if n == 1 else 'are'} not finished yet and the report covers the finished chunks only; "
                     "run `exotune report` again once the sweep has finished")
        elif self.missing_chunks:
            where = f" and -o {self.sweep_dir}" if self.sweep_dir is not None else ""
            text += (f"\npartial sweep: {chunk_list(self.missing_chunks)} missing; the report covers the finished "
                     f"chunks only; rerun `exotune sweep` with the same spec{where} to compute "
                     f"{'it' if len(self.missing_chunks) == 1 else 'them'}, then `exotune report` again")
        return printable(text, keep="\n")  # a directory name cannot drive the terminal
