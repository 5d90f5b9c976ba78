"""The controller file format: its version, the formats a file may be in, the bounds on
what one may hold, and what reading one gives (:class:`Controller`)."""

from __future__ import annotations

from dataclasses import dataclass

from elab.laws import ControlLaw

FORMATS = ("toml", "json", "mat", "npz", "py")
VERSION = 1
MAX_BYTES = 64 * 1024
MAX_ORDER = 20  # controller states, or polynomial coefficients
MAX_EXPANDED = 1 << 20  # bytes a .npz may expand to


@dataclass(frozen=True)
class Controller:
    """A controller read from a file: its law and what the file said about itself."""

    law: ControlLaw
    format: str
    name: str = ""
    plant: str | None = None  # the plant the file names, if it does
