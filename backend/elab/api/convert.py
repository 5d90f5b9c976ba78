"""Wire models ↔ core types (laws, signals, run specs). Validation happened in
the models; the core re-checks what only it knows (dimensions, sample time)."""

from __future__ import annotations

import dataclasses
import math
import secrets
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, assert_never

import numpy as np
from numpy.typing import NDArray

from elab.api import schemas as s
from elab.errors import InvalidInput
from elab.laws import PID, CodeController, ControlLaw, LTIController, OpenLoop, StateFeedback
from elab.plants.base import Plant, SignalDefaults
from elab.sim import signals as sig
from elab.sim.spec import RunSpec
from elab.store.base import JsonObject, RunRecord

if TYPE_CHECKING:
    from elab.design.response import StepInfo


def law(model: s.Controller, plant: Plant) -> ControlLaw:
    """The control law of a controller model (``predefined`` → the plant's)."""
    match model:
        case s.PredefinedController():
            return plant.predefined
        case s.StateFeedbackController():
            return StateFeedback(
                tuple(model.K),
                model.estimate,
                model.Nr,
                _rows(model.L),
                None
                if model.observer_poles is None
                else tuple(complex(p.re, p.im) for p in model.observer_poles),
            )
        case s.PIDController():
            return PID(**model.model_dump(exclude={"kind"}))
        case s.LTIControllerModel():
            return LTIController(
                num=_tuple(model.num),
                den=_tuple(model.den),
                A=_rows(model.A),
                B=_rows(model.B),
                C=_rows(model.C),
                D=_rows(model.D),
                dt=model.dt,
                ff_num=_tuple(model.ff_num),
                ff_den=_tuple(model.ff_den),
                B_r=_rows(model.B_r),
                D_r=_rows(model.D_r),
            )
        case s.OpenLoopController():
            return OpenLoop()
        case _:
            assert_never(model)


def law_model(law_: ControlLaw) -> s.Controller:
    """The model of a core law (for a plant's predefined controller)."""
    match law_:
        case StateFeedback():
            return s.StateFeedbackController(
                kind="state_feedback",
                K=list(law_.K),
                estimate=law_.estimate,
                Nr=law_.Nr,
                L=None if law_.L is None else [list(r) for r in law_.L],
                observer_poles=None
                if law_.observer_poles is None
                else complex_list(law_.observer_poles),
            )
        case PID():
            return s.PIDController(kind="pid", **dataclasses.asdict(law_))
        case OpenLoop():
            return s.OpenLoopController(kind="open_loop")
        case CodeController():
            raise InvalidInput("controller", law_.name, "a declarative law (this one is code)")
        case LTIController():
            matrices = {
                k: [list(r) for r in getattr(law_, k)]
                for k in ("A", "B", "C", "D", "B_r", "D_r")
                if getattr(law_, k) is not None
            }
            return s.LTIControllerModel.model_validate(
                {
                    "kind": "lti",
                    "num": _list(law_.num),
                    "den": _list(law_.den),
                    "dt": law_.dt,
                    "ff_num": _list(law_.ff_num),
                    "ff_den": _list(law_.ff_den),
                    **matrices,
                }
            )
        case _:
            assert_never(law_)


def signal(model: Any) -> sig.Signal:
    data = model.model_dump(exclude={"kind"})
    if isinstance(model, s.SamplesSignal):
        return sig.Samples(tuple(model.values))
    return sig.make_signal(model.kind, **data)


def default_signal(plant: Plant) -> Any:
    return signal_defaults(plant.signal)


def signal_defaults(d: SignalDefaults) -> Any:
    """The API's signal of a plant's defaults (its analysis run's, a lesson step's)."""
    if d.kind == "square":
        return s.SquareSignal.model_validate(
            {"kind": "square", "amplitude": d.amplitude, "period": d.period}
        )
    if d.kind == "sine":
        return s.SineSignal.model_validate(
            {"kind": "sine", "amplitude": d.amplitude, "frequency": 1 / d.period}
        )
    return s.StepSignal.model_validate({"kind": "step", "amplitude": d.amplitude})


def sensors(req: s.RunCreate) -> dict[str, Any]:
    """``noise``, ``seed`` and ``quantize`` as the run uses them: realistic sensors (the
    plant's noise and quantisation) by default for simulated identification runs, ideal
    ones otherwise; noise without a seed gets a random one, so the recorded request
    repeats the run."""
    realistic = req.experiment == "identification" and req.mode == "simulation"
    noise = req.noise if req.noise is not None else realistic or req.seed is not None
    if not noise and req.seed is not None:
        raise InvalidInput("seed", req.seed, "no seed with noise false (a seed draws the noise)")
    seed = None if not noise else req.seed if req.seed is not None else secrets.randbits(32)
    quantize = req.quantize if req.quantize is not None else realistic
    return {"noise": noise, "seed": seed, "quantize": quantize}


def run_spec(req: s.RunCreate, plant: Plant, law_: ControlLaw | None = None) -> RunSpec:
    """The core run of a request, with the plant's defaults filled in (``law_``: the law of
    an uploaded controller, instead of ``req.controller``'s)."""
    if req.mode == "rig" and "rig" not in plant.modes:
        raise InvalidInput("mode", req.mode, f"one of {', '.join(plant.modes)} for {plant.id}")
    if req.mode == "rig" and req.pace != "realtime":
        raise InvalidInput("pace", req.pace, "realtime: a rig run goes at the rig's clock")
    if req.experiment not in plant.experiments:
        raise InvalidInput("experiment", req.experiment, f"one of {', '.join(plant.experiments)}")
    return RunSpec(
        plant=plant,
        law=law_ if law_ is not None else law(req.controller, plant),
        reference=signal(req.signal or default_signal(plant)),
        duration=req.duration if req.duration is not None else plant.signal.duration,
        Ts=req.Ts,
        excitation=signal(req.excitation) if req.excitation else None,
        excitation_at=req.excitation_at,
        saturate=req.saturate,
        noise_seed=req.seed,
        quantize=bool(req.quantize),
        x0=tuple(req.x0) if req.x0 is not None else None,
    )


@dataclass(frozen=True)
class Requested:
    """What a run's stored request says about how it ran, read in this one place and
    leniently (a run recorded by an earlier version may lack any of it): its controller
    and signal as asked (``None``: the plant's), the noise's ``seed`` (``None``: no
    noise), whether outputs were quantised, the frequency (Hz) of a sine that excited
    it (its excitation's, else its signal's), and whether it ran in closed loop (any
    controller but an open-loop one: its own, an uploaded one, the plant's predefined),
    its plant, and whether it ran on the real rig."""

    controller: JsonObject | None
    signal: JsonObject | None
    seed: int | None
    quantize: bool
    sine_hz: float | None
    closed_loop: bool
    plant: str
    rig: bool


def requested(record: RunRecord) -> Requested:
    spec = record.spec
    noise = spec.get("noise", spec.get("seed") is not None)
    sines = [
        float(sig["frequency"])
        for sig in (spec.get("excitation"), spec.get("signal"))
        if isinstance(sig, dict) and sig.get("kind") == "sine"
    ]
    return Requested(
        controller=spec.get("controller"),
        signal=spec.get("signal"),
        seed=spec.get("seed") if noise else None,
        quantize=bool(spec.get("quantize")),
        sine_hz=sines[0] if sines else None,
        # its own controller, an uploaded one, or the plant's predefined feedback
        closed_loop=(spec.get("controller") or {}).get("kind") != "open_loop",
        plant=record.plant,
        rig=spec.get("mode") == "rig",
    )


def complex_list(values: Any) -> list[s.Complex]:
    return [s.Complex(re=float(complex(z).real), im=float(complex(z).imag)) for z in values]


def finite_or_none(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None


def step_info(info: StepInfo) -> s.StepInfoOut:
    """A step response's characteristics as the API gives them (undefined ones null)."""
    return s.StepInfoOut(**{k: finite_or_none(v) for k, v in vars(info).items()})


def finite_response(v: NDArray[np.float64]) -> list[float]:
    """A computed response's values; :class:`InvalidInput` naming the horizon ``T`` where
    it overflowed (an unstable loop)."""
    if not np.all(np.isfinite(v)):
        raise InvalidInput("T", None, "a shorter horizon: the response overflows (unstable loop)")
    return v.tolist()  # type: ignore[no-any-return]


def _tuple(v: list[float] | None) -> tuple[float, ...] | None:
    return tuple(v) if v is not None else None


def _rows(v: list[list[float]] | None) -> tuple[tuple[float, ...], ...] | None:
    return tuple(tuple(r) for r in v) if v is not None else None


def _list(v: tuple[float, ...] | None) -> list[float] | None:
    return list(v) if v is not None else None
