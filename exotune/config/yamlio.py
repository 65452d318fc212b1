"""Reading YAML: a safe loader with YAML 1.2 numbers and booleans, duplicate keys rejected.

YAML is read with a safe loader only (PyYAML's SafeLoader with YAML 1.2 floats, so ``1e-3`` is a
number); duplicate keys (which PyYAML would otherwise silently resolve to the last value) are
rejected. Every problem of a file (unreadable, not UTF-8, invalid YAML, not a mapping) raises a
:class:`~exotune.errors.ConfigError` naming the file.
"""

from __future__ import annotations

import os
import re
from typing import Any

import yaml

from ..errors import ConfigError
from .validate import join_path, kind_of

__all__ = ["load_yaml_text", "read_yaml"]


def _check_duplicate_keys(node, path: str = "") -> None:
    if isinstance(node, yaml.MappingNode):
        seen: dict[Any, int] = {}
        for k, v in node.value:
            key = k.value if isinstance(k, yaml.ScalarNode) else None
            sub = join_path(path, (str(key),)) if key is not None else path
            if key is not None:
                if key in seen:
                    raise ConfigError(
                        sub, f"duplicate key (line {k.start_mark.line + 1}; first at line {seen[key] + 1})"
                    )
                seen[key] = k.start_mark.line
            _check_duplicate_keys(v, sub)
    elif isinstance(node, yaml.SequenceNode):
        for i, v in enumerate(node.value):
            _check_duplicate_keys(v, f"{path}[{i}]")


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
        if v.startswith("0o"):
            return int(v[2:], 8)
        if v.startswith("0x"):
            return int(v[2:], 16)
        return int(v, 10)


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


def load_yaml_text(text: str):
    """Parse YAML text with exotune's safe loader (:class:`_Loader`, a ``yaml.SafeLoader``
    subclass: what ``yaml.safe_load`` does, with YAML 1.2 numbers and booleans)."""
    loader = _Loader(text)
    try:
        return loader.get_single_data()
    finally:
        loader.dispose()


def read_yaml(path) -> dict:
    """Read a YAML mapping from ``path`` with exotune's safe loader (YAML 1.2 numbers, duplicate
    keys rejected; file-level errors -> :class:`ConfigError` naming the file)."""
    name = os.fspath(path)
    try:
        with open(name, "rb") as fh:
            data = fh.read()
        text = data.decode("utf-8")
    except UnicodeDecodeError as e:
        raise ConfigError(name, f"cannot read file: not UTF-8 text ({e.reason} at byte {e.start})") from None
    except OSError as e:
        raise ConfigError(name, f"cannot read file: {e.strerror or e}") from None
    try:
        _check_duplicate_keys(yaml.compose(text, Loader=_Loader))
        mapping = load_yaml_text(text)
    except ConfigError:
        raise
    except yaml.YAMLError as e:
        mark = getattr(e, "problem_mark", None)
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark is not None else ""
        problem = getattr(e, "problem", None) or str(e)
        raise ConfigError(name, f"invalid YAML: {problem}{where}") from None
    except (ValueError, KeyError, AttributeError, TypeError, OverflowError) as e:
        # an explicit tag whose text does not fit it (``!!bool maybe``, ``!!timestamp abc``,
        # ``!!int 0b11``): PyYAML's constructors raise plain Python errors
        raise ConfigError(name, f"invalid YAML: a value does not fit its explicit tag ({type(e).__name__}: {e})") from None
    if not isinstance(mapping, dict):
        raise ConfigError(name, f"expected a YAML mapping at the top level, got {kind_of(mapping)}")
    return mapping
