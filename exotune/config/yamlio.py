"""Reading YAML and JSON input files through one guarded path: size, file type, nesting depth and
alias expansion bounded; YAML 1.2 numbers and booleans; duplicate keys rejected.

YAML is read with a safe loader only (PyYAML's SafeLoader with YAML 1.2 floats, so ``1e-3`` is a
number); duplicate keys (which PyYAML would otherwise silently resolve to the last value) are
rejected. Every problem of a file (unreadable, not a regular file, too large, too deeply nested,
an alias bomb, not UTF-8, invalid YAML, not a mapping) raises a
:class:`~exotune.errors.ConfigError` naming the file; errors quote at most a short excerpt of it.

Limits (docs/design-file.md#input-limits-and-accepted-ranges):

* only regular files are read (a directory, a FIFO or a device such as ``/dev/zero`` is refused
  before anything is read, so nothing blocks);
* a YAML file holds at most :data:`MAX_YAML_BYTES` (4 MiB), a JSON file (a sweep manifest) at most
  :data:`MAX_JSON_BYTES` (16 MiB);
* mappings and lists nest at most :data:`MAX_DEPTH` (64) levels deep;
* a YAML document expands (aliases counted as copies of what they name) to at most
  :data:`MAX_YAML_NODES` (250 000) nodes; a recursive alias is refused.
"""

from __future__ import annotations

import json
import os
import re
import stat
from typing import Any

import yaml

from ..errors import ConfigError
from .validate import excerpt, join_path, kind_of

__all__ = ["load_yaml_text", "read_yaml", "read_json_guarded", "read_guarded", "spec_base",
           "MAX_YAML_BYTES", "MAX_JSON_BYTES", "MAX_DEPTH", "MAX_YAML_NODES"]

# 4 MiB: a controller file holds one controller per gain-schedule entry (up to ~15 kB and ~800
# values each with float32 realizations, more with listed inconclusive cells; ~45 kB without a
# schedule): the design files' bound of 128 entries (exotune.config.schema.MAX_SCHEDULE_ENTRIES)
# keeps the file exotune writes within what it reads, bytes and values (a 100-entry schedule made
# a 1.2 MB file that certify refused as too large at 1 MiB)
MAX_YAML_BYTES = 4 << 20
MAX_JSON_BYTES = 16 << 20  # 16 MiB: a sweep manifest of ~10^5 chunks
MAX_DEPTH = 64  # nesting levels of mappings/lists (exotune's files use at most 8)
MAX_YAML_NODES = 250_000  # nodes of a YAML document once its aliases are expanded
MAX_INT_DIGITS = 4300  # Python's limit for converting a decimal string to an int


def _mib(n: int) -> str:
    return f"{n / (1 << 20):g} MiB"


def _file_kind(mode: int) -> str:
    if stat.S_ISDIR(mode):
        return "a directory"
    if stat.S_ISFIFO(mode):
        return "a FIFO (named pipe)"
    if stat.S_ISCHR(mode):
        return "a character device"
    if stat.S_ISBLK(mode):
        return "a block device"
    if stat.S_ISSOCK(mode):
        return "a socket"
    return "not a regular file"


def read_guarded(path, what: str = "file", max_bytes: int = MAX_YAML_BYTES) -> bytes:
    """The bytes of the regular file ``path``, at most ``max_bytes`` of them.

    The file type is checked with :func:`os.stat` before opening and again on the open
    descriptor (opened with ``O_NONBLOCK``), so a FIFO, a device (``/dev/zero``) or a directory is
    refused at once, never read or waited on.

    Parameters
    ----------
    path : str or os.PathLike
        The file to read.
    what : str
        What the file is, for the message (``"sweep manifest"``).
    max_bytes : int
        The size limit; a larger file is refused without reading it whole.

    Returns
    -------
    bytes
        The file's content.

    Raises
    ------
    exotune.errors.ConfigError
        ``<path>: cannot read the <what>: <reason>`` (missing, unreadable, not a regular file,
        too large).

    References
    ----------
    docs/design-file.md#input-limits-and-accepted-ranges.
    """
    name = os.fspath(path)
    where = f"cannot read the {what}" if what != "file" else "cannot read file"

    def refuse(reason: str):
        return ConfigError(name, f"{where}: {reason}")

    if not name:  # named as given: '' (the message would otherwise start with its reason)
        raise ConfigError("''", f"{where}: an empty path (give a file)")
    if "\x00" in name:  # os.stat raises a bare ValueError ("embedded null byte") naming nothing
        raise refuse("a path cannot contain a NUL character")
    try:
        st = os.stat(name)
        if not stat.S_ISREG(st.st_mode):
            raise refuse(f"{_file_kind(st.st_mode)}, not a regular file")
        if st.st_size > max_bytes:
            raise refuse(f"too large ({st.st_size} bytes; the limit is {_mib(max_bytes)})")
        fd = os.open(name, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOCTTY", 0))
        try:
            st = os.fstat(fd)
            if not stat.S_ISREG(st.st_mode):  # replaced between stat and open
                raise refuse(f"{_file_kind(st.st_mode)}, not a regular file")
            chunks, total = [], 0
            while total <= max_bytes:
                b = os.read(fd, min(1 << 20, max_bytes + 1 - total))
                if not b:
                    break
                chunks.append(b)
                total += len(b)
        finally:
            os.close(fd)
    except OSError as e:
        raise refuse(e.strerror or str(e)) from None
    data = b"".join(chunks)
    if len(data) > max_bytes:
        raise refuse(f"too large (more than {max_bytes} bytes; the limit is {_mib(max_bytes)})")
    return data


def _short_path(segments) -> str:
    """The field path of ``segments``, shortened to its first and last three levels when long."""
    if len(segments) <= 8:
        return join_path("", tuple(segments)) or "<top level>"
    return f"{join_path('', tuple(segments[:3]))}…{join_path('', tuple(segments[-3:]))}"


def _depth_error(name: str, segments) -> ConfigError:
    return ConfigError(name, f"nested more than {MAX_DEPTH} levels deep at {_short_path(segments)} "
                             f"(the limit is {MAX_DEPTH} levels)")


def _check_duplicate_keys(node, path: str = "", seen_nodes: set | None = None) -> None:
    """Refuse a mapping with a repeated key. A node reached again through an alias was already
    checked and is not walked again (aliases are never expanded here)."""
    if seen_nodes is None:
        seen_nodes = set()
    if id(node) in seen_nodes:
        return
    seen_nodes.add(id(node))
    if isinstance(node, yaml.MappingNode):
        seen: dict[Any, int] = {}
        for k, v in node.value:
            key = k.value if isinstance(k, yaml.ScalarNode) else None
            sub = join_path(path, (str(key),)) if key is not None else path
            if isinstance(k, yaml.ScalarNode) and k.tag not in (_STR_TAG, _MERGE_TAG):
                kind = k.tag.rsplit(":", 1)[-1]
                raise ConfigError(path or "<top level>", f"the key {excerpt(k.value, 40)!r} at line {k.start_mark.line + 1} "
                                  f"is a YAML {kind}, not a name (keys are names such as motor_inertia; quote it "
                                  "if it is meant as one)")
            if key is not None:
                if key in seen:
                    raise ConfigError(
                        sub, f"duplicate key (line {k.start_mark.line + 1}; first at line {seen[key] + 1})"
                    )
                seen[key] = k.start_mark.line
            _check_duplicate_keys(v, sub, seen_nodes)
        _check_merged_keys(node, path)
    elif isinstance(node, yaml.SequenceNode):
        for i, v in enumerate(node.value):
            _check_duplicate_keys(v, f"{path}[{i}]", seen_nodes)


_STR_TAG, _MERGE_TAG = "tag:yaml.org,2002:str", "tag:yaml.org,2002:merge"


def _check_merged_keys(node, path: str) -> None:
    """Refuse a key written both in a mapping and in what it merges (``<<: *base``): YAML lets the
    written one win silently, which hides a mistake as a duplicate key would."""
    merged = [v for k, v in node.value if isinstance(k, yaml.ScalarNode) and k.tag == _MERGE_TAG]
    if not merged:
        return
    own = {k.value: k.start_mark.line for k, _v in node.value if isinstance(k, yaml.ScalarNode) and k.tag == _STR_TAG}
    sources = [m for v in merged for m in (v.value if isinstance(v, yaml.SequenceNode) else [v])]
    for src in sources:
        if not isinstance(src, yaml.MappingNode):
            continue
        for k, _v in src.value:
            if isinstance(k, yaml.ScalarNode) and k.value in own:
                raise ConfigError(join_path(path, (str(k.value),)),
                                  f"duplicate key (line {own[k.value] + 1}, and merged by << from line "
                                  f"{k.start_mark.line + 1}): give it once")


class _Loader(yaml.SafeLoader):
    """PyYAML's safe loader with the YAML 1.2 core schema for numbers and booleans.

    PyYAML follows YAML 1.1: an exponent needs a decimal point and a signed exponent (``1e3``,
    ``1e-3`` and even ``1.0e3`` load as *strings*), ``0300`` is octal (192), ``1:30`` is
    sexagesimal (90), ``1_000`` is 1000 and ``yes``/``on``/``off`` are booleans. Engineers write
    delays as ``1e-3`` and may pad numbers with zeros; YAML 1.2 (and JSON) read ``1e-3`` as a
    float, ``0300`` as 300, and ``yes``, ``1:30``, ``1_000`` as strings (which validation then
    refuses, naming the field), and so does exotune. Only the implicit resolvers of int, float
    and bool and the int constructor change: no new tags, no object construction (still a safe
    loader)."""

    def construct_yaml_int(self, node):
        v = self.construct_scalar(node)
        if len(v) > MAX_INT_DIGITS:
            raise ConfigError(self.source_name, f"an integer of {len(v)} digits at line {node.start_mark.line + 1}: "
                                                f"too long to be a number here (at most {MAX_INT_DIGITS} digits)")
        if v.startswith("0o"):
            return int(v[2:], 8)
        if v.startswith("0x"):
            return int(v[2:], 16)
        return int(v, 10)

    # -- bounded composition: nesting depth and alias expansion (billion laughs) ------------------
    source_name = "<input>"

    def compose_document(self):
        self._depth = 0
        self._segments: list = []
        self._sizes: dict[int, int] = {}
        self._depths: dict[int, int] = {}  # collection levels of each composed node, aliases expanded
        return super().compose_document()

    def compose_node(self, parent, index):
        """Compose one node, refusing nesting deeper than :data:`MAX_DEPTH` levels (before the
        recursion goes deeper; an alias counts as the subtree it names, where it is used) and documents that expand, aliases counted as copies, to more than
        :data:`MAX_YAML_NODES` nodes. Each node's expanded size is kept, so an alias costs O(1)."""
        if self.check_event(yaml.AliasEvent):
            anchor = self.peek_event().anchor
            node = self.anchors.get(anchor)
            if node is not None and id(node) not in self._sizes:
                mark = self.peek_event().start_mark
                raise ConfigError(self.source_name, f"recursive alias *{excerpt(anchor, 40)} at line {mark.line + 1} "
                                                    "(an alias inside the node it names)")
            if node is not None and self._depth + self._depths.get(id(node), 0) > MAX_DEPTH:
                # the alias expands to a subtree that nests past the limit where it is used
                raise _depth_error(self.source_name, [x for x in self._segments if x is not None] + [f"*{anchor}"])
            return super().compose_node(parent, index)
        if isinstance(index, int):
            seg = index
        elif isinstance(index, yaml.ScalarNode):
            seg = excerpt(str(index.value), 40)
        else:
            seg = "?" if isinstance(parent, yaml.MappingNode) else None
        self._segments.append(seg)
        self._depth += 1
        try:
            if self._depth > MAX_DEPTH and (self.check_event(yaml.SequenceStartEvent)
                                            or self.check_event(yaml.MappingStartEvent)):
                raise _depth_error(self.source_name, [x for x in self._segments if x is not None])
            node = super().compose_node(parent, index)
        finally:
            self._depth -= 1
            self._segments.pop()
        if isinstance(node, yaml.SequenceNode):
            size = 1 + sum(self._sizes.get(id(c), 1) for c in node.value)
            self._depths[id(node)] = 1 + max((self._depths.get(id(c), 0) for c in node.value), default=0)
        elif isinstance(node, yaml.MappingNode):
            size = 1 + sum(self._sizes.get(id(k), 1) + self._sizes.get(id(v), 1) for k, v in node.value)
            self._depths[id(node)] = 1 + max((max(self._depths.get(id(k), 0), self._depths.get(id(v), 0))
                                              for k, v in node.value), default=0)
        else:
            size = 1
        if size > MAX_YAML_NODES:
            raise ConfigError(self.source_name, f"the document expands to more than {MAX_YAML_NODES} values once its "
                                                "aliases are expanded (an alias bomb?)")
        self._sizes[id(node)] = size
        return node


_YAML11 = ("tag:yaml.org,2002:float", "tag:yaml.org,2002:int", "tag:yaml.org,2002:bool")
_Loader.yaml_implicit_resolvers = {
    ch: [r for r in rs if r[0] not in _YAML11]
    for ch, rs in yaml.SafeLoader.yaml_implicit_resolvers.items()
}
_Loader.add_implicit_resolver(
    "tag:yaml.org,2002:bool", re.compile(r"^(?:true|True|TRUE|false|False|FALSE)$"), list("tTfF"))
_Loader.add_implicit_resolver(
    "tag:yaml.org,2002:int", re.compile(r"^(?:[-+]?[0-9]+|0o[0-7]+|0x[0-9a-fA-F]+)$"), list("-+0123456789"))
_Loader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(
        r"""^(?:[-+]?(?:\.[0-9]+|[0-9]+\.[0-9]*)(?:[eE][-+]?[0-9]+)?
        |[-+]?[0-9]+[eE][-+]?[0-9]+
        |[-+]?\.(?:inf|Inf|INF)
        |\.(?:nan|NaN|NAN))$""",
        re.X,
    ),
    list("-+0123456789."),
)
_Loader.add_constructor("tag:yaml.org,2002:int", _Loader.construct_yaml_int)


class _CEventLoader(_Loader):
    """:class:`_Loader` reading its events from libyaml's parser (PyYAML's ``CParser``) instead of
    PyYAML's pure-Python scanner and parser: the same events, hence the same bounded composition,
    duplicate-key checks, YAML 1.2 resolution and safe construction, about four times faster on a
    controller file (its golden vectors are thousands of scalars). Only the event source changes;
    libyaml's own composer is not used (it would bypass the depth and alias bounds)."""

    def __init__(self, text: str):
        from yaml._yaml import CParser

        self._events = CParser(text)
        yaml.composer.Composer.__init__(self)
        yaml.constructor.SafeConstructor.__init__(self)
        yaml.resolver.Resolver.__init__(self)

    def check_event(self, *choices):
        return self._events.check_event(*choices)

    def peek_event(self):
        return self._events.peek_event()

    def get_event(self):
        return self._events.get_event()

    def dispose(self):
        self._events.dispose()


# Text on which libyaml's parser and PyYAML's own are known to agree (tests/config/test_yamlio.py
# compares them on random text of this alphabet): printable characters and newlines, without what
# they treat differently — tabs, carriage returns, NEL, the byte-order mark, U+2028/U+2029, tags
# ("!": a bare "!" is null for one and "" for the other), a block scalar's header followed by a
# comment without a space ("|#": refused by one only) and "?" (complex keys; in flow collections
# libyaml accepts text that PyYAML refuses). Every file exotune writes is such text;
# anything else is read by PyYAML's own parser, as before.
_LIBYAML_SAFE = re.compile(r"[\n\x20\x22-\x7e\xa0-\u2027\u202a-\ud7ff\ue000-\ufefe\uff00-\ufffd\U00010000-\U0010ffff]*")
_DIVERGENT = re.compile(r"[|>][-+0-9]*#|\?")  # and "?": complex keys, flow oddities


def _loader_class(text: str):
    """:class:`_CEventLoader` for text both parsers read alike where PyYAML was built with libyaml,
    else :class:`_Loader`."""
    if (getattr(yaml, "__with_libyaml__", False) and _LIBYAML_SAFE.fullmatch(text)
            and not _DIVERGENT.search(text)):
        return _CEventLoader
    return _Loader


def _compose_construct(text: str, name: str):
    """Compose (bounded), check duplicate keys, construct: one parse of ``text``. Text that
    libyaml's parser refuses is parsed again by PyYAML's own, whose verdict and message stand (the
    two word their errors differently, and libyaml stops at 1000 nesting levels with a message of
    its own, where the bounded composer names the path at level 65)."""
    if _loader_class(text) is _CEventLoader:
        try:
            return _load(_CEventLoader, text, name)
        except yaml.YAMLError:
            pass
    return _load(_Loader, text, name)


def _load(cls, text: str, name: str):
    loader = cls(text)
    loader.source_name = name
    try:
        node = loader.get_single_node()
        if node is None:
            return None
        _check_duplicate_keys(node)
        return loader.construct_document(node)
    finally:
        loader.dispose()


def load_yaml_text(text: str, name: str = "<input>"):
    """Parse YAML text with exotune's safe loader (:class:`_Loader`, a ``yaml.SafeLoader``
    subclass: what ``yaml.safe_load`` does, with YAML 1.2 numbers and booleans, nesting depth and
    alias expansion bounded and duplicate keys refused — :class:`ConfigError` naming ``name``).

    Parameters
    ----------
    text : str
        The YAML (or JSON) text.
    name : str, optional
        What the text is (a file path), named by the errors.

    Returns
    -------
    Any
        The parsed document (mappings, lists, strings, numbers, booleans, null).

    Raises
    ------
    exotune.errors.ConfigError
        When the text is not valid YAML, nests too deeply, expands too many aliases or repeats a
        key.
    """
    return _compose_construct(text, name)


def read_yaml(path, max_bytes: int = MAX_YAML_BYTES) -> dict:
    """Read a YAML mapping from ``path`` through the guarded path.

    Parameters
    ----------
    path : str or os.PathLike
        A regular file of at most ``max_bytes`` bytes, UTF-8.
    max_bytes : int
        The size limit (:data:`MAX_YAML_BYTES`, 4 MiB).

    Returns
    -------
    dict
        The top-level mapping (YAML 1.2 numbers and booleans).

    Raises
    ------
    exotune.errors.ConfigError
        Naming the file: not a regular file, too large, not UTF-8, invalid YAML, nested deeper
        than :data:`MAX_DEPTH`, an alias bomb, a duplicate key (naming the key's path), not a
        mapping.

    References
    ----------
    docs/design-file.md#input-limits-and-accepted-ranges.
    """
    name = os.fspath(path)
    data = read_guarded(name, "file", max_bytes)
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as e:
        raise ConfigError(name, f"cannot read file: not UTF-8 text ({e.reason} at byte {e.start})") from None
    if "\x00" in text:
        raise ConfigError(name, "cannot read file: not a text file (it contains NUL bytes)")
    try:
        mapping = _compose_construct(text, name)
    except ConfigError:
        raise
    except yaml.YAMLError as e:
        mark = getattr(e, "problem_mark", None)
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark is not None else ""
        problem = getattr(e, "problem", None) or str(e)
        raise ConfigError(name, f"invalid YAML: {excerpt(problem)}{where}") from None
    except RecursionError:  # defensive: the composer bounds the depth before Python's stack does
        raise ConfigError(name, f"nested too deeply (the limit is {MAX_DEPTH} levels)") from None
    except (ValueError, KeyError, AttributeError, TypeError, OverflowError) as e:
        # an explicit tag whose text does not fit it (``!!bool maybe``, ``!!timestamp abc``,
        # ``!!int 0b11``): PyYAML's constructors raise plain Python errors
        raise ConfigError(name, f"invalid YAML: a value does not fit its explicit tag "
                                f"({type(e).__name__}: {excerpt(str(e))})") from None
    if not isinstance(mapping, dict):
        raise ConfigError(name, f"expected a YAML mapping at the top level, got {kind_of(mapping)}")
    return mapping


def spec_base(spec) -> str | None:
    """The design file a sweep or optimize spec file names as its ``base`` (resolved against the
    spec's directory), or None (a mapping spec, no base, or a spec that cannot be read: the
    command reports that in its own words): an input that no output may overwrite.

    Parameters
    ----------
    spec : str, os.PathLike or Any
        A spec file path; anything else (a mapping) gives None.

    Returns
    -------
    str or None
        The path of the base design file, or None.

    Raises
    ------
    exotune.errors.ConfigError
        When ``spec`` is a path holding a NUL character (no file system accepts one).
    """
    if not isinstance(spec, (str, os.PathLike)):
        return None
    if "\x00" in str(os.fspath(spec)):  # refused here, before the output checks stat it (a bare ValueError)
        read_guarded(spec)
    try:
        base = read_yaml(spec).get("base")
    except ConfigError:
        return None
    if not isinstance(base, str) or not base or "\x00" in base:  # the loader names a NUL in the base path
        return None
    spec = os.fspath(spec)
    return base if os.path.isabs(base) else os.path.join(os.path.dirname(os.path.abspath(spec)), base)


def _json_depth_path(obj) -> list | None:
    """The path to the first value nested deeper than :data:`MAX_DEPTH` (iterative), else None."""
    stack = [(obj, [])]
    while stack:
        cur, segs = stack.pop()
        if isinstance(cur, (dict, list)) and len(segs) >= MAX_DEPTH:
            return segs
        if isinstance(cur, dict):
            stack.extend((v, segs + [excerpt(str(k), 40)]) for k, v in cur.items())
        elif isinstance(cur, list):
            stack.extend((v, segs + [i]) for i, v in enumerate(cur))
    return None


def read_json_guarded(path, what: str = "JSON file", max_bytes: int = MAX_JSON_BYTES):
    """Read a JSON document from ``path`` through the guarded path (manifests of sweeps).

    Parameters
    ----------
    path : str or os.PathLike
        A regular file of at most ``max_bytes`` bytes, UTF-8 JSON.
    what : str
        What the file is, for the messages: ``cannot read the <what>: <reason>``.
    max_bytes : int
        The size limit (:data:`MAX_JSON_BYTES`, 16 MiB).

    Returns
    -------
    object
        The decoded document (any JSON value; the caller checks its shape).

    Raises
    ------
    exotune.errors.ConfigError
        Naming the file: missing or unreadable (a missing file included — test
        :func:`os.path.lexists` first to word that case differently), not a regular file
        (a FIFO, a device, a directory: refused without reading), too large, not UTF-8, invalid
        JSON, nested deeper than :data:`MAX_DEPTH` levels (with the field path).

    References
    ----------
    docs/design-file.md#input-limits-and-accepted-ranges.
    """
    name = os.fspath(path)
    data = read_guarded(name, what, max_bytes)
    try:
        doc = json.loads(data.decode("utf-8"))
    except UnicodeDecodeError as e:
        raise ConfigError(name, f"cannot read the {what}: not UTF-8 text ({e.reason} at byte {e.start})") from None
    except RecursionError:
        raise ConfigError(name, f"cannot read the {what}: nested more than {MAX_DEPTH} levels deep "
                                f"(the limit is {MAX_DEPTH} levels)") from None
    except ValueError as e:
        raise ConfigError(name, f"cannot read the {what}: invalid JSON ({excerpt(str(e))})") from None
    segs = _json_depth_path(doc)
    if segs is not None:
        raise ConfigError(name, f"cannot read the {what}: nested more than {MAX_DEPTH} levels deep at "
                                f"{_short_path(segs)} (the limit is {MAX_DEPTH} levels)")
    return doc
