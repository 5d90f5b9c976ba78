"""Identified models kept for design: keep one (a model of an identification's result),
list the caller's, read one, delete one; its open-loop step and its file (.mat, JSON).
Designs on a model are in :mod:`elab.api.designs`. docs/api.md.

A model belongs to whoever kept it. Anyone with its id may read it and design on it (its
link is shared, as a run's), only its owner or an instructor may delete it (403 for
others, as for runs).
"""

from __future__ import annotations

import asyncio
import io
import json
import secrets
import time
from typing import Any

import numpy as np
from starlette.requests import HTTPConnection, Request
from starlette.responses import Response

from elab.access import Identity, display_name, may_control, require_control
from elab.api import convert
from elab.api import schemas as s
from elab.api.auth import identity
from elab.api.http import (
    Param,
    computed,
    endpoint,
    ok,
    query,
    query_float,
    read_model,
    within_budget,
)
from elab.api.paths import PLANT_FILTER, plant_filter
from elab.api.state import lab
from elab.design.model import Model
from elab.errors import DimensionError, InvalidInput
from elab.plants import PLANTS, Plant, get_plant
from elab.store.base import ModelStore, StoredModel

FILE_FORMATS = {"json": "application/json", "mat": "application/x-matlab-data"}
STEP_POINTS = 2001


def store(conn: HTTPConnection) -> ModelStore:
    return lab(conn).models


@endpoint(
    "POST",
    "/models",
    body=s.ModelCreate,
    response=s.IdentifiedModel,
    status=201,
    errors=(413, 422, 429, 503),
    links=(
        ("get_model", "model_id"),
        ("model_step", "model_id"),
        ("design_on_model", "model_id"),
        ("model_file", "model_id"),
        ("delete_model", "model_id"),
    ),
)
async def create_model(request: Request) -> Response:
    """Keep an identified model: it gets an id and a design page to share

    A discrete model as identification gives it (``POST /ident``: a model's ``ss`` A, B,
    C, D and ``Ts``, the data's input and output names and units). Checked before it is
    kept: finite numbers, shapes that fit together (A n × n, B n × 1, C p × n, D p × 1,
    one output name per row of C), at most 20 states and 8 outputs; 422 names the field.
    At most ``ELAB_MAX_MODELS_PER_IDENTITY`` (100) per identity (429)."""
    req = await read_model(request, s.ModelCreate)
    if req.plant not in PLANTS:
        raise InvalidInput("plant", req.plant, "one of " + ", ".join(PLANTS))
    doc = _document(req)
    who = identity(request)
    limit = lab(request).settings.max_models_per_identity
    with lab(request).pending.hold("models", who.id) as others:
        have = await asyncio.to_thread(store(request).count_models, who.id)
        within_budget(have + others, limit, "identified models", "ELAB_MAX_MODELS_PER_IDENTITY")
        kept = StoredModel(
            id="m-" + secrets.token_hex(6),
            owner=who.id,
            plant=req.plant,
            name=req.name,
            model=doc,
            created_at=time.time(),
        )
        await asyncio.to_thread(store(request).add_model, kept)
    return ok(model_out(kept, who), status=201)


def _document(req: s.ModelCreate) -> dict[str, Any]:
    """The model as kept, once the core has checked it."""
    core = Model.checked(req.A, req.B, req.C, req.D, req.Ts)
    if len(req.outputs) != core.ny:
        raise DimensionError(
            "outputs", f"{len(req.outputs)} names", f"{core.ny}: one per row of C (output)"
        )
    if len(req.fit) > core.ny:
        raise DimensionError("fit", f"{len(req.fit)} values", f"at most {core.ny}: per output")
    with np.errstate(all="ignore"):
        z = np.linalg.eigvals(core.A)
        tfs = [_tf(core, i) for i in range(core.ny)]
    if not (np.all(np.isfinite(z)) and all(np.isfinite(t.num + t.den).all() for t in tfs)):
        raise InvalidInput("A", "…", "a model whose poles and transfer functions are finite")
    return {
        "Ts": req.Ts,
        "A": core.A.tolist(),
        "B": core.B.tolist(),
        "C": core.C.tolist(),
        "D": core.D.tolist(),
        "input": req.input.model_dump(),
        "outputs": [o.model_dump() for o in req.outputs],
        "source": req.source,
        "kind": req.kind,
        "fit": list(req.fit),
        "verdicts": [v.model_dump() for v in req.verdicts],
    }


@endpoint("GET", "/models", response=s.IdentifiedModelList, params=(PLANT_FILTER,), errors=(422,))
async def list_models(request: Request) -> Response:
    """The caller's identified models, newest first (an instructor's: everyone's)"""
    plant = plant_filter(request)
    who = identity(request)
    found = await asyncio.to_thread(
        store(request).list_models, None if who.instructor else who.id, plant
    )
    return ok(s.IdentifiedModelList(models=[model_out(m, who) for m in found]))


@endpoint("GET", "/models/{model_id}", response=s.IdentifiedModel, errors=(404,))
async def get_model(request: Request) -> Response:
    """An identified model: matrices, names, poles, transfer functions, its design page"""
    kept = await stored(request)
    return ok(model_out(kept, identity(request)))


@endpoint("DELETE", "/models/{model_id}", status=204, errors=(403, 404, 503))
async def delete_model(request: Request) -> Response:
    """Delete an identified model (its owner or an instructor)"""
    kept = await stored(request)
    require_control(identity(request), kept.owner, f"model {kept.id}", "delete")
    await asyncio.to_thread(store(request).delete_model, kept.id)
    return Response(status_code=204)


@endpoint(
    "GET",
    "/models/{model_id}/step",
    response=s.StepOut,
    params=(
        Param(
            "T",
            "query",
            "horizon (s); default: ten time constants of the slowest stable pole",
            {"type": "number", "exclusiveMinimum": 0, "maximum": 3600},
        ),
    ),
)
async def model_step(request: Request) -> Response:
    """The model's open-loop response to a unit step of its input

    Computed with python-control on the discrete model (x₀ = 0), every sample up to
    20,001, returned on at most 2001 points."""
    T = query_float(request, "T")
    if T is not None and not 0 < T <= 3600:
        raise InvalidInput("T", T, "a horizon in (0, 3600] s")
    kept = await stored(request)
    return ok(await asyncio.to_thread(computed, _open_step, kept, T, field="model", value=kept.id))


def _open_step(kept: StoredModel, T: float | None) -> s.StepOut:
    import control as ct

    from elab.design import loop
    from elab.design.response import default_horizon

    m = core_model(kept)
    poles, said, _ = loop.verdict(m.A, m.Ts)
    assert m.Ts is not None
    if T is None:
        with np.errstate(all="ignore"):  # z = 0: s = −∞, a pole that is gone at once
            s_poles = np.log(np.where(np.abs(poles) > 1e-300, poles, 1e-300)) / m.Ts
        T = default_horizon(s_poles[np.isfinite(s_poles)])
    n = min(loop.MAX_SAMPLES, max(2, round(T / m.Ts) + 1))
    t = np.arange(n) * m.Ts
    with np.errstate(all="ignore"):
        y = np.asarray(ct.forced_response(m.ss(), t, np.ones(n), squeeze=False).outputs)
    y = y.reshape(m.ny, n)
    keep = np.unique(np.append(np.arange(0, n, max(1, -(-(n - 1) // (STEP_POINTS - 1)))), n - 1))
    names = [o["name"] for o in kept.model["outputs"]]
    return s.StepOut(
        plant=kept.plant,
        loop="open",
        t=t[keep].tolist(),
        outputs={name: [_num(v) for v in y[i, keep]] for i, name in enumerate(names)},
        u=[1.0] * keep.size,
        info=None,
        poles=convert.complex_list(poles),
        verdict=said,
        cut=None,
    )


def _num(v: float) -> float:
    if not np.isfinite(v):
        raise InvalidInput("T", None, "a shorter horizon: the response overflows")
    return float(v)


@endpoint(
    "GET",
    "/models/{model_id}/file",
    response="file",
    files=tuple(FILE_FORMATS.values()),
    params=(
        Param(
            "format",
            "query",
            "json (default) or mat",
            {"type": "string", "enum": list(FILE_FORMATS)},
        ),
    ),
)
async def model_file(request: Request) -> Response:
    """The model as a file: JSON, or MATLAB .mat (A, B, C, D, Ts, names)"""
    fmt = query(request, "format")
    fmt = "json" if fmt is None else fmt
    if fmt not in FILE_FORMATS:
        raise InvalidInput("format", fmt, "json or mat")
    kept = await stored(request)
    data = await asyncio.to_thread(_file, kept, fmt)  # (.mat: scipy.io's first import)
    name = "".join(c if (c.isascii() and c.isalnum()) or c in "-_" else "-" for c in kept.name)[:60]
    return Response(
        data,
        media_type=FILE_FORMATS[fmt],
        headers={"content-disposition": f'attachment; filename="{kept.plant}-{name}.{fmt}"'},
    )


def _file(kept: StoredModel, fmt: str) -> bytes:
    doc = {"id": kept.id, "plant": kept.plant, "name": kept.name, **kept.model}
    if fmt == "json":
        return (json.dumps(doc, indent=1) + "\n").encode()
    import scipy.io

    m = kept.model
    arrays: dict[str, Any] = {k: np.asarray(m[k], dtype=np.float64) for k in "ABCD"}
    arrays |= {
        "Ts": float(m["Ts"]),
        "InputName": np.array([m["input"]["name"]], dtype=object),
        "InputUnit": np.array([m["input"]["unit"]], dtype=object),
        "OutputName": np.array([o["name"] for o in m["outputs"]], dtype=object),
        "OutputUnit": np.array([o["unit"] for o in m["outputs"]], dtype=object),
        "Name": kept.name,
        "Plant": kept.plant,
        "Source": m.get("source", ""),
    }
    buf = io.BytesIO()
    scipy.io.savemat(buf, arrays, format="5")
    return buf.getvalue()


async def stored(conn: HTTPConnection) -> StoredModel:
    return await asyncio.to_thread(store(conn).get_model, conn.path_params["model_id"])


def core_model(kept: StoredModel, ref: int = 0) -> Model:
    m = kept.model
    return Model.checked(m["A"], m["B"], m["C"], m["D"], m["Ts"], ref)


def reference_index(kept: StoredModel, plant: Plant) -> int:
    """The model output that follows r: the plant's reference output, else the first."""
    names = [o["name"] for o in kept.model["outputs"]]
    ref = plant.outputs[plant.reference_output].name
    return names.index(ref) if ref in names else 0


def not_runnable(kept: StoredModel, plant: Plant) -> str | None:
    """Why a controller designed on this model cannot run on the plant (None: it can):
    a run's controller measures the plant's reference output and drives its input."""
    m = kept.model
    ref = plant.outputs[plant.reference_output]
    outs = [o["name"] for o in m["outputs"]]
    if len(outs) != 1:
        return (
            f"it has {len(outs)} outputs ({', '.join(outs)}): a run's controller measures one, "
            f"the plant's {ref.name}; identify a model with output {ref.name} alone"
        )
    if outs[0] != ref.name or m["outputs"][0]["unit"] != ref.unit:
        return (
            f"its output {outs[0]} is not the plant's {ref.name} ({ref.unit}), which a run's "
            "controller measures"
        )
    if m["input"]["name"] != plant.inputs[0].name:
        return f"its input {m['input']['name']} is not the plant's {plant.inputs[0].name}"
    return None


def model_out(kept: StoredModel, who: Identity) -> s.IdentifiedModel:
    m = kept.model
    core = core_model(kept)
    z = np.linalg.eigvals(core.A)
    has_log = not np.any((np.abs(z) < 1e-9) | ((np.abs(z.imag) < 1e-12) & (z.real < 0)))
    plant = get_plant(kept.plant)
    return s.IdentifiedModel(
        id=kept.id,
        plant=kept.plant,
        name=kept.name,
        owner=display_name(kept.owner),
        mine=bool(who.id) and kept.owner == who.id,
        can_delete=may_control(who, kept.owner),
        created_at=kept.created_at,
        Ts=m["Ts"],
        A=m["A"],
        B=m["B"],
        C=m["C"],
        D=m["D"],
        input=s.ModelChannel.model_validate(m["input"]),
        outputs=[s.ModelChannel.model_validate(o) for o in m["outputs"]],
        source=m.get("source", ""),
        kind=m.get("kind", ""),
        fit=m.get("fit", []),
        verdicts=[s.VerdictOut.model_validate(v) for v in m.get("verdicts", [])],
        poles=convert.complex_list(z),
        poles_s=convert.complex_list(np.log(z.astype(complex)) / m["Ts"]) if has_log else None,
        stable=bool(np.all(np.abs(z) < 1)),
        tf=[_tf(core, i) for i in range(core.ny)],
        not_runnable=not_runnable(kept, plant),
        url=f"/api/v1/models/{kept.id}",
        page=f"/plants/{kept.plant}/design?model={kept.id}",
    )


def _tf(m: Model, i: int) -> s.TransferFunctionOut:
    """Gᵢ(z) = cᵢ (zI − A)⁻¹ b + dᵢ by the matrix determinant lemma (as identification)."""
    den = np.poly(m.A)
    num = np.poly(m.A - np.outer(m.B[:, 0], m.C[i])) + (m.D[i, 0] - 1.0) * den
    nz = np.flatnonzero(np.abs(num) > 1e-14 * max(1.0, float(np.max(np.abs(num)))))
    return s.TransferFunctionOut(
        num=(num[nz[0] :] if nz.size else np.zeros(1)).tolist(), den=den.tolist()
    )
