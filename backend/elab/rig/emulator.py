"""``elab rig-emulator``: a flexible-link rig behind the byte protocol, in its own process.

It behaves like hardware, not like the textbook: the nonlinear link with this rig's
hidden true parameters (:func:`~elab.rig.hardware.draw_rig_parameters`), encoder
quantisation, gauge noise and offset, a ±10 V amplifier, its own 1 kHz clock and its own
watchdog. One host at a time; a second is sent a :class:`Refusal` and closed. When the
host leaves the motor gets 0 V.

The clock: sample ``k`` is due at ``start + k·Ts`` (``time.monotonic_ns``); the loop
waits in ``select`` on its sockets until then, so it is best effort on a general-purpose
kernel. A sample sent more than ``Ts/2`` late carries :attr:`Status.LATE`; when the
emulator falls more than one period behind it integrates the missed periods and sends
only the newest sample (the host sees a gap in ``seq``, as with a rig that drops
samples). Lateness statistics are logged when it stops.

A voltage takes effect at the next 0.25 ms substep after it arrives, as an amplifier
fed mid-period would.
"""

from __future__ import annotations

import contextlib
import logging
import math
import select
import socket
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import assert_never

from elab.rig.hardware import (
    COUNTS_PER_REV,
    GAUGE_RAD_PER_COUNT,
    SUBSTEPS,
    Amplifier,
    Link,
    draw_rig_parameters,
)
from elab.rig.lateness import Lateness
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
from elab.rig.protocol import Decoder, FrameError, encode

log = logging.getLogger("elab.rig.emulator")

TS_NS = 1_000_000  # sample period, ns
MAX_BACKLOG = 64 * 1024  # bytes unsent to a host that does not read before it is dropped


@dataclass(frozen=True)
class EmulatorConfig:
    """Where the emulator listens, which rig it is, and its watchdog (samples)."""

    host: str = "127.0.0.1"
    port: int = 0
    rig_seed: int = 0
    watchdog_samples: int = 5


class Host:
    """The connected host: its socket, decoder, unsent bytes, and whether it said HELLO."""

    def __init__(self, sock: socket.socket) -> None:
        sock.setblocking(False)
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self.sock = sock
        self.decoder = Decoder()
        self.backlog = bytearray()
        self.greeted = False
        self.seq = 0

    def send(self, message: Message) -> bool:
        """Queue and send what the socket takes; False when the host is not reading."""
        self.backlog += encode(message)
        try:
            sent = self.sock.send(self.backlog)
        except BlockingIOError:
            sent = 0
        except OSError:  # gone: the next read sees it and drops the host
            return True
        del self.backlog[:sent]
        return len(self.backlog) <= MAX_BACKLOG


class Emulator:
    """The rig: bind in the constructor (see :attr:`address`), then :meth:`serve`."""

    def __init__(self, config: EmulatorConfig) -> None:
        self.config = config
        self.params = draw_rig_parameters(config.rig_seed)
        self.link = Link(self.params, TS_NS * 1e-9, noise_seed=config.rig_seed)
        self.amplifier = Amplifier(self.params.plant.u_sat, config.watchdog_samples)
        self.identity = RigIdentity(
            rig_id=f"emulator-{config.rig_seed}",
            firmware="elab-rig-emulator 1",
            emulated=True,
            counts_per_rev=COUNTS_PER_REV,
            gauge_rad_per_count=GAUGE_RAD_PER_COUNT,
            gauge_offset=0,
            Ts=TS_NS * 1e-9,
            watchdog_samples=config.watchdog_samples,
        )
        self.listener = socket.create_server((config.host, config.port))
        self.listener.setblocking(False)
        self.host: Host | None = None
        self.lateness = Lateness(TS_NS)
        self._u = [0.0] * SUBSTEPS  # the motor voltage on each substep of this period
        self._period_start = 0

    @property
    def address(self) -> tuple[str, int]:
        host, port = self.listener.getsockname()[:2]
        return str(host), int(port)

    def serve(self, stopping: Callable[[], bool]) -> None:
        """Run the clock until ``stopping()``; then 0 V, close, and log the lateness."""
        start = time.monotonic_ns()
        k = 0
        while not stopping():
            due = start + (k + 1) * TS_NS
            self._wait(due, stopping)
            late = time.monotonic_ns() - due
            missed = max(0, late // TS_NS)
            for _ in range(missed):  # the periods the emulator slept through
                self._advance()
            k += missed + 1
            self._advance()
            self.lateness.record(late, missed)
            self._send_sample(skipped=missed, late=late > TS_NS // 2)
        self._drop_host("the emulator stopped")
        self.listener.close()
        log.info("stopped; %s", self.lateness.summary())

    def _wait(self, due: int, stopping: Callable[[], bool]) -> None:
        while (remaining := due - time.monotonic_ns()) > 0 and not stopping():
            sockets = [self.listener] + ([self.host.sock] if self.host else [])
            readable, _, _ = select.select(sockets, [], [], remaining * 1e-9)
            # the host first: a host that left and a new one can arrive together
            for sock in sorted(readable, key=lambda s: s is self.listener):
                if sock is self.listener:
                    self._accept()
                else:
                    self._receive()

    def _advance(self) -> None:
        self.link.advance(tuple(self._u))
        self._u = [self.amplifier.output] * SUBSTEPS
        self._period_start = time.monotonic_ns()

    def _send_sample(self, skipped: int, late: bool) -> None:
        counts, gauge = self.link.measure()
        host = self.host
        if host is None or not host.greeted:
            return
        host.seq = (host.seq + skipped) % 2**32
        status = self.amplifier.status | (Status.LATE if late or skipped else 0)
        if not host.send(Sample(host.seq, counts, gauge, status)):
            self._drop_host(f"the host has not read {MAX_BACKLOG} bytes of samples")
            return
        host.seq = (host.seq + 1) % 2**32
        self.amplifier.sample_sent()
        self._output_changed()  # the watchdog may have tripped

    def _output_changed(self) -> None:
        """The amplifier's output now holds from the next substep of this period on."""
        elapsed = time.monotonic_ns() - self._period_start
        j = min(SUBSTEPS, math.ceil(elapsed * SUBSTEPS / TS_NS))
        self._u[j:] = [self.amplifier.output] * (SUBSTEPS - j)

    def _accept(self) -> None:
        try:
            sock, peer = self.listener.accept()
        except BlockingIOError:
            return
        if self.host is not None:
            log.warning("refused %s: a host is connected", peer)
            sock.setblocking(True)
            sock.settimeout(0.1)
            with contextlib.suppress(OSError):  # it left already
                sock.sendall(encode(Refusal("rig busy: another host is connected")))
            sock.close()
            return
        log.info("host %s connected", peer)
        self.host = Host(sock)

    def _receive(self) -> None:
        assert self.host is not None
        while True:  # to the end of what arrived: a close after data is seen now
            try:
                data = self.host.sock.recv(65536)
            except BlockingIOError:
                break
            except OSError as err:
                self._drop_host(f"connection lost ({err})")
                return
            if not data:
                self._drop_host("the host closed the connection")
                return
            self.host.decoder.feed(data)
        try:
            while self.host is not None and (message := self.host.decoder.next()) is not None:
                self._handle(message)
        except FrameError as err:
            self._refuse(f"protocol error: {err}")

    def _handle(self, message: Message) -> None:
        host = self.host
        assert host is not None
        match message:
            case Hello(version) if version != PROTOCOL_VERSION:
                self._refuse(f"protocol version {version}; this rig speaks {PROTOCOL_VERSION}")
            case Hello():
                host.greeted = True
                host.send(self.identity)
            case Voltage() | Command() if not host.greeted:
                self._refuse("HELLO first")
            case Voltage(_, u):
                self.amplifier.voltage(u)
                self._output_changed()
            case Command(action):
                if action is Action.ZERO:
                    self.link.zero()
                self.amplifier.command(action)
                self._output_changed()
                log.info("host command %s", action.name)
            case RigIdentity() | Sample() | Refusal():
                self._refuse(f"a host does not send {type(message).__name__}")
            case _:
                assert_never(message)

    def _refuse(self, reason: str) -> None:
        if self.host is not None:
            self.host.send(Refusal(reason))
        self._drop_host(reason)

    def _drop_host(self, reason: str) -> None:
        """Forget the host and put the motor at 0 V, disabled."""
        if self.host is None:
            return
        log.info("host gone (%s): motor at 0 V, disabled", reason)
        self.host.sock.close()
        self.host = None
        self.amplifier.host_left()
        self._output_changed()
