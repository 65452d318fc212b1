"""exotune.version: the version string is the one pyproject.toml declares."""

import re
import tomllib
from pathlib import Path

import exotune
from exotune.version import __version__

ROOT = Path(__file__).resolve().parent.parent


def test_version_is_pyprojects():
    declared = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]["version"]
    assert __version__ == declared


def test_version_is_a_release_number_and_the_package_exports_it():
    assert re.fullmatch(r"\d+\.\d+\.\d+([.-]?\w+)?", __version__)
    assert exotune.__version__ == __version__
