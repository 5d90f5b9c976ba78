"""A real PostgreSQL server for the tests: Debian's ``postgresql`` package, a cluster of its
own in a temporary directory (``initdb`` as the unprivileged ``postgres`` user when the
tests run as root, as PostgreSQL requires), listening on a free loopback port, and a fresh
schema per test (``schema()``: a URL whose ``search_path`` is that schema alone, so every
test starts from an empty database without the cost of creating one).

For the tests durability is off (``fsync``, ``synchronous_commit``): they check what the
store keeps across connections and processes, not across power cuts. ``durable=True`` (the
benchmark) keeps ``fsync`` and full-page writes on, with ``synchronous_commit = off``."""

from __future__ import annotations

import os
import shutil
import socket
import subprocess
import tempfile
import uuid
from pathlib import Path

import psycopg

_BIN = sorted(Path("/usr/lib/postgresql").glob("*/bin"), key=lambda p: int(p.parent.name))


def available() -> bool:
    return bool(_BIN)


class PostgresServer:
    """``start()``, then ``url`` (the database ``elab``), ``schema()`` for a fresh one;
    ``stop()`` removes the cluster."""

    def __init__(self, *, durable: bool = False) -> None:
        if not _BIN:
            raise RuntimeError("PostgreSQL is not installed: `make test-debs` installs it")
        self.bin = _BIN[-1]
        self.root = Path(tempfile.mkdtemp(prefix="elab-pg-"))
        self.port = _free_port()
        self.url = f"postgresql://postgres@127.0.0.1:{self.port}/elab"
        self.durable = durable

    def _as_owner(self, *cmd: str) -> list[str]:
        return ["runuser", "-u", "postgres", "--", *cmd] if os.geteuid() == 0 else list(cmd)

    def start(self) -> None:
        if os.geteuid() == 0:
            shutil.chown(self.root, "postgres", "postgres")
        data, log = self.root / "data", self.root / "log"
        run = {"check": True, "capture_output": True, "timeout": 120}
        subprocess.run(
            self._as_owner(
                str(self.bin / "initdb"), "-D", str(data), "-U", "postgres", "--auth=trust",
                "--encoding=UTF8", *([] if self.durable else ["--no-sync"]),
            ),
            **run,
        )  # fmt: skip
        unsafe = "" if self.durable else "-c fsync=off -c full_page_writes=off "
        options = (
            f"-p {self.port} -k {self.root} -c listen_addresses=127.0.0.1 {unsafe}"
            "-c synchronous_commit=off -c max_connections=300"
        )
        subprocess.run(
            self._as_owner(
                str(self.bin / "pg_ctl"), "-D", str(data), "-l", str(log), "-o", options,
                "-w", "-t", "120", "start",
            ),
            **run,
        )  # fmt: skip
        with psycopg.connect(self.url.rsplit("/", 1)[0] + "/postgres", autocommit=True) as c:
            c.execute("CREATE DATABASE elab")

    def schema(self) -> str:
        """A URL on a new, empty schema of ``elab`` (its only ``search_path``)."""
        name = "t_" + uuid.uuid4().hex[:12]
        with psycopg.connect(self.url, autocommit=True) as c:
            c.execute(f"CREATE SCHEMA {name}")
        return f"{self.url}?options=-csearch_path%3D{name}"

    def restart(self) -> None:
        """Stop (fast: every session ended) and start again on the same port and data."""
        subprocess.run(
            self._as_owner(str(self.bin / "pg_ctl"), "-D", str(self.root / "data"), "-l",
                           str(self.root / "log"), "-m", "fast", "-w", "-t", "120", "restart"),
            check=True,
            capture_output=True,
            timeout=180,
        )  # fmt: skip

    def stop(self) -> None:
        subprocess.run(
            self._as_owner(str(self.bin / "pg_ctl"), "-D", str(self.root / "data"), "-m",
                           "immediate", "stop"),
            capture_output=True,
            timeout=60,
        )  # fmt: skip
        shutil.rmtree(self.root, ignore_errors=True)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])
