"""The package's import graph: layered, acyclic, no private names across modules, no click or
print in the library (docs/architecture.md).

Every ``import``/``from … import`` statement of every module under ``exotune/`` is parsed with
:mod:`ast` (function-level imports included, since a lazy import is still a dependency), and so is
the lazy table of every package ``__init__`` (``attach(__name__, {name: submodule})``,
:mod:`exotune.lazy`): each entry is an edge from the package to the submodule that defines the name.
"""

from __future__ import annotations

import ast
import functools
from pathlib import Path

import pytest

PKG = Path(__file__).resolve().parent.parent / "exotune"

# Lower layers never import higher ones; a layer may import its own package and any lower layer.
LAYERS = [
    {"version", "errors", "lazy"},
    {"jsonio", "units", "starter", "options"},  # may raise errors.ConfigError (jsonio.write_outputs)
    {"record"},  # the base of the typed results (to_json uses jsonio)
    {"numerics"},
    {"model"},
    {"config"},
    {"sampled"},
    {"analysis"},
    {"controllerfile", "sweeps", "identification"},
    {"optimization", "simulation"},
    {"text", "plots"},
    {"results"},
    {"api"},
    {"__init__"},
    {"cli"},
    {"__main__"},
]
LEVEL = {name: i for i, layer in enumerate(LAYERS) for name in layer}


def _modules() -> dict[str, Path]:
    out = {}
    for p in sorted(PKG.rglob("*.py")):
        rel = p.relative_to(PKG).with_suffix("")
        parts = list(rel.parts)
        if parts[-1] == "__init__" and len(parts) > 1:
            parts = parts[:-1]
            name = ".".join(parts) + ".__init__"
        else:
            name = ".".join(parts)
        out[name] = p
    return out


MODULES = _modules()


def _package_of(mod: str) -> list[str]:
    parts = mod.split(".")
    return parts[:-1]


def _resolve(mod: str, node: ast.ImportFrom) -> list[tuple[str, str | None]]:
    """(target module under exotune, imported name or None) for one ``from`` import."""
    if node.level == 0:
        if not (node.module or "").startswith("exotune"):
            return []
        base = node.module.split(".")[1:]
    else:
        pkg = _package_of(mod)
        if mod.endswith(".__init__"):
            pkg = mod.split(".")[:-1]
        base = pkg[: len(pkg) - (node.level - 1)] + (node.module.split(".") if node.module else [])
    out = []
    for alias in node.names:
        cand = ".".join(base + [alias.name])
        if cand in MODULES or cand + ".__init__" in MODULES:
            out.append((cand if cand in MODULES else cand + ".__init__", None))
        else:
            tgt = ".".join(base)
            if tgt + ".__init__" in MODULES:
                tgt = tgt + ".__init__"
            elif not base:
                tgt = "__init__"
            out.append((tgt, alias.name))
    return out


def _is_attach(node) -> bool:
    """A package's lazy table: ``attach(__name__, {"name": "submodule", …})`` (exotune.lazy)."""
    return (isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == "attach"
            and len(node.args) == 2 and isinstance(node.args[1], ast.Dict))


def lazy_tables() -> dict[str, dict[str, str]]:
    """Package → its lazy table {public name: submodule}, read from the ``__init__`` sources."""
    out = {}
    for mod, path in MODULES.items():
        if mod.endswith(".__init__"):
            for node in ast.walk(ast.parse(path.read_text())):
                if _is_attach(node):
                    out[mod.removesuffix(".__init__")] = {k.value: v.value for k, v in zip(node.args[1].keys,
                                                                                          node.args[1].values)}
    return out


VIEW_METHODS = {"plot", "to_text", "__str__", "summary"}  # a result's views: late-bound, see test_imports_point_downward


@functools.cache
def _edges():
    """(module, target, imported name or None, line, enclosing function name or None); parsed on
    first use (not at collection, which every worker does)."""
    edges = []
    for mod, path in MODULES.items():
        tree = ast.parse(path.read_text(), str(path))
        parents = {}
        for node in ast.walk(tree):
            for ch in ast.iter_child_nodes(node):
                parents[ch] = node

        def func_of(n):
            while n in parents:
                n = parents[n]
                if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef)):
                    return n.name
            return None

        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom):
                for tgt, name in _resolve(mod, node):
                    edges.append((mod, tgt, name, node.lineno, func_of(node)))
            elif mod.endswith(".__init__") and _is_attach(node):
                pkg = mod.removesuffix(".__init__")
                for key, value in zip(node.args[1].keys, node.args[1].values):
                    sub = f"{pkg}.{value.value}"
                    edges.append((mod, sub if sub in MODULES else sub + ".__init__", key.value, node.lineno, None))
            elif isinstance(node, ast.Import):
                for a in node.names:
                    if a.name.startswith("exotune."):
                        t = a.name.split(".", 1)[1]
                        edges.append((mod, t if t in MODULES else t + ".__init__", None, node.lineno, func_of(node)))
    return edges


def _top(mod: str) -> str:
    return mod.split(".")[0]


def test_every_module_has_a_layer():
    missing = sorted({_top(m) for m in MODULES} - set(LEVEL))
    assert not missing, f"modules outside the layer table: {missing}"


def test_imports_point_downward():
    """Lower layers never import higher ones. The one exception: a result's view methods
    (``plot``, ``to_text``, ``__str__``, ``summary``) import the ``plots``/``text`` layer when called, so that
    ``exotune.analyze(path).plot()`` works while nothing below depends on the views at import time."""
    bad = []
    for src, tgt, name, line, func in _edges():
        a, b = _top(src), _top(tgt)
        if a == b:
            continue
        if func in VIEW_METHODS and b in ("plots", "text"):
            continue
        if LEVEL[b] > LEVEL[a] or (LEVEL[b] == LEVEL[a] and a != b):
            bad.append(f"{src}:{line} imports {tgt} ({a} → {b})")
    assert not bad, "\n".join(bad)


# Package namespaces (docs/architecture.md#public-names): every package __init__ is its lazy table
# of public names (exotune.lazy.attach) and imports nothing else, so that importing a package or a
# submodule never imports the sibling submodules. The exception: the compiled kernels' namespace,
# imported whole by the modules that run them.
EAGER_PACKAGES = {"numerics.kernels"}


def test_package_inits_are_lazy_tables():
    tables = lazy_tables()
    bad = []
    for mod, path in MODULES.items():
        pkg = mod.removesuffix(".__init__")
        if not mod.endswith(".__init__") or pkg in EAGER_PACKAGES:
            continue
        if pkg not in tables:
            bad.append(f"{pkg}: no attach(__name__, {{name: submodule}}) table")
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import) or (isinstance(node, ast.ImportFrom) and not (
                    node.module == "lazy" and node.level == pkg.count(".") + 2 or node.module == "__future__")):
                bad.append(f"{pkg}:{node.lineno} imports at import time (list the name in the lazy table)")
        for name, sub in tables.get(pkg, {}).items():
            if f"{pkg}.{sub}" not in MODULES:
                bad.append(f"{pkg}: {name} from the missing submodule {sub}")
    assert not bad, "\n".join(bad)


def test_library_never_imports_the_root_package():
    """Subpackages import ``exotune.version``, never the package root (which is the public API)."""
    bad = [f"{s}:{ln}" for s, t, _, ln, _f in _edges() if t == "__init__" and s not in ("__init__", "cli", "__main__", "api")]
    assert not bad, bad


def test_module_graph_is_acyclic():
    graph: dict[str, set[str]] = {m: set() for m in MODULES}
    for src, tgt, _, _, _func in _edges():  # view methods included: no exception
        if tgt in graph and tgt != src:
            graph[src].add(tgt)
    # a package __init__ that re-exports is an edge __init__ → submodule; a submodule importing its
    # own package's __init__ would then be a cycle, which is what we want to catch.
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(n):
        state[n] = 1
        stack.append(n)
        for m in sorted(graph[n]):
            if state.get(m) == 1:
                cyc = stack[stack.index(m):] + [m]
                pytest.fail("import cycle: " + " → ".join(cyc))
            if m not in state:
                visit(m)
        stack.pop()
        state[n] = 2

    for n in sorted(graph):
        if n not in state:
            visit(n)


def test_no_private_names_across_modules():
    bad = [f"{s}:{ln} imports {n} from {t}" for s, t, n, ln, _f in _edges()
           if n and n.startswith("_") and not n.startswith("__") and t != s]
    assert not bad, "\n".join(bad)


def test_library_never_imports_click_or_prints():
    bad = []
    for mod, path in MODULES.items():
        if mod in ("cli", "__main__"):
            continue
        tree = ast.parse(path.read_text(), str(path))
        for node in ast.walk(tree):
            if isinstance(node, ast.Import) and any(a.name.split(".")[0] == "click" for a in node.names):
                bad.append(f"{mod}:{node.lineno} imports click")
            if isinstance(node, ast.ImportFrom) and (node.module or "").split(".")[0] == "click":
                bad.append(f"{mod}:{node.lineno} imports click")
            if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == "print":
                bad.append(f"{mod}:{node.lineno} calls print")
    assert not bad, "\n".join(bad)


def test_tests_import_no_private_names_from_other_modules():
    root = PKG.parent / "tests"
    bad = []
    for p in root.rglob("*.py"):
        tree = ast.parse(p.read_text(), str(p))
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("exotune"):
                for a in node.names:
                    if a.name.startswith("_") and not a.name.startswith("__"):
                        bad.append(f"{p.relative_to(root)}:{node.lineno} imports {a.name} from {node.module}")
    assert not bad, "\n".join(bad)


MAX_MODULE_LINES = 650  # lines of code: docstrings (their numpydoc sections, issue 24) not counted


def _docstring_lines(tree: ast.Module) -> int:
    n = 0
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)) and node.body:
            first = node.body[0]
            if isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant) and isinstance(first.value.value, str):
                n += first.end_lineno - first.lineno + 1
    return n


def test_modules_are_small():
    big = []
    for mod, path in MODULES.items():
        text = path.read_text()
        n = len(text.splitlines()) - _docstring_lines(ast.parse(text))
        if n > MAX_MODULE_LINES:
            big.append(f"{mod}: {n} lines of code")
    assert not big, "\n".join(big)


MAX_FUNCTION_LINES = 80  # code lines, the docstring not counted


def test_long_functions_say_why():
    """A function over MAX_FUNCTION_LINES lines of code states in its docstring why it is one
    function ("One function on purpose" / "One function (over 80 lines)")."""
    bad = []
    for mod, path in MODULES.items():
        for node in ast.walk(ast.parse(path.read_text())):
            if not isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                continue
            doc = ast.get_docstring(node) or ""
            first = node.body[0]
            has_doc = isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant) and isinstance(first.value.value, str)
            start = first.end_lineno + 1 if has_doc and len(node.body) > 1 else first.lineno
            if node.end_lineno - start + 1 > MAX_FUNCTION_LINES and "One function" not in doc:
                bad.append(f"{mod}.{node.name}: {node.end_lineno - start + 1} lines of code, no reason in its docstring")
    assert not bad, "\n".join(bad)


def test_documented_layer_table_matches_the_enforced_layers():
    """docs/architecture.md's layer table names every layer's modules in the order enforced here."""
    import re

    doc = (PKG.parent / "docs" / "architecture.md").read_text(encoding="utf-8")
    rows = [line for line in doc.splitlines() if re.match(r"\| \d", line)]
    named = [re.findall(r"`([\w_]+)`", row.split("|")[2]) for row in rows]
    flat = [m for row in named for m in row]
    assert set(flat) == set(LEVEL), sorted(set(flat) ^ set(LEVEL))
    levels = [LEVEL[m] for m in flat]
    assert levels == sorted(levels), list(zip(flat, levels))
    for row in named:  # one table row never spans two layers unless it says "<" (12–13: api < __init__)
        assert len({LEVEL[m] for m in row}) == 1 or len(row) == len({LEVEL[m] for m in row})


# What the command line may import besides exotune.api: the version and errors it reports, the
# option parser, the engine choice and the one-shot declaration of the process (numerics.beside), and the
# sweep's progress bar (a view).
CLI_MAY_IMPORT = {"api", "version", "errors", "options", "numerics.engine", "numerics.beside", "sweeps"}
CLI_NOT_YET: set = set()


def test_the_command_line_calls_only_the_api():
    """cli.py is parse → one exotune.api call → view → exit code (docs/architecture.md)."""
    tree = ast.parse((PKG / "cli.py").read_text(encoding="utf-8"))
    bad = []
    for fn in [n for n in tree.body if isinstance(n, ast.FunctionDef) and n.name not in CLI_NOT_YET] + [
            n for n in tree.body if not isinstance(n, ast.FunctionDef)]:
        for node in ast.walk(fn):
            if isinstance(node, ast.ImportFrom) and node.level == 1:
                mod = node.module or ""
                if mod not in CLI_MAY_IMPORT:
                    bad.append(f"{getattr(fn, 'name', 'module')}: from .{mod} import …")
            if isinstance(node, ast.ImportFrom) and node.level == 1 and node.module == "sweeps":
                names = {a.name for a in node.names}
                if names != {"TqdmProgress"}:
                    bad.append(f"{getattr(fn, 'name', 'module')}: from .sweeps import {', '.join(sorted(names))}")
    assert not bad, bad


# The columns of a batch analysis (docs/sweep-spec.md#columns) are user-facing names: the sweep's
# Parquet schema and the optimizer's objectives. They are spelled where they are written or looked
# up by name; everything else reads the typed fields of exotune.analysis.BatchAnalysis.
COLUMN_WRITERS = {
    "analysis.batch_result": "BatchAnalysis.to_columns/column: the one spelling of the columns",
    "sweeps.sampledcols": "writes the sweep's sampled_* Parquet columns",
}
# other string-keyed documents whose keys look like columns (not batch analyses)
COLUMN_LIKE_DOCUMENTS = {
    "controllerfile.certify": "the sampled-data verdicts of a controller file (sa[f'{key}_stable'])",
}
# batch columns whose names are also keys of the JSON reports, of controller files and of the
# optimize spec's constraints: only checked in the consumers of analyze_batch (below)
SHARED_NAMES = {"free_stable", "locked_stable", "latency_margin_s"}
FAMILY_SUFFIXES = ("_robust", "_stable", "_conclusive", "_stable_intervals", "_critical", "_edges",
                   "_verification_mismatches")
# the modules that get a BatchAnalysis (analyze_batch's callers and the functions they pass it to)
BATCH_CONSUMERS = {"analysis.design", "analysis.latency_margin", "analysis.plant_margin", "analysis.latency",
                   "analysis.crosscheck", "sweeps.compute", "sweeps.sampledcols", "optimization.evaluate",
                   "optimization.diagnose", "optimization.search"}


def _fixed_column_names() -> set:
    """The columns of a batch analysis without families (the fixed part of the schema)."""
    import numpy as np

    from exotune.analysis.batch_result import (GAIN_NAMES, AmplificationBatch, BatchAnalysis, DobBatch, LoopBatch,
                                               PassivityBatch)
    from exotune.model.shaping import Gains

    e = np.zeros(0)
    res = BatchAnalysis(free=LoopBatch(e, e, e), humans=(), environment=(), passivity=PassivityBatch(e, e, []),
                        dob=DobBatch.absent(0), amplification=AmplificationBatch(e, e, e, e), locked=LoopBatch(e, e),
                        gains=Gains(*[e] * len(GAIN_NAMES)), latency_margin_s=e)
    return set(res.to_columns()) - set(GAIN_NAMES)


def _key_text(node) -> str | None:
    """A string key as written: a literal, or an f-string with ``{}`` for each placeholder."""
    if isinstance(node, ast.Constant) and isinstance(node.value, str):
        return node.value
    if isinstance(node, ast.JoinedStr):
        return "".join(v.value if isinstance(v, ast.Constant) else "{}" for v in node.values)
    return None


def _column_lookups(path: Path):
    """(line, key, subscripted name) of every ``x[key]`` / ``x.get(key)`` / ``x.pop(key)`` with a string key."""
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Subscript):
            key, obj = _key_text(node.slice), node.value
        elif isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and node.func.attr in ("get", "pop") \
                and node.args:
            key, obj = _key_text(node.args[0]), node.func.value
        else:
            continue
        yield node.lineno, key, (obj.id if isinstance(obj, ast.Name) else None)


def test_batch_columns_are_read_through_the_typed_analysis():
    """No module looks a batch-analysis column up by name in a dict except the declared writers: a
    family column (``human0_mass_robust``, ``f"{key}_stable_intervals"``, …) or a fixed one
    (``dob_phase_margin_deg``, …) anywhere; in the consumers of analyze_batch also the names shared
    with the reports (``free_stable``, …) and any ``cols[…]`` (sweeps.compute, the Parquet writer,
    keeps its ``cols`` of ``to_columns()``)."""
    import re

    fixed = _fixed_column_names()
    family = re.compile(r"^(human|env)\d+_\w+(%s)$" % "|".join(FAMILY_SUFFIXES))

    def column_name(key, strict):
        if key is None:
            return False
        if key in fixed - SHARED_NAMES or family.match(key) or (strict and key in SHARED_NAMES):
            return True
        return "{}" in key and key.endswith(FAMILY_SUFFIXES) and key.startswith(("{}", "human", "env"))

    bad = []
    for mod, path in MODULES.items():
        if mod in COLUMN_WRITERS or mod in COLUMN_LIKE_DOCUMENTS:
            continue
        consumer = mod in BATCH_CONSUMERS and not mod.startswith("optimization.")  # optimize: constraint names
        for line, key, obj in _column_lookups(path):
            if column_name(key, consumer):
                bad.append(f"{mod}:{line} looks up the column {key!r}")
            if mod in BATCH_CONSUMERS and mod != "sweeps.compute" and obj == "cols":
                bad.append(f"{mod}:{line} subscripts cols")
    assert not bad, "\n".join(bad)


# Every module has a test file named after it: tests/<package>/test_<module>.py (issue 24 item 3).
# The modules still without one: none left. The set only shrinks: a module listed here that has
# its test file (or no longer exists) fails too.
NO_TEST_FILE_YET: set[str] = set()


def _own_test_file(mod: str) -> Path:
    *pkg, name = mod.split(".")
    return PKG.parent.joinpath("tests", *pkg, f"test_{name}.py")


def test_every_module_has_its_own_test_file():
    mods = sorted(m for m in MODULES if m.split(".")[-1] not in ("__init__", "__main__"))
    missing = {m for m in mods if not _own_test_file(m).exists()}
    new = sorted(missing - NO_TEST_FILE_YET)
    assert not new, "modules without their test file tests/<package>/test_<module>.py: " + ", ".join(
        str(_own_test_file(m).relative_to(PKG.parent)) for m in new)
    done = sorted(NO_TEST_FILE_YET - missing)
    assert not done, "remove from NO_TEST_FILE_YET (the test file exists now, or the module is gone): " + ", ".join(done)


# Figures never compute (docs/architecture.md, issue 24): the plots take the analysis's numbers as
# typed records (exotune.analysis.figure_data.AnalysisFigures, LatencyBoundary, …) and may import
# from exotune.analysis only classes, module-level constants and these display conversions of the
# numbers they are given (dB, continuous phase, finiteness), never a function that computes.
PLOTS_DISPLAY_CONVERSIONS = {"db", "phase_deg", "finite"}


def test_plots_import_no_computing_function_from_the_analysis():
    import importlib
    import inspect

    bad = []
    for mod, tgt, name, line, _func in _edges():
        if _top(mod) != "plots" or _top(tgt) != "analysis":
            continue
        if name is None:  # a whole module: any of its functions could be called
            bad.append(f"{mod}:{line} imports the module {tgt}")
            continue
        obj = getattr(importlib.import_module("exotune." + tgt.removesuffix(".__init__")), name)
        constant = name.isupper() and not callable(obj)
        if not (inspect.isclass(obj) or constant or name in PLOTS_DISPLAY_CONVERSIONS):
            bad.append(f"{mod}:{line} imports {tgt}.{name}, which computes (pass its result as a typed record)")
    assert not bad, "\n".join(bad)
