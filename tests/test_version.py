"""The version is written once, in vptoolkit/_version.py, and the package metadata reads it."""

from __future__ import annotations

import importlib.metadata
import tomllib

import vptoolkit
from fixtures.paths import REPO
from vptoolkit import _version


def test_the_metadata_and_the_package_give_the_one_written_version() -> None:
    project = tomllib.loads((REPO / "pyproject.toml").read_text())
    assert "version" not in project["project"] and "version" in project["project"]["dynamic"]
    attr = project["tool"]["setuptools"]["dynamic"]["version"]["attr"]
    assert attr == "vptoolkit._version.__version__"
    assert vptoolkit.__version__ == _version.__version__
    assert importlib.metadata.version("vptoolkit") == _version.__version__
