"""A plain (non-editable) install ships every subpackage: pyproject.toml lists them by hand."""

from __future__ import annotations

import tomllib

from helpers import ROOT


def test_every_subpackage_is_listed_in_pyproject():
    listed = set(tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["packages"])
    found = {".".join(p.parent.relative_to(ROOT).parts)
             for p in (ROOT / "mitsonar").rglob("__init__.py")}
    assert found, "no packages found under mitsonar/"
    assert found <= listed, f"missing from [tool.setuptools] packages: {sorted(found - listed)}"
