"""The rig's byte protocol: every message survives a round trip, any single corrupt
byte is caught, and how the stream is cut into reads does not matter."""

from __future__ import annotations

import binascii
import struct
import zlib

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from elab.rig.messages import (
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
from elab.rig.protocol import Decoder, FrameError, UnknownMessage, UnsupportedVersion, encode

u32 = st.integers(0, 2**32 - 1)
i32 = st.integers(-(2**31), 2**31 - 1)
text = st.text(max_size=40)
messages: st.SearchStrategy[Message] = st.one_of(
    st.builds(Hello, st.integers(0, 2**16 - 1)),
    st.builds(Voltage, u32, st.floats(width=32, allow_nan=False)),
    st.builds(Command, st.sampled_from(Action)),
    st.builds(Sample, u32, i32, i32, st.integers(0, 2**16 - 1).map(Status)),
    st.builds(Refusal, text),
    st.builds(
        RigIdentity,
        text,
        text,
        st.booleans(),
        st.integers(1, 2**32 - 1),
        st.floats(allow_nan=False),
        i32,
        st.integers(1, 2**32 - 1).map(lambda ns: ns * 1e-9),
        st.integers(1, 2**16 - 1),
    ),
)


def decode_all(decoder: Decoder) -> list[Message]:
    out = []
    while (m := decoder.next()) is not None:
        out.append(m)
    return out


@given(messages)
def test_every_message_survives_a_round_trip(message: Message) -> None:
    decoder = Decoder()
    decoder.feed(encode(message))
    assert decode_all(decoder) == [message]


@given(messages, st.data())
def test_any_single_corrupt_byte_is_detected(message: Message, data: st.DataObject) -> None:
    frame = bytearray(encode(message))
    at = data.draw(st.integers(0, len(frame) - 1), label="at")
    frame[at] ^= data.draw(st.integers(1, 255), label="xor")
    decoder = Decoder()
    decoder.feed(bytes(frame))
    with pytest.raises(FrameError):
        decoder.next()


@settings(max_examples=60)
@given(st.lists(messages, max_size=8), st.data())
def test_how_the_stream_is_cut_does_not_matter(ms: list[Message], data: st.DataObject) -> None:
    stream = b"".join(encode(m) for m in ms)
    cuts = sorted(data.draw(st.lists(st.integers(0, len(stream)), max_size=12), label="cuts"))
    decoder, got = Decoder(), []
    for a, b in zip([0, *cuts], [*cuts, len(stream)], strict=True):
        decoder.feed(stream[a:b])
        got += decode_all(decoder)
    assert got == ms


def test_a_partial_frame_waits_for_the_rest() -> None:
    frame = encode(Sample(7, -3, 12, Status.MOTOR_ENABLED))
    decoder = Decoder()
    decoder.feed(frame[:-1])
    assert decoder.next() is None
    decoder.feed(frame[-1:])
    assert decoder.next() == Sample(7, -3, 12, Status.MOTOR_ENABLED)


def frame_of(version: int, kind: int, payload: bytes) -> bytes:
    """A frame with valid checksums and any version and type, built by hand from the
    layout in docs/rig-protocol.md."""
    head = b"EL" + struct.pack("<BBH", version, kind, len(payload))
    head += struct.pack("<H", binascii.crc_hqx(head, 0xFFFF))
    return head + payload + struct.pack("<I", zlib.crc32(head + payload))


def test_the_layout_is_the_documented_one() -> None:
    assert encode(Voltage(5, 1.5)) == frame_of(1, 0x02, struct.pack("<If", 5, 1.5))


def test_a_newer_version_is_refused_by_name_and_skipped() -> None:
    decoder = Decoder()
    decoder.feed(frame_of(2, 0x01, b"\x02\x00") + encode(Hello()))
    with pytest.raises(UnsupportedVersion, match=r"frame\.version: got 2; allowed: 1"):
        decoder.next()
    assert decoder.next() == Hello()  # the stream goes on after the bad frame


def test_an_unknown_type_is_refused_by_name() -> None:
    decoder = Decoder()
    decoder.feed(frame_of(1, 0x7F, b""))
    with pytest.raises(UnknownMessage, match=r"frame\.type: got '0x7f'; allowed: 0x01, 0x02"):
        decoder.next()


def test_a_wrong_payload_length_is_refused() -> None:
    decoder = Decoder()
    decoder.feed(frame_of(1, 0x82, b"\x00" * 5))
    with pytest.raises(FrameError, match=r"frame\.length: got 5"):
        decoder.next()


def test_an_unknown_command_is_refused() -> None:
    decoder = Decoder()
    decoder.feed(frame_of(1, 0x03, b"\x09"))
    with pytest.raises(FrameError, match=r"command\.action: got 9; allowed: 1 \(ZERO\)"):
        decoder.next()


def test_out_of_range_fields_are_refused_on_encoding() -> None:
    with pytest.raises(FrameError, match=r"voltage\.seq: got -1; allowed: an integer from 0"):
        encode(Voltage(-1, 0.0))
    with pytest.raises(FrameError, match=r"refusal\.reason \(UTF-8 bytes\): got 300"):
        encode(Refusal("x" * 300))


def test_garbage_before_a_frame_is_reported_then_skipped() -> None:
    decoder = Decoder()
    decoder.feed(b"\x00\x01" + encode(Command(Action.STOP)))
    with pytest.raises(FrameError, match=r"frame\.magic"):
        decoder.next()
    assert decoder.next() == Command(Action.STOP)
