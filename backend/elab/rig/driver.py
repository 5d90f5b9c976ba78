"""How a host loop talks to a rig: the :class:`Driver` protocol and its TCP implementation.

The rig is the clock: :meth:`Driver.read` blocks until the rig's next sample, and the
host answers each with :meth:`Driver.write`. :class:`TcpDriver` speaks E-Lab's byte
protocol (docs/rig-protocol.md) to a rig or to ``elab rig-emulator``;
:class:`elab.rig.quanser.QuanserDriver` drives a Quanser HIL board directly.
"""

from __future__ import annotations

import contextlib
import math
import socket
import time
from dataclasses import dataclass
from typing import Protocol, assert_never

from elab.errors import Conflict, Unavailable
from elab.rig import messages as m
from elab.rig.protocol import Decoder, FrameError, encode


class RigTimeout(Unavailable):
    """The rig sent nothing for longer than the host waits: it is stopped or unplugged."""


class RigDisconnected(Unavailable):
    """The connection to the rig is gone (closed, reset or never made)."""


@dataclass(frozen=True)
class RigSample:
    """One calibrated sample: θ and α in rad, the status word, and when it arrived
    (``received_ns``, host ``time.monotonic_ns()``)."""

    seq: int
    theta: float
    alpha: float
    status: m.Status
    received_ns: int


class Driver(Protocol):
    """A rig as a host loop sees it. Call :meth:`connect` once, then per sample
    :meth:`read` and :meth:`write`; :meth:`close` leaves the motor at 0 V."""

    def connect(self) -> m.RigIdentity: ...

    def read(self, timeout: float) -> RigSample: ...

    def write(self, seq: int, u: float) -> None: ...

    def command(self, action: m.Action) -> None: ...

    def close(self) -> None: ...


def calibrate(sample: m.Sample, identity: m.RigIdentity, received_ns: int) -> RigSample:
    """The sample in rad through the rig's calibration (:class:`~elab.rig.messages.RigIdentity`)."""
    theta = sample.encoder_counts * 2 * math.pi / identity.counts_per_rev
    alpha = (sample.gauge_reading - identity.gauge_offset) * identity.gauge_rad_per_count
    return RigSample(sample.seq, theta, alpha, sample.status, received_ns)


class TcpDriver:
    """A rig behind E-Lab's byte protocol on TCP (Nagle off: one frame per packet)."""

    def __init__(self, host: str, port: int, connect_timeout: float = 2.0) -> None:
        self.host, self.port = host, port
        self.connect_timeout = connect_timeout
        self._sock: socket.socket | None = None
        self._decoder = Decoder()
        self._identity: m.RigIdentity | None = None

    @property
    def identity(self) -> m.RigIdentity:
        if self._identity is None:
            raise RigDisconnected(f"rig at {self._where}: not connected; call connect() first")
        return self._identity

    @property
    def _where(self) -> str:
        return f"{self.host}:{self.port}"

    def connect(self) -> m.RigIdentity:
        """Open the connection and say HELLO; the rig's identity, or a typed error."""
        try:
            self._sock = socket.create_connection((self.host, self.port), self.connect_timeout)
        except OSError as err:
            raise RigDisconnected(f"rig at {self._where}: cannot connect ({err})") from None
        self._sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        try:
            return self._greet()
        except BaseException:
            self._sock.close()
            self._sock = None
            raise

    def _greet(self) -> m.RigIdentity:
        self._send(m.Hello())
        message = self._receive(time.monotonic() + self.connect_timeout)
        match message:
            case m.RigIdentity():
                self._identity = message
                return message
            case m.Refusal(reason):
                raise Conflict(f"rig at {self._where} refused the host: {reason}")
            case m.Sample() | m.Hello() | m.Voltage() | m.Command():
                raise FrameError("message", type(message).__name__, "the rig's identity")
            case _:
                assert_never(message)

    def read(self, timeout: float) -> RigSample:
        """The rig's next sample, waiting at most ``timeout`` s for it."""
        identity = self.identity
        message = self._receive(time.monotonic() + timeout)
        match message:
            case m.Sample():
                return calibrate(message, identity, time.monotonic_ns())
            case m.Refusal(reason):
                raise Conflict(f"rig at {self._where} refused the host: {reason}")
            case m.RigIdentity() | m.Hello() | m.Voltage() | m.Command():
                raise FrameError("message", type(message).__name__, "a sample")
            case _:
                assert_never(message)

    def write(self, seq: int, u: float) -> None:
        """Answer sample ``seq`` with the voltage ``u`` (V)."""
        self._send(m.Voltage(seq, u))

    def command(self, action: m.Action) -> None:
        self._send(m.Command(action))

    def close(self) -> None:
        """STOP the motor (best effort) and close; the rig also stops on a lost host."""
        if self._sock is None:
            return
        with contextlib.suppress(OSError):  # a rig already gone has stopped on its own
            self._sock.sendall(encode(m.Command(m.Action.STOP)))
        self._sock.close()
        self._sock = None
        self._identity = None

    def _send(self, message: m.Message) -> None:
        if self._sock is None:
            raise RigDisconnected(f"rig at {self._where}: not connected; call connect() first")
        try:
            self._sock.sendall(encode(message))
        except OSError as err:
            raise RigDisconnected(f"rig at {self._where}: connection lost ({err})") from None

    def _receive(self, deadline: float) -> m.Message:
        if self._sock is None:
            raise RigDisconnected(f"rig at {self._where}: not connected; call connect() first")
        while (message := self._decoder.next()) is None:
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                raise RigTimeout(f"rig at {self._where}: silent; nothing arrived in time")
            self._sock.settimeout(remaining)
            try:
                data = self._sock.recv(65536)
            except TimeoutError:
                raise RigTimeout(
                    f"rig at {self._where}: silent for {remaining:.3f} s; is it running?"
                ) from None
            except OSError as err:
                raise RigDisconnected(f"rig at {self._where}: connection lost ({err})") from None
            if not data:
                raise RigDisconnected(f"rig at {self._where}: the rig closed the connection")
            self._decoder.feed(data)
        return message
