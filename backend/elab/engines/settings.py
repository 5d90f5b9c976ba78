"""What an engine and a Python controller may take: settings read once by the web process
(:mod:`elab.api.settings`) and handed to the engine process and the trial workers.

Here, apart from the engines that use them: the web process reads them without importing
the stepping code (numba, python-control: seconds of imports at every start).
"""

from __future__ import annotations

from dataclasses import dataclass

from elab.engines.rigseat import SeatSettings
from elab.rig_queue import QueuePolicy

#: s of a run the rig's trial tries at most (its start: where a bad law shows); here, where
#: the web process reads it to key its passed trials, apart from the trial's own imports
TRIAL_S = 10.0


@dataclass(frozen=True)
class CodeSettings:
    """``deadline``: s a step may take; ``max_misses``: steps in a row whose own compute
    time passed it that fail the run (a simulation waits for a late answer, so a busy
    machine never changes the samples or fails a run; the rig will hold the last u);
    ``budget``: the share of the run's time the controller may compute in all (a
    controller slow in 9 steps of 10 never misses 10 in a row, but passes this)."""

    deadline: float = 0.5e-3
    max_misses: int = 10
    budget: float = 0.5
    # s a simulation waits for one answer before the controller fails: a controller that
    # never answers holds its own run's thread that long (once: then its run fails); on a
    # loaded machine a 20 ms step waited 0.2 s for a CPU (issue 24)
    patience: float = 1.0
    # s its process may take to load and reset(): less than the engine's 10 s to answer a
    # command (ELAB_ENGINE_TIMEOUT), so a reset() that never returns is this run's 422,
    # not the engine's 503
    start: float = 5.0


@dataclass(frozen=True)
class EngineSettings:
    """``tick``: the stepper's period (one 20 ms frame per run per tick);
    ``flush_interval``: how often samples are committed (what a crash may lose);
    ``retry_for``: how long a busy store is retried before its runs fail;
    ``max_pending``: bytes of samples that may wait for a busy store; ``realtime``: the
    stepping thread's real-time priority (SCHED_FIFO; 0: none). Code controllers:
    ``max_code_runs`` live at once, ``code_deadline`` s per step before the last u is held,
    ``code_misses`` late steps in a row that fail the run, ``code_budget`` the share of the
    run's time it may compute in all, ``code_patience`` s one answer may take before the
    run fails."""

    tick: float = 0.02
    flush_interval: float = 0.25
    retry_for: float = 30.0
    max_pending: int = 256 << 20
    realtime: int = 0  # SCHED_FIFO priority of the stepping thread (0: an ordinary thread)
    max_code_runs: int = 8
    code_deadline: float = 0.5e-3
    code_misses: int = 10
    code_budget: float = 0.5
    code_patience: float = 1.0

    @property
    def code(self) -> CodeSettings:
        """What a Python controller may take (its runs and its upload trial)."""
        return CodeSettings(
            self.code_deadline, self.code_misses, self.code_budget, self.code_patience
        )


@dataclass(frozen=True)
class RigSettings:
    """``address``: the rig's ``host:port`` (E-Lab's byte protocol); ``sample_timeout``:
    s without a sample before the rig counts as silent (its run fails); ``block``:
    samples per block to the recorder and the watchers (20 ms at 1 kHz); ``realtime``:
    the loop thread's SCHED_FIFO priority (0: none); ``omega_c``: rad/s of the
    differentiators that estimate θ̇ and α̇ for the record and the supervisor (the seed's
    velocity filter for θ); the store's settings as the simulation engine's; ``rig``,
    ``slot``, ``grace``: the rig's queue in the store and its policy
    (:mod:`elab.engines.rigseat`); ``estop``: the e-stop socket to listen on
    (:mod:`elab.rig.estop`); ``code_deadline``: s a Python controller may take per
    step before its answer counts as late."""

    address: str = "127.0.0.1:7100"
    sample_timeout: float = 0.1
    block: int = 20
    realtime: int = 0
    omega_c: float = 150.0
    still_for: float = 2.0  # s the link must be still after a run before the next
    flush_interval: float = 0.25
    retry_for: float = 30.0
    max_pending: int = 256 << 20
    rig: str = "rig"  # the rig's queue in the store
    slot: float = QueuePolicy.slot
    grace: float = QueuePolicy.grace
    estop: str | None = None  # the e-stop socket (elab.rig.estop.estop_address); None: none
    code_deadline: float = CodeSettings.deadline  # s a Python controller's step may take

    @property
    def seat(self) -> SeatSettings:
        return SeatSettings(self.rig, QueuePolicy(self.slot, self.grace))

    @property
    def code(self) -> CodeSettings:
        return CodeSettings(deadline=self.code_deadline)
