"""A real Redis server for the tests: Debian's ``redis-server``, on a free loopback port,
in a temporary directory, nothing saved to disk; ``url()`` gives each caller a database
number of its own (up to 10,000), so that the test servers sharing it never see each
other's engines or streams."""

from __future__ import annotations

import itertools
import shutil
import subprocess
import tempfile
import time
from pathlib import Path

import redis

from tests.postgres import _free_port

DATABASES = 10_000


def available() -> bool:
    return shutil.which("redis-server") is not None


class RedisServer:
    """``start()``, then ``url()`` for a fresh database; ``stop()`` ends it."""

    def __init__(self) -> None:
        if not available():
            raise RuntimeError("Redis is not installed: `make test-debs` installs redis-server")
        self.root = Path(tempfile.mkdtemp(prefix="elab-redis-"))
        self.port = _free_port()
        self._numbers = itertools.count(0)
        self.proc: subprocess.Popen[bytes] | None = None

    def start(self) -> None:
        self.proc = subprocess.Popen(
            ["redis-server", "--port", str(self.port), "--bind", "127.0.0.1", "--save", "",
             "--appendonly", "no", "--databases", str(DATABASES), "--dir", str(self.root),
             "--logfile", str(self.root / "redis.log")],
            stdout=subprocess.DEVNULL,
        )  # fmt: skip
        client = redis.Redis(port=self.port)
        deadline = time.monotonic() + 60
        while True:
            try:
                client.ping()
                break
            except redis.ConnectionError:
                if self.proc.poll() is not None or time.monotonic() > deadline:
                    raise RuntimeError((self.root / "redis.log").read_text()[-2000:]) from None
                time.sleep(0.05)
        client.close()

    def url(self) -> str:
        """A URL on a database nobody else uses."""
        return f"redis://127.0.0.1:{self.port}/{next(self._numbers) % DATABASES}"

    def kill9(self) -> None:
        """``kill -9``: everything it held is gone (nothing is saved)."""
        assert self.proc is not None
        self.proc.kill()
        self.proc.wait()

    def stop(self) -> None:
        if self.proc is not None and self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait()
        shutil.rmtree(self.root, ignore_errors=True)
