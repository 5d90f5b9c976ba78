"""The emulated rig a server starts for itself (``ELAB_RIG=emulator``, what ``make run``
does): ``elab rig-emulator`` as a child process on a free loopback port, so that a
newcomer can try the whole rig flow without hardware. Everything the lab shows about it
says *emulated* (the rig's identity says so on the wire)."""

from __future__ import annotations

import contextlib
import logging
import signal
import subprocess
import sys

from elab.errors import ElabError

log = logging.getLogger(__name__)


class EmulatorProcess:
    """Start with :meth:`start` (its ``host:port``), end with :meth:`close`."""

    def __init__(self, rig_seed: int, watchdog_samples: int = 5) -> None:
        self.rig_seed = rig_seed
        self.watchdog_samples = watchdog_samples
        self.proc: subprocess.Popen[str] | None = None

    def start(self, timeout: float = 60.0) -> str:
        cmd = [sys.executable, "-m", "elab.cli", "rig-emulator", "--port", "0"]
        self.proc = subprocess.Popen(
            [
                *cmd,
                "--rig-seed",
                str(self.rig_seed),
                "--watchdog-samples",
                str(self.watchdog_samples),
            ],
            stdout=subprocess.PIPE,
            stdin=subprocess.DEVNULL,
            text=True,
            start_new_session=True,  # a Ctrl-C reaches the server, which ends it in order
        )
        assert self.proc.stdout is not None
        line = self.proc.stdout.readline()  # "listening on HOST:PORT", or "" if it died
        if not line.startswith("listening on "):
            self.close()
            raise ElabError(f"the rig emulator did not start (it said {line!r})")
        return line.split()[-1]

    def close(self) -> None:
        proc, self.proc = self.proc, None
        if proc is None or proc.poll() is not None:
            return
        proc.send_signal(signal.SIGTERM)
        try:
            proc.wait(10)
        except subprocess.TimeoutExpired:
            log.error("the rig emulator did not stop in 10 s; killing it")
            proc.kill()
            proc.wait()
        with contextlib.suppress(OSError):
            if proc.stdout is not None:
                proc.stdout.close()
