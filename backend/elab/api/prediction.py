"""``GET /runs/{id}/prediction``: what the model predicts for a run and how far the run
went from it (:mod:`elab.runs.prediction`), made in a controller-trial worker."""

from __future__ import annotations

import asyncio
from typing import TYPE_CHECKING

from pydantic import ValidationError
from starlette.requests import Request
from starlette.responses import Response

from elab.api import controllers, convert
from elab.api import schemas as s
from elab.api.auth import identity
from elab.api.http import endpoint, ok
from elab.api.runs import manager
from elab.api.state import lab
from elab.errors import Conflict, NotFound
from elab.laws import ControlLaw
from elab.plants import Plant, get_plant
from elab.runs.prediction import Predicted, Replayed, compare, predict
from elab.sim.spec import RunSpec
from elab.store.base import ParamChange, RunRecord

if TYPE_CHECKING:
    from elab.design.response import StepInfo


@endpoint(
    "GET",
    "/runs/{run_id}/prediction",
    response=s.RunPrediction,
    errors=(404, 409, 422, 429, 503),
)
async def get_prediction(request: Request) -> Response:
    """What the model predicts for a run, and how far the run is from it

    The same plant model, controller, reference, excitation, start state and actuator
    limit with ideal sensors (no noise, no quantisation), its live changes of gains and
    reference replayed at the samples they took effect; a Python controller is stepped in
    its sandbox. For a rig run the model is the nominal linear model of the flexible link.
    ``gaps`` compares the recording with it, channel by channel (``u`` and the outputs),
    over the samples recorded so far; a live run's prediction is whole from its start."""
    m = manager(request)
    record = await m.get(request.path_params["run_id"], identity(request))
    plant = get_plant(record.plant)
    changes = await m.param_changes(record.id)
    state = lab(request)
    limit = state.settings.prediction_samples

    async def make() -> Predicted:
        spec = await _spec(request, record, plant)
        replay = [_replayed(c, plant) for c in changes]
        code = state.settings.engine.code
        return await state.trials.run(predict, spec, replay, limit, code)

    predicted = await state.predictions.get((record.id, len(changes), limit), make)
    stored, read = m.durable(record.id)
    n = record.n_stored if stored is None else min(stored, record.n_stored)
    names = [name for name, _ in record.channels]
    ref = plant.outputs[plant.reference_output].name
    offset = float((plant.C @ plant.operating_point)[plant.reference_output])
    seen = await asyncio.to_thread(compare, predicted, names, read, n, record.Ts, (ref, offset))
    units = dict(record.channels)
    labels = {"u": plant.inputs[0].label} | {c.name: c.label for c in plant.outputs}
    notes = list(predicted.notes)
    if n > predicted.values.shape[0] and predicted.diverged_at is None:
        notes.append(
            f"predicted for the first {predicted.values.shape[0]} samples "
            f"(ELAB_PREDICTION_SAMPLES); the rest of the run is not compared"
        )
    return ok(
        s.RunPrediction(
            run_id=record.id,
            model=_model(record, plant),
            Ts=record.Ts,
            n=int(predicted.values.shape[0]),
            compared=seen.compared,
            replayed=predicted.replayed,
            diverged_at=predicted.diverged_at,
            channels=[
                s.PredictedChannel(
                    name=name,
                    unit=units.get(name, ""),
                    label=labels.get(name, name),
                    values=predicted.values[:, j].tolist(),
                )
                for j, name in enumerate(predicted.names)
            ],
            gaps=[
                s.PredictionGap(
                    name=g.name,
                    unit=units.get(g.name, ""),
                    rms=g.rms,
                    max_abs=g.max_abs,
                    t_max=g.t_max,
                )
                for g in seen.gaps
            ],
            steps=[
                s.PredictionStep(
                    output=st.output,
                    unit=units.get(st.output, ""),
                    t=st.t,
                    span=st.span,
                    start=st.start,
                    target=st.target,
                    run=_info(st.run),
                    prediction=_info(st.prediction),
                )
                for st in seen.steps
            ],
            notes=notes,
        )
    )


def _info(info: StepInfo | None) -> s.StepInfoOut | None:
    if info is None:
        return None
    return convert.step_info(info)


def _model(record: RunRecord, plant: Plant) -> str:
    if record.mode == "rig":
        return (
            f"the nominal linear model of the {plant.name.lower()} with ideal sensors: the rig "
            "differs by its own parameters, friction, the motor's dead zone and its sensors"
        )
    return f"the {plant.name.lower()}'s model with ideal sensors (no noise, no quantisation)"


async def _spec(request: Request, record: RunRecord, plant: Plant) -> RunSpec:
    """The run as its stored request describes it (an uploaded Python controller read
    from the store: seeing a run is seeing what its controller does)."""
    asked = {k: v for k, v in record.spec.items() if k in s.RunCreate.model_fields}
    try:  # (a rig run's request holds the rig's facts too, under ``rig``)
        req = s.RunCreate.model_validate(asked)
    except ValidationError as exc:
        raise Conflict(
            f"run {record.id}'s recorded request cannot be read back ({exc.error_count()} "
            "error(s)): no prediction for it"
        ) from None
    law: ControlLaw | None = None
    if req.controller_id is not None:
        # a declarative upload's law is in the request; a Python one's only in the store
        try:
            stored = await asyncio.to_thread(
                controllers.store(request).get_controller, req.controller_id
            )
        except NotFound:
            if req.controller.kind != "predefined":
                return convert.run_spec(req, plant)
            raise Conflict(
                f"run {record.id}'s Python controller {req.controller_id} was deleted: "
                "no prediction for it"
            ) from None
        if stored.format == "py":
            law = controllers.stored_law(stored)
    return convert.run_spec(req, plant, law)


def _replayed(change: ParamChange, plant: Plant) -> Replayed:
    """A recorded change as the prediction replays it (its JSON read back as when asked)."""
    params = s.ParamsUpdate.model_validate(
        {key: value for key, value in change.params.items() if key in ("controller", "signal")}
    )
    return Replayed(
        change.k,
        convert.law(params.controller, plant) if params.controller is not None else None,
        convert.signal(params.signal) if params.signal is not None else None,
    )
