"""How a running sweep reports to its caller: the :class:`SweepProgress` hooks.

The sweep never writes to the terminal itself. :func:`~exotune.sweeps.run.run_sweep` calls the
hooks of the ``progress`` object it is given: :meth:`SweepProgress.message` for the lines a user
reads (what is about to run, a failed chunk, completion, a stop by Ctrl-C or SIGTERM) and
:meth:`~SweepProgress.start` / :meth:`~SweepProgress.advance` / :meth:`~SweepProgress.close` for
the number of designs done. :class:`SweepProgress` itself ignores everything (a silent sweep);
:class:`TqdmProgress` draws a tqdm bar and writes the lines to a stream (the command line passes
``sys.stderr``); :class:`LineProgress` hands each line to a function (``progress=print`` in a
notebook).
"""

from __future__ import annotations

__all__ = ["SweepProgress", "TqdmProgress", "LineProgress", "as_progress", "MESSAGE_KINDS"]

MESSAGE_KINDS = ("start", "chunk_failed", "design_failed", "complete", "interrupted", "terminated")


class SweepProgress:
    """Progress hooks of a sweep; this base class ignores every event (a silent sweep).

    Subclass it and override the hooks to show progress. The hooks are called in the parent
    process only, in this order: ``message("start", …)``, ``start``, any number of ``advance``
    and ``message("chunk_failed", …)``, ``close``, then ``message("complete", …)`` when every
    chunk succeeded. A sweep stopped by Ctrl-C (SIGINT) or ``kill PID`` (SIGTERM) calls ``close``
    and then ``message("interrupted", …)`` or ``message("terminated", …)`` (how many chunks are kept
    and how to resume).

    References
    ----------
    docs/sweep-spec.md#resuming-parallelism-stopping.
    """

    def message(self, kind: str, text: str) -> None:
        """A line for the user.

        Parameters
        ----------
        kind : str
            One of :data:`MESSAGE_KINDS`: ``"start"`` (designs, chunks, backend, resumed chunks),
            ``"chunk_failed"`` (one line per failed chunk), ``"design_failed"`` (one line per chunk
            holding designs whose analysis raised: they are kept as rows without results), ``"complete"`` (designs computed, wall
            time, rate, output directory), ``"interrupted"`` (stopped by Ctrl-C) or ``"terminated"``
            (stopped by SIGTERM).
        text : str
            The line, without a trailing newline.
        """

    def start(self, total: int, done: int) -> None:
        """The sweep starts computing: ``total`` designs, of which ``done`` are already done
        (resumed chunks)."""

    def advance(self, n: int) -> None:
        """``n`` more designs are done (one chunk, computed or failed)."""

    def close(self) -> None:
        """No more designs will be computed (the sweep ended, failed or was interrupted)."""


class TqdmProgress(SweepProgress):
    """A tqdm progress bar (``sweep: 40%|████ | 8000/20000 …``) and the sweep's lines, on ``stream``.

    Lines of failed chunks are written with :meth:`tqdm.tqdm.write` so that they appear above
    the bar; the other lines are written as they are, each followed by a newline; their control
    characters (other than line breaks) are shown escaped (:func:`exotune.errors.printable`).

    Parameters
    ----------
    stream : file-like
        Where to write, e.g. ``sys.stderr`` (the command line).
    """

    def __init__(self, stream):
        self.stream = stream
        self._bar = None

    def message(self, kind: str, text: str) -> None:
        from ..errors import printable

        text = printable(text, keep="\n")  # an error quoting a user's string: its escapes shown, not acted on
        if kind in ("chunk_failed", "design_failed"):
            from tqdm import tqdm

            tqdm.write(text, file=self.stream)
        else:
            self.stream.write(text + "\n")

    def start(self, total: int, done: int) -> None:
        from tqdm import tqdm

        self._bar = tqdm(total=total, initial=done, unit="design", file=self.stream, disable=False,
                         dynamic_ncols=True, smoothing=0.05, desc="sweep")

    def advance(self, n: int) -> None:
        if self._bar is not None:
            self._bar.update(n)

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()


class LineProgress(SweepProgress):
    """Hands every line of the sweep (start, failed chunks, completion, a stop) to ``fn``;
    no progress bar.

    Parameters
    ----------
    fn : callable
        Called with one line of text (no trailing newline) at a time.
    """

    def __init__(self, fn):
        self.fn = fn

    def message(self, kind: str, text: str) -> None:
        self.fn(text)


def as_progress(progress) -> SweepProgress:
    """The :class:`SweepProgress` for a ``progress`` argument: itself, a :class:`LineProgress` for a
    callable, a silent :class:`SweepProgress` for ``None``/``False``.

    Parameters
    ----------
    progress : SweepProgress, callable, None or False
        What the caller passed.

    Returns
    -------
    SweepProgress
        The hooks the sweep calls.

    Raises
    ------
    TypeError
        For anything else (``True`` included: the library does not choose a stream itself).
    """
    if progress is None or progress is False:
        return SweepProgress()
    if isinstance(progress, SweepProgress):
        return progress
    if callable(progress):
        return LineProgress(progress)
    raise TypeError("progress must be a SweepProgress (e.g. TqdmProgress(sys.stderr)), a function of one line "
                    f"of text, or None; got {type(progress).__name__}")
