"""Runs whose controller is Python code (:class:`~elab.laws.CodeController`): stepped one
sample at a time outside the shared batch.

Per sample the plant's sensors and its discrete model are the batch's own compiled
arithmetic (:func:`elab.sim.kernel.sense`, :func:`~elab.sim.kernel.actuate`), and ``u``
comes from the controller's sandboxed process (:class:`~elab.controllers.sandbox.Sandboxed`)
given the absolute measured outputs, as the rig gives them. The actuator limit and an
input excitation apply to its ``u`` as to any controller's. The same class steps a run on
the server (:class:`~elab.engines.stepper.Stepper`) and offline (``elab simulate
--controller my.py``), so both give the same samples for the same seed.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np
from numpy.typing import NDArray

from elab.controllers.report import Report, check, saturation
from elab.controllers.sandbox import ControllerFailed, Sandboxed, StepTimes
from elab.engines.outcome import RUNAWAY
from elab.engines.settings import CodeSettings
from elab.errors import InvalidInput
from elab.laws import CodeController, ControlLaw
from elab.plants import Plant
from elab.sim.engine import diverged, first_divergence
from elab.sim.kernel import actuate, sense
from elab.sim.signals import Square, Step
from elab.sim.spec import CompiledRun, RunSpec, compile_run

Array = NDArray[np.float64]


LATE_SHARE = 0.001  # steps slower than the deadline past this share are a warning


@dataclass(frozen=True)
class ResetParams:
    """What a code controller's ``reset(params)`` is given about its run, as a dict of these
    fields (docs/controllers.md): ``Ts`` in s, ``u_max`` in V (``None``: no limit), the
    outputs' names and units, ``y_op`` the outputs at the operating point."""

    plant: str
    Ts: float
    u_max: float | None
    outputs: list[str]
    units: list[str]
    y_op: list[float]
    reference_output: int


def controller_params(run: CompiledRun) -> ResetParams:
    """What a code controller's ``reset(params)`` is given about its run."""
    p = run.spec.plant
    return ResetParams(
        plant=p.id,
        Ts=run.Ts,
        u_max=run.u_lim if math.isfinite(run.u_lim) else None,
        outputs=[o.name for o in p.outputs],
        units=[o.unit for o in p.outputs],
        y_op=(p.C @ p.operating_point).tolist(),
        reference_output=p.reference_output,
    )


class CodedRun:
    """A run with a code controller: :meth:`advance` steps it ``n`` samples. Starting it
    starts the controller's process (about 0.1 s); :meth:`close` ends it."""

    def __init__(self, run: CompiledRun, settings: CodeSettings | None = None) -> None:
        match run.spec.law:
            case CodeController() as law:
                pass
            case other:
                raise InvalidInput("controller", type(other).__name__, "a CodeController")
        settings = settings or CodeSettings()
        p = run.spec.plant
        self.run = run
        self.k = 0
        self.peak_command = 0.0  # the largest |u| asked for, before the actuator's limit
        self._C = np.ascontiguousarray(p.C, dtype=np.float64)[np.newaxis]
        self._Ad = run.Ad[np.newaxis].copy()
        self._Bd = run.Bd[np.newaxis].copy()
        self._x = run.x0[np.newaxis].copy()
        self._xn = np.zeros(p.nx)
        self._y = np.zeros(p.ny)
        self._quantum = run.quantum[np.newaxis].copy()
        self._y_op = (p.C @ p.operating_point)[np.newaxis]
        self._x_op = np.asarray(p.operating_point, dtype=np.float64)[np.newaxis]
        self.sandbox = Sandboxed(
            law.source,
            ny=p.ny,
            params=asdict(controller_params(run)),
            deadline=settings.deadline,
            max_misses=settings.max_misses,
            filename=law.name,
            hold=False,  # a simulated plant waits: the samples never depend on the load
            patience=settings.patience,
            budget=settings.budget,
            start_timeout=settings.start,
        )

    @property
    def width(self) -> int:
        """Columns of a row: ``r, u, y…, x…``."""
        p = self.run.spec.plant
        return 2 + p.ny + p.nx

    def set_run(self, run: CompiledRun) -> None:
        """New signals from the next sample on (the same controller and plant)."""
        self.run = run

    def advance(self, n: int) -> tuple[Array, str | None]:
        """The next ``n`` samples (rows ``r, u, y…, x…``, absolute), or those before the
        controller failed and why."""
        run, ny = self.run, self.run.spec.plant.ny
        exo = run.exogenous(self.k, n)
        out = np.empty((n, self.width))
        u_lim, Ts, step = run.u_lim, run.Ts, self.sandbox.step
        C, x, xn, y, q, y_op, x_op = (
            self._C,
            self._x,
            self._xn,
            self._y,
            self._quantum,
            self._y_op,
            self._x_op,
        )
        Ad, Bd = self._Ad, self._Bd
        peak = self.peak_command
        for i in range(n):
            row, e = out[i], exo[i]
            r = float(e[0])
            sense(C, x, e[2:], q, y_op, x_op, y, row)
            try:
                v = step((self.k + i) * Ts, row[2 : 2 + ny].tolist(), r)
            except ControllerFailed as exc:
                self.k += i
                self.peak_command = peak
                return out[:i], str(exc)
            asked = v + float(e[1])
            peak = max(peak, abs(asked))
            u = min(max(asked, -u_lim), u_lim)
            row[0], row[1] = r, u
            actuate(Ad, Bd, x, u, xn)
        self.k += n
        self.peak_command = peak
        return out, None

    def times(self) -> dict[str, float | int]:
        """The controller's compute time per step so far."""
        return self.sandbox.times.summary()

    def close(self) -> None:
        self.sandbox.close()


@dataclass(frozen=True)
class Outcome:
    """A whole code-controller run stepped at once: its rows (``r, u, y…, x…``), why it
    ended early (``None``: it ran to the end) and the controller's compute times."""

    rows: Array
    failed: str | None
    times: dict[str, float | int]
    peak_command: float = 0.0  # the largest |u| the controller asked for (before the limit)


def run_through(run: CompiledRun, settings: CodeSettings | None = None) -> Outcome:
    """Step ``run`` to its end as fast as it goes, in the same blocks of samples and with
    the same divergence check as the server's stepper, so the samples are the server's."""
    try:
        coded = CodedRun(run, settings)
    except ControllerFailed as exc:  # it did not start: its module or reset() failed
        p = run.spec.plant
        return Outcome(np.zeros((0, 2 + p.ny + p.nx)), str(exc), StepTimes().summary())
    parts: list[Array] = []
    failed = None
    try:
        while coded.k < run.n_samples and failed is None:
            k0 = coded.k
            data, failed = coded.advance(min(1024, run.n_samples - k0))
            i = first_divergence(data[:, 1:])
            if i is not None:
                data = data[:i]
                failed = diverged((k0 + i) * run.Ts)
            parts.append(data)
    finally:
        coded.close()
    rows = np.concatenate(parts) if parts else np.zeros((0, coded.width))
    return Outcome(rows, failed, coded.times(), coded.peak_command)


def trial(plant: Plant, law: CodeController, settings: CodeSettings | None = None) -> Report:
    """A code controller's report: trial runs on the plant's model in its sandbox, a step
    and a square wave of the plant's default amplitude (each the plant's default duration,
    at most 10 s), with the controller's compute time. A failure (it raised, returned no
    number, missed its deadline too often, tried what the sandbox forbids) or a diverging
    loop is a problem; saturation, slow settling, chatter and late steps are warnings."""
    settings = settings or CodeSettings()
    amplitude = plant.signal.amplitude or 1.0
    T = min(plant.signal.duration, 10.0)
    period = plant.signal.period or min(4.0, T / 2)
    ref = plant.reference_output
    problems: list[str] = []
    warnings: list[str] = []
    peak = 0.0
    compute: dict[str, float | int] = {}
    for what, signal in (("step", Step(amplitude)), ("square wave", Square(amplitude, period))):
        out = run_through(compile_run(RunSpec(plant, law, signal, duration=T)), settings)
        rows = out.rows
        if out.failed is not None:
            t = rows.shape[0] * plant.Ts
            problems.append(f"in the {what} trial at t = {t:.4g} s: {out.failed}")
        if what == "step":
            # what it asked for, before the actuator's limit: the linear report's peak
            # |u| for the same step, in its words (a law agrees with itself as code)
            peak = out.peak_command
            warnings += saturation(plant, amplitude, peak)
        if rows.shape[0]:
            u = rows[:, 1]
            du = np.diff(u)
            flips = np.mean(du[1:] * du[:-1] < 0) if du.size > 2 else 0.0
            if flips > 0.3 and np.std(du) > 0.01 * plant.u_max:
                warnings.append(
                    f"u chatters in the {what} trial: its direction changes in {flips:.0%} "
                    "of the samples"
                )
        if what == "step" and out.failed is None:
            tail = rows[-max(1, rows.shape[0] // 10) :, 2 + ref]
            y_op = float((plant.C @ plant.operating_point)[ref])
            err = float(np.max(np.abs(tail - y_op - amplitude)))
            unit = plant.outputs[ref].unit
            if err > RUNAWAY * abs(amplitude):
                problems.append(
                    f"the step response runs away (off by {err:.3g} {unit} after {T:g} s, "
                    f"{err / abs(amplitude):.3g} times the step): the loop is unstable, or a "
                    "sign is wrong"
                )
            elif err > 0.05 * abs(amplitude):
                warnings.append(
                    f"the step response has not settled within 5 % after {T:g} s (off by "
                    f"{err:.3g} {unit} at the end)"
                )
        compute = _worse(compute, out.times)
        if out.failed is not None:
            break  # the other trial would only fail the same way
    slow, steps = int(compute.get("slow", 0)), int(compute.get("steps", 0))
    if slow > LATE_SHARE * max(steps, 1):
        warnings.append(
            f"{slow} of {steps} steps took the controller longer than the deadline of "
            f"{settings.deadline * 1e3:g} ms: on the rig each holds the last u; the "
            "controller is slow for this sample time"
        )
    unit = plant.outputs[ref].unit
    return Report(
        plant=plant.id,
        kind="CodeController",
        poles=(),
        stable=not problems,
        gain_margin_db=None,
        phase_margin_deg=None,
        peak_u=peak if not problems else None,
        u_max=plant.u_max,
        step_amplitude=amplitude,
        problems=tuple(problems),
        warnings=tuple(warnings),
        domain="trial",
        compute=compute,
        trial=f"a step and a square wave (period {period:g} s) of {amplitude:.4g} {unit}, "
        f"{T:g} s each, on the model",
    )


def report(plant: Plant, law: ControlLaw, settings: CodeSettings | None = None) -> Report:
    """The validation report of any controller: on the linear model, or for code a trial
    in its sandbox (what upload and ``elab check`` give)."""
    match law:
        case CodeController():
            return trial(plant, law, settings)
        case _:
            return check(plant, law)


def _worse(a: dict[str, float | int], b: dict[str, float | int]) -> dict[str, float | int]:
    """Two trials' compute times: the larger of each figure, the counts summed."""
    if not a:
        return dict(b)
    out = {k: max(a[k], b[k]) for k in a}
    for count in ("steps", "misses", "slow"):
        out[count] = a[count] + b[count]
    return out
