"""The stream's messages in msgpack (subprotocol ``elab.v1``), built from the wire models.

Every message but ``frame`` is a model of :mod:`elab.api.schemas`, validated as it
is built, so a change to the schema that the server does not follow fails at
once. Frames are the hot path: many runs' frames are filled into one byte array
from a template whose keys are :class:`~elab.api.schemas.Frame`'s fields (a test
decodes them and validates them against the model).
"""

from __future__ import annotations

import functools
from typing import Any

import msgpack
import numpy as np
from numpy.typing import NDArray

from elab.api import schemas as s

Array = NDArray[np.float64]
SKIPPED_REASON = "slow watcher: frames dropped; send resume_from to receive them from the recording"


def pack(message: s.Model) -> bytes:
    return msgpack.packb(message.model_dump(mode="python"), use_bin_type=True)  # type: ignore[no-any-return]


class MsgpackCodec:
    """:class:`elab.runs.fanout.Codec` for ``elab.v1``."""

    def frames(
        self, names: tuple[str, ...], F: int, k0: NDArray[np.int64], data: Array
    ) -> list[bytes]:
        return encode_frames(names, F, k0, data)

    def skipped(self, from_seq: int, to_seq: int) -> bytes:
        return pack(s.Skipped(from_seq=from_seq, to_seq=to_seq, reason=SKIPPED_REASON))

    def status(self, state: str, k: int, error: str | None) -> bytes:
        return pack(s.Status(state=state, k=k, error=error))  # type: ignore[arg-type]

    def params(self, k: int, t: float, params: dict[str, Any]) -> bytes:
        return pack(s.ParamsNotice(k=k, t=t, params=params))


def encode_frame(names: tuple[str, ...], F: int, k0: int, data: Array) -> bytes:
    """One ``frame`` message of samples ``k0 .. k0+n−1`` (``data``: n × channels)."""
    return encode_frames(names, F, np.array([k0]), data[np.newaxis])[0]


def encode_frames(
    names: tuple[str, ...], F: int, k0: NDArray[np.int64], data: Array
) -> list[bytes]:
    """``frame`` messages of R runs at once (``data``: R × n × channels, ``k0``: R).

    A frame is the msgpack map ``{type: "frame", seq, k0, n, columns: {name: bin}}``
    with float32 little-endian bytes per channel. Every message of one shape has the
    same layout (``seq`` and ``k0`` are written as uint64), so all R are filled into
    one byte array by a few array copies instead of being packed one by one.
    """
    R, n, _ = data.shape
    template, at_seq, at_k0, at_cols = _layout(names, n)
    out = np.empty((R, len(template)), np.uint8)
    out[:] = np.frombuffer(template, np.uint8)
    k0 = np.asarray(k0, dtype=np.int64)
    out[:, at_seq : at_seq + 8] = (k0 // F).astype(">u8").view(np.uint8).reshape(R, 8)
    out[:, at_k0 : at_k0 + 8] = k0.astype(">u8").view(np.uint8).reshape(R, 8)
    with np.errstate(over="ignore"):  # beyond float32's range is ±inf on the wire, as it should
        cols = np.ascontiguousarray(data.transpose(0, 2, 1), dtype="<f4").view(np.uint8)
    for i, at in enumerate(at_cols):
        out[:, at : at + 4 * n] = cols[:, i]
    return [row.tobytes() for row in out]


@functools.lru_cache(maxsize=256)
def _layout(names: tuple[str, ...], n: int) -> tuple[bytes, int, int, tuple[int, ...]]:
    """A frame of ``n`` samples with zeros for ``seq``, ``k0`` and the data, and where
    ``seq``, ``k0`` and each channel's bytes begin."""
    type_, seq, k0, count, columns = s.Frame.model_fields  # the model's keys, in order
    packer = msgpack.Packer(use_bin_type=True)
    head = packer.pack_map_header(5) + packer.pack(type_) + packer.pack("frame") + packer.pack(seq)
    at_seq = len(head) + 1
    head += b"\xcf" + bytes(8) + packer.pack(k0)
    at_k0 = len(head) + 1
    head += b"\xcf" + bytes(8) + packer.pack(count) + packer.pack(n) + packer.pack(columns)
    head += packer.pack_map_header(len(names))
    at_cols = []
    for name in names:
        head += packer.pack(name) + packer.pack(bytes(4 * n))
        at_cols.append(len(head) - 4 * n)
    return head, at_seq, at_k0, tuple(at_cols)
