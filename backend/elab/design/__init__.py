"""Analysis and design of LTI plants and models, built on python-control.

- :mod:`~elab.design.analysis`: eigenvalues and stability, controllability,
  observability, transfer functions;
- :mod:`~elab.design.response`: step response and its metrics, Bode, margins;
- :mod:`~elab.design.realise`: any control law as one continuous LTI controller;
- :mod:`~elab.design.closed_loop`: a plant closed by any control law, loop transfer;
- :mod:`~elab.design.synthesis`: LQR (continuous and discrete) and pole placement;
- on a given model (an identified one, continuous or discrete):
  :mod:`~elab.design.model` (the model, its continuous equivalent),
  :mod:`~elab.design.observed` (state feedback on an observer, PID, the law a run takes),
  :mod:`~elab.design.loop` (the closed loop, its verdict, step and margins) and
  :mod:`~elab.design.locus` (the root locus).

Every result is a frozen dataclass of read-only numpy arrays.
"""

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
from elab.design.closed_loop import closed_loop, loop_transfer
from elab.design.realise import Realisation, lti_ss, pid_tf, realise
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
    "realise",
    "stability",
    "step_info",
    "step_response",
    "transfer_functions",
]
