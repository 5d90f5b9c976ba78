"""The controller process, inside the sandbox (started by :mod:`elab.controllers.sandbox`).

It is a script of its own: it imports nothing of E-Lab. It reads the user's code and the
run's parameters from stdin, makes the ``Controller``, then closes itself in: a seccomp
filter that allows only reading and writing the two pipes it has, memory, clocks and
exiting (anything else kills it with SIGSYS), and an import hook that refuses every
module a controller has no business with. Then it answers steps: a request of
``k, t, r, y[0..ny-1]`` (little-endian int64 and float64) gets ``k, u`` and the CPU
seconds ``step`` took; an exception ends it with ``k = -1`` and a message.
"""

import json
import math
import os
import struct
import sys
import time
from typing import Any, BinaryIO, NoReturn

ALLOWED = {  # the syscalls a stepping controller makes (x86-64 and aarch64 names)
    "read", "write", "exit", "exit_group", "rt_sigreturn", "rt_sigprocmask", "brk", "mmap",
    "munmap", "mremap", "madvise", "mprotect", "futex", "clock_gettime", "getrandom",
    "sigaltstack", "gettid", "getpid",
}  # fmt: skip
MODULES = ("numpy", "math", "cmath", "collections", "dataclasses", "functools", "itertools")


def _read_exactly(f: BinaryIO, n: int) -> bytes:
    data = b""
    while len(data) < n:
        part = f.read(n - len(data))
        if not part:
            sys.exit(0)  # the parent is gone
        data += part
    return data


def _why(exc: BaseException) -> str:
    """The exception and where in the controller's file it happened (no source lines:
    reading them would be a file access, which the filter forbids)."""
    where = []
    tb = exc.__traceback__
    while tb is not None:
        code = tb.tb_frame.f_code
        if code.co_filename == FILENAME:
            where.append(f"line {tb.tb_lineno}, in {code.co_name}")
        tb = tb.tb_next
    if isinstance(exc, SyntaxError) and exc.lineno:
        where.append(f"line {exc.lineno}, column {exc.offset or 0}")
    place = f" ({FILENAME}: {'; '.join(where[-3:])})" if where else ""
    return f"{type(exc).__name__}: {exc}{place}"


FILENAME = "controller.py"


def _fail(out: BinaryIO, message: str) -> NoReturn:
    text = message.encode("utf-8", "replace")[:4000]
    out.write(struct.pack("<qdd", -1, 0.0, 0.0) + struct.pack("<I", len(text)) + text)
    out.flush()
    sys.exit(3)


def _close_in() -> None:
    import ctypes.util

    # pyseccomp looks its library up with find_library, which would run ldconfig or a
    # compiler through a temporary file; the sandbox has neither (nor a /tmp)
    libraries = {"c": "libc.so.6", "seccomp": "libseccomp.so.2"}
    ctypes.util.find_library = libraries.get  # type: ignore[assignment]
    import pyseccomp as seccomp  # libseccomp through ctypes, loaded before the filter

    f = seccomp.SyscallFilter(defaction=seccomp.KILL_PROCESS)
    for name in sorted(ALLOWED):
        try:
            f.add_rule(seccomp.ALLOW, name)
        except (RuntimeError, ValueError, OSError):  # not a syscall on this architecture
            continue
    f.load()


class _Refuse:
    """Only numpy and a few pure modules may be imported by the controller's code."""

    def find_spec(self, name: str, path: Any = None, target: Any = None) -> None:
        top = name.partition(".")[0]
        if top in MODULES or name in sys.modules:
            return None
        raise ImportError(f"{name} cannot be imported in the controller sandbox")


class _Sink:
    """print() in a controller goes nowhere (stdout is the protocol's pipe)."""

    def write(self, text: str) -> int:
        return len(text)

    def flush(self) -> None:
        pass


def main() -> None:
    stdin, out = sys.stdin.buffer, sys.stdout.buffer
    sys.stdout = sys.stderr = _Sink()
    (n,) = struct.unpack("<I", _read_exactly(stdin, 4))
    setup = json.loads(_read_exactly(stdin, n))
    global FILENAME
    FILENAME = str(setup.get("filename") or FILENAME)[:80]
    sys.path[:0] = setup["paths"]
    import numpy  # loaded before the filter: it maps its libraries

    try:
        namespace: dict[str, Any] = {"__name__": "controller"}
        code = compile(setup["code"], FILENAME, "exec")
        _close_in()
        for name in ("ctypes", "_ctypes", "os", "subprocess", "socket", "pyseccomp"):
            sys.modules.pop(name, None)
        sys.meta_path.insert(0, _Refuse())
        exec(code, namespace)
        cls = namespace.get("Controller")
        if cls is None:
            raise TypeError("the file defines no class Controller")
        ctrl = cls()
        reset = getattr(ctrl, "reset", None)
        if reset is not None:
            reset(setup["params"])
    except BaseException as exc:
        _fail(out, _why(exc))
    out.write(struct.pack("<qdd", 0, 0.0, 0.0))
    out.flush()
    ny = int(setup["ny"])
    request = struct.Struct("<q" + "d" * (2 + ny))
    answer = struct.Struct("<qdd")
    # the step's CPU time (clock_gettime of this thread's CPU clock): the controller's own
    # work, which a busy machine's preemption does not lengthen
    clock = time.thread_time
    step = ctrl.step
    y = numpy.zeros(ny)
    read, write, size = os.read, os.write, request.size
    while True:  # raw reads and writes from here: one system call each way per step
        raw = read(0, size)  # a request is one write of the parent's: it comes whole
        while len(raw) < size:
            more = read(0, size - len(raw))
            if not more:
                sys.exit(0)  # the parent is gone
            raw += more
        k, t, r, *values = request.unpack(raw)
        y[:] = values
        try:
            began = clock()
            u = float(step(t, y.copy(), r))
            spent = clock() - began
            if not math.isfinite(u):
                raise ValueError(f"step returned {u} at t = {t:g} s: u must be a finite number")
        except BaseException as exc:
            _fail(out, _why(exc))
        write(1, answer.pack(k, u, spent))


if __name__ == "__main__":
    main()
