"""What a run is (:class:`RunSpec`) and its validated, discretised form.

:func:`compile_run` checks every user-given number once, discretises the plant
exactly (zero-order hold) and the controller (Tustin), and returns a
:class:`CompiledRun` the stepping loop trusts.
"""

from __future__ import annotations

import math
import threading
import weakref
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Literal

import numpy as np
from numpy.typing import NDArray

from elab.errors import InvalidInput
from elab.laws import ControlLaw
from elab.plants.base import Plant
from elab.sim.noise import sensor_noise
from elab.sim.signals import PRBS, Chirp, Signal, Sine, Square, Step
from elab.sim.signals import Samples as UserSamples
from elab.validate import computable, finite_array, finite_float, finite_result

if TYPE_CHECKING:
    from elab.sim.controllers import DiscreteController

Array = NDArray[np.float64]

MAX_POLE_TS = 0.5  # largest allowed |λ|·Ts: at least 2π/0.5 ≈ 13 samples per radian period
MAX_DURATION = 3600.0  # s
MIN_SAMPLES = 10  # the shortest run: fewer samples show no response
#: the longest run the loop steps (an hour at 10 kHz): its block is allocated whole, and a
#: sample time of 1e-300 s asked for more than memory holds (the server's own limit,
#: ELAB_MAX_RUN_SAMPLES, is lower and may not be set above this)
MAX_SAMPLES = 36_000_000
DIVERGENCE_LIMIT = 1e9  # |state| or |input| beyond this (SI units) means the loop diverged
#: the largest value a signal may take (SI units): a larger reference would fail its run
#: as diverged ("unstable") at its first sample
MAX_SIGNAL = DIVERGENCE_LIMIT
MIN_PERIOD_SAMPLES = 4  # samples per period of a periodic signal (2 is Nyquist's bare minimum)


@dataclass(frozen=True)
class RunSpec:
    """A simulation run: plant, controller, signals, duration and sensors.

    ``Ts``, ``saturate`` and ``u_max`` default to the plant's. ``excitation`` is
    added at the reference or at the plant input (closed-loop identification).
    ``noise_seed=None`` means noise-free sensors; ``quantize`` rounds outputs
    to the sensor resolution. ``x0`` is the absolute initial state.
    """

    plant: Plant
    law: ControlLaw
    reference: Signal = field(default_factory=lambda: Step(0.0))
    duration: float = 10.0
    Ts: float | None = None
    excitation: Signal | None = None
    excitation_at: Literal["reference", "input"] = "input"
    saturate: bool | None = None
    u_max: float | None = None
    noise_seed: int | None = None
    quantize: bool = False
    x0: tuple[float, ...] | None = None


@dataclass(frozen=True)
class CompiledRun:
    """A validated run with its discrete plant and controller."""

    spec: RunSpec
    Ts: float
    n_samples: int
    Ad: Array
    Bd: Array
    controller: DiscreteController
    u_lim: float
    quantum: Array
    noise_std: Array
    x0: Array  # deviation from the operating point

    def exogenous(self, k0: int, n: int, out: Array | None = None) -> Array:
        """Inputs from outside the loop for samples k0..k0+n-1: ``[r, e, v_1..v_ny]``,
        written into ``out`` (n × 2 + ny) where given (a batch's own block)."""
        spec, ny = self.spec, self.spec.plant.ny
        exo = np.empty((n, 2 + ny)) if out is None else out
        exo[:, 0] = spec.reference.sample(k0, n, self.Ts)
        exo[:, 1] = 0.0
        if spec.excitation is not None:
            col = 0 if spec.excitation_at == "reference" else 1
            exo[:, col] += spec.excitation.sample(k0, n, self.Ts)
        if spec.noise_seed is not None:
            sensor_noise(spec.noise_seed, k0, n, self.noise_std, out=exo[:, 2:])
        else:
            exo[:, 2:] = 0.0
        return exo


def compile_run(spec: RunSpec) -> CompiledRun:
    """Validate ``spec`` and discretise it; errors name the field and allowed values."""
    # here, not at the top: a process that only describes runs (the web process) need not
    # import scipy (docs/architecture.md)
    from elab.lti import zoh
    from elab.sim.controllers import discretise

    plant = spec.plant
    Ts = plant.Ts if spec.Ts is None else finite_float("Ts", spec.Ts, 0.0, lo_open=True)
    duration = finite_float("duration", spec.duration, 0.0, MAX_DURATION, lo_open=True)
    if not duration / Ts <= MAX_SAMPLES:  # also inf, for a subnormal Ts
        raise InvalidInput(
            "Ts",
            Ts,
            f"a sample time ≥ {duration / MAX_SAMPLES:g} s for a {duration:g} s run: at most "
            f"{MAX_SAMPLES:,} samples (duration / Ts)",
        )
    n_samples = round(duration / Ts)
    if n_samples < MIN_SAMPLES:
        raise InvalidInput(
            "duration",
            duration,
            f"at least {MIN_SAMPLES} samples: a duration ≥ {MIN_SAMPLES * Ts:g} s at Ts = {Ts:g} s",
        )
    _check_periods("signal", spec.reference, Ts)
    _check_periods("excitation", spec.excitation, Ts)
    _check_size("signal", spec.reference)
    _check_size("excitation", spec.excitation)
    seed = spec.noise_seed
    if seed is not None and (
        not isinstance(seed, int) or isinstance(seed, bool) or not 0 <= seed <= 2**63 - 1
    ):
        raise InvalidInput("noise_seed", seed, "an integer in [0, 2^63 − 1]")
    allowed = (
        "a controller whose numbers keep its arithmetic finite: no gain, coefficient or "
        "time constant so large or so small that it overflows or divides by zero"
    )
    done = _DISCRETE.get(plant, spec.law, Ts)
    if done is None:
        with computable("controller", spec.law, allowed):
            _check_sample_time(spec.law, plant, Ts)
            controller = discretise(spec.law, plant, Ts)
            c = controller
            finite_result("controller", spec.law, allowed, c.Ac, c.Bc, c.Cc, c.Dc, c.Lw)
        Ad, Bd = zoh(plant.A, plant.B, Ts)
        done = _DISCRETE.put(
            plant,
            spec.law,
            Ts,
            _Discrete(
                _readonly(controller),
                _frozen(Ad),
                _frozen(Bd[:, 0]),
            ),
        )
    saturate = plant.saturate if spec.saturate is None else spec.saturate
    u_max = (
        plant.u_max if spec.u_max is None else finite_float("u_max", spec.u_max, 0.0, lo_open=True)
    )
    return CompiledRun(
        spec=spec,
        Ts=Ts,
        n_samples=n_samples,
        Ad=done.Ad,
        Bd=done.Bd,
        controller=done.controller,
        u_lim=u_max if saturate else math.inf,
        quantum=np.array(plant.sensors.quantum if spec.quantize else (0.0,) * plant.ny),
        noise_std=np.array(plant.sensors.noise_std),
        x0=_initial_state(spec),
    )


@dataclass(frozen=True)
class _Discrete:
    """What discretising a law for a plant at a sample time gave (read-only arrays)."""

    controller: DiscreteController
    Ad: Array
    Bd: Array


def _frozen(a: Array) -> Array:
    a.setflags(write=False)
    return a


def _readonly(c: DiscreteController) -> DiscreteController:
    for a in (c.Ac, c.Bc, c.Cc, c.Dc, c.Lw):
        a.setflags(write=False)
    return c


_Entries = dict[tuple[ControlLaw, float], _Discrete]


class _DiscreteCache:
    """Each plant's discretised laws by (law, Ts), the last :data:`PER_PLANT` of each:
    python-control's c2d and Tustin are 1–2 ms of every :func:`compile_run` (most of a
    short simulation, and of each run a burst creates), for the same few laws again and
    again. A plant is frozen; its entries are keyed by its identity and dropped with it
    (a weak reference), a law by its value (laws are frozen, hashable dataclasses; one
    that is not hashable is not kept). Only laws that passed the checks are kept."""

    PER_PLANT = 64

    def __init__(self) -> None:
        # reentrant: a plant's weak-reference callback may run in a collection that an
        # allocation under the lock set off
        self._lock = threading.RLock()
        self._by: dict[
            int, tuple[weakref.ref[Plant], dict[tuple[ControlLaw, float], _Discrete]]
        ] = {}

    def get(self, plant: Plant, law: ControlLaw, Ts: float) -> _Discrete | None:
        with self._lock:
            held = self._by.get(id(plant))
            if held is None or held[0]() is not plant:
                return None
            try:
                return held[1].get((law, Ts))
            except TypeError:  # an unhashable law
                return None

    def put(self, plant: Plant, law: ControlLaw, Ts: float, done: _Discrete) -> _Discrete:
        with self._lock:
            held = self._by.get(id(plant))
            if held is None or held[0]() is not plant:
                key = id(plant)

                def forget(_: weakref.ref[Plant], key: int = key) -> None:
                    self._forget(key)

                held = self._by[key] = (weakref.ref(plant, forget), {})
            entries = held[1]
            try:
                if len(entries) >= self.PER_PLANT:
                    del entries[next(iter(entries))]
                entries[(law, Ts)] = done
            except TypeError:
                pass
        return done

    def _forget(self, key: int) -> None:
        with self._lock:
            held = self._by.get(key)
            if held is not None and held[0]() is None:
                del self._by[key]


_DISCRETE = _DiscreteCache()


def _check_periods(name: str, signal: Signal | None, Ts: float) -> None:
    """A periodic signal needs :data:`MIN_PERIOD_SAMPLES` samples per period: a faster one
    aliases (a sine at the Nyquist frequency samples as a constant)."""
    shortest = MIN_PERIOD_SAMPLES * Ts
    at = f"at least {MIN_PERIOD_SAMPLES} samples per period at Ts = {Ts:g} s"
    if isinstance(signal, Square) and signal.period < shortest:
        raise InvalidInput(f"{name}.period", signal.period, f"a period ≥ {shortest:g} s ({at})")
    fastest = 1.0 / shortest
    if isinstance(signal, Sine) and signal.frequency > fastest:
        raise InvalidInput(
            f"{name}.frequency", signal.frequency, f"a frequency ≤ {fastest:g} Hz ({at})"
        )
    if isinstance(signal, Chirp):
        for f, value in (("f0", signal.f0), ("f1", signal.f1)):
            if value > fastest:
                raise InvalidInput(f"{name}.{f}", value, f"a frequency ≤ {fastest:g} Hz ({at})")


def _check_size(name: str, signal: Signal | None) -> None:
    """A signal's values stay within :data:`MAX_SIGNAL` (its offset ± its amplitude, or
    its samples)."""
    if isinstance(signal, UserSamples):
        peak = float(np.max(np.abs(signal.values))) if signal.values else 0.0
        field, value = f"{name}.values", peak
    elif isinstance(signal, Step | Square | Sine | Chirp | PRBS):
        peak = abs(signal.offset) + abs(signal.amplitude)
        field, value = f"{name}.amplitude", signal.amplitude
    else:
        return  # none, or a signal of the caller's own making: its values are its own
    if not peak <= MAX_SIGNAL:
        raise InvalidInput(
            field,
            value,
            f"values within ±{MAX_SIGNAL:g} (offset ± amplitude, in SI units): a state or "
            f"input beyond it counts as diverged",
        )


def _check_sample_time(law: ControlLaw, plant: Plant, Ts: float) -> None:
    from elab.sim.controllers import controller_poles

    poles = np.concatenate([np.linalg.eigvals(plant.A), controller_poles(law, plant)])
    fastest = float(np.max(np.abs(poles))) if poles.size else 0.0
    if fastest * Ts > MAX_POLE_TS:
        raise InvalidInput(
            "Ts",
            Ts,
            f"a sample time ≤ {MAX_POLE_TS}/|λ|max = {MAX_POLE_TS / fastest:.3g} s "
            f"(fastest pole of plant and controller: {fastest:.4g} rad/s)",
        )


def _initial_state(spec: RunSpec) -> Array:
    plant = spec.plant
    if spec.x0 is None:
        return np.zeros(plant.nx)
    x0 = finite_array("x0", spec.x0, (plant.nx,))
    for s, lo, hi in plant.initial_state_ranges:
        if not lo <= x0[s] <= hi:
            raise InvalidInput(
                f"x0[{s}] ({plant.states[s].name})",
                float(x0[s]),
                f"[{lo:.4g}, {hi:.4g}] {plant.states[s].unit} (the linear model's validity range)",
            )
    return x0 - plant.operating_point
