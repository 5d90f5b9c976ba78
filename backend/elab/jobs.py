"""Heavy work out of the web process: worker processes, each job with a time limit.

An identification of 100,000 samples takes seconds of CPU. In the web process it
would hold the GIL against every stream; here it runs in a worker process of its
own, at a lower priority (``nice``), at most ``workers`` at once. A job waits for
a free worker at most ``wait`` seconds (then :class:`~elab.errors.TooMany`); one
that runs past ``timeout`` seconds, or whose caller goes away (its task is
cancelled), is stopped by killing its process, and a fresh worker takes its place.

Jobs and results cross by pickle between this process and workers it started
itself (nothing from outside is unpickled).
"""

from __future__ import annotations

import asyncio
import logging
import multiprocessing
import os
from collections.abc import Callable
from multiprocessing.connection import Connection
from multiprocessing.process import BaseProcess
from typing import Any, TypeVar

from elab.errors import ElabError, InvalidInput, TooMany

log = logging.getLogger(__name__)
T = TypeVar("T")
Progress = Callable[[str, float], None]


class _Worker:
    def __init__(self, nice: int) -> None:
        ctx = multiprocessing.get_context("spawn")  # no copy of the server's threads and loop
        self.conn, child = ctx.Pipe()
        self.proc: BaseProcess = ctx.Process(
            target=_serve, args=(child, nice), daemon=True, name="elab-job"
        )
        self.proc.start()
        child.close()

    def kill(self) -> None:
        """Kill the process (its zombie is reaped by multiprocessing's next start or join)."""
        self.proc.kill()
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
        setting: str = "ELAB_IDENT_TIMEOUT",
    ) -> None:
        self.workers = workers
        self.timeout = timeout
        self.wait = wait
        self.nice = nice
        self.setting = setting
        self._idle: asyncio.Queue[_Worker] | None = None
        self.busy = 0

    async def start(self) -> None:
        """Start the workers (they load in the background)."""
        self._idle = asyncio.Queue()
        for _ in range(self.workers):
            self._idle.put_nowait(_Worker(self.nice))

    async def close(self) -> None:
        assert self._idle is not None
        while not self._idle.empty():
            self._idle.get_nowait().kill()

    async def run(self, fn: Callable[..., T], *args: Any, progress: Progress | None = None) -> T:
        """``fn(*args, progress=…)`` in a worker (``progress`` called here, on the loop, for
        each report), or the :class:`ElabError` it raised."""
        assert self._idle is not None, "start() first"
        try:
            worker = await asyncio.wait_for(self._idle.get(), self.wait)
        except TimeoutError:
            raise TooMany(
                f"all {self.workers} identification workers are busy (ELAB_IDENT_WORKERS)"
                f" and none was free within {self.wait:g} s; retry later",
                retry_after=self.wait,
            ) from None
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
                f"work that finishes within {self.setting} = {self.timeout:g} s: "
                "fewer samples, a smaller order search or fewer models",
            ) from None
        except ElabError:
            healthy = True  # the job failed, the worker is fine
            raise
        finally:
            self.busy -= 1
            if not healthy:  # timed out, cancelled (its caller left) or broken: replace it
                worker.kill()
                worker = _Worker(self.nice)
            self._idle.put_nowait(worker)

    async def _results(self, worker: _Worker, progress: Progress | None) -> Any:
        while True:
            try:
                kind, *body = await asyncio.to_thread(worker.conn.recv)
            except (EOFError, OSError):
                code = worker.proc.exitcode
                raise ElabError(
                    f"the identification worker ended unexpectedly (exit code "
                    f"{code}); the server log has its message"
                ) from None
            if kind == "progress" and progress is not None:
                progress(*body)
            elif kind == "ok":
                return body[0]
            elif kind == "error":
                raise body[0]


def _serve(conn: Connection, nice: int) -> None:  # pragma: no cover - in the worker process
    os.nice(nice)  # lower the priority: always allowed
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
            conn.send(("error", ElabError(f"internal error in the identification: {exc!r}")))
