"""Controllers users bring: files in the lab's formats, templates, and the validation
report (docs/controllers.md).

The names are loaded on first use (PEP 562): the report brings python-control, which the
web process imports only when it checks a controller itself (elab/sim/__init__.py).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from elab._lazy import Where, lazy_exports

if TYPE_CHECKING:
    from elab.controllers.file_format import FORMATS, Controller
    from elab.controllers.files import format_of, law_from_fields, read_controller
    from elab.controllers.report import Report, check
    from elab.controllers.templates import law_fields, law_file, template

#: each exported name: its module
_EXPORTS: dict[str, Where] = {
    "FORMATS": "elab.controllers.file_format",
    "Controller": "elab.controllers.file_format",
    "format_of": "elab.controllers.files",
    "law_from_fields": "elab.controllers.files",
    "read_controller": "elab.controllers.files",
    "Report": "elab.controllers.report",
    "check": "elab.controllers.report",
    "law_fields": "elab.controllers.templates",
    "law_file": "elab.controllers.templates",
    "template": "elab.controllers.templates",
}

__all__ = [
    "FORMATS",
    "Controller",
    "Report",
    "check",
    "format_of",
    "law_fields",
    "law_file",
    "law_from_fields",
    "read_controller",
    "template",
]


__getattr__ = lazy_exports(__name__, _EXPORTS)
