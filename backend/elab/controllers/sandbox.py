"""Python controllers in a sandbox: one process per run, stepped over a pipe with a
deadline per step (docs/controllers.md).

The process is a fresh interpreter running :mod:`elab.controllers._inside`:

- **bubblewrap** gives it every namespace of its own (no network, its own PID and IPC
  namespaces), a read-only view of the interpreter and numpy and nothing else of the
  file system, and ``--die-with-parent``;
- **rlimits** (set by ``prlimit`` before bubblewrap starts): address space, CPU seconds,
  open files, file size 0;
- **ordinary scheduling**: the engine runs under SCHED_FIFO, which a child would inherit;
  the controller's process is put back to SCHED_OTHER (``chrt --other``), so user code
  never runs ahead of
  the machine (a controller starting up, importing numpy for 0.1 s at real-time priority,
  held the other controllers on its core past their deadlines: runs failed). The
  stepping thread sleeps while it waits for an answer, so the process still gets the CPU
  at once. ``RLIMIT_RTTIME`` stays as a second guard;
- **seccomp**: once the code is compiled and numpy loaded, only reading and writing its
  pipes, memory, clocks and exiting are allowed; anything else (open, socket, fork,
  kill, exec) kills it;
- an import hook keeps everything but numpy and a few pure modules out of reach (a
  convenience for clear errors: the boundary is the kernel's).

Each step has a deadline (``deadline`` s, measured with ``select()``, which does not
round up to milliseconds as ``poll`` does). On the rig (``hold``) a late step holds the
last u and ``max_misses`` late steps in a row end the controller; in a simulation the
model waits for the answer (so samples never depend on the machine's load) and
``max_misses`` steps in a row whose own compute time passed the deadline end it. An
exception, a non-finite u, or the process dying end it too, with the reason.
"""

from __future__ import annotations

import functools
import json
import os
import select
import shutil
import struct
import subprocess
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any, NoReturn

import numpy as np

from elab.errors import ElabError, InvalidInput, Unavailable

INSIDE = Path(__file__).with_name("_inside.py")
MAX_CODE = 64 * 1024
ANSWER = struct.Struct("<qdd")  # k, u, the step's compute time inside (s)
SPIN = 50e-6  # s an answer is polled for before the process sleeps in select()
BUDGET_GRACE = 0.1  # s of compute a controller may take at its start beyond its budget
RT_SOFT_US = 500_000  # µs a real-time controller process may run without waiting


class ControllerFailed(ElabError):
    """The controller's code failed: it raised, returned no finite number, missed its
    deadline too often, or its process died (the reason says which)."""


class StepTimes:
    """Time per step, in constant memory (an hour at 1 kHz is 3.6 million steps): the
    controller's own compute time (its CPU time around ``step``, inside its process) and the
    round trip the run waits for (request written to answer read), each kept as a
    histogram of 100 bins per decade (percentiles to within 2.3 %), with the exact
    maximum; ``misses``: steps whose answer came after the deadline; ``slow``: steps whose
    own compute time passed it (the controller's doing, not the machine's load)."""

    EDGES = np.logspace(-7, 1, 801)  # s: 0.1 µs .. 10 s

    def __init__(self) -> None:
        self.misses = 0
        self.slow = 0
        self.steps = 0
        self.compute = 0.0  # s: the controller's own compute time, all steps together
        self._buf = np.zeros((2, 4096))
        self._n = 0
        self._counts = np.zeros((2, self.EDGES.size + 1), np.int64)
        self._max = np.zeros(2)

    def add(self, compute: float, round_trip: float) -> None:
        self.compute += compute
        buf, n = self._buf, self._n
        buf[0, n], buf[1, n] = compute, round_trip
        self._n = n + 1
        if self._n == buf.shape[1]:
            self._fold()

    def _fold(self) -> None:
        part = self._buf[:, : self._n]
        for i in (0, 1):
            self._counts[i] += np.bincount(
                np.searchsorted(self.EDGES, part[i]), minlength=self._counts.shape[1]
            )
        if self._n:
            self._max = np.maximum(self._max, part.max(axis=1))
        self.steps += self._n
        self._n = 0

    def summary(self) -> dict[str, float | int]:
        """``steps``; the compute time's ``median_us``, ``p99_us``, ``max_us``; the round
        trip's ``round_trip_median_us``, ``round_trip_p99_us``; ``misses``; ``slow``."""
        self._fold()
        out: dict[str, float | int] = {
            "steps": self.steps,
            "misses": self.misses,
            "slow": self.slow,
        }
        for i, prefix in ((0, ""), (1, "round_trip_")):
            out[prefix + "median_us"] = self._percentile(i, 0.5)
            out[prefix + "p99_us"] = self._percentile(i, 0.99)
        out["max_us"] = float(self._max[0] * 1e6)
        return out

    def _percentile(self, i: int, q: float) -> float:
        """The geometric middle of the bin holding the ``q`` quantile, in µs."""
        counts = self._counts[i]
        if not self.steps:
            return 0.0
        b = int(np.searchsorted(np.cumsum(counts), q * self.steps))
        lo = self.EDGES[max(b - 1, 0)]
        hi = self.EDGES[min(b, self.EDGES.size - 1)]
        return float(min(np.sqrt(lo * hi), self._max[i]) * 1e6)


def available() -> str | None:
    """``None`` if code controllers can run here, else why not."""
    if shutil.which("bwrap") is None:
        return "bubblewrap (bwrap) is not installed: apt-get install bubblewrap"
    for tool in ("prlimit", "chrt"):
        if shutil.which(tool) is None:
            return f"{tool} is not installed: apt-get install util-linux"
    try:
        import pyseccomp  # noqa: F401
    except ImportError:
        return "pyseccomp is not installed"
    return None


class Sandboxed:
    """A controller's code in its own sandboxed process: :meth:`step` per sample."""

    def __init__(
        self,
        code: str,
        *,
        ny: int,
        params: dict[str, Any] | None = None,
        deadline: float = 0.5e-3,
        max_misses: int = 10,
        start_timeout: float = 10.0,
        memory: int = 1 << 30,
        cpu_seconds: int = 3600,
        filename: str = "controller.py",
        hold: bool = True,
        patience: float = 1.0,
        budget: float | None = None,
        nice: int = 0,
    ) -> None:
        why = available()
        if why is not None:
            raise Unavailable(f"code controllers cannot run on this server: {why}")
        if len(code.encode()) > MAX_CODE:
            raise InvalidInput("code", f"{len(code.encode())} bytes", f"at most {MAX_CODE} bytes")
        self.ny = ny
        self.deadline = deadline
        self.max_misses = max_misses
        self.hold = hold
        self.patience = patience
        self.budget = budget
        self.nice = nice
        self.times = StepTimes()
        self._k = 0
        self._u = 0.0
        self._misses = 0
        self._request = struct.Struct("<q" + "d" * (2 + ny))
        self._proc = subprocess.Popen(
            _command(memory, cpu_seconds, nice),
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=subprocess.DEVNULL,
            env={"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "PYTHONHASHSEED": "0"},
        )
        assert self._proc.stdin is not None and self._proc.stdout is not None
        self._in, self._out = self._proc.stdin, self._proc.stdout.fileno()
        self._fd_in, self._watch = self._in.fileno(), [self._out]
        os.set_blocking(self._out, False)  # polled first (see _answer)
        # on one CPU the controller cannot answer while this thread polls: no polling
        self._spin = SPIN if len(os.sched_getaffinity(0)) > 1 else 0.0
        setup = json.dumps(
            {
                "code": code,
                "filename": filename,
                "params": params or {},
                "ny": ny,
                "paths": _paths(),
            }
        ).encode()
        try:
            self._in.write(struct.pack("<I", len(setup)) + setup)
            self._in.flush()
        except BrokenPipeError:
            pass
        first = self._answer(start_timeout, starting=True)
        if first is None or first[0] != 0:
            raise ControllerFailed("the controller did not start")

    def step(self, t: float, y: Sequence[float], r: float) -> float:
        """u for sample ``k`` (counted here).

        ``hold`` (the rig: the plant does not wait): an answer later than the deadline
        holds the last u, and ``max_misses`` late answers in a row fail the controller.
        Otherwise (a simulation: the model waits, so a run's samples never depend on how
        busy the machine is) the answer is waited for, up to ``patience`` s; a late one
        is counted, and ``max_misses`` steps in a row whose own compute time passed the
        deadline fail the controller: it is too slow, whatever the machine's load."""
        self._k += 1
        k = self._k
        start = time.perf_counter()
        try:
            os.write(self._fd_in, self._request.pack(k, t, r, *y))
        except BrokenPipeError:
            self._died()
        wait = self.deadline if self.hold else self.patience
        while True:
            left = wait - (time.perf_counter() - start)
            got = self._answer(max(left, 0.0))
            if got is None and not self.hold:
                self.close()
                raise ControllerFailed(
                    f"the controller did not answer within {self.patience:g} s (at t = {t:g} s)"
                )
            if got is None:  # late: hold u; its answer is read (and dropped) later
                self.times.misses += 1
                self._misses += 1
                if self._misses >= self.max_misses:
                    self.close()
                    raise ControllerFailed(
                        f"the controller missed its deadline of {self.deadline * 1e3:g} ms "
                        f"{self._misses} times in a row (at t = {t:g} s)"
                    )
                return self._u
            if got[0] == k:
                break  # an older, late answer is dropped
        trip = time.perf_counter() - start
        self.times.add(got[2], trip)
        self.times.slow += got[2] > self.deadline
        if self.hold:
            self._misses = 0
        else:
            self.times.misses += trip > self.deadline
            self._misses = self._misses + 1 if got[2] > self.deadline else 0
            if self._misses >= self.max_misses:
                self.close()
                raise ControllerFailed(
                    f"the controller's step took longer than its deadline of "
                    f"{self.deadline * 1e3:g} ms {self._misses} times in a row (at t = {t:g} "
                    f"s; the last took {got[2] * 1e3:.3g} ms): too slow for this sample time"
                )
        if self.budget is not None and self.times.compute > self.budget * t + BUDGET_GRACE:
            self.close()
            raise ControllerFailed(
                f"the controller computed for {self.times.compute:.3g} s in the first "
                f"{t:.3g} s of its run, more than its budget of {self.budget:.0%} of the "
                f"run's time (after a start of {BUDGET_GRACE:g} s; ELAB_CODE_BUDGET): too "
                "slow for this sample time"
            )
        self._u = got[1]
        return self._u

    def _answer(self, timeout: float, starting: bool = False) -> tuple[int, float, float] | None:
        """The next answer ``(k, u, compute seconds)``, or ``None`` after ``timeout`` s.

        It first asks for it without waiting for up to :data:`SPIN` s (most steps answer
        within that: sleeping in ``select`` and being woken costs several µs each way;
        not where this process has one CPU only), then waits in ``select``."""
        head = b""
        spin_until = time.perf_counter() + min(self._spin, timeout)
        while not starting and self._spin:
            try:
                head = os.read(self._out, ANSWER.size)
                break
            except BlockingIOError:
                if time.perf_counter() >= spin_until:
                    break
        if not head:
            ready, _, _ = select.select(self._watch, [], [], timeout)
            if not ready:
                if starting:
                    self.close()
                    raise ControllerFailed(f"the controller did not start within {timeout:g} s")
                return None
            head = os.read(self._out, ANSWER.size)  # an answer is one write: it comes whole
        if len(head) < ANSWER.size:
            rest = _read(self._out, ANSWER.size - len(head), 1.0) if head else None
            if rest is None:
                self._died()
            head += rest
        k, u, spent = ANSWER.unpack(head)
        if k == -1:
            size = _read(self._out, 4, 1.0)
            n = int(struct.unpack("<I", size)[0]) if size is not None else 0
            text = _read(self._out, n, 1.0) if n <= 4000 else None
            self.close()
            if text is None:
                raise ControllerFailed("the controller broke the step protocol")
            raise ControllerFailed(f"the controller failed: {text.decode('utf-8', 'replace')}")
        if not 0 <= k <= self._k:  # not an answer to any step: it wrote to the pipe itself
            self.close()
            raise ControllerFailed("the controller broke the step protocol (it wrote to stdout)")
        return k, u, spent

    def _died(self) -> NoReturn:
        try:
            code = self._proc.wait(timeout=5)
        except subprocess.TimeoutExpired:
            code = None
        self.close()
        # bubblewrap passes a signal that ended the process on as 128 + its number
        why = {
            128 + 31: "it made a system call the sandbox forbids (SIGSYS)",
            128 + 9: "it was killed (a memory or CPU limit)",
            128 + 24: "it used up its CPU time",
            None: "it stopped answering",
        }.get(code, f"exit status {code}")
        raise ControllerFailed(f"the controller's process ended: {why}")

    def close(self) -> None:
        if self._proc.poll() is None:
            self._proc.kill()
        self._proc.wait()
        for f in (self._proc.stdin, self._proc.stdout):
            if f is not None:
                f.close()

    def __enter__(self) -> Sandboxed:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _read(fd: int, n: int, timeout: float, ready: bool = False) -> bytes | None:
    """``n`` bytes, or ``None`` if the pipe closes or they do not all come in time
    (``ready``: the pipe was just seen readable, so the first read does not wait)."""
    data = b""
    end = time.perf_counter() + timeout
    while len(data) < n:
        if not ready and not select.select([fd], [], [], max(0.0, end - time.perf_counter()))[0]:
            return None
        ready = False
        part = os.read(fd, n - len(data))
        if not part:
            return None
        data += part
    return data


@functools.cache
def _paths() -> list[str]:
    """Where numpy and pyseccomp are (the only packages the process needs)."""
    import numpy
    import pyseccomp

    assert numpy.__file__ is not None
    return sorted({str(Path(numpy.__file__).parents[1]), str(Path(pyseccomp.__file__).parent)})


def _command(memory: int, cpu_seconds: int, nice: int = 0) -> list[str]:
    """The controller's process: its limits set by ``prlimit`` and its scheduling by
    ``chrt`` (util-linux) and ``nice`` (coreutils: where lowering it is not allowed, it
    says so and runs the process as it is), each then exec'ing the next, so no Python
    runs between fork and exec in the engine's threaded process (``preexec_fn`` may
    deadlock there); then bubblewrap, then the interpreter."""
    binds: list[str] = []
    for path in sorted(
        {"/usr", "/lib", "/lib64", "/bin", "/etc/ld.so.cache", sys.prefix, sys.base_prefix}
        | set(_paths())
    ):
        if os.path.exists(path):
            binds += ["--ro-bind", path, path]
    return [
        _tool("prlimit"),
        f"--as={memory}",
        f"--cpu={cpu_seconds}",
        "--fsize=0",
        "--nofile=16",
        "--core=0",
        # µs of CPU under a real-time policy without a blocking call: SIGXCPU, then SIGKILL
        f"--rttime={RT_SOFT_US}:{2 * RT_SOFT_US}",
        _tool("chrt"),
        "--other",  # never real-time, whatever the engine is
        "0",
        _tool("nice"),
        "-n",
        str(nice),
        _tool("bwrap"),
        "--unshare-all",
        "--die-with-parent",
        "--new-session",
        *binds,
        "--ro-bind",
        str(INSIDE),
        "/inside.py",
        "--chdir",
        "/",
        sys.executable,
        "-I",
        "-S",
        "-B",
        "/inside.py",
    ]


def _tool(name: str) -> str:
    found = shutil.which(name)
    if found is None:
        raise Unavailable(f"code controllers cannot run on this server: {name} is not installed")
    return found
