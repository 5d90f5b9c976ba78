"""What the rig's host loop steps per sample, apart from the loop itself: a run's controller
as the loop calls it (:class:`LinearLaw` for a declarative law, :class:`CodeLaw` for Python
code in its sandbox), the differentiators that estimate θ̇ and α̇, and the response-latency
record.

A controller on the rig sees only what the rig measures (θ and α); its voltage goes to the
trusted :class:`~elab.rig.supervisor.Supervisor`, never straight to the amplifier. A
Python controller answers within its deadline or the loop holds its last voltage and
tells the supervisor it was late (the supervisor, not the student's process, is
real-time: ``n_late`` late answers in a row trip the run).
"""

from __future__ import annotations

import threading
from dataclasses import asdict, dataclass, replace
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from elab.controllers.sandbox import Sandboxed
from elab.engines.coded import controller_params
from elab.engines.settings import CodeSettings
from elab.errors import InvalidInput
from elab.laws import CodeController
from elab.plants import get_plant
from elab.rig.supervisor import Trip
from elab.sim.kernel import control_step
from elab.sim.spec import CompiledRun, RunSpec, compile_run

Array = NDArray[np.float64]
#: The niceness of a Python controller's process on the rig: ahead of ordinary processes
#: when it wakes for a sample, never real-time (where not allowed, it runs at 0)
CODE_NICE = -10


def compile_for_rig(spec: RunSpec) -> CompiledRun:
    """The run as the loop steps it: its sensors are the rig's, not simulated ones."""
    run = compile_run(replace(spec, noise_seed=None, quantize=False))
    if run.controller.feedback != "output":
        raise InvalidInput(
            "controller.estimate",
            "true state",
            "velocity_filters or observer: on the rig a controller sees only the measured "
            "θ and α, never the true state",
        )
    return run


class RigLaw(Protocol):
    """A run's controller as the loop calls it once per sample."""

    run: CompiledRun

    def u(self, t: float, r: float, e: float, theta: float, alpha: float) -> tuple[float, bool]:
        """The voltage the controller asks for at ``t`` given reference ``r``, input
        excitation ``e`` (V) and the measured angles; and whether its answer was late
        (the voltage is then the last one, held)."""
        ...

    def changed(self, run: CompiledRun) -> RigLaw:
        """This controller with ``run``'s law and signals from the next sample on (the
        controller's state goes on)."""
        ...

    def close(self) -> None: ...


def law_for(run: CompiledRun, code: CodeSettings | None = None, *, trial: bool = False) -> RigLaw:
    """The loop's controller for ``run``; a Python controller's process starts here (about
    0.1 s: in the engine's command thread, never in the loop). ``trial``: for a trial off
    the rig, where a Python controller is waited for as in a simulation (its own compute
    time, not the machine's load, decides whether it is too slow)."""
    match run.spec.law:
        case CodeController() as law:
            return CodeLaw(run, law, code or CodeSettings(), trial=trial)
        case _:
            return LinearLaw.of(run)


@dataclass
class LinearLaw:
    """A declarative law's discrete controller as :func:`control_step` takes it (slot 0 of
    one): the simulation's own compiled arithmetic on the measured θ and α."""

    run: CompiledRun
    Ac: Array
    Bc: Array
    Cc: Array
    Dc: Array
    Lw: Array
    u_lim: Array
    xc: Array  # (1, nc): the controller's state
    xcn: Array  # (nc,): its next state
    z: Array  # (2,): θ and α as measured

    @classmethod
    def of(cls, run: CompiledRun, xc: Array | None = None) -> LinearLaw:
        c = run.controller
        return cls(
            run,
            c.Ac[None].copy(),
            c.Bc[None].copy(),
            c.Cc[None].copy(),
            c.Dc[None].copy(),
            c.Lw[None].copy(),
            np.array([run.u_lim]),
            np.zeros((1, c.nc)) if xc is None else xc,
            np.zeros(c.nc),
            np.zeros(2),
        )

    def u(self, t: float, r: float, e: float, theta: float, alpha: float) -> tuple[float, bool]:
        self.z[0], self.z[1] = theta, alpha
        u = control_step(
            0, r, self.z, e, self.Ac, self.Bc, self.Cc, self.Dc, self.Lw, self.u_lim, self.xc,
            self.xcn,
        )  # fmt: skip
        self.xc[0, :] = self.xcn
        return float(u), False

    def changed(self, run: CompiledRun) -> RigLaw:
        if run.controller.nc != self.run.controller.nc:
            raise InvalidInput(
                "controller",
                type(run.spec.law).__name__,
                f"a {type(self.run.spec.law).__name__} law like the run's (its controller "
                "state size cannot change mid-run); start a new run instead",
            )
        return LinearLaw.of(run, self.xc)

    def close(self) -> None:
        pass


class CodeLaw:
    """A Python controller in its sandbox (:class:`Sandboxed` with ``hold``): an answer
    later than the deadline holds the last voltage and counts as late for the supervisor,
    which trips the run; the sandbox itself never ends the controller for lateness."""

    def __init__(
        self, run: CompiledRun, law: CodeController, settings: CodeSettings, trial: bool = False
    ) -> None:
        self.run = run
        self.sandbox = Sandboxed(
            law.source,
            ny=run.spec.plant.ny,
            params=asdict(controller_params(run)),
            deadline=settings.deadline,
            # on the rig the supervisor trips first (n_late); in a trial, as in a
            # simulation, steps too slow by their own compute time fail it
            max_misses=settings.max_misses if trial else 1 << 62,
            filename=law.name,
            hold=not trial,
            patience=settings.patience,
            start_timeout=settings.start,
            nice=CODE_NICE,
        )

    def u(self, t: float, r: float, e: float, theta: float, alpha: float) -> tuple[float, bool]:
        misses = self.sandbox.times.misses
        v = self.sandbox.step(t, (theta, alpha), r)  # ControllerFailed: the run fails
        u = min(max(v + e, -self.run.u_lim), self.run.u_lim)
        # late: held (on the rig); a trial's late round trips are the machine's, not late
        return u, self.sandbox.hold and self.sandbox.times.misses > misses

    def changed(self, run: CompiledRun) -> RigLaw:
        self.run = run  # new signals; the code stays (a Python controller is not swapped)
        return self

    def close(self) -> None:
        """Ends the controller's process off the caller's thread (the loop's)."""
        threading.Thread(target=self.sandbox.close, name="elab-rig-code-close").start()


def warm() -> None:
    """Compile the controller step now, not on a live sample (about a second)."""
    plant = get_plant("flexible_link")
    law = LinearLaw.of(compile_for_rig(RunSpec(plant, plant.predefined, duration=0.01)))
    law.u(0.0, 0.0, 0.0, 0.0, 0.0)


def tripped(trip: Trip) -> str:
    return (
        f"safety trip ({trip.reason}) at sample {trip.k}: {trip.message}; the motor at 0 V "
        "from then on"
    )


class Differentiator:
    """θ̇ from θ: the filter ωc s / (s + ωc) discretised by backward Euler."""

    def __init__(self, omega_c: float) -> None:
        self.omega_c = omega_c
        self.last: float | None = None
        self.value = 0.0

    def reset(self, x: float) -> None:
        self.last, self.value = x, 0.0

    def next(self, x: float, Ts: float) -> float:
        if self.last is None:
            self.last = x
            return 0.0
        a = 1.0 / (1.0 + self.omega_c * Ts)
        self.value = a * self.value + (1 - a) * (x - self.last) / Ts
        self.last = x
        return self.value


class Latency:
    """Response latencies over the last 10,000 samples (ns in, µs out)."""

    def __init__(self, keep: int = 10_000) -> None:
        self._ns = np.zeros(keep, dtype=np.int64)
        self._n = 0
        self.late_1ms = 0  # answers later than 1 ms, all time
        self.samples = 0

    def add(self, ns: int) -> None:
        self._ns[self._n % self._ns.size] = ns
        self._n += 1
        self.samples += 1
        self.late_1ms += ns > 1_000_000

    def summary(self) -> dict[str, float | int]:
        n = min(self._n, self._ns.size)
        if n == 0:
            return {"samples": 0, "late_1ms": 0}
        us = self._ns[:n] / 1e3
        return {
            "samples": self.samples,
            "late_1ms": self.late_1ms,
            "latency_p50_us": float(np.percentile(us, 50)),
            "latency_p99_us": float(np.percentile(us, 99)),
            "latency_max_us": float(us.max()),
        }
