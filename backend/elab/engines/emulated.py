"""The emulated rig a server starts for itself (``ELAB_RIG=emulator``, what ``make run``
does): ``elab rig-emulator`` as a child process on a free loopback port, so that a
newcomer can try the whole rig flow without hardware. Everything the lab shows about it
says *emulated* (the rig's identity says so on the wire). One that dies is started again
on the same port (:meth:`EmulatorProcess.keep`), as a power-cycled board would come back;
the rig engine reconnects by itself."""

from __future__ import annotations

import asyncio
import contextlib
import logging
import signal
import subprocess
import sys

from elab.errors import ElabError

log = logging.getLogger(__name__)


class EmulatorProcess:
    """Start with :meth:`start` (its ``host:port``), end with :meth:`close`."""

    def __init__(self, rig_seed: int, watchdog_samples: int = 5, realtime: int = 0) -> None:
        self.rig_seed = rig_seed
        self.watchdog_samples = watchdog_samples
        self.realtime = realtime  # its clock's SCHED_FIFO priority, as a board's own
        self.proc: subprocess.Popen[str] | None = None
        self.port = 0  # chosen by the first start, kept by later ones
        self.restarts = 0

    def start(self) -> str:
        """Start it; its ``host:port``."""
        cmd = [sys.executable, "-m", "elab.cli", "rig-emulator", "--port", str(self.port)]
        cmd += ["--realtime", str(self.realtime), "--exit-with-parent"]
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
        address = line.split()[-1]
        self.port = int(address.rpartition(":")[2])
        return address

    async def keep(self, every: float = 1.0) -> None:
        """Start it again whenever it has died (until cancelled)."""
        while True:
            await asyncio.sleep(every)
            proc = self.proc
            if proc is None or proc.poll() is None:
                continue
            log.error("the rig emulator ended (exit status %s); starting it again", proc.returncode)
            try:
                await asyncio.to_thread(self.start)
                self.restarts += 1
            except (ElabError, OSError) as exc:
                log.error("the rig emulator did not start again: %s", exc)

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
