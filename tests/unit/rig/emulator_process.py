"""``elab rig-emulator`` as a real process for the tests, and a host that answers it."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

from elab.rig.driver import RigSample, TcpDriver

BACKEND = Path(__file__).resolve().parents[3] / "backend"


@dataclass(frozen=True)
class Running:
    proc: subprocess.Popen[str]
    host: str
    port: int

    def driver(self) -> TcpDriver:
        return TcpDriver(self.host, self.port)


def environment() -> dict[str, str]:
    path = os.environ.get("PYTHONPATH", "")
    return {**os.environ, "PYTHONPATH": f"{BACKEND}{os.pathsep}{path}" if path else str(BACKEND)}


@contextmanager
def running_emulator(*args: str) -> Iterator[Running]:
    """Start the emulator on a free port (it prints ``listening on HOST:PORT`` first);
    SIGTERM it afterwards and expect a clean exit."""
    proc = subprocess.Popen(
        [sys.executable, "-m", "elab.cli", "rig-emulator", "--port", "0", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=environment(),
    )
    try:
        assert proc.stdout is not None
        line = proc.stdout.readline()  # blocks until it listens; a crash gives ""
        assert line.startswith("listening on "), proc.communicate(timeout=10)
        host, port = line.split()[-1].rsplit(":", 1)
        yield Running(proc, host, int(port))
    finally:
        if proc.poll() is None:
            proc.send_signal(signal.SIGTERM)
        try:
            proc.communicate(timeout=10)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.communicate()
            raise


def drive(driver: TcpDriver, u: float, n: int) -> list[RigSample]:
    """Answer ``n`` samples with the voltage ``u``."""
    samples = []
    for _ in range(n):
        s = driver.read(timeout=2.0)
        driver.write(s.seq, u)
        samples.append(s)
    return samples


def listen(driver: TcpDriver, n: int) -> list[RigSample]:
    """Read ``n`` samples without answering them."""
    return [driver.read(timeout=2.0) for _ in range(n)]
