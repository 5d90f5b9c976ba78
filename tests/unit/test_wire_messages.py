"""Every stream message the server sends is built from, or checked against, the wire
models: renaming a field of a message or narrowing a state in the schema fails here."""

from __future__ import annotations

import msgpack
import numpy as np
from pydantic import TypeAdapter

from elab.api import schemas as s
from elab.api.frames import MsgpackCodec, encode_frames
from elab.lifecycle import RunState

SERVER = TypeAdapter(s.ServerMessage)
CODEC = MsgpackCodec()


def test_status_of_every_run_state_is_a_status_message() -> None:
    for state in RunState:
        for error in (None, "diverged at t = 1 s"):
            msg = SERVER.validate_python(msgpack.unpackb(CODEC.status(state.value, 42, error)))
            assert isinstance(msg, s.Status) and (msg.state, msg.k, msg.error) == (state, 42, error)


def test_skipped_and_params_are_their_messages() -> None:
    skipped = SERVER.validate_python(msgpack.unpackb(CODEC.skipped(3, 9)))
    assert isinstance(skipped, s.Skipped) and (skipped.from_seq, skipped.to_seq) == (3, 9)
    params = {"controller": {"kind": "pid", "Kp": 2.0}}
    notice = SERVER.validate_python(msgpack.unpackb(CODEC.params(120, 0.12, params)))
    assert isinstance(notice, s.ParamsNotice) and notice.params == params


def test_frames_filled_from_a_template_are_frame_messages() -> None:
    names = ("r", "u", "theta")
    data = np.arange(2 * 20 * 3, dtype=np.float64).reshape(2, 20, 3)
    for payload, k0 in zip(
        encode_frames(names, 20, np.array([0, 2**40]), data), [0, 2**40], strict=True
    ):
        frame = SERVER.validate_python(msgpack.unpackb(payload))
        assert isinstance(frame, s.Frame) and (frame.seq, frame.k0, frame.n) == (k0 // 20, k0, 20)
        assert list(frame.columns) == list(names)
