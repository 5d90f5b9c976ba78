"""The binary formats, MATLAB ``.mat`` and NumPy ``.npz``, read into a controller file's
fields: plain matrices named as in the text formats, the kind following from which are
there. Nothing is unpickled, and sizes are checked before anything is expanded."""

from __future__ import annotations

import io
import math
import zipfile
from typing import Any

import numpy as np

from elab.controllers.file_format import MAX_EXPANDED, VERSION
from elab.errors import InvalidInput

_MAT_FIX = "save -v7 ctrl.mat A B C D Ts  (or K, or Kp Ki Kd, or num den Ts)"


def mat_fields(data: bytes) -> dict[str, Any]:
    import scipy.io

    if data[:128].find(b"MATLAB 7.3") >= 0 or data[512:516] == b"\x89HDF":
        raise InvalidInput(
            "file", "a MATLAB v7.3 (HDF5) file", f"a v7 or older .mat file: {_MAT_FIX}"
        )
    _mat_sizes(data)
    try:
        raw = scipy.io.loadmat(io.BytesIO(data), squeeze_me=False, struct_as_record=True)
    except Exception as exc:  # scipy raises many kinds for a damaged file
        raise InvalidInput(
            "file", f"not a readable .mat file ({exc})", f"a v4-v7 .mat file: {_MAT_FIX}"
        ) from None
    out: dict[str, Any] = {}
    for name, value in raw.items():
        if name.startswith("__"):
            continue
        out[name] = _mat_value(name, value)
    return _binary_kind(out)


_MAT_NUMERIC = frozenset(
    {"double", "single", "logical", "char"}
    | {f"{sign}int{bits}" for sign in ("", "u") for bits in (8, 16, 32, 64)}
)


def _mat_sizes(data: bytes) -> None:
    """Refuse a .mat file whose variables, as its headers declare them, are not plain
    matrices or would expand past :data:`MAX_EXPANDED` bytes as float64, before any of
    them is decompressed (issue 24: a 58 KB file declaring 60 M elements took the server
    from 237 MB to 3 GB while it was read)."""
    import scipy.io

    try:
        variables = scipy.io.whosmat(io.BytesIO(data))
    except Exception as exc:  # scipy raises many kinds for a damaged file
        raise InvalidInput(
            "file", f"not a readable .mat file ({exc})", f"a v4-v7 .mat file: {_MAT_FIX}"
        ) from None
    if len(variables) > 16:
        raise InvalidInput("file", f"{len(variables)} variables", "at most 16 matrices")
    total = 0
    for name, shape, kind in variables:
        if kind not in _MAT_NUMERIC:
            raise InvalidInput(
                name,
                f"a MATLAB {kind}",
                f"plain numeric matrices (no ss/tf objects, structs or cells): {_MAT_FIX}",
            )
        total += math.prod(shape) * 8
        if total > MAX_EXPANDED:
            raise InvalidInput(
                name,
                f"a {'×'.join(map(str, shape))} matrix",
                f"matrices of at most {MAX_EXPANDED} bytes together as float64",
            )


def _mat_value(name: str, value: Any) -> Any:
    if isinstance(value, np.ndarray) and value.dtype.kind in "U":
        return "".join(value.ravel().tolist())
    if not isinstance(value, np.ndarray) or value.dtype.kind not in "fiub":
        raise InvalidInput(
            name,
            f"a MATLAB {type(value).__name__ if not isinstance(value, np.ndarray) else 'object'}",
            f"plain numeric matrices (no ss/tf objects, structs or cells): {_MAT_FIX}",
        )
    return value.astype(np.float64)


def npz_fields(data: bytes) -> dict[str, Any]:
    try:
        archive = zipfile.ZipFile(io.BytesIO(data))
        members = archive.infolist()
    except zipfile.BadZipFile:
        raise InvalidInput("file", "not a zip archive", "an .npz file (numpy.savez)") from None
    if len(members) > 16 or sum(m.file_size for m in members) > MAX_EXPANDED:
        raise InvalidInput(
            "file",
            f"{len(members)} members expanding to {sum(m.file_size for m in members)} bytes",
            f"at most 16 arrays and {MAX_EXPANDED} bytes expanded",
        )
    try:
        npz = np.load(io.BytesIO(data), allow_pickle=False)
        out = {name: npz[name] for name in npz.files}
    except ValueError as exc:  # object arrays need pickle: refused
        raise InvalidInput(
            "file", f"{exc}", "numeric arrays (pickled objects are never loaded)"
        ) from None
    except Exception as exc:
        raise InvalidInput(
            "file", f"not a readable .npz ({exc})", "an .npz file (numpy.savez)"
        ) from None
    for name, value in out.items():
        if value.dtype.kind == "U":
            out[name] = str(value.item()) if value.size == 1 else value
        elif value.dtype.kind not in "fiub":
            raise InvalidInput(name, str(value.dtype), "numeric arrays")
        else:
            out[name] = value.astype(np.float64)
    return _binary_kind(out)


def _binary_kind(fields: dict[str, Any]) -> dict[str, Any]:
    """The kind a set of matrices means (the names say it); ``Ts`` is MATLAB's ``dt``."""
    out: dict[str, Any] = {k: _plain(v) for k, v in fields.items()}
    if "Ts" in out:
        ts = out.pop("Ts")
        out["dt"] = None if ts in (0, 0.0, -1, -1.0) else ts
    names = set(out)
    if "kind" in out:
        return {"version": VERSION, **out}
    for kind, marker in (("state_feedback", {"K"}), ("pid", {"Kp"}), ("lti", {"num", "A"})):
        if names & marker:
            return {"version": VERSION, "kind": kind, **out}
    raise InvalidInput(
        "file",
        ", ".join(sorted(names)) or "no matrices",
        "K (state feedback), Kp/Ki/Kd (PID), num and den, or A, B, C, D (with Ts)",
    )


def _plain(value: Any) -> Any:
    """A matrix as nested lists (a 1×1 one as a number), as the text formats give them."""
    if isinstance(value, np.ndarray):
        if value.size == 1:
            return float(value.ravel()[0])
        return value.tolist()
    return value
