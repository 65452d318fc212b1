"""exotune.lazy.attach and the package namespaces built with it (issue 24, item 3): every package
``__init__`` lists its public names and loads them on first use, so that importing a package or
one of its submodules imports none of its sibling submodules (docs/architecture.md#public-names)."""

from __future__ import annotations

import importlib
import json
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PKG = ROOT / "exotune"
# every package but the compiled kernels' namespace (exotune.numerics.kernels, loaded whole on purpose)
PACKAGES = sorted(p.parent.name for p in PKG.glob("*/__init__.py"))


def _submodules(pkg: str) -> set[str]:
    d = PKG / pkg
    return {p.stem for p in d.glob("*.py") if p.stem != "__init__"} | {p.parent.name for p in d.glob("*/__init__.py")}


def _run(code: str):
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, check=True).stdout
    return json.loads(out)


def test_attach_loads_a_name_on_first_use(tmp_path, monkeypatch):
    pkg = tmp_path / "lazypkg_t"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("from exotune.lazy import attach\n"
                                     "__getattr__, __dir__, __all__ = attach(__name__, {'f': 'mod', 'K': 'other'})\n")
    (pkg / "mod.py").write_text("def f():\n    return 42\n")
    (pkg / "other.py").write_text("K = 7\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    try:
        m = importlib.import_module("lazypkg_t")
        assert m.__all__ == ["f", "K"]
        assert "lazypkg_t.mod" not in sys.modules and "lazypkg_t.other" not in sys.modules
        assert {"f", "K"} <= set(dir(m)) and dir(m) == sorted(dir(m))
        from lazypkg_t import f

        assert f() == 42 and "lazypkg_t.mod" in sys.modules and "lazypkg_t.other" not in sys.modules
        assert vars(m)["f"] is f  # cached: the next look-up is a plain attribute
        assert m.K == 7
        with pytest.raises(AttributeError, match="lazypkg_t.*no attribute 'g'"):
            m.g  # noqa: B018
        with pytest.raises(ImportError):
            from lazypkg_t import g  # noqa: F401
    finally:
        for name in [n for n in sys.modules if n.split(".")[0] == "lazypkg_t"]:
            del sys.modules[name]


@pytest.mark.parametrize("pkg", PACKAGES)
def test_every_public_name_resolves_and_is_listed(pkg):
    mod = importlib.import_module(f"exotune.{pkg}")
    if pkg == "numerics":
        assert "kernels" not in mod.__all__
    assert mod.__all__, f"exotune.{pkg} lists no public name"
    assert len(set(mod.__all__)) == len(mod.__all__)
    listed = dir(mod)
    for name in mod.__all__:
        value = getattr(mod, name)
        assert name in listed, name
        assert not isinstance(value, type(mod)), f"exotune.{pkg}.{name} is a module"
        assert not name.startswith("_"), name


@pytest.mark.parametrize("pkg", PACKAGES)
def test_no_public_name_is_a_submodule(pkg):
    """Importing ``exotune.<pkg>.<name>`` would set the package attribute to the module and shadow
    the public name (why ``latency_margin`` and ``evaluate`` are taken from their modules)."""
    mod = importlib.import_module(f"exotune.{pkg}")
    assert not set(mod.__all__) & _submodules(pkg)


def test_internals_are_not_reexported():
    import exotune.analysis as analysis
    import exotune.config as config
    import exotune.controllerfile as controllerfile
    import exotune.sampled as sampled

    for mod, names in ((analysis, ("char_terms", "RootCounter", "CharTerms", "strip_qps", "trim_poly",
                                   "amplification_qps", "rhp_count", "MAX_FAMILY_PIECES")),
                       (config, ("hash_mapping", "MAX_DEPTH", "check_limit")),
                       (controllerfile, ("discrete_from_file", "plant_from_file", "sos_ss")),
                       (sampled, ("tustin", "zoh_fractional", "spectral_verdict"))):
        for name in names:
            assert name not in mod.__all__
            with pytest.raises(AttributeError):
                getattr(mod, name)
    from exotune.analysis.counting import RootCounter  # internals come from their module

    assert RootCounter.__module__ == "exotune.analysis.counting"


def test_importing_every_package_imports_no_submodule():
    code = textwrap.dedent(f"""
        import importlib, json, sys
        for p in {PACKAGES!r}:
            importlib.import_module('exotune.' + p)
        print(json.dumps(sorted(m for m in sys.modules if m.startswith('exotune')) + ['numpy' in sys.modules]))
    """)
    loaded = _run(code)
    assert loaded.pop() is False  # not even numpy
    assert set(loaded) == {"exotune", "exotune.version", "exotune.lazy"} | {f"exotune.{p}" for p in PACKAGES}


def test_a_submodule_imports_none_of_its_siblings():
    """The regression of issue 24: exotune.controllerfile.verdicts (on the path of every
    ``exotune analyze``) used to import the whole controllerfile package, the C code generator and
    scipy.signal with it."""
    code = ("import json, sys, exotune.controllerfile.verdicts; "
            "print(json.dumps(sorted(m for m in sys.modules if m.startswith('exotune.controllerfile.'))))")
    assert _run(code) == ["exotune.controllerfile.verdicts"]
