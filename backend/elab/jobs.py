"""Heavy work out of the web process: worker processes, each job with a time limit.

An identification of 100,000 samples takes seconds of CPU. In the web process it
would hold the GIL against every stream; here it runs in a worker process of its
own, at a lower priority (``nice``), at most ``workers`` at once. A job waits for
a free, ready worker at most ``wait`` seconds (then :class:`~elab.errors.TooMany`); one
that runs past ``timeout`` seconds, or whose caller goes away (its task is
cancelled), is stopped by killing its process, and a fresh worker takes its place.

A worker is ready once it has imported the modules the pool ``preload``s: the time limit
counts the job, not a fresh worker's start-up (seconds of imports at a low priority on a
busy machine), so the same job passes or fails its limit whenever it comes.

Workers are forked from one fork server (``multiprocessing``'s ``forkserver``: a process
started once, single-threaded, that imported every pool's ``preload``), not spawned: a
spawned worker imported numpy, scipy and python-control again, 1.7 s of CPU each, three
times at every server start and again for every worker replaced after a timeout. A fork
of the server's own process is not safe (its threads and event loop); a fork of the fork
server is. Starting a worker waits for the fork server's imports, so it happens on a
thread, never on the event loop. The engine process is forked from the same fork server
(:class:`Forked`), which imports its modules too: one set of imports at a server's start
instead of two.

Jobs and results cross by pickle between this process and workers it started
itself (nothing from outside is unpickled).
"""

from __future__ import annotations

import asyncio
import importlib
import logging
import multiprocessing
import os
import threading
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from multiprocessing.connection import Connection
from multiprocessing.process import BaseProcess
from typing import Any, TypeVar

from elab.errors import ElabError, InvalidInput, TooMany

log = logging.getLogger(__name__)
T = TypeVar("T")
Progress = Callable[[str, float], None]


@dataclass(frozen=True)
class Names:
    """What a pool's errors call its work and its settings, and what to change when a
    job runs past the time limit (``advice``)."""

    work: str = "identification"
    workers: str = "ELAB_IDENT_WORKERS"
    timeout: str = "ELAB_IDENT_TIMEOUT"
    wait: str = "ELAB_IDENT_WAIT"
    advice: str = "fewer samples, a smaller order search or fewer models"


_FORKSERVER = multiprocessing.get_context("forkserver")
_PRELOAD: set[str] = set()  # what the fork server imports when it starts
_PRELOAD_LOCK = threading.Lock()
_STARTED: list[frozenset[str]] = []  # what it imported, once start_fork_server started it


def import_in_fork_server(modules: Iterable[str]) -> None:
    """Have the fork server import ``modules`` (those asked for after it started are
    imported by each process forked from it instead: slower, still correct, and logged)."""
    with _PRELOAD_LOCK:
        new = set(modules) - _PRELOAD
        _PRELOAD.update(new)
        _FORKSERVER.set_forkserver_preload(sorted(_PRELOAD))
        if _STARTED and new - _STARTED[0]:
            log.warning(
                "the fork server started without %s: each process forked from it imports "
                "them itself (add them to elab.api.preload)",
                ", ".join(sorted(new - _STARTED[0])),
            )


def start_fork_server(modules: Iterable[str]) -> None:
    """Start the fork server now, importing ``modules`` (and any asked for before): it
    imports in its own process while the caller goes on. Without this call it starts at
    the first process forked from it, and the caller waits for its imports then."""
    import multiprocessing.forkserver

    with _PRELOAD_LOCK:
        _PRELOAD.update(modules)
        _FORKSERVER.set_forkserver_preload(sorted(_PRELOAD))
        multiprocessing.forkserver.ensure_running()
        _STARTED.append(frozenset(_PRELOAD))


class Forked:
    """``target(*args)`` in a process forked from the fork server, with what a supervisor
    needs of :class:`subprocess.Popen`: ``pid``, ``wait`` (the exit code, negative for a
    signal) and ``kill``. For a long-lived process that needs the fork server's imports
    (the engine: :func:`import_in_fork_server` its module first). :meth:`start` waits
    for the fork server's imports: call it on a thread."""

    def __init__(self, target: Callable[..., object], args: tuple[Any, ...], name: str) -> None:
        # daemonic: the web process never waits for it at exit (its supervisor closes it)
        self._proc = _FORKSERVER.Process(target=target, args=args, daemon=True, name=name)
        # the exit status is read once from the fork server's pipe; a second reader at the
        # same time would find it gone (and report 255): one wait at a time
        self._waiting = threading.Lock()

    def start(self) -> Forked:
        self._proc.start()
        return self

    @property
    def pid(self) -> int | None:
        return self._proc.pid

    def wait(self) -> int | None:
        with self._waiting:
            self._proc.join()
            return self._proc.exitcode

    def kill(self) -> None:
        self._proc.kill()


class _Worker:
    def __init__(self, nice: int, preload: tuple[str, ...], work: str) -> None:
        self.conn, self._child = _FORKSERVER.Pipe()
        self.proc: BaseProcess = _FORKSERVER.Process(
            target=_serve, args=(self._child, nice, preload, work), daemon=True, name="elab-job"
        )
        self._lock = threading.Lock()
        self._killed = False
        # the worker's first message says it has imported ``preload``; the thread goes on
        # if nobody waits for it (a request that gave up), so no message is lost
        self._ready = asyncio.ensure_future(asyncio.to_thread(self._start))
        self._ready.add_done_callback(lambda f: f.cancelled() or f.exception())  # seen here
        self.work = work

    def _start(self) -> Any:
        """Start the process (this waits for the fork server) and wait for its first
        message; on a thread."""
        with self._lock:
            if self._killed:
                raise EOFError("killed before it started")
            self.proc.start()
        self._child.close()
        return self.conn.recv()

    @property
    def ready(self) -> bool:
        return self._ready.done()

    async def until_ready(self) -> None:
        try:
            await asyncio.shield(self._ready)
        except (EOFError, OSError):
            raise ElabError(
                f"a {self.work} worker ended while starting (exit code "
                f"{self.proc.exitcode}); the server log has its message"
            ) from None

    def kill(self) -> None:
        """Kill the process (its zombie is reaped by multiprocessing's next start or join);
        one not started yet never starts."""
        with self._lock:
            self._killed = True
            if self.proc.pid is not None:
                self.proc.kill()
            else:  # never started: its end of the pipe is closed here, not by _start
                self._child.close()
        self.conn.close()


class JobPool:
    """``run(fn, *args)`` in a worker process; see the module's docstring."""

    def __init__(
        self,
        *,
        workers: int = 1,
        timeout: float = 120.0,
        wait: float = 30.0,
        nice: int = 10,
        names: Names = Names(),
        preload: tuple[str, ...] = (),
    ) -> None:
        self.workers = workers
        self.timeout = timeout
        self.wait = wait
        self.nice = nice
        self.names = names
        self.preload = preload
        import_in_fork_server(preload)
        self._idle: asyncio.Queue[_Worker] = asyncio.Queue()  # bound to a loop on first use
        self._all: list[_Worker] = []
        self.busy = 0

    @property
    def starting(self) -> int:
        """Workers still importing: a job given to one waits for it."""
        return sum(not w.ready for w in self._all)

    def _spawn(self) -> _Worker:
        worker = _Worker(self.nice, self.preload, self.names.work)
        self._all.append(worker)
        return worker

    async def start(self) -> None:
        """Start the workers (they load in the background)."""
        for _ in range(self.workers):
            self._idle.put_nowait(self._spawn())

    async def close(self) -> None:
        for worker in self._all:
            worker.kill()

    async def run(self, fn: Callable[..., T], *args: Any, progress: Progress | None = None) -> T:
        """``fn(*args, progress=…)`` in a worker (``progress`` called here, on the loop, for
        each report), or the :class:`ElabError` it raised. A job that must wait for a
        worker says so first, through ``progress``: why, and how long at most."""
        worker = await self._free_worker(progress)
        self.busy += 1
        healthy = False
        try:
            worker.conn.send((fn, args, progress is not None))
            result = await asyncio.wait_for(self._results(worker, progress), self.timeout)
            healthy = True
            return result  # type: ignore[no-any-return]
        except TimeoutError:
            raise InvalidInput(
                "body",
                f"a job over {self.timeout:g} s",
                f"work that finishes within {self.names.timeout} = {self.timeout:g} s: "
                + self.names.advice,
            ) from None
        except ElabError:
            healthy = worker.proc.is_alive()  # the job failed; the worker may be fine
            raise
        finally:
            self.busy -= 1
            # timed out, cancelled (its caller left) or broken: a fresh one takes its place
            self._idle.put_nowait(worker if healthy else self._replace(worker))

    def _replace(self, worker: _Worker) -> _Worker:
        worker.kill()
        self._all.remove(worker)
        return self._spawn()

    async def _free_worker(self, progress: Progress | None = None) -> _Worker:
        """An idle worker that is ready, within ``wait`` seconds in all; ``progress`` hears
        why it waits, if it must."""
        loop = asyncio.get_running_loop()
        deadline = loop.time() + self.wait
        if progress is not None and self._idle.empty():
            progress(
                f"waiting for a free {self.names.work} worker: all {self.workers} busy; "
                f"up to {self.wait:g} s ({self.names.wait}), then 429",
                0.0,
            )
        try:
            worker = await asyncio.wait_for(self._idle.get(), self.wait)
        except TimeoutError:
            raise TooMany(
                f"all {self.workers} {self.names.work} workers are busy ({self.names.workers})"
                f" and none was free within {self.wait:g} s; retry later",
                retry_after=self.wait,
            ) from None
        if progress is not None and not worker.ready:
            progress(
                f"waiting for the {self.names.work} worker to start (a new worker loads "
                f"its modules); up to {max(0.0, deadline - loop.time()):.0f} s more",
                0.0,
            )
        try:
            await asyncio.wait_for(worker.until_ready(), max(0.0, deadline - loop.time()))
        except TimeoutError:
            self._idle.put_nowait(worker)  # still starting: it stays for the next job
            raise TooMany(
                f"the {self.names.work} worker is still starting and was not ready within "
                f"{self.wait:g} s ({self.names.wait}); retry shortly",
                retry_after=self.wait,
            ) from None
        except ElabError:
            self._idle.put_nowait(self._replace(worker))
            raise
        except BaseException:  # the caller left while it started
            self._idle.put_nowait(worker)
            raise
        return worker

    async def _results(self, worker: _Worker, progress: Progress | None) -> Any:
        while True:
            try:
                kind, *body = await asyncio.to_thread(worker.conn.recv)
            except (EOFError, OSError):
                code = worker.proc.exitcode
                raise ElabError(
                    f"the {self.names.work} worker ended unexpectedly (exit code "
                    f"{code}); the server log has its message"
                ) from None
            if kind == "progress" and progress is not None:
                progress(*body)
            elif kind == "ok":
                return body[0]
            elif kind == "error":
                raise body[0]


def _serve(  # pragma: no cover - in the worker process
    conn: Connection, nice: int, preload: tuple[str, ...], work: str
) -> None:
    for module in preload:  # at the server's priority: a fresh worker is soon ready
        importlib.import_module(module)
    os.nice(nice)  # jobs at a lower priority: always allowed
    conn.send(("ready",))
    while True:
        try:
            fn, args, with_progress = conn.recv()
        except EOFError:
            return
        kwargs = (
            {"progress": lambda stage, done: conn.send(("progress", stage, done))}
            if with_progress
            else {}
        )
        try:
            conn.send(("ok", fn(*args, **kwargs)))
        except ElabError as exc:
            conn.send(("error", exc))
        except Exception as exc:  # a bug: its traceback to the server's log, an error back
            log.exception("job %s failed", getattr(fn, "__name__", fn))
            conn.send(("error", ElabError(f"internal error in the {work}: {exc!r}")))
