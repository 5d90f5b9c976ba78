"""Analysis and design of LTI plants and models, built on python-control.

- :mod:`~elab.design.analysis`: eigenvalues and stability, controllability,
  observability, transfer functions;
- :mod:`~elab.design.response`: step response and its metrics, Bode, margins;
- :mod:`~elab.design.realise`: any control law as one continuous LTI controller;
- :mod:`~elab.design.plant_loop`: a plant closed by any control law, loop transfer;
- :mod:`~elab.design.synthesis`: LQR (continuous and discrete) and pole placement;
- on a given model (an identified one, continuous or discrete):
  :mod:`~elab.design.model` (the model, its continuous equivalent),
  :mod:`~elab.design.observed` (state feedback on an observer, PID, the law a run takes),
  :mod:`~elab.design.loop` (the closed loop, its verdict, step and margins) and
  :mod:`~elab.design.locus` (the root locus).

Every result is a frozen dataclass of read-only numpy arrays.

The names are loaded on first use (PEP 562; ``realise`` is the module's name here, its
function is ``elab.design.realise.realise``): python-control is seconds of imports, which a
process that only checks and stores a model (the web process) does without.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from elab._lazy import Where, lazy_exports

if TYPE_CHECKING:
    from elab.design.analysis import (
        Analysis,
        RankReport,
        Stability,
        TransferFunction,
        analyze,
        controllability,
        observability,
        stability,
        transfer_functions,
    )
    from elab.design.plant_loop import closed_loop, loop_transfer
    from elab.design.realise import Realisation, lti_ss, pid_tf
    from elab.design.response import (
        Bode,
        Margins,
        StepInfo,
        StepResponse,
        bode,
        default_horizon,
        margins,
        step_info,
        step_response,
    )
    from elab.design.synthesis import LQR, Placement, design_lqr, design_place, dlqr, lqr, place

#: each exported name: its module
_EXPORTS: dict[str, Where] = {
    "Analysis": "elab.design.analysis",
    "RankReport": "elab.design.analysis",
    "Stability": "elab.design.analysis",
    "TransferFunction": "elab.design.analysis",
    "analyze": "elab.design.analysis",
    "controllability": "elab.design.analysis",
    "observability": "elab.design.analysis",
    "stability": "elab.design.analysis",
    "transfer_functions": "elab.design.analysis",
    "closed_loop": "elab.design.plant_loop",
    "loop_transfer": "elab.design.plant_loop",
    "Realisation": "elab.design.realise",
    "lti_ss": "elab.design.realise",
    "pid_tf": "elab.design.realise",
    "Bode": "elab.design.response",
    "Margins": "elab.design.response",
    "StepInfo": "elab.design.response",
    "StepResponse": "elab.design.response",
    "bode": "elab.design.response",
    "default_horizon": "elab.design.response",
    "margins": "elab.design.response",
    "step_info": "elab.design.response",
    "step_response": "elab.design.response",
    "LQR": "elab.design.synthesis",
    "Placement": "elab.design.synthesis",
    "design_lqr": "elab.design.synthesis",
    "design_place": "elab.design.synthesis",
    "dlqr": "elab.design.synthesis",
    "lqr": "elab.design.synthesis",
    "place": "elab.design.synthesis",
}

__all__ = [
    "LQR",
    "Analysis",
    "Bode",
    "Margins",
    "Placement",
    "RankReport",
    "Realisation",
    "Stability",
    "StepInfo",
    "StepResponse",
    "TransferFunction",
    "analyze",
    "bode",
    "closed_loop",
    "controllability",
    "default_horizon",
    "design_lqr",
    "design_place",
    "dlqr",
    "loop_transfer",
    "lqr",
    "lti_ss",
    "margins",
    "observability",
    "pid_tf",
    "place",
    "stability",
    "step_info",
    "step_response",
    "transfer_functions",
]


__getattr__ = lazy_exports(__name__, _EXPORTS)
