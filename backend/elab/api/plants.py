"""``/plants``: models, analysis, Bode, step responses and state-feedback design."""

from __future__ import annotations

import asyncio
from typing import Any, Literal

import numpy as np
from starlette.requests import Request
from starlette.responses import Response

from elab import design
from elab.api import convert
from elab.api import schemas as s
from elab.api.http import Param, computed, endpoint, ok, query
from elab.api.paths import plant_and_body, plant_of
from elab.api.state import lab
from elab.errors import NotFound
from elab.laws import ControlLaw, OpenLoop, has_feedback
from elab.plants import PLANTS, Channel, Plant

#: every output name of any plant (which ones a plant has: GET /plants/{plant_id})
OUTPUTS = sorted({o.name for p in PLANTS.values() for o in p.outputs})


def _summary(p: Plant, request: Request) -> s.PlantSummary:
    engines = lab(request).manager.engines
    return s.PlantSummary(
        id=p.id,
        name=p.name,
        summary=p.summary,
        # what this server can run: the rig only where it has one (ELAB_RIG)
        modes=[m for m in p.modes if m in engines],
        experiments=list(p.experiments),
    )


@endpoint("GET", "/plants", response=list[s.PlantSummary], errors=())
async def list_plants(request: Request) -> Response:
    """List the plants"""
    return ok([_summary(p, request) for p in PLANTS.values()])


@endpoint("GET", "/plants/{plant_id}", response=s.PlantDetail, errors=(404,))
async def get_plant_detail(request: Request) -> Response:
    """A plant: model, units, limits, defaults, description"""
    p = plant_of(request)

    def ch(cs: tuple[Channel, ...]) -> list[s.PlantChannel]:
        return [s.PlantChannel(name=c.name, unit=c.unit, label=c.label) for c in cs]

    return ok(
        s.PlantDetail(
            **_summary(p, request).model_dump(),
            A=p.A.tolist(),
            B=p.B.tolist(),
            C=p.C.tolist(),
            D=p.D.tolist(),
            states=ch(p.states),
            inputs=ch(p.inputs),
            outputs=ch(p.outputs),
            u_max=p.u_max,
            saturate=p.saturate,
            Ts=p.Ts,
            reference_output=p.outputs[p.reference_output].name,
            operating_point=p.operating_point.tolist(),
            initial_state_ranges=[
                (p.states[i].name, lo, hi) for i, lo, hi in p.initial_state_ranges
            ],
            predefined=convert.law_model(p.predefined),
            predefined_design=p.predefined_design,
            default_signal=convert.default_signal(p),
            default_duration=p.signal.duration,
            default_x0=None if p.signal.x0 is None else list(p.signal.x0),
            sensors={"quantum": list(p.sensors.quantum), "noise_std": list(p.sensors.noise_std)},
            identification=s.IdentDefaultsInfo(
                models=p.identification.models,
                decimate=p.identification.decimate,
                why=p.identification.why,
            ),
            integrating=bool(np.min(np.abs(np.linalg.eigvals(p.A))) < 1e-9),
            lesson=[
                s.LessonStepInfo(
                    title=step.title,
                    text=step.text,
                    controller=convert.law_model(step.law),
                    signal=convert.signal_defaults(step.signal),
                    duration=step.signal.duration,
                    x0=None if step.signal.x0 is None else list(step.signal.x0),
                )
                for step in p.lesson
            ],
            description=p.description,
        )
    )


def _rank(r: design.RankReport, n: int) -> s.RankInfo:
    return s.RankInfo(
        rank=r.rank,
        n=n,
        full=r.full,
        condition_number=convert.finite_or_none(r.condition_number),
        singular_values=r.singular_values.tolist(),
    )


@endpoint("GET", "/plants/{plant_id}/analysis", response=s.AnalysisInfo, errors=(404,))
async def analysis(request: Request) -> Response:
    """Eigenvalues, stability verdict, controllability, observability, transfer functions"""
    p = plant_of(request)
    a = await asyncio.to_thread(_analyze, p)
    return ok(
        s.AnalysisInfo(
            plant=p.id,
            eigenvalues=convert.complex_list(a.stability.eigenvalues),
            verdict=a.stability.verdict,
            reason=a.stability.reason,
            controllability=_rank(a.controllability, p.nx),
            observability=_rank(a.observability, p.nx),
            transfer_functions=[
                s.TransferFunctionInfo(
                    output=tf.output,
                    input=tf.input,
                    num=tf.num.tolist(),
                    den=tf.den.tolist(),
                    text=tf.text(),
                    latex=tf.latex(),
                )
                for tf in a.transfer_functions
            ],
        )
    )


@endpoint(
    "GET",
    "/plants/{plant_id}/bode",
    response=s.BodeList,
    params=(
        Param(
            "output",
            "query",
            "one output's name (404: not one of the plant's)",
            {"type": "string", "enum": OUTPUTS},
        ),
    ),
)
async def bode(request: Request) -> Response:
    """Open-loop Bode diagram of each output (or one)"""
    p = plant_of(request)
    name = query(request, "output")
    names = [o.name for o in p.outputs]
    if name is not None and name not in names:
        raise NotFound(f"output of {p.id}", name, names)
    b = await asyncio.to_thread(_bode, p)
    keep = [i for i, o in enumerate(names) if name in (None, o)]
    return ok(
        s.BodeList(
            plant=p.id,
            input=p.inputs[0].name,
            bode=[
                s.BodeInfo(
                    output=names[i],
                    omega=b.omega.tolist(),
                    hz=b.hz.tolist(),
                    mag_db=b.mag_db[i].tolist(),
                    phase_deg=b.phase_deg[i].tolist(),
                )
                for i in keep
            ],
        )
    )


@endpoint("POST", "/plants/{plant_id}/step", body=s.StepRequest, response=s.StepOut)
async def step(request: Request) -> Response:
    """Step response: open loop, or closed loop with a controller (linear, continuous)"""
    p, req = await plant_and_body(request, s.StepRequest)
    law = OpenLoop() if req.controller is None else convert.law(req.controller, p)
    return ok(await asyncio.to_thread(computed, _step, p, law, req))


def _step(p: Plant, law: ControlLaw, req: s.StepRequest) -> s.StepOut:
    loop: Literal["open", "closed"] = "closed" if has_feedback(law) else "open"
    sys = design.closed_loop(p, law)
    stab = design.stability(sys.A)
    T = req.T or design.default_horizon(stab.eigenvalues)
    r = design.step_response(sys, T=T, n=req.n, amplitude=req.amplitude, u_output=-1)
    cut = _leaves_range(p, r.y)
    if cut is not None and req.T is None:  # again up to just past the exit, finely sampled
        T = 1.25 * float(r.t[cut[1]])
        r = design.step_response(sys, T=T, n=req.n, amplitude=req.amplitude, u_output=-1)
        cut = _leaves_range(p, r.y)
    end = r.t.size if cut is None else cut[1] + 1
    y_ref = r.y[p.reference_output]
    info = None
    if loop == "closed" and cut is None and np.all(np.isfinite(r.y)):
        si = design.step_info(r.t, y_ref, req.amplitude)
        info = convert.step_info(si)
    return s.StepOut(
        plant=p.id,
        loop=loop,
        t=r.t[:end].tolist(),
        outputs={o.name: convert.finite_response(r.y[i, :end]) for i, o in enumerate(p.outputs)},
        u=convert.finite_response(r.u[:end]),
        info=info,
        poles=convert.complex_list(stab.eigenvalues),
        verdict=stab.verdict,
        cut=None
        if cut is None
        else s.StepCut(
            output=p.outputs[cut[0]].name, t=float(r.t[cut[1]]), low=cut[2], high=cut[3]
        ),
    )


def _leaves_range(p: Plant, y: np.ndarray) -> tuple[int, int, float, float] | None:
    """``(output, first sample outside, lo, hi)`` of the earliest exit of a (deviation)
    response from the plant's output ranges, or None."""
    op = p.C @ p.operating_point
    exits = []
    for i, lo, hi in p.output_ranges:
        with np.errstate(invalid="ignore"):
            outside = ~((y[i] + op[i] >= lo) & (y[i] + op[i] <= hi))
        if outside.any():
            exits.append((int(np.argmax(outside)), i, lo, hi))
    if not exits:
        return None
    k, i, lo, hi = min(exits)
    return i, k, lo, hi


@endpoint("POST", "/plants/{plant_id}/design/lqr", body=s.LQRRequest, response=s.DesignOut)
async def design_lqr(request: Request) -> Response:
    """LQR state feedback from Q and R"""
    p, req = await plant_and_body(request, s.LQRRequest)
    res = await asyncio.to_thread(computed, _lqr, p, req.Q, req.R, field="Q", value=req.Q)
    return ok(_design_out(p, "lqr", res))


@endpoint("POST", "/plants/{plant_id}/design/place", body=s.PlaceRequest, response=s.DesignOut)
async def design_place(request: Request) -> Response:
    """Pole placement: K from closed-loop poles"""
    p, req = await plant_and_body(request, s.PlaceRequest)
    poles = [complex(z.re, z.im) for z in req.poles]
    res = await asyncio.to_thread(computed, _place, p, poles, field="poles", value=req.poles)
    return ok(_design_out(p, "place", res))


def _design_out(
    p: Plant, method: Literal["lqr", "place"], res: design.LQR | design.Placement
) -> s.DesignOut:
    return s.DesignOut(
        plant=p.id,
        method=method,
        K=np.ravel(res.K).tolist(),
        closed_loop_poles=convert.complex_list(res.poles),
    )


# On threads, never on the event loop: the first lookup of a name of ``elab.design``
# imports it and python-control (seconds on a loaded host; tests/api/loopaudit).


def _analyze(p: Plant) -> design.Analysis:
    return design.analyze(p)


def _lqr(p: Plant, Q: Any, R: Any) -> design.LQR:
    return design.design_lqr(p, Q, R)


def _place(p: Plant, poles: list[complex]) -> design.Placement:
    return design.design_place(p, poles)


def _bode(p: Plant) -> design.Bode:
    import control as ct  # at the first analysis, not at the web process's start

    return design.bode(ct.ss(p.A, p.B, p.C, p.D))
