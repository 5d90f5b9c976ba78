"""What the processes forked from the fork server (:mod:`elab.jobs`) import before their
first job, named in one module that imports nothing, so that ``elab serve`` can start the
fork server before it imports the web app: the fork server's imports (python-control,
scipy, numba: about 4 s of CPU on a slow two-core host) then run beside the web process's
own (about 1.6 s) instead of after them.

Each pool and the engine supervisor still ask for their own modules
(:func:`elab.jobs.import_in_fork_server`); one asked for after the fork server started
without it is imported by every process forked for it instead, and logged.
"""

from __future__ import annotations

#: the engine process's body (:data:`elab.engines.process.CHILD`)
ENGINE = ("elab.engines.child",)

#: the identification workers: the jobs' functions and the estimators they call lazily
IDENT = (
    "elab.api.identjson",
    "elab.ident.files",
    "elab.ident.nonparametric",
    "elab.ident.pem",
    "elab.ident.polynomial",
    "elab.ident.subspace",
    "elab.ident.validation",
)

#: the controller-trial workers: the upload check and the rig's trial
#: (:mod:`elab.runs.rigdesk`), never imported by the web process
TRIALS = (
    "elab.api.controllers",
    "elab.engines.coded",
    "elab.controllers.report",
    "elab.engines.rigtrial",
)

#: everything, as ``elab serve`` starts the fork server
ALL = (*ENGINE, *IDENT, *TRIALS)
