"""The rig's byte protocol: frames, their checksums and an incremental decoder.

A frame (all integers little-endian; docs/rig-protocol.md)::

    magic "EL" | version u8 | type u8 | length u16 | header CRC-16 u16 | payload | CRC-32 u32

The header CRC is CRC-16/CCITT (``binascii.crc_hqx``, initial 0xFFFF) of the six bytes
before it, so a corrupt length is caught before the decoder waits for a payload that
will never come; the trailing CRC-32 (``zlib.crc32``) covers header and payload.
Any single corrupt byte is detected (tests/unit/rig/test_protocol.py).
"""

from __future__ import annotations

import binascii
import struct
import zlib
from typing import assert_never

from elab.errors import InvalidInput
from elab.rig.messages import (
    PROTOCOL_VERSION,
    Action,
    Command,
    Hello,
    Message,
    Refusal,
    RigIdentity,
    Sample,
    Status,
    Voltage,
)

MAGIC = b"EL"
HEADER = struct.Struct("<2sBBHH")
TRAILER = struct.Struct("<I")
MAX_PAYLOAD = 1024  # bytes
TYPES = {Hello: 0x01, Voltage: 0x02, Command: 0x03, RigIdentity: 0x81, Sample: 0x82, Refusal: 0x83}

_HELLO = struct.Struct("<H")
_VOLTAGE = struct.Struct("<If")
_COMMAND = struct.Struct("<B")
_SAMPLE = struct.Struct("<IiiH")
_CALIBRATION = struct.Struct("<BIdiIH")  # flags, counts/rev, rad/count, offset, Ts ns, watchdog
_U32, _I32 = (0, 2**32 - 1), (-(2**31), 2**31 - 1)


class FrameError(InvalidInput):
    """Bytes that are not a valid frame (corrupt, truncated, out of range)."""


class UnsupportedVersion(FrameError):
    """A frame of a protocol version this side does not speak."""


class UnknownMessage(FrameError):
    """A frame whose type code names no message."""


def encode(message: Message) -> bytes:
    """The frame of ``message``; out-of-range fields raise :class:`FrameError`."""
    payload = _payload(message)
    head = struct.pack("<2sBBH", MAGIC, PROTOCOL_VERSION, TYPES[type(message)], len(payload))
    frame = head + struct.pack("<H", binascii.crc_hqx(head, 0xFFFF)) + payload
    return frame + TRAILER.pack(zlib.crc32(frame))


def _payload(message: Message) -> bytes:
    match message:
        case Hello(version):
            return _HELLO.pack(_checked("hello.version", version, (0, 2**16 - 1)))
        case Voltage(seq, u):
            return _VOLTAGE.pack(_checked("voltage.seq", seq, _U32), u)
        case Command(action):
            return _COMMAND.pack(int(action))
        case Sample(seq, counts, gauge, status):
            return _SAMPLE.pack(
                _checked("sample.seq", seq, _U32),
                _checked("sample.encoder_counts", counts, _I32),
                _checked("sample.gauge_reading", gauge, _I32),
                _checked("sample.status", int(status), (0, 2**16 - 1)),
            )
        case RigIdentity():
            return _identity(message)
        case Refusal(reason):
            return _text("refusal.reason", reason)
        case _:
            assert_never(message)


def _identity(m: RigIdentity) -> bytes:
    return (
        _text("identity.rig_id", m.rig_id)
        + _text("identity.firmware", m.firmware)
        + _CALIBRATION.pack(
            int(m.emulated),
            _checked("identity.counts_per_rev", m.counts_per_rev, (1, 2**32 - 1)),
            m.gauge_rad_per_count,
            _checked("identity.gauge_offset", m.gauge_offset, _I32),
            _checked("identity.Ts", round(m.Ts * 1e9), (1, 2**32 - 1)),
            _checked("identity.watchdog_samples", m.watchdog_samples, (1, 2**16 - 1)),
        )
    )


def _checked(field: str, value: int, bounds: tuple[int, int]) -> int:
    if not bounds[0] <= value <= bounds[1]:
        raise FrameError(field, value, f"an integer from {bounds[0]} to {bounds[1]}")
    return value


def _text(field: str, text: str) -> bytes:
    data = text.encode("utf-8")
    return struct.pack("<H", _checked(f"{field} (UTF-8 bytes)", len(data), (0, 255))) + data


class Decoder:
    """Frames out of a byte stream read in arbitrary pieces.

    :meth:`feed` the bytes as they arrive; :meth:`next` returns the next whole message,
    or ``None`` until more bytes come. A bad frame raises :class:`FrameError` (or a
    subclass) once and is skipped, so the caller may go on decoding after it.
    """

    def __init__(self) -> None:
        self._buffer = bytearray()

    def feed(self, data: bytes) -> None:
        self._buffer += data

    def next(self) -> Message | None:
        buf = self._buffer
        if not MAGIC.startswith(buf[:2]):
            skipped = self._resync(1)
            raise FrameError("frame.magic", bytes(skipped[:2]), f"the bytes {MAGIC!r}")
        if len(buf) < HEADER.size:
            return None
        _, version, kind, length, check = HEADER.unpack_from(buf)
        if binascii.crc_hqx(bytes(buf[:6]), 0xFFFF) != check:
            self._resync(1)
            raise FrameError("frame.header_crc", check, "the CRC-16 of the header")
        size = HEADER.size + length + TRAILER.size
        if length > MAX_PAYLOAD:
            self._resync(1)
            raise FrameError("frame.length", length, f"at most {MAX_PAYLOAD} bytes")
        if len(buf) < size:
            return None
        frame = bytes(buf[:size])
        del buf[:size]
        (crc,) = TRAILER.unpack_from(frame, size - TRAILER.size)
        if zlib.crc32(frame[: size - TRAILER.size]) != crc:
            raise FrameError("frame.crc32", crc, "the CRC-32 of the header and payload")
        if version != PROTOCOL_VERSION:
            raise UnsupportedVersion("frame.version", version, f"{PROTOCOL_VERSION}")
        return _decode(kind, frame[HEADER.size : size - TRAILER.size])

    def _resync(self, skip: int) -> bytearray:
        """Drop ``skip`` bytes and everything up to the next magic; return what went."""
        at = self._buffer.find(MAGIC[:1], skip)
        cut = len(self._buffer) if at < 0 else at
        skipped = self._buffer[:cut]
        del self._buffer[:cut]
        return skipped


def _decode(kind: int, payload: bytes) -> Message:
    try:
        match kind:
            case 0x01:
                return Hello(*_HELLO.unpack(payload))
            case 0x02:
                return Voltage(*_VOLTAGE.unpack(payload))
            case 0x03:
                return Command(_action(*_COMMAND.unpack(payload)))
            case 0x81:
                return _decode_identity(payload)
            case 0x82:
                seq, counts, gauge, status = _SAMPLE.unpack(payload)
                return Sample(seq, counts, gauge, Status(status))
            case 0x83:
                reason, rest = _read_text(payload)
                _expect_end(rest)
                return Refusal(reason)
    except struct.error:
        raise FrameError(
            "frame.length", len(payload), f"the length of message {kind:#04x}"
        ) from None
    known = ", ".join(f"{code:#04x}" for code in TYPES.values())
    raise UnknownMessage("frame.type", f"{kind:#04x}", known)


def _action(code: int) -> Action:
    try:
        return Action(code)
    except ValueError:
        allowed = ", ".join(f"{a.value} ({a.name})" for a in Action)
        raise FrameError("command.action", code, allowed) from None


def _decode_identity(payload: bytes) -> RigIdentity:
    rig_id, rest = _read_text(payload)
    firmware, rest = _read_text(rest)
    flags, cpr, rad_per_count, offset, ts_ns, watchdog = _CALIBRATION.unpack(rest)
    return RigIdentity(
        rig_id, firmware, bool(flags & 1), cpr, rad_per_count, offset, ts_ns * 1e-9, watchdog
    )


def _read_text(data: bytes) -> tuple[str, bytes]:
    (n,) = struct.unpack_from("<H", data)
    if len(data) < 2 + n:
        raise struct.error("short string")
    try:
        return data[2 : 2 + n].decode("utf-8"), data[2 + n :]
    except UnicodeDecodeError:
        raise FrameError("frame.text", data[2 : 2 + n], "UTF-8 text") from None


def _expect_end(rest: bytes) -> None:
    if rest:
        raise struct.error("trailing bytes")
