"""The identification workflow of the seed's chapter, as one call: data → estimation and
validation sets → correlation, spectral and sine analysis → ARX order search and subspace
singular values → the requested models, each compared on the validation set (simulation
and one-step fit %) with its residual analysis. The API, the CLI and the browser panels
all run this, so they give the same numbers. Fit % on the validation set: simulated from
a zero initial state (as the published figures), from the best initial state, and one
step ahead; on the estimation set, simulated from the best initial state.

Every result is JSON-ready (``Result.as_dict``); plotted series are thinned to at most
``MAX_POINTS`` points per series (every k-th sample; the fit figures use every sample).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any, Literal

import numpy as np
import scipy.linalg
from numpy.typing import NDArray

from elab.errors import InvalidInput
from elab.ident.data import IdData, require_varying, suspicious
from elab.ident.models import LinearModel
from elab.ident.nonparametric import cra, sine_response, spa
from elab.ident.pem import C_RADIUS, armax, oe
from elab.ident.polynomial import arx, arxstruc, selstruc, struc
from elab.ident.subspace import choose_order, decompose, n4sid
from elab.ident.validation import compare, resid

Array = NDArray[np.float64]
Progress = Callable[[str, float], None]
MAX_POINTS = 5000
MAX_SEARCH = 2000  # ARX structures in one order search
KINDS = {
    "arx": ("na", "nb", "nk"),
    "armax": ("na", "nb", "nc", "nk"),
    "oe": ("nb", "nf", "nk"),
    "n4sid": ("order", "horizon"),
}


@dataclass(frozen=True)
class ModelRequest:
    """A model to estimate: ``kind`` with its orders (n4sid: ``order`` 0 = choose by MDL
    over ``Plan.n4sid_orders``; ``horizon`` 0 = the default)."""

    kind: Literal["arx", "armax", "oe", "n4sid"]
    orders: dict[str, int]

    @property
    def name(self) -> str:
        given = [k for k in KINDS[self.kind] if self.kind != "n4sid" or self.orders.get(k)]
        return f"{self.kind} " + " ".join(str(self.orders[k]) for k in given)


@dataclass(frozen=True)
class Plan:
    """What to compute; ``split`` is the estimation share (the rest validates)."""

    models: tuple[ModelRequest, ...] = ()
    detrend: Literal["mean", "linear", "none"] = "mean"
    split: float = 0.5
    correlation: bool = True
    max_lag: int = 30
    spectral: bool = True
    sine_hz: float | None = None
    arx_search: tuple[range, range, range] | None = None
    n4sid_orders: range | None = None
    horizon: int | None = None


@dataclass
class Result:
    data: dict[str, Any]
    analyses: dict[str, Any] = field(default_factory=dict)
    models: list[dict[str, Any]] = field(default_factory=list)
    fitted: list[LinearModel] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)

    def as_dict(self) -> dict[str, Any]:
        return {
            "data": self.data,
            "analyses": self.analyses,
            "models": self.models,
            "notes": self.notes,
        }


def parse_model(text: str) -> ModelRequest:
    """``arx:4,4,3``, ``armax:2,2,2,3``, ``oe:2,2,3``, ``n4sid:4`` or ``n4sid:4,16`` or
    ``n4sid`` (order chosen from the singular values)."""
    kind, _, rest = text.strip().partition(":")
    if kind not in KINDS:
        raise InvalidInput("model", text, f"kind:orders with kind one of {', '.join(KINDS)}")
    names = KINDS[kind]
    try:
        values = [int(v) for v in rest.split(",")] if rest else []
    except ValueError:
        raise InvalidInput("model", text, f"{kind}:{','.join(names)} (integers)") from None
    if kind == "n4sid":
        values = [*values, 0, 0][:2] if len(values) <= 2 else values
    if len(values) != len(names):
        raise InvalidInput("model", text, f"{kind}:{','.join(names)}")
    return ModelRequest(kind, dict(zip(names, values, strict=True)))  # type: ignore[arg-type]


def run(
    data: IdData,
    plan: Plan,
    progress: Progress | None = None,
    validation: IdData | None = None,
) -> Result:
    """Everything ``plan`` asks for on ``data`` (see the module docstring). ``validation``:
    a separate record to validate on (``data`` is then all estimation, and ``split`` is
    not used)."""
    report = progress or (lambda stage, done: None)
    if validation is None:
        if not 0 < plan.split < 1:
            raise InvalidInput("split", plan.split, "a fraction in (0, 1): the estimation share")
        ze, zv = data.split(float(plan.split))
    else:
        ze, zv = data, _same_channels(data, validation)
    require_varying(ze.y, list(data.output_names), "estimation part")
    if plan.detrend != "none" and validation is None:
        # each part its own trend, as MATLAB's standard experiment
        ze, zv = ze.detrend(plan.detrend), zv.detrend(plan.detrend)
    elif plan.detrend == "mean":  # a record of its own: the estimation record's means
        y0, u0 = ze.y.mean(axis=0), ze.u.mean(axis=0)
        ze = replace(ze, y=ze.y - y0, u=ze.u - u0, trend="mean")
        zv = replace(zv, y=zv.y - y0, u=zv.u - u0, trend="mean")
    elif plan.detrend == "linear":  # a line does not carry over: each record its own
        ze, zv = ze.detrend("linear"), zv.detrend("linear")
    z = IdData(
        np.vstack([ze.y, zv.y]),
        np.vstack([ze.u, zv.u]),
        data.Ts,
        data.output_names,
        data.input_names,
        data.output_units,
        data.input_units,
        data.k0,
        ze.trend,
    )
    siso = z.ny == 1 and z.nu == 1
    out = Result(
        data=_data_view(z, ze.N) | {"validation": "split" if validation is None else "record"}
    )
    out.notes += suspicious(data)  # on the data as given: detrending moves the edges
    if validation is not None:
        out.notes += [f"validation record: {n}" for n in suspicious(validation)]
    report("data", 0.02)
    if not siso and (plan.correlation or plan.spectral or plan.sine_hz):
        out.notes.append(
            f"{z.ny} outputs and {z.nu} inputs: correlation, spectral and sine "
            "analysis need one of each; they were skipped"
        )
    asked_more = bool(plan.models or plan.arx_search or plan.n4sid_orders or plan.sine_hz)
    if siso and plan.correlation:
        try:
            c = cra(ze, max_lag=min(plan.max_lag, max(ze.N // 4 - 12, 1)))
        except InvalidInput as exc:
            if not asked_more:  # it was all that was asked for
                raise
            out.notes.append(f"correlation analysis skipped: {exc}")
        else:
            out.analyses["correlation"] = c.as_dict() | {"Ts": z.Ts}
        report("correlation", 0.05)
    if siso and plan.spectral:
        try:
            out.analyses["spectral"] = spa(ze).as_dict()
        except InvalidInput as exc:
            if not asked_more:
                raise
            out.notes.append(f"spectral analysis skipped: {exc}")
        report("spectral", 0.08)
    if siso and plan.sine_hz is not None:
        out.analyses["sine"] = sine_response(z, plan.sine_hz).as_dict()
    if plan.arx_search is not None:
        searches = _arx_search(ze, zv, plan.arx_search, report)
        if siso:
            out.analyses["arx_search"] = searches[0]
        else:  # one search per output
            out.analyses["arx_search_outputs"] = searches
    chosen = [m for m in plan.models if m.kind == "n4sid" and not m.orders.get("order")]
    if plan.n4sid_orders is not None or chosen:  # the order table: asked for, or needed
        sub = decompose(ze, plan.horizon)
        orders = plan.n4sid_orders or range(1, min(10, sub.max_order) + 1)
        best, rows, why = choose_order(sub, orders)
        out.analyses["n4sid_orders"] = {
            "horizon": sub.horizon,
            "best": best,
            "reason": why,
            "orders": rows,
            "singular_values": sub.singular_values.tolist(),
        }
        report("subspace", 0.6)
    else:
        sub, best = None, 0
    flat = [zv.output_names[j] for j in range(zv.ny) if np.ptp(zv.y[:, j]) == 0]
    if flat and plan.models:
        out.notes.append(
            f"the validation part of {', '.join(flat)} is constant: fits on it are "
            "undefined (null); the estimation fits stand"
        )
    for i, request in enumerate(plan.models):
        model = _estimate(ze, request, sub, best, plan.horizon, i)
        out.fitted.append(model)
        out.models.append(_describe(model, request, ze, zv, i))
        out.notes += _said(out.models[-1]["name"], model)
        report(f"model {request.name}", 0.6 + 0.4 * (i + 1) / len(plan.models))
    report("done", 1.0)
    return out


def _same_channels(data: IdData, validation: IdData) -> IdData:
    """The validation record, checked to be the same experiment's kind: the same sample
    time and channels."""
    if not math.isclose(validation.Ts, data.Ts, rel_tol=1e-9):
        raise InvalidInput(
            "validation.Ts", validation.Ts, f"the estimation record's sample time {data.Ts:g} s"
        )
    for what in ("output_names", "input_names"):
        if getattr(validation, what) != getattr(data, what):
            raise InvalidInput(
                f"validation.{what}",
                list(getattr(validation, what)),
                f"the estimation record's {', '.join(getattr(data, what))}",
            )
    return validation


def _said(name: str, m: LinearModel) -> list[str]:
    """What a reader of a model must know: an unstable estimate kept or reflected (with
    the estimation fits that chose), a Kalman gain that could not be had."""
    notes = []
    top = float(np.max(np.abs(m.poles))) if m.n else 0.0
    p = m.parameters
    chose = ""
    if "estimation_fit_reflected" in p:
        chose = (
            f": estimation fit {_pct(p['estimation_fit_as_estimated'])} as estimated, "
            f"{_pct(p['estimation_fit_reflected'])} reflected"
        )
    if m.kind == "n4sid" and p.get("reflected"):
        moved = ", ".join(f"|z| {a:.4g} → {b:.4g}" for a, b in p["reflected"])
        notes.append(
            f"{name}: poles outside the unit circle were reflected into it ({moved}){chose}"
        )
    elif top > 1.0:
        notes.append(
            f"{name}: a pole outside the unit circle (|z| = {top:.4g}): the model is "
            f"unstable as estimated, and kept so{chose}"
        )
    if m.kind == "armax" and p.get("c_at_margin"):
        notes.append(
            f"{name}: C's roots were held at |z| = {C_RADIUS:g}: the noise model wants one on "
            "the unit circle (a drift, or a disturbance that integrates); the one-step "
            "predictor stays stable, but try detrending the data or a model with an integrator"
        )
    if m.kind == "n4sid" and p.get("kalman") == "none":
        notes.append(
            f"{name}: no Kalman gain (the Riccati equation had no stabilising solution): "
            "K = 0, so its one-step prediction is its simulation"
        )
    return notes


def _pct(v: float) -> str:
    return f"{v:.2f} %" if math.isfinite(v) else "−∞ %"


def _arx_search(
    ze: IdData, zv: IdData, ranges: tuple[range, range, range], report: Progress
) -> list[dict[str, Any]]:
    """Each output's own search (with every input, each structure's nb and nk for all)."""
    S = struc(*ranges)
    if S.shape[0] * ze.ny > MAX_SEARCH:
        raise InvalidInput(
            "arx_search",
            f"{S.shape[0]} structures" + (f" for each of {ze.ny} outputs" if ze.ny > 1 else ""),
            f"at most {MAX_SEARCH} structures (na × nb × nk × outputs)",
        )
    delays = np.unique(S[:, 2])
    out = []
    for i in range(ze.ny):
        parts = []
        for k, nk in enumerate(delays):  # one delay at a time, to report progress
            parts.append(arxstruc(_output(ze, i), _output(zv, i), S[S[:, 2] == nk]))
            report("arx search", 0.1 + 0.4 * (i * len(delays) + k + 1) / (len(delays) * ze.ny))
        V = np.vstack(parts)
        out.append(
            {
                "rows": V.tolist(),
                "best": list(selstruc(V, 0)),
                "aic": list(selstruc(V, "aic", zv.N)),
                "mdl": list(selstruc(V, "mdl", zv.N)),
            }
        )
    return [{"output": y} | r for y, r in zip(ze.output_names, out, strict=True)]


def _estimate(
    ze: IdData, r: ModelRequest, sub: Any, best: int, horizon: int | None, i: int
) -> LinearModel:
    o = r.orders
    if r.kind in ("armax", "oe") and (ze.ny != 1 or ze.nu != 1):
        raise InvalidInput(
            f"models[{i}].kind",
            r.kind,
            f"arx or n4sid for {ze.ny} outputs and {ze.nu} inputs "
            f"({r.kind}: one output and one input)",
        )
    try:
        if r.kind == "arx":
            return arx(ze, o["na"], o["nb"], o["nk"])
        if r.kind == "armax":
            return armax(ze, o["na"], o["nb"], o["nc"], o["nk"])
        if r.kind == "oe":
            return oe(ze, o["nb"], o["nf"], o["nk"])
        own = o.get("horizon") or None
        if sub is None or (own is not None and own != sub.horizon):
            sub = decompose(ze, own or horizon)
        return n4sid(ze, o.get("order") or best, sub=sub)
    except InvalidInput as exc:
        raise InvalidInput(f"models[{i}].{exc.field}", exc.value, exc.allowed) from None


def _describe(m: LinearModel, r: ModelRequest, ze: IdData, zv: IdData, i: int) -> dict[str, Any]:
    sim = compare(m, zv)  # zero initial state, as the published figures
    sim_x0 = compare(m, zv, x0="estimate")
    one = compare(m, zv, horizon=1, x0="estimate")
    est = compare(m, ze, x0="estimate")
    headline = _headline(m, zv.N)
    out: dict[str, Any] = {
        "name": r.name if r.kind != "n4sid" or r.orders.get("order") else f"n4sid {m.n}",
        "kind": m.kind,
        "orders": m.orders,
        "parameters": _jsonable(m.parameters),
        "fit": {
            "validation_simulation": sim.fit.tolist(),
            "validation_simulation_x0": sim_x0.fit.tolist(),
            "validation_one_step": one.fit.tolist(),
            "estimation_simulation": est.fit.tolist(),
            "headline": (sim_x0 if headline["x0"] == "estimated" else sim).fit.tolist(),
            "headline_x0": headline["x0"],
            "headline_why": headline["why"],
        },
        "noise_variance": m.noise_variance.tolist(),
        "poles": [[p.real, p.imag] for p in m.poles],
        "stable": bool(np.all(np.abs(m.poles) < 1)) if m.n else True,
        "ss": {
            "A": m.A.tolist(),
            "B": m.B.tolist(),
            "C": m.C.tolist(),
            "D": m.D.tolist(),
            "K": m.K.tolist(),
            "Ts": m.Ts,
        },
        "tf": _tf(m),
        "continuous": _continuous(m),
        "simulated": _thin(sim.yhat),
        "simulated_x0": _thin(sim_x0.yhat),
        "one_step": _thin(one.yhat),
    }
    if ze.ny == 1 and ze.nu == 1:
        lag = min(25, zv.N // 4 - 1)
        out["residuals"] = resid(m, zv, max_lag=lag).as_dict() if lag >= 1 else None
    return out


def _headline(m: LinearModel, N: int) -> dict[str, str]:
    """Which validation fit means something for this model: from a zero initial state
    (the published figures' convention) when every mode decays within the validation
    record, else from the estimated initial state — an integrating or unstable plant (or
    one slower than the record) starts where the record starts, and a zero-state
    simulation mostly measures that start (an ARX model of an integrating plant whose
    poles matched the physics to four digits "fitted" −36.82 % from a zero state)."""
    slowest = float(np.max(np.abs(m.poles))) if m.n else 0.0
    if slowest < math.exp(-1.0 / max(N, 1)):
        return {"x0": "zero", "why": "every mode decays within the validation record"}
    if slowest > 1.0:
        why = f"a pole at |z| = {slowest:.4g} is unstable"
    else:
        why = f"a pole at |z| = {slowest:.4g} takes longer than the {N}-sample record to decay"
    return {"x0": "estimated", "why": f"{why}, so the initial state is estimated"}


def _tf(m: LinearModel) -> list[list[dict[str, list[float]]]]:
    """Discrete transfer functions, [output][input], coefficients in powers of z."""
    return [
        [{"num": num.tolist(), "den": den.tolist()} for num, den in row]
        for row in m.transfer_functions()
    ]


def _continuous(m: LinearModel) -> dict[str, Any] | None:
    """The model in continuous time (inverse zero-order hold), if it has no pole on the
    negative real axis or at zero (where the matrix logarithm has no real value)."""
    if (
        m.n == 0
        or np.any(np.abs(m.poles) < 1e-9)
        or np.any((np.abs(m.poles.imag) < 1e-12) & (m.poles.real < 0))
    ):
        return None
    try:
        Ac, Bc = _d2c_zoh(m)  # python-control 0.10 has c2d but no d2c
    except (ValueError, np.linalg.LinAlgError):
        return None
    A = np.real_if_close(Ac)
    if np.iscomplexobj(A):
        return None
    return {"A": A.tolist(), "B": Bc.tolist(), "C": m.C.tolist(), "D": m.D.tolist()}


def _d2c_zoh(m: LinearModel) -> tuple[Array, Array]:
    """Ac, Bc of the inverse of the zero-order hold: [[A, B], [0, I]] = expm(Ts [[Ac, Bc],
    [0, 0]]); C and D carry over."""
    n, nu = m.n, m.nu
    M = np.zeros((n + nu, n + nu))
    M[:n, :n], M[:n, n:], M[n:, n:] = m.A, m.B, np.eye(nu)
    L = scipy.linalg.logm(M) / m.Ts
    if np.max(np.abs(np.imag(L))) > 1e-8:
        raise ValueError("no real logarithm")
    L = np.real(L)
    return L[:n, :n], L[:n, n:]


def _thin(a: Array) -> list[list[float]]:
    step = max(1, math.ceil(a.shape[0] / MAX_POINTS))
    rows: list[list[float]] = np.asarray(a[::step]).T.tolist()
    return rows


def _data_view(z: IdData, n_est: int) -> dict[str, Any]:
    step = max(1, math.ceil(z.N / MAX_POINTS))
    return {
        "N": z.N,
        "Ts": z.Ts,
        "estimation": n_est,
        "step": step,
        "trend": z.trend,
        "t": z.t[::step].tolist(),
        "u": z.u[::step].T.tolist(),
        "y": z.y[::step].T.tolist(),
        "input_names": list(z.input_names),
        "output_names": list(z.output_names),
        "input_units": list(z.input_units),
        "output_units": list(z.output_units),
    }


def _jsonable(obj: Any) -> Any:
    if isinstance(obj, dict):
        return {k: _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    if isinstance(obj, np.generic):
        return obj.item()
    return obj


def _output(z: IdData, i: int) -> IdData:
    """Output ``i`` of ``z`` with every input."""
    if z.ny == 1:
        return z
    return replace(
        z, y=z.y[:, [i]], output_names=(z.output_names[i],), output_units=(z.output_units[i],)
    )
