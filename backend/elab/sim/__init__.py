"""The simulation engine: one stepping loop for every plant and controller.

:func:`simulate` runs a whole :class:`RunSpec` at once; :class:`Simulation`
steps one run chunk by chunk (the same samples either way); :class:`Batch`
steps many runs with one call of the compiled loop.

The names below are loaded on first use (PEP 562): the engine brings python-control,
scipy and numba (seconds of imports), which a module that needs only the signals
(:mod:`elab.sim.signals`, the web process's schemas) must not pay for.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from elab._lazy import Where, lazy_exports

if TYPE_CHECKING:
    from elab.sim.batch import Batch
    from elab.sim.controllers import DiscreteController, discretise
    from elab.sim.engine import Simulation, simulate
    from elab.sim.result import Samples
    from elab.sim.signals import PRBS, Chirp, Signal, Sine, Square, Step, make_signal
    from elab.sim.signals import Samples as UserSamples
    from elab.sim.spec import CompiledRun, RunSpec, compile_run

#: each exported name: (its module, its name there)
_EXPORTS: dict[str, Where] = {
    "Batch": ("elab.sim.batch", "Batch"),
    "DiscreteController": ("elab.sim.controllers", "DiscreteController"),
    "discretise": ("elab.sim.controllers", "discretise"),
    "Simulation": ("elab.sim.engine", "Simulation"),
    "simulate": ("elab.sim.engine", "simulate"),
    "Samples": ("elab.sim.result", "Samples"),
    "PRBS": ("elab.sim.signals", "PRBS"),
    "Chirp": ("elab.sim.signals", "Chirp"),
    "Signal": ("elab.sim.signals", "Signal"),
    "Sine": ("elab.sim.signals", "Sine"),
    "Square": ("elab.sim.signals", "Square"),
    "Step": ("elab.sim.signals", "Step"),
    "make_signal": ("elab.sim.signals", "make_signal"),
    "UserSamples": ("elab.sim.signals", "Samples"),
    "CompiledRun": ("elab.sim.spec", "CompiledRun"),
    "RunSpec": ("elab.sim.spec", "RunSpec"),
    "compile_run": ("elab.sim.spec", "compile_run"),
}

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


__getattr__ = lazy_exports(__name__, _EXPORTS)
