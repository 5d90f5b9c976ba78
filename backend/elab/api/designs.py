"""Designs and their loops, computed here (python-control; the one simulator):

- a design on a kept model (``POST /models/{model_id}/design``): LQR, pole placement, a
  gain typed by hand (each on an observer's estimate) or PID, in discrete or continuous
  time, with the loop's step, root locus, margins, peak input, and the law a run of the
  plant takes;
- the loop of any controller on a plant's physics model (``POST /plants/{id}/loop``):
  poles, verdict, root locus, margins, peak input;
- any controller as a file (``POST /plants/{id}/controller-file``), which reads back as
  the same law.

python-control and the design modules are imported by the functions that compute, at the
first design: the web process starts without them (docs/architecture.md, start-up).
"""

from __future__ import annotations

import asyncio
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, TypeVar

import numpy as np
from starlette.requests import Request
from starlette.responses import Response

from elab import controllers as ctl
from elab.api import convert
from elab.api import schemas as s
from elab.api.controllers import MEDIA
from elab.api.http import computed, endpoint, ok, read_model
from elab.api.models import core_model, not_runnable, reference_index, stored
from elab.api.paths import plant_and_body
from elab.errors import InvalidInput
from elab.laws import PID, ControlLaw, LTIController, has_feedback
from elab.plants import Plant, get_plant
from elab.store.base import StoredModel

if TYPE_CHECKING:
    from elab.design import loop
    from elab.design.locus import RootLocus
    from elab.design.model import Model
    from elab.design.response import Margins

M = TypeVar("M", bound=s.Model)
#: the most samples a design's check on the physics model simulates (200 s at 1 kHz)
ON_PLANT_SAMPLES = 200_000
BRYSON_SHARE = 0.8  # Bryson's rule: the largest acceptable u, a share of the actuator's limit


@endpoint("POST", "/models/{model_id}/design", body=s.ModelDesignRequest, response=s.ModelDesignOut)
async def design_on_model(request: Request) -> Response:
    """Design a controller on an identified model: its loop's step, root locus and margins

    ``method``: ``lqr`` (Q or an output weight, R; discrete time: dlqr), ``place``
    (closed-loop poles in z or s), ``gain`` (K typed by hand) — each state feedback on a
    full-order observer's estimate, u = Nr r − K x̂ — or ``pid`` on the error of the
    reference output. ``domain`` discrete designs on the model as identified; continuous on
    its zero-order-hold inverse. The answer has the closed loop (model and controller) with
    its verdict, the step of r by ``amplitude`` (y and u, and the peak |u| against the
    plant's actuator limit), the root locus in the loop gain, the margins at the plant
    input, and ``controller``: the law for ``POST /runs`` (with ``Ts`` = ``run_Ts``)."""
    req = (await read_model(request, s.ModelDesignRequest)).root
    kept = await stored(request)
    return ok(await asyncio.to_thread(computed, model_design, kept, req))


def model_design(kept: StoredModel, req: Any) -> s.ModelDesignOut:
    from elab.design import loop, observed
    from elab.design.model import in_domain

    plant = get_plant(kept.plant)
    m = in_domain(core_model(kept, reference_index(kept, plant)), req.domain)
    ref_name = kept.model["outputs"][m.ref]["name"]
    plant_ref = plant.outputs[plant.reference_output].name
    amplitude = _amplitude(req.amplitude, plant if ref_name == plant_ref else None)
    why_not = not_runnable(kept, plant)
    K = Nr = L = obs = None
    weight: Weight | None = None
    law: ControlLaw | None
    if req.method == "pid":
        law = PID(req.Kp, req.Ki, req.Kd, req.N)
        controller = observed.pid_controller(m, law)
    else:
        poles = None if req.observer_poles is None else [_z(p) for p in req.observer_poles]
        gain, weight = _gain(m, req, plant.u_max, amplitude, poles)
        fb = observed.observed_feedback(m, gain, poles)
        K, Nr, L, obs, controller = fb.K, fb.Nr, fb.L, fb.observer_poles, fb.controller
        law = observed.feedback_law(m, controller) if why_not is None else None
    a = loop.analyse(m, controller, amplitude, req.T)
    names = [o["name"] for o in kept.model["outputs"]]
    r = loop.thinned(a.step)
    common = _loop_out(plant, a.loop, a.locus, a.margins, a.peak_u, amplitude)
    return s.ModelDesignOut(
        **common,
        model=kept.id,
        method=req.method,
        domain=req.domain,
        K=None if K is None else np.ravel(K).tolist(),
        Nr=Nr,
        L=None if L is None else L.tolist(),
        observer_poles=None if obs is None else convert.complex_list(obs),
        step=s.StepOut(
            plant=plant.id,
            loop="closed",
            t=r.t.tolist(),
            outputs={n: convert.finite_response(r.y[i]) for i, n in enumerate(names)},
            u=convert.finite_response(r.u),
            info=None if a.info is None else convert.step_info(a.info),
            poles=convert.complex_list(a.loop.poles),
            verdict=a.loop.verdict,
            cut=None,
        ),
        controller=None if law is None or why_not else convert.law_model(law),
        run_Ts=kept.model["Ts"] if req.domain == "discrete" else None,
        not_runnable=why_not,
        output_weight=None if weight is None else weight.q,
        weight_note=None if weight is None else weight.note,
        on_plant=None
        if law is None or why_not
        else _on_plant(
            plant,
            law,
            amplitude,
            float(a.step.t[-1]),
            kept.model["Ts"] if req.domain == "discrete" else None,
        ),
    )


def _sampled(plant: Plant, dt: float) -> Model:
    """The plant's reference output, sampled at ``dt`` (zero-order hold): what a discrete
    LTI law closes its loop with."""
    import control as ct

    from elab.design.model import Model

    ref = [plant.reference_output]
    P = ct.c2d(ct.ss(plant.A, plant.B, plant.C[ref], plant.D[ref]), dt, "zoh")
    return Model(P.A, P.B, P.C, P.D, dt)


def _physics_verdict(plant: Plant, law: ControlLaw) -> tuple[list[s.Complex], str]:
    """The poles and verdict of ``law``'s loop on the physics model, as
    :func:`_plant_loop` closes it, without its step, root locus and margins."""
    from elab.design import loop, observed
    from elab.design.plant_loop import closed_loop

    match law:
        case LTIController(dt=dt) if dt is not None:
            closed = loop.close(_sampled(plant, dt), observed.two_dof(law))
            return convert.complex_list(closed.poles), closed.verdict
    poles, said, _ = loop.verdict(closed_loop(plant, law).A, None)
    return convert.complex_list(poles), said


def _on_plant(
    plant: Plant, law: ControlLaw, amplitude: float, T: float, Ts: float | None
) -> s.StepOut:
    """A design's step on the lab's physics model, as a run of it goes (issue 26: an LQR on
    an identified model predicted 0 % overshoot, the plant overshot 30 %, and nothing said
    so): the one simulator, noise-free, with the plant's actuator limit."""
    from elab.design.response import step_info
    from elab.sim import RunSpec, Step, simulate

    dt = Ts or plant.Ts
    duration = min(max(T, 20 * dt), ON_PLANT_SAMPLES * dt)  # a long horizon: its start
    spec = RunSpec(plant, law, Step(amplitude), duration=duration, Ts=Ts)
    run = simulate(spec)
    t = np.arange(run.y.shape[0]) * run.Ts
    k = np.unique(np.linspace(0, t.size - 1, min(t.size, 2001)).round().astype(int))
    ref = plant.reference_output
    y_ref = run.y[:, ref] - float((plant.C @ plant.operating_point)[ref])
    info = step_info(t, y_ref, amplitude) if np.all(np.isfinite(y_ref)) else None
    poles, verdict = _physics_verdict(plant, law)
    return s.StepOut(
        plant=plant.id,
        loop="closed",
        t=t[k].tolist(),
        outputs={o.name: convert.finite_response(run.y[k, i]) for i, o in enumerate(plant.outputs)},
        u=convert.finite_response(run.u[k]),
        info=None if info is None else convert.step_info(info),
        poles=poles,
        verdict=verdict,
        cut=None,
    )


def _amplitude(given: float | None, plant: Plant | None) -> float:
    """The reference step: as given, else the plant's default amplitude for a model of its
    reference output, else 1."""
    a = given if given is not None else (plant.signal.amplitude or 1.0) if plant else 1.0
    if a == 0:
        raise InvalidInput("amplitude", a, "a nonzero step of the reference")
    return a


@dataclass(frozen=True)
class Weight:
    """The LQR output weight a design used, and how it was chosen (``None``: as given)."""

    q: float
    note: str | None


#: the robust rule's targets: the loop broken at the plant input, on the model
GAIN_MARGIN_DB, PHASE_MARGIN_DEG = 6.0, 30.0
ROBUST_STEPS = 24  # steps of q down by √2 tried: to 1/4096 of the first


def _gain(
    m: Model, req: Any, u_max: float, amplitude: float, observer_poles: Any
) -> tuple[Any, Weight | None]:
    from elab.design import observed

    if req.method == "gain":
        return req.K, None
    if req.method == "place":
        return observed.place_gain(m, [_z(p) for p in req.poles]).K, None
    if req.Q is not None and req.output_weight is not None:
        raise InvalidInput("Q", "Q and output_weight", "either Q or output_weight, not both")
    if req.Q is not None:
        return observed.lqr_gain(m, req.Q, req.R).K, None
    # Bryson's rule unless a weight is given: the step's size against the limit
    given = req.output_weight is not None
    q0 = req.output_weight if given else (BRYSON_SHARE * u_max / amplitude) ** 2
    if not req.robust:
        return observed.lqr_gain(m, observed.output_weight(m, q0), req.R).K, Weight(q0, None)
    return _robust(m, q0, req.R, observer_poles, "the given q" if given else "Bryson's rule")


def _robust(m: Model, q0: float, R: float, observer_poles: Any, source: str) -> tuple[Any, Weight]:
    """The LQR gain for the largest q = q0 / √2ᵏ whose loop on ``m`` (with its observer)
    has at least :data:`GAIN_MARGIN_DB` and :data:`PHASE_MARGIN_DEG`; q0's if none has.
    A loop whose margins are that thin lives on the model's details near its crossover,
    and an identified model's resonance is never exact: the plant then rings or goes
    unstable where the model predicted a clean step (issue 26)."""
    from elab.design import loop, observed

    before = "its margins could not be computed"  # what q0's loop has, said if lowered
    for k in range(ROBUST_STEPS + 1):
        q = q0 / 2 ** (k / 2)
        K = observed.lqr_gain(m, observed.output_weight(m, q), R).K
        try:
            lp = loop.close(m, observed.observed_feedback(m, K, observer_poles).controller)
            margins = loop.loop_margins(lp, m.Ts)
        except (ArithmeticError, ValueError, np.linalg.LinAlgError):
            continue
        gm, pm = margins.gain_margin_db, margins.phase_margin_deg
        if gm >= GAIN_MARGIN_DB and pm >= PHASE_MARGIN_DEG:
            if k == 0:
                return K, Weight(q, None)
            note = (
                f"q lowered from {q0:.4g} ({source}) to {q:.4g}: with {q0:.4g} the loop on the "
                f"model {before}, too thin to trust a model's details; now {gm:.1f} dB and "
                f"{pm:.0f}° (at least {GAIN_MARGIN_DB:g} dB and {PHASE_MARGIN_DEG:g}°). Give q "
                "and robust false to keep yours"
            )
            return K, Weight(q, note)
        if k == 0:
            before = f"has {gm:.1f} dB of gain and {pm:.0f}° of phase margin"
    K = observed.lqr_gain(m, observed.output_weight(m, q0), R).K
    return K, Weight(
        q0,
        f"q = {q0:.4g} ({source}) kept: no q down to {q0 / 2 ** (ROBUST_STEPS / 2):.3g} gives the "
        f"loop {GAIN_MARGIN_DB:g} dB and {PHASE_MARGIN_DEG:g}° of margin on the model; check the "
        "step on the physics model before a run",
    )


def _z(p: s.Complex) -> complex:
    return complex(p.re, p.im)


def _loop_out(
    plant: Plant, lp: loop.Loop, locus: RootLocus, m: Margins, peak: float | None, amplitude: float
) -> dict[str, Any]:
    return {
        "plant": plant.id,
        "closed_loop_poles": convert.complex_list(lp.poles),
        "verdict": lp.verdict,
        "reason": lp.reason,
        "margins": s.MarginsOut(
            gain_margin_db=m.gain_margin_db,
            phase_margin_deg=m.phase_margin_deg,
            gain_crossover=m.gain_crossover,
            phase_crossover=m.phase_crossover,
        ),
        "root_locus": s.RootLocusOut(
            domain="s" if lp.closed.isctime() else "z",
            gains=locus.gains.tolist(),
            re=[[convert.finite_or_none(x) for x in row] for row in locus.branches.real],
            im=[[convert.finite_or_none(x) for x in row] for row in locus.branches.imag],
            poles=convert.complex_list(locus.poles),
            zeros=convert.complex_list(locus.zeros),
        ),
        "amplitude": amplitude,
        "peak_u": peak,
        "u_max": plant.u_max,
        "saturates": peak is not None and peak > plant.u_max,
    }


@endpoint("POST", "/plants/{plant_id}/loop", body=s.LoopRequest, response=s.LoopOut)
async def plant_loop(request: Request) -> Response:
    """A controller's loop on the plant's model: poles, verdict, root locus, margins, peak u

    The loop as a run closes it (the law's own state estimate; a discrete LTI law on
    the plant's zero-order-hold model at its ``dt``), linear: closed-loop poles and
    verdict, the root locus in the loop gain, the margins at the plant input, and the peak
    |u| of a step of r by ``amplitude`` (default: the plant's default reference
    amplitude) against the actuator limit."""
    plant, req = await plant_and_body(request, s.LoopRequest)
    law = convert.law(req.controller, plant)
    amplitude = _amplitude(req.amplitude, plant)
    return ok(await asyncio.to_thread(computed, _plant_loop, plant, law, amplitude))


def _plant_loop(plant: Plant, law: ControlLaw, amplitude: float) -> s.LoopOut:
    import control as ct

    from elab.design import loop, observed
    from elab.design.locus import root_locus
    from elab.design.plant_loop import closed_loop, loop_transfer
    from elab.design.response import default_horizon, step_response

    if not has_feedback(law):
        raise InvalidInput("controller", "open_loop", "a feedback law: an open loop has no loop")
    match law:
        case LTIController(dt=dt) if dt is not None:  # on the plant sampled at its dt
            m = _sampled(plant, dt)
            a = loop.analyse(m, observed.two_dof(law), amplitude)
            return s.LoopOut(**_loop_out(plant, a.loop, a.locus, a.margins, a.peak_u, amplitude))
    closed = closed_loop(plant, law)
    L = ct.ss(loop_transfer(plant, law))
    poles, said, reason = loop.verdict(closed.A, None)
    peak = None
    if said == "asymptotically stable":
        T = min(max(plant.signal.duration, default_horizon(poles)), 600.0)
        u = step_response(closed, T, 4001, amplitude, u_output=-1).u
        peak = float(np.max(np.abs(u))) if np.all(np.isfinite(u)) else None
    lp = loop.Loop(closed, L, poles, said, reason)
    return s.LoopOut(
        **_loop_out(plant, lp, root_locus(L), loop.loop_margins(lp, None), peak, amplitude)
    )


@endpoint(
    "POST",
    "/plants/{plant_id}/controller-file",
    body=s.ControllerFileRequest,
    response="file",
    files=tuple(dict.fromkeys(MEDIA.values())),
)
async def controller_file(request: Request) -> Response:
    """A controller as a file (TOML, JSON, .mat, .npz, Python) that uploads as the same law

    The law in the controller file format (docs/controllers.md): what a designed gain
    or a design on a model exports. The file is read back before it is sent: 422 if it
    would not read as the same law (a Python file exists for state feedback on the
    plant's velocity filters and for PID only)."""
    plant, req = await plant_and_body(request, s.ControllerFileRequest)
    law = convert.law(req.controller, plant)
    data = await asyncio.to_thread(computed, _file, plant, law, req.format, req.name)
    stem = "".join(
        c if (c.isascii() and c.isalnum()) or c in "-_" else "-" for c in (req.name or "designed")
    )
    return Response(
        data,
        media_type=MEDIA[req.format],
        headers={
            "content-disposition": f'attachment; filename="{plant.id}-{stem[:60]}.{req.format}"'
        },
    )


def _file(plant: Plant, law: ControlLaw, fmt: str, name: str | None) -> bytes:
    try:
        ctl.law_from_fields(ctl.law_fields(law), plant)  # what a file may hold, by name
        data = ctl.law_file(plant, law, fmt, name)
        back = ctl.read_controller(data, fmt, plant).law
    except InvalidInput as e:
        raise InvalidInput(
            f"controller.{e.field}" if e.field != "format" else "format", e.value, e.allowed
        ) from None
    if fmt != "py" and back != law:
        raise InvalidInput("controller", "this law", f"a law the {fmt} format holds")
    return data
