"""The packages that load their names on first use (``elab.sim``, ``elab.design``,
``elab.controllers``: PEP 562, so that the web process starts without python-control)
give the same objects as their modules, whatever was imported before: a name equal to one
of the package's submodules would be replaced by that module once it is imported."""

from __future__ import annotations

import importlib
import pkgutil

import pytest

LAZY = ("elab.sim", "elab.design", "elab.controllers")


@pytest.mark.parametrize("name", LAZY)
def test_every_exported_name_is_its_modules_object_after_every_submodule_loaded(
    name: str,
) -> None:
    package = importlib.import_module(name)
    for info in pkgutil.iter_modules(package.__path__):
        importlib.import_module(f"{name}.{info.name}")
    exports = package._EXPORTS
    assert sorted(package.__all__) == sorted(exports)
    for export in package.__all__:
        where = exports[export]
        module, attr = where if isinstance(where, tuple) else (where, export)
        assert getattr(package, export) is getattr(importlib.import_module(module), attr), export
        assert not isinstance(getattr(package, export), type(package)), export


def test_an_unknown_name_is_an_attribute_error() -> None:
    design = importlib.import_module("elab.design")
    with pytest.raises(AttributeError, match="no attribute 'nothing'"):
        design.nothing  # noqa: B018
