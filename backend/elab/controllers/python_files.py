"""Python controllers (``.py``), read only as far as their syntax: they run only in the
sandbox (:mod:`elab.controllers.sandbox`)."""

from __future__ import annotations

import ast

from elab.controllers.file_format import Controller
from elab.controllers.text_files import utf8_text
from elab.errors import InvalidInput
from elab.laws import CodeController


def python_controller(data: bytes, filename: str = "controller.py") -> Controller:
    """A Python controller's source, parsed (never run here): its syntax, with line and
    column, and a top-level ``class Controller`` with a ``step`` method."""
    text = utf8_text(data)
    if "\0" in text:
        raise InvalidInput("file", f"a NUL character at offset {text.index(chr(0))}", "text")
    try:
        tree = ast.parse(text, filename)
    except SyntaxError as exc:
        raise InvalidInput(
            "file",
            f"line {exc.lineno}, column {exc.offset}: {exc.msg}",
            "valid Python 3 source",
        ) from None
    except (RecursionError, MemoryError):
        raise InvalidInput("file", "nested too deeply", "plain Python source") from None
    classes = [n for n in tree.body if isinstance(n, ast.ClassDef) and n.name == "Controller"]
    if not classes:
        raise InvalidInput(
            "file", "no top-level class Controller", "a module defining class Controller"
        )
    methods = {n.name for n in classes[-1].body if isinstance(n, ast.FunctionDef)}
    if "step" not in methods:
        raise InvalidInput(
            "Controller",
            f"methods {', '.join(sorted(methods)) or 'none'}",
            "a class with step(self, t, y, r) (and optionally reset(self, params))",
        )
    doc = ast.get_docstring(tree) or ""
    name = doc.strip().splitlines()[0][:80] if doc.strip() else ""
    return Controller(CodeController(text, filename), "py", name)
