"""exotune.sweeps.store: numpy columns → Arrow arrays equal to pyarrow's own conversion, Parquet
bytes, chunk paths and the failed-rows metadata."""

import io
import json
import os

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from hypothesis import given
from hypothesis import strategies as st

from exotune.sweeps.store import (CHUNK_DIR, FAILED_ROWS_KEY, arrow_column, chunk_file, failed_rows_of,
                                  nested_float_lists, np_arrow, schema_list, table_bytes)

LL = pa.list_(pa.list_(pa.float64()))


@given(st.lists(st.floats(allow_nan=True, allow_infinity=True), max_size=20), st.integers(1, 3))
def test_np_arrow_equals_pa_array(xs, step):
    v = np.array(xs, dtype=float)[::step]  # strided: not contiguous
    got = np_arrow(v, "f")
    ref = pa.array(v, type=pa.float64(), from_pandas=False)
    assert got.type == pa.float64() and got.to_pylist() == pytest.approx(ref.to_pylist(), nan_ok=True)
    assert got.null_count == 0  # NaN is a value, not a null


@given(st.lists(st.booleans(), max_size=40))
def test_bool_columns_are_packed_correctly(bs):
    assert np_arrow(np.array(bs, dtype=bool), "b").to_pylist() == bs


def test_int_kinds():
    assert np_arrow(np.array([1, -2, 3]), "i").type == pa.int64()
    assert np_arrow(np.array([1, 2], dtype=np.int64), "i32").to_pylist() == [1, 2]


@given(st.lists(st.lists(st.lists(st.floats(allow_nan=False), min_size=2, max_size=2), max_size=3), max_size=6))
def test_nested_float_lists_equal_pa_array(rows):
    got = nested_float_lists(rows)
    assert got.type == LL
    assert got.equals(pa.array(rows, type=LL))


def test_arrow_column_dispatch_and_errors():
    assert arrow_column("a", np.array([1.0, 2.0]), 2).type == pa.float64()
    assert arrow_column("u", np.array([1, 2], dtype=np.uint8), 2).type == pa.int64()
    assert arrow_column("b", np.array([True, False]), 2).to_pylist() == [True, False]
    iv = [[[0.0, 1.0]], []]
    assert arrow_column("iv", iv, 2).to_pylist() == iv
    assert arrow_column("obj", np.array([[[0.0, 1.0]], []], dtype=object), 2).to_pylist() == iv
    with pytest.raises(ValueError, match=r"column 'a' has shape \(3,\), expected \(2,\)"):
        arrow_column("a", np.zeros(3), 2)
    with pytest.raises(ValueError, match="column 'iv' has 1 entries, expected 2"):
        arrow_column("iv", [[]], 2)
    with pytest.raises(TypeError, match="column 'c': unsupported dtype complex128"):
        arrow_column("c", np.zeros(2, complex), 2)
    with pytest.raises(TypeError, match="column 'd': unsupported type dict"):
        arrow_column("d", {}, 2)


def test_table_bytes_round_trip_and_schema_list():
    t = pa.table({"x": np_arrow(np.array([1.0, np.inf]), "f"), "iv": nested_float_lists([[[0.0, 1.0]], []]),
                  "ok": np_arrow(np.array([True, False]), "b")})
    data = table_bytes(t)
    back = pq.read_table(io.BytesIO(data))
    assert back.equals(t)
    assert pq.ParquetFile(io.BytesIO(data)).metadata.row_group(0).column(0).compression == "ZSTD"
    # Parquet names list children "element", Arrow "item": the text is the same
    assert schema_list(back.schema) == schema_list(t.schema) == [["x", "double"], ["iv", "list<list<double>>"],
                                                                 ["ok", "bool"]]


def test_chunk_file():
    assert chunk_file("/s", 12) == os.path.join("/s", CHUNK_DIR, "part-000012.parquet")


def test_failed_rows_of():
    rows = [{"row": 1, "point_index": 7, "reason": "ValueError: x"}]
    schema = pa.schema([("x", pa.float64())])
    assert failed_rows_of(schema) == []
    assert failed_rows_of(schema.with_metadata({FAILED_ROWS_KEY: json.dumps(rows).encode()})) == rows
    bad = failed_rows_of(schema.with_metadata({FAILED_ROWS_KEY: b"{not json"}))
    assert bad == [{"row": None, "point_index": None, "reason": "unreadable failed_rows metadata"}]
    assert failed_rows_of(schema.with_metadata({FAILED_ROWS_KEY: b"{}"})) == []
