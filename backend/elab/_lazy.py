"""A package's names loaded on first use (PEP 562): ``elab.sim``, ``elab.design`` and
``elab.controllers`` name what they export in a table and load its module when a name is
first looked up, so that a process importing the package for one light name (the web
process: a signal, a file format) does not import python-control, scipy.signal or numba
(docs/architecture.md, start-up). ``tests/unit/test_lazy_exports.py`` checks every table.
"""

from __future__ import annotations

import importlib
import sys
from collections.abc import Callable, Mapping
from typing import Any

#: an exported name's module, or (its module, its name there)
Where = str | tuple[str, str]


def lazy_exports(package: str, exports: Mapping[str, Where]) -> Callable[[str], Any]:
    """The module ``__getattr__`` of ``package``: a name in ``exports`` is loaded from its
    module and kept in the package (the next lookup is a plain one); any other name is the
    usual ``AttributeError``."""

    def __getattr__(name: str) -> Any:
        try:
            where = exports[name]
        except KeyError:
            raise AttributeError(f"module {package!r} has no attribute {name!r}") from None
        module, attr = (where, name) if isinstance(where, str) else where
        value = getattr(importlib.import_module(module), attr)
        setattr(sys.modules[package], name, value)
        return value

    return __getattr__
