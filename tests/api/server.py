"""A real ``elab serve`` on loopback in its own process, and a websocket watcher."""

from __future__ import annotations

import asyncio
import copy
import os
import signal
import socket
import ssl
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TypeVar

import httpx
import msgpack
import numpy as np
import psycopg
from websockets.asyncio.client import ClientConnection, connect

ELAB = str(Path(sys.executable).parent / "elab")
T = TypeVar("T")
#: clients drop a connection idle for 2 s, before the server's keep-alive (uvicorn: 5 s)
#: closes it: a request sent just as the server closes its connection is lost ("Server
#: disconnected without sending a response"; seen on a loaded machine)
KEEP_ALIVE = httpx.Limits(keepalive_expiry=2.0)
#: the TLS context of the test clients, made once. The servers here speak plain HTTP on
#: loopback, yet httpx loads certifi's bundle into a new context for every client and every
#: bare ``httpx.get``: 15-35 ms of CPU each, which a poll every 50 ms made most of a core.
#: Pass it (``verify=TLS``) wherever a test makes clients or requests in a loop.
TLS = ssl.create_default_context()
#: s a server may take to become ready: about 4 s on a quiet two-core machine, 35 s seen
#: beside three other test suites (load average 10); a cap, not an expectation
START_CAP = 180
#: put first on every test server's path: records heavy imports on its event loop
LOOP_AUDIT = str(Path(__file__).parent / "loopaudit")


#: set by tests/conftest.py for ``--store postgres``: a new database URL for each server
DATABASES: Callable[[], str] | None = None
#: set by tests/conftest.py for ``--engines broker``: a new broker URL for each server, whose
#: simulation engines are then processes of their own (``elab engine``) started beside it
BROKERS: Callable[[], str] | None = None
#: engines a server on a broker has (its runs go to the least busy)
ENGINES = 2


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


class Server:
    """``elab serve`` as a subprocess: start, stop, kill -9, restart on the same data. Its
    log (the web process's and the engine's) goes to ``log_path`` beside the data (a pipe
    nobody read would fill up and stop the server)."""

    def __init__(self, data: Path, **env: str) -> None:
        self.data = data
        self.port = free_port()
        self.proc: subprocess.Popen[bytes] | None = None
        self.log_path = data.parent / f"{data.name}-server.log"
        self.loop_imports_path = data.parent / f"{data.name}-loop-imports.log"
        path = os.pathsep.join(filter(None, [LOOP_AUDIT, os.environ.get("PYTHONPATH")]))
        self.env = {
            **os.environ,
            "ELAB_DATA": str(data),
            "PYTHONPATH": path,
            "ELAB_TEST_LOOP_IMPORTS": str(self.loop_imports_path),
            **env,
        }
        if DATABASES is not None and "ELAB_DATABASE_URL" not in env:
            self.env["ELAB_DATABASE_URL"] = DATABASES()
        if BROKERS is not None and "ELAB_REDIS_URL" not in env:
            self.env["ELAB_REDIS_URL"] = BROKERS()
            # an engine killed is noticed when its heartbeats stop, not when a socket closes
            self.env.setdefault("ELAB_ENGINE_STALL", "5")
        self.engines: list[subprocess.Popen[bytes] | None] = []
        self.engine_count = ENGINES  # on a broker: the engines it starts (0: another's)
        self._keeping: threading.Thread | None = None
        self._stopping = threading.Event()
        self.log_from = 0  # where this view's part of the log starts (see visitor())
        # the identity of client(): one browser's, given by the server on first contact
        self.cookies = httpx.Cookies()

    @property
    def log(self) -> str:
        """What the server has logged so far (since this view was made)."""
        if not self.log_path.exists():
            return ""
        with self.log_path.open("rb") as f:
            f.seek(self.log_from)
            return f.read().decode(errors="replace")

    def visitor(self) -> Server:
        """The same running server seen by a new visitor: its own identity for
        ``client()`` and its own part of the log, so that tests sharing one server do not
        see each other's runs, budgets or log lines. Only the server's owner stops it."""
        view = copy.copy(self)
        view.log_from = self.log_path.stat().st_size if self.log_path.exists() else 0
        view.cookies = httpx.Cookies()
        r = httpx.get(self.url + "/api/v1/me", timeout=30, cookies=view.cookies, verify=TLS)
        r.raise_for_status()
        view.cookies.update(r.cookies)
        return view

    @property
    def url(self) -> str:
        return f"http://127.0.0.1:{self.port}"

    @property
    def ws_url(self) -> str:
        return f"ws://127.0.0.1:{self.port}"

    def start(self) -> Server:
        self.log_path.parent.mkdir(parents=True, exist_ok=True)
        with self.log_path.open("ab") as log:
            self.proc = subprocess.Popen(
                [ELAB, "serve", "--port", str(self.port)],
                env=self.env,
                stdout=subprocess.DEVNULL,
                stderr=log,
            )
        deadline = time.monotonic() + START_CAP
        while time.monotonic() < deadline:
            if self.proc.poll() is not None:
                raise RuntimeError(f"server exited: {self.log[-4000:]}")
            try:
                r = httpx.get(self.url + "/api/v1/me", timeout=1, cookies=self.cookies, verify=TLS)
                r.raise_for_status()
                self.cookies.update(r.cookies)
                if self.on_broker and self.engine_count and not self.engines:
                    self._start_engines()  # the store is migrated by now
                # ready: the identification workers have imported what their jobs need,
                # and the engines have started (in the background since the web process
                # serves at once: its health says 503 until then)
                st = self.status()
                engines = [st["engine"], *([st["rig"]["engine"]] if st.get("rig") else [])]
                started = all(e["up"] or e["problem"] not in (None, "starting") for e in engines)
                if self.on_broker:  # and every engine of its own is up
                    started &= sum(e["up"] for e in st["engines"]) >= max(1, self.engine_count)
                if st["ident"]["starting"] == 0 and started:
                    return self
            except httpx.HTTPError:
                pass
            time.sleep(0.1)
        # not left running: a server that never became ready (its engine real-time, a rig
        # emulator at 1 kHz) would take the CPU from every test after this one
        self.stop()
        raise RuntimeError(f"server did not start in {START_CAP} s: {self.log[-4000:]}")

    @property
    def on_broker(self) -> bool:
        """Its simulation engines are processes of their own on a broker."""
        return "ELAB_REDIS_URL" in self.env

    def another_node(self) -> Server:
        """A second web process (not started) on this server's store, broker and data
        directory (its secret: the same visitors), with a log of its own and no engines."""
        env = {k: v for k, v in self.env.items() if k.startswith("ELAB_") and k != "ELAB_DATA"}
        node = Server(self.data, **env)
        node.log_path = self.data.parent / f"{self.data.name}-node-{node.port}.log"
        node.loop_imports_path = self.data.parent / f"{self.data.name}-node-{node.port}.imports"
        node.engine_count = 0
        return node

    def _start_engines(self) -> None:
        """``engine_count`` engines on its broker, kept running as a supervisor (systemd) would:
        one that ends is started again after half a second, until the server stops."""
        self._stopping.clear()
        self.engines = [self._engine(i) for i in range(self.engine_count)]
        self._keeping = threading.Thread(target=self._keep_engines, daemon=True)
        self._keeping.start()

    def _engine(self, i: int) -> subprocess.Popen[bytes]:
        with self.log_path.open("ab") as log:
            return subprocess.Popen(
                [ELAB, "engine", "--name", f"sim-{i}"],
                env=self.env,
                stdout=subprocess.DEVNULL,
                stderr=log,
            )

    def _keep_engines(self) -> None:
        while not self._stopping.wait(0.5):
            for i, proc in enumerate(self.engines):
                if proc is not None and proc.poll() is not None and not self._stopping.is_set():
                    self.engines[i] = self._engine(i)

    def _stop_engines(self) -> None:
        self._stopping.set()
        if self._keeping is not None:
            self._keeping.join()
        for proc in self.engines:
            if proc is not None and proc.poll() is None:
                proc.send_signal(signal.SIGTERM)
        for proc in self.engines:
            if proc is None:
                continue
            try:
                proc.wait(timeout=30)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
        self.engines = []

    def stop(self) -> None:
        """Stop the server (SIGINT, then SIGKILL after 20 s), and its engines if they are
        its own processes, and fail if its web process imported a heavy module on its event
        loop (``loopaudit/sitecustomize.py``) or its fork server started without a module
        asked for later."""
        if self.proc and self.proc.poll() is None:
            self.proc.send_signal(signal.SIGINT)
            try:
                self.proc.wait(timeout=20)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        self._stop_engines()
        self.check_audit()

    def check_audit(self) -> None:
        """Fail if the web process imported a heavy module on its event loop
        (``loopaudit/sitecustomize.py``) or its fork server started without a module asked
        for later (``api/preload.py``)."""
        stalls = self.loop_imports()
        assert not stalls, "imported on the web process's event loop:\n" + "\n".join(stalls)
        assert "the fork server started without" not in self.log, self.log[-4000:]

    def loop_imports(self) -> list[str]:
        """The heavy imports this server's web process made on its event loop."""
        if self.proc is None or not self.loop_imports_path.exists():
            return []
        mine = f"{self.proc.pid} "
        lines = self.loop_imports_path.read_text().splitlines()
        return [line for line in lines if line.startswith(mine)]

    def kill9(self, engines: bool = True) -> None:
        """``kill -9`` of the web process; engines of their own are killed with it (as a
        host's power cut would) unless ``engines`` is false (they go on, as on other hosts;
        ``start()`` then starts only a web process)."""
        assert self.proc is not None
        self.proc.send_signal(signal.SIGKILL)
        self.proc.wait()
        if engines:
            for proc in self.engines if self.on_broker else ():
                if proc is not None:
                    proc.kill()
            self._stop_engines()
        self.check_audit()  # what it did up to its end

    def client(self) -> httpx.Client:
        """A client with this test's identity (the same browser for every call; a bare
        ``httpx.get`` is a new anonymous visitor each time)."""
        return httpx.Client(
            base_url=self.url + "/api/v1",
            timeout=30,
            cookies=self.cookies,
            limits=KEEP_ALIVE,
            verify=TLS,
        )

    def stranger(self) -> httpx.Client:
        """A client with an identity of its own (another browser)."""
        return httpx.Client(
            base_url=self.url + "/api/v1", timeout=30, limits=KEEP_ALIVE, verify=TLS
        )

    @contextmanager
    def store_locked(self) -> Iterator[Callable[[], None]]:
        """Another process holding this server's store so that nobody writes to it (reads
        go on) until the function this yields is called, or the block ends: SQLite, an
        exclusive lock on the file; PostgreSQL, a session holding the tables the engine
        writes in EXCLUSIVE mode."""
        url = self.env.get("ELAB_DATABASE_URL")
        if url is None:
            from tests.unit.store.test_versions_and_faults import locked

            with locked(self.data / "elab.sqlite3") as release:
                yield release
            return
        conn = psycopg.connect(url)
        conn.execute("LOCK TABLE runs, chunks, param_changes, probe IN EXCLUSIVE MODE")

        def release() -> None:
            if not conn.closed:
                conn.rollback()
                conn.close()

        try:
            yield release
        finally:
            release()

    def status(self) -> dict[str, Any]:
        """``GET /api/v1/server``."""
        r = httpx.get(self.url + "/api/v1/server", timeout=30, verify=TLS)
        return r.json()  # type: ignore[no-any-return]

    @property
    def engine_pid(self) -> int:
        pid = self.status()["engine"]["pid"]
        assert isinstance(pid, int), "the engine is not up"
        return pid


def identity_of(client: httpx.Client | Server) -> dict[str, str]:
    """The headers that carry the identity of ``client`` (or of a server's ``client()``)
    to a websocket: its cookies (as a browser sends them) or its bearer token."""
    if isinstance(client, httpx.Client) and "authorization" in client.headers:
        return {"authorization": client.headers["authorization"]}
    jar = "; ".join(f"{k}={v}" for k, v in client.cookies.items())
    return {"cookie": jar} if jar else {}


def until(cond: Callable[[], T | None], timeout: float = 60.0, every: float = 0.05) -> T:
    """Poll ``cond`` until it returns something truthy (then that), or fail after
    ``timeout`` seconds: tests wait on state, never on the clock alone."""
    deadline = time.monotonic() + timeout
    while True:
        got = cond()
        if got:
            return got
        if time.monotonic() > deadline:
            raise AssertionError(f"not reached in {timeout} s: {cond}")
        time.sleep(every)


@dataclass
class Watcher:
    """Collects a run's stream: frames by sample index, and every other message."""

    conn: ClientConnection
    hello: dict[str, Any]
    columns: dict[int, dict[str, np.ndarray]] = field(default_factory=dict)  # k0 -> columns
    messages: list[dict[str, Any]] = field(default_factory=list)
    arrivals: list[float] = field(default_factory=list)
    last_seq: int = -1

    @classmethod
    async def open(
        cls,
        ws_url: str,
        run_id: str,
        query: str = "",
        *,
        as_: httpx.Client | Server | None = None,
        **kw: Any,
    ) -> Watcher:
        """Watch a run; ``as_``: with that client's identity (its cookies), so it may
        control the runs that client started."""
        if as_ is not None:
            kw["additional_headers"] = {**kw.get("additional_headers", {}), **identity_of(as_)}
        conn = await connect(
            f"{ws_url}/api/v1/runs/{run_id}/stream{query}",
            subprotocols=["elab.v1"],
            max_size=None,
            **kw,
        )  # type: ignore[list-item]
        hello = msgpack.unpackb(await conn.recv())
        assert hello["type"] == "hello"
        return cls(conn, hello)

    async def next(self, timeout: float = 30) -> dict[str, Any]:
        msg = msgpack.unpackb(await asyncio.wait_for(self.conn.recv(), timeout))
        if msg["type"] == "frame":
            self.columns[msg["k0"]] = {
                k: np.frombuffer(v, "<f4") for k, v in msg["columns"].items()
            }
            self.arrivals.append(time.monotonic())
            self.last_seq = msg["seq"] + max(
                0, -(-msg["n"] // self.hello["run"]["frame_samples"]) - 1
            )
        else:
            self.messages.append(msg)
        return msg  # type: ignore[no-any-return]

    async def until_status(self, states: set[str], timeout: float = 60) -> dict[str, Any]:
        deadline = time.monotonic() + timeout
        while True:
            msg = await self.next(max(0.1, deadline - time.monotonic()))
            if msg["type"] == "status" and msg["state"] in states:
                return msg

    def assemble(self, n: int) -> dict[str, np.ndarray]:
        """Every channel's samples 0..n-1 from all frames received (overlaps must agree;
        samples past n are left out); asserts none is missing."""
        names = [c["name"] for c in self.hello["run"]["channels"]]
        out = {name: np.full(n, np.nan, dtype="<f4") for name in names}
        for k0, cols in self.columns.items():
            for name, v in cols.items():
                seg = out[name][k0 : k0 + v.size]
                v = v[: seg.size]
                seen = ~np.isnan(seg)
                assert np.array_equal(seg[seen], v[seen]), f"frames disagree near sample {k0}"
                seg[:] = v
        missing = np.flatnonzero(np.isnan(out[names[0]]))
        assert missing.size == 0, f"{missing.size} samples missing, first at {missing[:5]}"
        return out

    def samples(self) -> tuple[int, dict[str, np.ndarray]]:
        """(first k, concatenated columns); asserts the frames are contiguous."""
        keys = sorted(self.columns)
        k = keys[0]
        for k0 in keys:
            assert k0 == k, f"gap or overlap at sample {k} (next frame starts at {k0})"
            k += len(next(iter(self.columns[k0].values())))
        names = self.columns[keys[0]].keys()
        return keys[0], {n: np.concatenate([self.columns[k0][n] for k0 in keys]) for n in names}


def identification_run(plant: str, seed: int, amplitude: float = 1.0) -> dict[str, Any]:
    """The identification page's default experiment as a fast run's request: 30 s of a
    PRBS at the plant input under the predefined controller, the reference at 0, the
    server's realistic sensors (noise drawn from ``seed``)."""
    return {
        "plant": plant,
        "experiment": "identification",
        "pace": "fast",
        "duration": 30,
        "controller": {"kind": "predefined"},
        "signal": {"kind": "step", "amplitude": 0},
        "excitation": {"kind": "prbs", "amplitude": amplitude, "order": 10, "band": 0.05},
        "excitation_at": "input",
        "seed": seed,
    }
