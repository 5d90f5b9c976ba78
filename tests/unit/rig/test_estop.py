"""The emergency stop's datagram (elab/rig/estop.py): sent, or a clear 503 when nobody
can take it, never a hang or a crash."""

from __future__ import annotations

import os
import socket

import pytest

from elab.errors import Unavailable
from elab.rig.estop import PREFIX, send_estop


def _address() -> str:
    return f"\0elab-test-estop-{os.getpid()}-{os.urandom(4).hex()}"


def test_a_listener_gets_the_stop_with_who_pressed_it() -> None:
    address = _address()
    with socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM) as listener:
        listener.bind(address)
        send_estop(address, "a tester")
        assert listener.recv(1024) == PREFIX + b"a tester"


def test_nobody_listening_is_503() -> None:
    with pytest.raises(Unavailable, match="no rig engine listens"):
        send_estop(_address(), "a tester")


def test_a_listener_that_stopped_reading_is_503_within_a_second_not_a_hang() -> None:
    """An engine stopped with SIGSTOP: its socket's buffer fills, and a blocking send
    would wait for ever."""
    address = _address()
    with socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM) as listener:
        listener.bind(address)
        with pytest.raises(Unavailable, match="takes no emergency stops now"):
            for _ in range(100_000):  # the buffer holds a few hundred
                send_estop(address, "a tester")
