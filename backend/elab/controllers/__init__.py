"""Controllers users bring: files in the lab's formats, templates, and the validation
report (docs/controllers.md)."""

from elab.controllers.file_format import FORMATS, Controller
from elab.controllers.files import format_of, law_from_fields, read_controller
from elab.controllers.report import Report, check
from elab.controllers.templates import law_fields, law_file, template

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
