"""Controllers as users write them: TOML, JSON, MATLAB ``.mat`` and NumPy ``.npz`` files,
read into the lab's control laws (:mod:`elab.laws`); their templates are in
:mod:`elab.controllers.templates`.

Every format says the same thing (docs/controllers.md):

- ``kind = "state_feedback"``: ``K`` (one gain per plant state), ``estimate``
  (``"velocity_filters"``, what the rig can measure, or ``"true_state"``);
- ``kind = "pid"``: ``Kp``, ``Ki``, ``Kd``, ``N`` (derivative filter), ``Tt``
  (anti-windup tracking time);
- ``kind = "lti"``: a transfer function ``num``, ``den`` or a state space ``A``, ``B``,
  ``C``, ``D`` on the error r − y, continuous (Tustin at the run's sample time) or
  discrete with its sample time ``dt`` (MATLAB's ``Ts``; 0 means continuous); a state
  space may add the reference's own input ``B_r``, ``D_r`` (two degrees of freedom);
- ``kind = "open_loop"``: u = r;
- a Python file (``.py``) defining ``class Controller`` with ``reset(params)`` and
  ``step(t, y, r) -> u``: read here only as far as its syntax; it runs only in the
  sandbox (:mod:`elab.controllers.sandbox`).

A ``.mat`` or ``.npz`` file holds plain matrices named as above; the kind follows from
which are there. Nothing is ever unpickled, and every size is bounded before data are
read (:mod:`elab.controllers.file_format`): a file of at most ``MAX_BYTES``, at most
``MAX_ORDER`` controller states or coefficients, a ``.npz`` whose members together expand
to at most ``MAX_EXPANDED``.

This module reads a file of any format; :mod:`~elab.controllers.text_files` (TOML, JSON),
:mod:`~elab.controllers.binary_files` (.mat, .npz) and
:mod:`~elab.controllers.python_files` read each format, and
:mod:`~elab.controllers.fields` makes the fields a law.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from elab.controllers.binary_files import mat_fields, npz_fields
from elab.controllers.fields import controller_of_fields
from elab.controllers.file_format import FORMATS, MAX_BYTES, VERSION, Controller
from elab.controllers.python_files import python_controller
from elab.controllers.text_files import text_fields
from elab.errors import InvalidInput
from elab.laws import ControlLaw
from elab.plants import Plant


def read_controller(data: bytes, fmt: str, plant: Plant) -> Controller:
    """Read a controller file for ``plant``. :class:`InvalidInput` names what is wrong:
    the line and column of a syntax error, an unknown field and the allowed ones, a
    dimension against the plant, a non-finite number."""
    if fmt not in FORMATS:
        raise InvalidInput("format", fmt, ", ".join(FORMATS))
    if len(data) > MAX_BYTES:
        raise InvalidInput("file", f"{len(data)} bytes", f"a file of at most {MAX_BYTES} bytes")
    if not data:
        raise InvalidInput("file", "an empty file", f"a {fmt} controller file")
    if fmt == "py":
        return python_controller(data)
    if fmt in ("toml", "json"):
        fields = text_fields(data, fmt)
    elif fmt == "mat":
        fields = mat_fields(data)
    else:
        fields = npz_fields(data)
    return controller_of_fields(fields, fmt, plant)


def law_from_fields(fields: Mapping[str, Any], plant: Plant) -> ControlLaw:
    """The law of a controller file's fields (as :func:`elab.controllers.law_fields`
    writes them; how a stored controller comes back)."""
    return controller_of_fields({"version": VERSION, **fields}, "stored", plant).law


def format_of(filename: str) -> str:
    """The format of a file from its name's extension."""
    ext = filename.rsplit(".", 1)[-1].lower() if "." in filename else ""
    if ext not in FORMATS:
        raise InvalidInput(
            "file", filename, "a name ending in " + ", ".join("." + f for f in FORMATS)
        )
    return ext
