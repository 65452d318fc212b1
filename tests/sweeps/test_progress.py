"""exotune.sweeps.progress: the progress hooks a sweep calls (silent, tqdm on a stream, lines to a function)."""

import io

import pytest

from exotune.sweeps.progress import MESSAGE_KINDS, LineProgress, SweepProgress, TqdmProgress, as_progress


def test_the_base_class_is_silent():
    p = SweepProgress()
    for kind in MESSAGE_KINDS:
        assert p.message(kind, "text") is None
    assert p.start(10, 2) is None and p.advance(3) is None and p.close() is None


def test_line_progress_hands_every_message_to_the_function():
    lines = []
    p = LineProgress(lines.append)
    for kind in MESSAGE_KINDS:
        p.message(kind, f"{kind} line")
    p.start(5, 0)
    p.advance(5)
    p.close()
    assert lines == [f"{k} line" for k in MESSAGE_KINDS]


def test_tqdm_progress_writes_lines_and_a_bar_to_its_stream():
    out = io.StringIO()
    p = TqdmProgress(out)
    p.advance(1)  # before start: no bar, nothing happens
    p.close()
    p.message("start", "running 10 designs")
    p.start(10, 4)
    p.advance(6)
    p.message("chunk_failed", "chunk 3 failed: boom")
    p.close()
    p.message("complete", "done")
    text = out.getvalue()
    assert text.startswith("running 10 designs\n")
    assert "chunk 3 failed: boom\n" in text
    assert "10/10" in text and "sweep" in text
    assert text.endswith("done\n")


def test_as_progress():
    assert type(as_progress(None)) is SweepProgress and type(as_progress(False)) is SweepProgress
    p = TqdmProgress(io.StringIO())
    assert as_progress(p) is p
    lines = []
    lp = as_progress(lines.append)
    assert isinstance(lp, LineProgress)
    lp.message("start", "x")
    assert lines == ["x"]
    with pytest.raises(TypeError, match="got bool"):
        as_progress(True)
    with pytest.raises(TypeError, match="got str"):
        as_progress("stderr")
