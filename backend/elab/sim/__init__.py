"""The simulation engine: one stepping loop for every plant and controller.

:func:`simulate` runs a whole :class:`RunSpec` at once; :class:`Simulation`
steps one run chunk by chunk (the same samples either way); :class:`Batch`
steps many runs with one call of the compiled loop.
"""

from elab.sim.batch import Batch
from elab.sim.controllers import DiscreteController, discretise
from elab.sim.engine import Simulation, simulate
from elab.sim.result import Samples
from elab.sim.signals import PRBS, Chirp, Signal, Sine, Square, Step, make_signal
from elab.sim.signals import Samples as UserSamples
from elab.sim.spec import CompiledRun, RunSpec, compile_run

__all__ = [
    "PRBS",
    "Batch",
    "Chirp",
    "CompiledRun",
    "DiscreteController",
    "RunSpec",
    "Samples",
    "Signal",
    "Simulation",
    "Sine",
    "Square",
    "Step",
    "UserSamples",
    "compile_run",
    "discretise",
    "make_signal",
    "simulate",
]
