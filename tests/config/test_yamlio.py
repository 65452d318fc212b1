"""exotune.config.yamlio: the guarded YAML/JSON readers (YAML 1.2 numbers, duplicate keys, depth
and alias bounds, file kinds and sizes), each error naming the file or field."""

import json
import os

import pytest

from exotune.config.yamlio import (MAX_DEPTH, load_yaml_text, read_guarded, read_json_guarded, read_yaml,
                                   spec_base)
from exotune.errors import ConfigError


@pytest.mark.parametrize("text, value", [
    ("1e-3", 1e-3), ("1e3", 1000.0), ("1.0e3", 1000.0), ("-2.5", -2.5), (".5", 0.5), ("0300", 300), ("0o17", 15),
    ("0x1F", 31), ("yes", "yes"), ("on", "on"), ("1:30", "1:30"), ("1_000", "1_000"), ("true", True),
    ("False", False), (".inf", float("inf")), ("-.inf", float("-inf")), ("null", None), ("~", None),
])
def test_yaml_1_2_scalars(text, value):
    got = load_yaml_text(f"x: {text}")["x"]
    assert got == value and type(got) is type(value)


def test_nan_loads_as_nan():
    v = load_yaml_text("x: .nan")["x"]
    assert v != v


def test_duplicate_keys_are_refused_with_their_path_and_lines():
    with pytest.raises(ConfigError) as ei:
        load_yaml_text("plant:\n  motor_inertia: 1\n  motor_inertia: 2\n")
    assert ei.value.field == "plant.motor_inertia"
    assert ei.value.reason == "duplicate key (line 3; first at line 2)"
    with pytest.raises(ConfigError) as ei:
        load_yaml_text("humans:\n  - {kind: mass, kind: spring}\n")
    assert ei.value.field == "humans[0].kind"


def test_depth_and_alias_bombs_are_bounded():
    deep = "x: " + "[" * (MAX_DEPTH + 5) + "]" * (MAX_DEPTH + 5)
    with pytest.raises(ConfigError) as ei:
        load_yaml_text(deep, "deep.yaml")
    assert ei.value.field == "deep.yaml" and f"nested more than {MAX_DEPTH} levels" in ei.value.reason
    bomb = "a: &a [x, x, x, x, x, x, x, x, x, x]\n" + "".join(
        f"{c}: &{c} [" + ", ".join([f"*{p}"] * 10) + "]\n" for p, c in zip("abcdef", "bcdefg"))
    with pytest.raises(ConfigError, match="expands to more than .* values"):
        load_yaml_text(bomb, "bomb.yaml")
    assert load_yaml_text("a: &a [1, 2]\nb: *a\n") == {"a": [1, 2], "b": [1, 2]}  # plain aliases work


def test_read_yaml_errors_name_the_file(tmp_path):
    p = tmp_path / "d.yaml"
    p.write_text("plant: [1, 2\n", encoding="utf-8")
    with pytest.raises(ConfigError) as ei:
        read_yaml(p)
    assert ei.value.field == str(p) and ei.value.reason.startswith("invalid YAML:") and "line" in ei.value.reason
    p.write_text("- 1\n- 2\n")
    with pytest.raises(ConfigError, match="expected a YAML mapping at the top level"):
        read_yaml(p)
    p.write_bytes(b"x: \xff\xfe\n")
    with pytest.raises(ConfigError, match="not UTF-8 text"):
        read_yaml(p)
    p.write_bytes(b"x: 1\x00\n")
    with pytest.raises(ConfigError, match="NUL bytes"):
        read_yaml(p)
    p.write_text("x: !!bool maybe\n")
    with pytest.raises(ConfigError, match="does not fit its explicit tag"):
        read_yaml(p)
    p.write_text("x: !!python/object:os.system {}\n")
    with pytest.raises(ConfigError, match="invalid YAML"):
        read_yaml(p)  # the safe loader constructs no objects
    p.write_text("plant: {motor_inertia: 1e-3}\n")
    assert read_yaml(p) == {"plant": {"motor_inertia": 0.001}}


def test_read_guarded_refuses_what_is_not_a_small_regular_file(tmp_path):
    with pytest.raises(ConfigError) as ei:
        read_guarded(tmp_path)
    assert ei.value.field == str(tmp_path) and ei.value.reason == "cannot read file: a directory, not a regular file"
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    with pytest.raises(ConfigError, match="a FIFO \\(named pipe\\), not a regular file"):
        read_guarded(fifo, "sweep manifest")
    big = tmp_path / "big"
    big.write_bytes(b"x" * 101)
    with pytest.raises(ConfigError, match=r"too large \(101 bytes"):
        read_guarded(big, max_bytes=100)
    assert read_guarded(big, max_bytes=101) == b"x" * 101
    with pytest.raises(ConfigError, match="cannot read the sweep manifest: No such file"):
        read_guarded(tmp_path / "missing", "sweep manifest")


def test_read_json_guarded(tmp_path):
    p = tmp_path / "m.json"
    p.write_text(json.dumps({"a": [1, 2.5, None]}))
    assert read_json_guarded(p) == {"a": [1, 2.5, None]}
    p.write_text("{bad json")
    with pytest.raises(ConfigError, match="cannot read the JSON file: invalid JSON"):
        read_json_guarded(p)
    p.write_text("[" * (MAX_DEPTH + 2) + "]" * (MAX_DEPTH + 2))
    with pytest.raises(ConfigError, match=f"nested more than {MAX_DEPTH} levels deep"):
        read_json_guarded(p, "manifest")


def test_spec_base(tmp_path):
    spec = tmp_path / "sub" / "spec.yaml"
    spec.parent.mkdir()
    spec.write_text("base: ../paper.yaml\naxes: {}\n")
    assert spec_base(spec) == os.path.join(str(spec.parent), "../paper.yaml")
    spec.write_text("base: /abs/paper.yaml\n")
    assert spec_base(str(spec)) == "/abs/paper.yaml"
    spec.write_text("base: {plant: {}}\n")
    assert spec_base(spec) is None
    assert spec_base({"base": "x.yaml"}) is None
    assert spec_base(tmp_path / "missing.yaml") is None


def test_aliases_count_for_the_nesting_depth_where_they_are_used():
    """40 anchors, each a 58-level nest of the previous one, passed the depth check (each node on
    its own is shallow) and reached 2 320 levels once expanded: a RecursionError in the JSON view
    of certify. The depth of an aliased subtree now counts where the alias is used."""
    level = 58
    lines = ["a0: &a0 " + "[" * level + "0" + "]" * level]
    for i in range(1, 40):
        lines.append(f"a{i}: &a{i} " + "[" * level + f"*a{i - 1}" + "]" * level)
    with pytest.raises(ConfigError) as ei:
        load_yaml_text("\n".join(lines), "deep.yaml")
    assert ei.value.field == "deep.yaml" and f"nested more than {MAX_DEPTH} levels" in ei.value.reason
    assert "*a0" in ei.value.reason
    shallow = "a: &a [[1]]\nb: [[*a]]\n"  # 4 levels once expanded: fine
    assert load_yaml_text(shallow) == {"a": [[1]], "b": [[[[1]]]]}


@pytest.mark.parametrize("text, field, contains", [
    ("plant:\n  1: 2\n", "plant", "the key '1' at line 2 is a YAML int, not a name"),
    ("plant:\n  ~: 2\n", "plant", "is a YAML null, not a name"),
    ("true: 1\n", "<top level>", "is a YAML bool, not a name"),
])
def test_keys_that_are_not_names_are_refused(text, field, contains):
    with pytest.raises(ConfigError) as ei:
        load_yaml_text(text)
    assert ei.value.field == field and contains in ei.value.reason
    assert load_yaml_text("plant:\n  '1': 2\n") == {"plant": {"1": 2}}  # a quoted key is a name


def test_a_key_written_and_merged_is_a_duplicate():
    text = "base: &b {motor_inertia: 99.0}\nplant:\n  <<: *b\n  motor_inertia: 0.44\n"
    with pytest.raises(ConfigError) as ei:
        load_yaml_text(text)
    assert ei.value.field == "plant.motor_inertia" and "merged by <<" in ei.value.reason
    ok = load_yaml_text("base: &b {motor_inertia: 99.0}\nplant:\n  <<: *b\n  motor_damping: 1.0\n")
    assert ok["plant"] == {"motor_inertia": 99.0, "motor_damping": 1.0}  # merging without a collision works


def test_an_integer_too_long_to_convert_is_named_with_its_line():
    with pytest.raises(ConfigError) as ei:
        load_yaml_text("x: 1\ny: " + "9" * 5000 + "\n", "big.yaml")
    assert ei.value.field == "big.yaml" and "an integer of 5000 digits at line 2" in ei.value.reason
    assert load_yaml_text("x: " + "9" * 400)["x"] == int("9" * 400)  # long but convertible: validation names it


# ---------------------------------------------------------------------------------------------
# libyaml's events and PyYAML's own parser give the same documents and the same errors
# ---------------------------------------------------------------------------------------------
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402
import yaml  # noqa: E402

_SCALARS = st.one_of(
    st.integers(-10**30, 10**30), st.floats(allow_nan=False), st.booleans(), st.none(),
    st.sampled_from(["yes", "on", "1:30", "1_000", "0300", "0o17", "0x1F", "1e3", ".inf", "~", "null", "",
                     "a: b", "- x", "#c", "&a", "*a", "!!str", "'q'", '"dq"', "é ☃ 𝄞", "\t", " lead"]),
    st.text(max_size=12))
_DOCS = st.recursive(_SCALARS, lambda kids: st.one_of(
    st.lists(kids, max_size=4), st.dictionaries(st.text(min_size=1, max_size=8), kids, max_size=4)), max_leaves=20)
_ALPHABET = list("abcxyz019.-+eE:,[]{}#&*!|>'\"%@`?~ \t\n") + ["\u00e9", "\u2603", "\x85", "\ufeff", "\x07"]


def _outcome(text: str, libyaml: bool, monkeypatch):
    monkeypatch.setattr(yaml, "__with_libyaml__", libyaml)
    try:
        return ("ok", repr(load_yaml_text(text, "in.yaml")))
    except ConfigError as e:
        return ("error", e.field, e.reason)
    except yaml.YAMLError as e:  # load_yaml_text leaves the wording to its callers (read_yaml)
        return ("yaml", type(e).__name__, str(e))


@pytest.mark.skipif(not getattr(yaml, "__with_libyaml__", False), reason="PyYAML built without libyaml")
@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(doc=_DOCS, flow=st.sampled_from([None, True, False]), key=st.text(min_size=1, max_size=6))
def test_libyaml_events_load_every_document_as_pyyamls_parser(doc, flow, key, monkeypatch):
    """A document dumped in any style loads to the same value through libyaml's events as through
    PyYAML's pure-Python parser (YAML 1.2 scalars, bounds and duplicate checks are shared)."""
    text = yaml.safe_dump({key: doc}, default_flow_style=flow, allow_unicode=True)
    assert _outcome(text, True, monkeypatch) == _outcome(text, False, monkeypatch)


@pytest.mark.skipif(not getattr(yaml, "__with_libyaml__", False), reason="PyYAML built without libyaml")
@settings(max_examples=600, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(text=st.text(alphabet=_ALPHABET, max_size=40))
def test_libyaml_events_accept_and_refuse_text_as_pyyamls_parser(text, monkeypatch):
    """Arbitrary YAML-ish text, mostly invalid: the same value or the same error (field and reason)
    through either parser."""
    assert _outcome(text, True, monkeypatch) == _outcome(text, False, monkeypatch)


def test_libyaml_is_used_and_its_refusals_are_worded_by_pyyamls_parser(monkeypatch):
    """With libyaml, text nested past libyaml's own limit is still refused by the bounded composer's
    message (PyYAML's parser words every refusal), and a valid file loads."""
    if not getattr(yaml, "__with_libyaml__", False):
        pytest.skip("PyYAML built without libyaml")
    deep = "x: " + "[" * 1200 + "]" * 1200
    with pytest.raises(ConfigError) as ei:
        load_yaml_text(deep, "in.yaml")
    assert f"{MAX_DEPTH} levels" in ei.value.reason
    calls = []
    real = yaml._yaml.CParser

    class Spy(real):
        def __init__(self, *a):
            calls.append(1)
            super().__init__(*a)

    monkeypatch.setattr(yaml._yaml, "CParser", Spy)
    assert load_yaml_text("a: [1, 2e3, yes]\n") == {"a": [1, 2000.0, "yes"]}
    assert calls == [1]
