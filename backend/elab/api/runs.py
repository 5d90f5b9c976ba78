"""``/runs``: start, list, inspect, control, delete and download runs.

Every run belongs to whoever started it (:mod:`elab.api.auth`); the rules of
:mod:`elab.access` decide who may do what, in the run manager."""

from __future__ import annotations

from typing import Any

from starlette.requests import HTTPConnection, Request
from starlette.responses import Response

from elab.access import Identity, display_name, may_control, may_view, require_control
from elab.api import controllers, convert
from elab.api import schemas as s
from elab.api.auth import identity
from elab.api.http import Param, endpoint, ok, query, query_int, read_model
from elab.api.paths import PLANT_FILTER, plant_filter
from elab.api.state import lab
from elab.engines.base import Action, EngineStatus, StoreHealth
from elab.errors import InvalidInput, Unavailable
from elab.laws import is_code
from elab.plants import get_plant
from elab.runs.changes import Change
from elab.runs.fanout import frame_samples
from elab.runs.manager import ManagerStatus, RunManager
from elab.store.base import JsonObject, RunRecord, RunSummary


def manager(request: HTTPConnection) -> RunManager:
    return lab(request).manager


def run_summary(record: RunSummary, who: Identity) -> s.RunSummaryInfo:
    return s.RunSummaryInfo(**_summary_fields(record, who))


def _summary_fields(record: RunSummary, who: Identity) -> dict[str, Any]:
    return {
        "id": record.id,
        "plant": record.plant,
        "mode": record.mode,
        "experiment": record.experiment,
        "status": record.status,
        "Ts": record.Ts,
        "channels": [s.ChannelInfo(name=n, unit=u) for n, u in record.channels],
        "n_planned": record.n_planned,
        "n_samples": record.n_stored,
        "created_at": record.created_at,
        "started_at": record.started_at,
        "finished_at": record.finished_at,
        "error": record.error,
        "compute": record.compute,
        "outcome": record.outcome,
        "url": f"/api/v1/runs/{record.id}",
        "owner": display_name(record.owner),
        "private": record.private,
        "mine": bool(who.id) and record.owner == who.id,
        "can_control": may_control(who, record.owner),
    }


async def run_info(request: HTTPConnection, record: RunRecord) -> s.RunInfo:
    changes = await manager(request).param_changes(record.id)
    base = "/api/v1/runs/" + record.id
    return s.RunInfo(
        **_summary_fields(record, identity(request)),
        frame_samples=frame_samples(record.Ts),
        stream_url=base + "/stream",
        data_url=base + "/data",
        request=record.spec,
        param_changes=[
            s.ParamChangeInfo(k=c.k, t=c.k * record.Ts, at=c.at, params=c.params) for c in changes
        ],
    )


@endpoint(
    "POST",
    "/runs",
    "Start a run (simulation); samples stream live and are recorded",
    body=s.RunCreate,
    response=s.RunInfo,
    status=201,
    errors=(404, 409, 413, 415, 422, 429, 503),
    links=tuple(
        (op, "run_id")
        for op in (
            "get_run",
            "pause_run",
            "resume_run",
            "stop_run",
            "set_params",
            "get_data",
            "delete_run",
        )
    ),
)
async def create_run(request: Request) -> Response:
    """Starts stepping at once (paced to real time unless ``pace`` is ``fast``). Follow it on
    ``stream_url`` (websocket, subprotocol ``elab.v1``); download it from ``data_url``.
    The run belongs to the caller; a real-time run whose owner has had no connection to
    it (its stream, or a request about it) for ``ELAB_OWNER_GRACE`` s pauses, and stops
    at ``ELAB_OWNER_GONE`` s."""
    req = await read_model(request, s.RunCreate)
    plant = get_plant(req.plant)
    manager(request).engine_for(req.mode)  # a server without a rig says so here
    rig = manager(request).status().engines.get("rig") if req.mode == "rig" else None
    if rig is not None and (problem := _rig_problem(rig)) is not None:
        raise Unavailable(problem, retry_after=5.0)  # before the queue seats a run
    uploaded = None
    if req.controller_id is not None:
        uploaded = await controllers.law_of(request, req.controller_id, plant.id)
    req = req.model_copy(
        update={  # store what ran, with the plant's defaults filled in
            "signal": req.signal or convert.default_signal(plant),
            "duration": req.duration if req.duration is not None else plant.signal.duration,
        }
        | convert.sensors(req)
        | (
            {"controller": convert.law_model(uploaded)}
            if uploaded is not None and not is_code(uploaded)
            else {}
        )
    )
    spec = convert.run_spec(req, plant, uploaded)
    record = await manager(request).create(
        spec,
        pace=req.pace,
        mode=req.mode,
        experiment=req.experiment,
        request=req.model_dump(mode="json"),
        who=identity(request),
        private=req.private,
    )
    return ok(await run_info(request, record), status=201)


@endpoint(
    "GET",
    "/runs",
    response=s.RunList,
    errors=(422,),
    params=(
        PLANT_FILTER,
        Param("owner", "query", "me: only the caller's runs", {"type": "string", "enum": ["me"]}),
        Param(
            "live",
            "query",
            "true: only runs that are live (created, running or paused)",
            {"type": "string", "enum": ["true", "false"]},
        ),
        Param(
            "limit",
            "query",
            "page size (default 50)",
            {"type": "integer", "minimum": 1, "maximum": 500},
        ),
        Param(
            "offset",
            "query",
            "runs to skip (default 0)",
            {"type": "integer", "minimum": 0, "maximum": 10**9},
        ),
    ),
)
async def list_runs(request: Request) -> Response:
    """List runs, newest first (others' private runs only for instructors)"""
    m = manager(request)
    plant = plant_filter(request)
    owner = query(request, "owner")
    if owner not in (None, "me"):
        raise InvalidInput("owner", owner, "me (or leave it out for every run you may see)")
    live = query(request, "live")
    if live not in (None, "true", "false"):
        raise InvalidInput("live", live, "true or false")
    limit = query_int(request, "limit", 50, 1, 500)
    offset = query_int(request, "offset", 0, 0, 10**9)
    who = identity(request)
    mine = who.id if owner == "me" else None
    if owner == "me" and not who.id:
        records: list[RunSummary] = []
        total = 0
    elif live == "true":
        every = [
            r
            for r in m.live_runs()[::-1]
            if (plant is None or r.plant == plant)
            and (mine is None or r.owner == mine)
            and may_view(who, r.owner, r.private)
        ]
        records, total = list(every[offset : offset + limit]), len(every)
    else:
        records, total = await m.page(who=who, plant=plant, owner=mine, limit=limit, offset=offset)
    return ok(
        s.RunList(
            runs=[run_summary(r, who) for r in records], total=total, limit=limit, offset=offset
        )
    )


@endpoint("GET", "/server", response=s.ServerStatus, errors=())
async def server_status(request: Request) -> Response:
    """The server: live runs, watchers, the engine, the store, and how closely the engine keeps time

    For operators and benchmarks: is the engine up and keeping up? Its ticks' lateness
    over the last minute and the trend of that lateness (the drift of the runs' clocks);
    whether its writes to the store work."""
    jobs, uploads = lab(request).jobs, lab(request).uploads
    return ok(
        server_model(
            manager(request).status(),
            s.JobsInfo(workers=jobs.workers, busy=jobs.busy, starting=jobs.starting),
            s.UploadsInfo(receiving=uploads.reading, limit=uploads.limit),
        )
    )


@endpoint("GET", "/health", response=s.HealthInfo, errors=(503,))
async def health(request: Request) -> Response:
    """200 when the server can take runs, else 503 and why

    For a load balancer or a supervisor: the engine is up and ticking and its store
    writes work."""
    engines = manager(request).status().engines
    st = engines["simulation"]
    down = st.problem or (None if st.up else "the engine is not running")
    if down:
        return ok(s.HealthInfo(status="unavailable", problems=[down]), status=503)
    problems = [e.warning for e in engines.values() if e.warning]
    problems += [  # a rig out of service leaves the rest of the lab working
        f"{mode}: {problem}"
        for mode, e in engines.items()
        if mode != "simulation" and (problem := _rig_problem(e))
    ]
    if problems:
        return ok(s.HealthInfo(status="degraded", problems=problems))
    return ok(s.HealthInfo(status="ok", problems=[]))


def server_model(status: ManagerStatus, jobs: s.JobsInfo, uploads: s.UploadsInfo) -> s.ServerStatus:
    st = status.engines["simulation"]
    h = st.health
    timing = s.StepperTiming() if h is None else s.StepperTiming.model_validate(h.timing)
    store = h.store if h is not None else StoreHealth()
    return s.ServerStatus(
        live_runs=status.live_runs,
        watchers=status.watchers,
        delivery=s.DeliveryInfo(
            lag_max_ms=round(status.delivery_lag_max * 1e3, 3),
            catching_up=status.catching_up,
            skipping=status.skipping,
        ),
        stepper=timing,
        engine=_engine_model(st),
        engines=[_engine_model(e) for e in status.simulation_engines],
        store=s.StoreInfo(
            ok=store.ok,
            error=store.error,
            since=store.since,
            transient=store.transient,
            pending_bytes=store.pending_bytes,
        ),
        ident=jobs,
        uploads=uploads,
        rig=rig_model(status.engines.get("rig")),
    )


def _rig_problem(st: EngineStatus) -> str | None:
    """Why the rig cannot take a run now, if it cannot."""
    if st.problem or not st.up:
        return st.problem or "its engine is not running"
    link = st.health.rig if st.health is not None else None
    if link is not None and not link.connected:
        return f"the rig is not connected: {link.problem}"
    return link.problem if link is not None else None


def _engine_model(st: EngineStatus) -> s.EngineInfo:
    return s.EngineInfo(
        id=st.engine,
        up=st.up,
        problem=st.problem,
        restarts=st.restarts,
        pid=st.pid,
        heartbeat_age_s=st.heartbeat_age,
        live_runs=None if st.health is None else st.health.live_runs,
    )


def rig_model(st: EngineStatus | None) -> s.RigInfo | None:
    if st is None:
        return None
    h = st.health
    link = h.rig if h is not None else None
    timing = h.timing if h is not None else {}
    latency = {k: float(timing[k]) if k in timing else None for k in _LATENCY}
    return s.RigInfo(
        engine=_engine_model(st),
        connected=link is not None and link.connected,
        rig_id=link.rig_id if link else None,
        firmware=link.firmware if link else None,
        emulated=link is not None and link.emulated,
        problem=(link.problem if link else None) or st.problem,
        settling=link is not None and link.settling,
        samples=int(timing.get("samples", 0)),
        late_1ms=int(timing.get("late_1ms", 0)),
        **latency,
    )


_LATENCY = ("latency_p50_us", "latency_p99_us", "latency_max_us")


@endpoint("GET", "/runs/{run_id}", response=s.RunInfo, errors=(404,))
async def get_run(request: Request) -> Response:
    """A run: state, progress, channels, parameter changes"""
    record = await manager(request).get(request.path_params["run_id"], identity(request))
    return ok(await run_info(request, record))


@endpoint("DELETE", "/runs/{run_id}", status=204, errors=(403, 404, 409, 503))
async def delete_run(request: Request) -> Response:
    """Delete an ended run and its recording (its owner or an instructor)"""
    await manager(request).delete(request.path_params["run_id"], identity(request))
    return Response(status_code=204)


def _control_endpoint(action: Action, summary: str) -> None:
    """``POST /runs/{run_id}/<action>`` (operation ``<action>_run``), answered with the run."""

    async def control(request: Request) -> Response:
        run_id, who = request.path_params["run_id"], identity(request)
        return ok(await run_info(request, await manager(request).control(run_id, action, who)))

    control.__name__ = control.__qualname__ = f"{action}_run"
    path, errors = f"/runs/{{run_id}}/{action}", (403, 404, 409, 503)
    endpoint("POST", path, summary, response=s.RunInfo, errors=errors)(control)


_control_endpoint("stop", "Stop a run; its samples so far stay recorded")
_control_endpoint("pause", "Pause a run (its clock stops)")
_control_endpoint("resume", "Resume a paused run")


@endpoint(
    "POST",
    "/runs/{run_id}/params",
    body=s.ParamsUpdate,
    response=s.ParamsApplied,
    errors=(403, 404, 409, 413, 415, 422, 503),
)
async def set_params(request: Request) -> Response:
    """Change the controller gains and/or the reference of a live run

    Applied from the next sample; the change and its sample index are recorded, and the
    answer lists every value it altered (``changed``). A part equal to what the run uses
    (gains or reference) is left out of the change; when nothing differs, nothing is
    applied or recorded."""
    req = await read_model(request, s.ParamsUpdate)
    return ok(await apply_params(request, request.path_params["run_id"], req, identity(request)))


async def apply_params(
    conn: HTTPConnection, run_id: str, update: s.ParamsUpdate | s.SetParams, who: Identity
) -> s.ParamsApplied:
    """Shared by REST and the websocket's ``set_params``: the update as a typed change
    (:class:`~elab.runs.changes.Change`), decided and applied by the run manager."""
    controller, cid, signal = update.controller, update.controller_id, update.signal
    if controller is None and cid is None and signal is None:
        raise InvalidInput("body", {}, "controller, controller_id and/or signal")
    if controller is not None and cid is not None:
        raise InvalidInput("controller_id", cid, "either controller or controller_id, not both")
    m = manager(conn)
    record = await m.get(run_id, who)
    require_control(who, record.owner, f"run {run_id}", "change")  # before its controller
    applied = await m.set_params(run_id, await _change(conn, update, record.plant), who)
    return s.ParamsApplied(
        k=applied.k,
        t=applied.k * record.Ts,
        changed=[
            s.ParamDiff(field=d.field, before=d.before, after=d.after) for d in applied.changed
        ],
    )


async def _change(
    conn: HTTPConnection, update: s.ParamsUpdate | s.SetParams, plant_id: str
) -> Change:
    """``update`` (a controller, or an uploaded one's ``controller_id``, and/or a signal) as
    a change of the plant's run, with what it asks as JSON."""
    controller, cid, signal = update.controller, update.controller_id, update.signal
    plant = get_plant(plant_id)
    asked: JsonObject = {}
    law = None
    if cid is not None:
        law = await controllers.law_of(conn, cid, plant.id)
        if not is_code(law):  # (code has no such form: the change refuses it)
            asked = {"controller": convert.law_model(law).model_dump(mode="json")}
        asked["controller_id"] = cid
    elif controller is not None:
        law = convert.law(controller, plant)
        asked["controller"] = controller.model_dump(mode="json")
    if signal is not None:
        asked["signal"] = signal.model_dump(mode="json")
    reference = convert.signal(signal) if signal is not None else None
    return Change(law, reference, cid, asked)
