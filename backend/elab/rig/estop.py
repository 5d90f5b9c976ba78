"""The emergency stop's own path to the rig engine: one datagram on a local socket.

The web process forwards every engine command over one ordered pipe, and a web process
that is stopped (``SIGSTOP``), swapping or stuck forwards nothing. An emergency stop
must not wait for it: the rig engine listens on a Unix datagram socket of its own, and
anything on the machine (the web process's e-stop endpoint, ``elab rig-estop``, an
operator's script) sends one datagram to it. The socket lives in Linux's abstract
namespace, named after the lab's data directory, so the web process, the engine and the
CLI find it from ``ELAB_DATA`` alone and no file is left behind; any local process may
send it, and all it can do is stop the rig.

A datagram is ``estop <who>`` (UTF-8, at most :data:`MAX_DATAGRAM` bytes); the engine
answers nothing (a stop that waits for an answer is a stop that can hang).
"""

from __future__ import annotations

import contextlib
import hashlib
import socket
import threading
from collections.abc import Callable
from pathlib import Path

from elab.errors import Unavailable

MAX_DATAGRAM = 256
PREFIX = b"estop "


def estop_address(data_dir: Path) -> str:
    """The abstract socket name of the rig engine serving the lab whose data is in
    ``data_dir`` (one rig per lab)."""
    digest = hashlib.sha256(str(data_dir.resolve()).encode()).hexdigest()[:20]
    return "\0elab-rig-estop-" + digest


def send_estop(address: str, who: str) -> None:
    """Send the emergency stop; :class:`Unavailable` if no rig engine listens."""
    datagram = PREFIX + who.encode("utf-8", "replace")[: MAX_DATAGRAM - len(PREFIX)]
    with socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM) as sock:
        # a listener that stopped reading (its engine stopped with SIGSTOP) and whose
        # buffer is full would block the send for ever
        sock.settimeout(1.0)
        try:
            sock.sendto(datagram, address)
        except (ConnectionRefusedError, FileNotFoundError, BrokenPipeError) as exc:
            # (EPIPE: the listener's socket was closing as the datagram went)
            raise Unavailable(
                f"no rig engine listens for emergency stops here ({exc.strerror})",
                retry_after=1.0,
            ) from None
        except TimeoutError:
            raise Unavailable(
                "the rig engine takes no emergency stops now (its socket is full: the engine "
                "is stalled); its watchdog cuts the motor when the loop stops answering",
                retry_after=1.0,
            ) from None


class EStopListener:
    """A thread that calls ``on_stop(who)`` for every e-stop datagram to ``address``."""

    def __init__(self, address: str, on_stop: Callable[[str], None]) -> None:
        self._sock = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
        self._sock.bind(address)  # OSError (address in use): another engine has this rig
        self._on_stop = on_stop
        self._thread = threading.Thread(target=self._listen, name="elab-rig-estop", daemon=True)
        self._closed = False

    def start(self) -> None:
        self._thread.start()

    def _listen(self) -> None:
        while not self._closed:
            try:
                data = self._sock.recv(MAX_DATAGRAM)
            except OSError:
                return
            if data.startswith(PREFIX):
                self._on_stop(data[len(PREFIX) :].decode("utf-8", "replace") or "someone")

    def close(self) -> None:
        self._closed = True
        with contextlib.suppress(OSError):
            self._sock.shutdown(socket.SHUT_RDWR)
        self._sock.close()
