"""Python controllers in the sandbox: a controller that behaves steps with its compute
time recorded; every escape attempt (files, sockets, processes, signals, /proc, memory and
CPU bombs, infinite loops, huge outputs, bad answers) is contained: the controller fails
with the reason, the test process and the next controller are unaffected."""

from __future__ import annotations

import os
import time

import numpy as np
import pytest

from elab.controllers.sandbox import ControllerFailed, Sandboxed, available

pytestmark = pytest.mark.skipif(available() is not None, reason=str(available()))

GOOD = """
import numpy as np

class Controller:
    def reset(self, params):
        self.K = np.array(params["K"])
        self.n = 0

    def step(self, t, y, r):
        self.n += 1
        return float(self.K @ (np.array([r, 0.0]) - y)) + 0.0 * self.n
"""


def test_a_controller_steps_with_its_state_inside_and_its_times_recorded() -> None:
    # about the arithmetic and the state, not the timing: every answer waited for, as a
    # simulation does (the rig's hold returns the last u for an answer later than the
    # deadline: a machine busy past 50 ms once made step 30 answer with step 29's u)
    with Sandboxed(
        GOOD, ny=2, params={"K": [2.0, -1.0]}, deadline=0.05, hold=False, patience=30.0
    ) as c:
        us = [c.step(k * 1e-3, [0.1 * k, 0.5], 1.0) for k in range(200)]
        summary = c.times.summary()
    want = [2.0 * (1.0 - 0.1 * k) - 1.0 * (0.0 - 0.5) for k in range(200)]
    assert us == pytest.approx(want, rel=0, abs=0)  # the same float64 arithmetic
    assert summary["steps"] == 200
    assert 0 < summary["median_us"] < 5_000


def step_body(body: str) -> str:
    return "import numpy as np\n\nclass Controller:\n    def step(self, t, y, r):\n" + "".join(
        "        " + line + "\n" for line in body.strip().splitlines()
    )


ESCAPES = {
    "read a file": "return len(open('/etc/passwd').read())",
    "write a file": "open('/tmp/pwned', 'w').write('x'); return 0.0",
    "import os": "import os; return float(os.getpid())",
    "import socket": "import socket; socket.create_connection(('127.0.0.1', 8000)); return 0.0",
    "import subprocess": "import subprocess; subprocess.run(['id']); return 0.0",
    "import ctypes": "import ctypes; return float(ctypes.CDLL(None).getpid())",
    "__import__ os": "return float(__import__('os').getpid())",
    "importlib": "import importlib; return float(importlib.import_module('os').getpid())",
    # the import hook is a convenience: a loaded module's own os still reaches the kernel
    "os through a loaded module": (
        "import sys\n"
        "os = next(m.os for m in list(sys.modules.values()) if getattr(m, 'os', None))\n"
        "return float(os.system('id'))"
    ),
    "posix open": "import posix; posix.open('/etc/passwd', 0); return 0.0",
    "posix fork": "import posix; posix.fork(); return 0.0",
    "posix exec": "import posix; posix.execv('/bin/sh', ['sh']); return 0.0",
    "kill the parent": "import posix; posix.kill(posix.getppid(), 9); return 0.0",
    "walk /proc": "import posix; return float(len(posix.listdir('/proc')))",
    "a thread": "import threading; threading.Thread(target=print).start(); return 0.0",
    "memory bomb": "x = bytearray(8 << 30); return 0.0",
    "list bomb": "x = [0] * (1 << 31); return 0.0",
    "infinite loop": "while True: pass",
    "NaN": "return float('nan')",
    "not a number": "return 'ten volts'",
    "raises": "raise RuntimeError('my bug')",
    "exits": "raise SystemExit(0)",
    "dies": "import posix; posix._exit(0)",
    "output bomb": "print('x' * 10_000_000); return 0.0",
    "garbage on the pipe": "import posix; posix.write(1, b'\\xff' * 64); return 0.0",
}


# contained when the run either goes on with clean answers or fails: printing 10 MB is
# harmless (stdout is a sink inside), though building the string can make the steps slow
# enough to fail them — which of the two depends on the machine's speed at that moment
HARMLESS = {"output bomb"}


@pytest.mark.parametrize("attempt", list(ESCAPES))
def test_every_escape_attempt_is_contained(attempt: str, tmp_path: object) -> None:
    before = set(os.listdir("/tmp"))
    started = time.monotonic()
    outcome: object
    with Sandboxed(step_body(ESCAPES[attempt]), ny=1, max_misses=5, memory=1 << 30) as c:
        try:
            outcome = [c.step(k * 1e-3, [0.0], 1.0) for k in range(20)]
        except ControllerFailed as exc:
            outcome = exc
    if attempt in HARMLESS and outcome == [0.0] * 20:
        pass  # print() goes nowhere and the pipe stays clean: contained without a failure
    else:
        assert isinstance(outcome, ControllerFailed), f"{attempt}: not contained: {outcome}"
    assert time.monotonic() - started < 30
    assert "pwned" not in set(os.listdir("/tmp")) - before
    # and the next controller is fine
    with Sandboxed(GOOD, ny=2, params={"K": [1.0, 0.0]}, deadline=0.05) as c:
        assert c.step(0.0, [0.25, 0.0], 1.0) == 0.75


def test_print_goes_nowhere_and_the_steps_go_on() -> None:
    with Sandboxed(step_body("print('u is', 0.5 * r); return 0.5 * r"), ny=1, deadline=0.05) as c:
        assert [c.step(k * 1e-3, [0.0], 2.0) for k in range(50)] == [1.0] * 50


def test_module_level_attacks_and_a_missing_class_fail_at_start() -> None:
    for code in (
        "open('/etc/passwd')",
        "import os",
        "x = 1",
        "class Controller:\n    def __init__(self):\n        while True: pass",
        "def broken(:",
    ):
        with pytest.raises(ControllerFailed):
            Sandboxed(code, ny=1, start_timeout=3.0).close()


@pytest.mark.parametrize(
    ("attempt", "reason"),
    [
        ("raises", r"RuntimeError: my bug \(controller\.py: line 5, in step\)"),
        ("NaN", "finite number"),
        ("read a file", "forbids"),
        ("import os", "cannot be imported"),
    ],
)
def test_reasons_say_what_happened(attempt: str, reason: str) -> None:
    # a deadline far beyond the step's time: on a busy machine the sandbox may not run for
    # milliseconds, and ten missed 0.5 ms deadlines would be the reason instead
    with (
        pytest.raises(ControllerFailed, match=reason),
        Sandboxed(step_body(ESCAPES[attempt]), ny=1, deadline=2.0) as c,
    ):
        for k in range(50):
            c.step(k * 1e-3, [0.0], 0.0)


def test_a_controller_too_slow_too_often_fails_naming_the_deadline() -> None:
    with (
        pytest.raises(ControllerFailed, match=r"missed its deadline of 0\.5 ms 3 times"),
        Sandboxed(step_body(ESCAPES["infinite loop"]), ny=1, max_misses=3) as c,
    ):
        for k in range(5):
            c.step(k * 1e-3, [0.0], 0.0)


def test_a_late_answer_holds_the_last_u_and_is_dropped_when_it_comes() -> None:
    slow_once = """
class Controller:
    def reset(self, params):
        self.n = 0

    def step(self, t, y, r):
        self.n += 1
        if self.n == 3:
            s = 0
            for i in range(2_000_000):  # about 100 ms, once
                s += i
        return float(self.n)
"""
    with Sandboxed(slow_once, ny=1, deadline=0.02, max_misses=10_000) as c:
        us = [c.step(k * 1e-3, [0.0], 0.0) for k in range(6)]
        while c.times.misses and us[-1] < 10:
            us.append(c.step(0.0, [0.0], 0.0))
            if len(us) > 200:
                break
    assert us[:2] == [1.0, 2.0] and us[2] == 2.0  # step 3 late: u held
    assert c.times.misses >= 1
    assert us[-1] == float(len(us))  # later answers belong to their own steps
    assert np.all(np.diff(us[2:]) >= 0)


def test_a_controller_never_runs_under_the_engines_real_time_scheduling() -> None:
    """The engine runs under SCHED_FIFO and a child would inherit it: user code must not
    (a controller importing numpy at real-time priority starved the others on its core)."""
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(5))
    except PermissionError:
        pytest.skip("real-time scheduling is not allowed here")
    try:
        with Sandboxed(GOOD, ny=2, params={"K": [2.0, -1.0]}, deadline=0.05) as c:
            assert os.sched_getscheduler(c._proc.pid) == os.SCHED_OTHER
            inside = _descendants(c._proc.pid)
            assert inside and all(os.sched_getscheduler(p) == os.SCHED_OTHER for p in inside)
            assert c.step(0.0, [0.0, 0.5], 1.0) == pytest.approx(2.0 + 0.5)
    finally:
        os.sched_setscheduler(0, os.SCHED_OTHER, os.sched_param(0))


def _descendants(pid: int) -> list[int]:
    out, todo = [], [pid]
    while todo:
        p = todo.pop()
        for task in os.listdir(f"/proc/{p}/task"):
            with open(f"/proc/{p}/task/{task}/children") as f:
                kids = [int(k) for k in f.read().split()]
            out += kids
            todo += kids
    return out


SLOW_AT = """
import time

class Controller:
    def step(self, t, y, r):
        if {slow}:
            t0 = time.thread_time()  # 2 ms of CPU, however busy the machine is
            while time.thread_time() - t0 < 2e-3:
                pass
        return t
"""


def test_a_simulation_waits_for_a_late_answer_and_fails_a_controller_slow_in_itself() -> None:
    """Without ``hold`` a late answer is waited for (u is the controller's, not the last
    one), counted late and slow; ten steps in a row slow in the controller itself fail it,
    and so does an answer that never comes."""
    with Sandboxed(SLOW_AT.format(slow="t == 0.003"), ny=1, hold=False) as c:
        us = [c.step(k * 1e-3, [0.0], 0.0) for k in range(6)]
        assert us == [k * 1e-3 for k in range(6)]  # the late one too
        s = c.times.summary()
        assert s["misses"] >= 1 and s["slow"] == 1
    too_slow = r"longer than its deadline of 0\.5 ms 10 times"
    with (
        Sandboxed(SLOW_AT.format(slow="t >= 0.002"), ny=1, hold=False) as c,
        pytest.raises(ControllerFailed, match=too_slow),
    ):
        for k in range(20):
            c.step(k * 1e-3, [0.0], 0.0)
    with Sandboxed(
        SLOW_AT.format(slow="False").replace("return t", "while True: pass"),
        ny=1,
        hold=False,
        patience=0.2,
    ) as c:
        t0 = time.monotonic()
        with pytest.raises(ControllerFailed, match=r"did not answer within 0\.2 s"):
            c.step(0.0, [0.0], 0.0)
        assert time.monotonic() - t0 < 1.0
