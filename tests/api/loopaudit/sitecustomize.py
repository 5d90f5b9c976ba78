"""Loaded by every test server's interpreter (its directory is put first on PYTHONPATH by
``tests/api/server.py``): records each heavy numerical module imported *on a running event
loop*, with the lab's frames that asked for it.

Such an import (python-control, scipy.signal, numba: seconds of CPU on a busy machine)
stalls every stream, request and websocket the web process serves; the lab imports them on
threads or in other processes (docs/architecture.md, start-up). A test server whose web
process wrote here fails at its stop."""

from __future__ import annotations

import asyncio
import os
import sys
import traceback

#: the modules whose first import takes long enough to stall a loop
HEAVY = frozenset({"control", "scipy.signal", "scipy.stats", "scipy.io", "numba", "matplotlib"})


class _LoopImports:
    def __init__(self, log: str) -> None:
        self.log = log

    def find_spec(self, name: str, path: object = None, target: object = None) -> None:
        if name in HEAVY:
            try:
                asyncio.get_running_loop()
            except RuntimeError:
                return None  # not on a loop: a thread, a worker, the start-up
            frames = [
                f"{f.filename}:{f.lineno} {f.name}"
                for f in traceback.extract_stack()
                if "/elab/" in f.filename
            ]
            with open(self.log, "a") as f:
                f.write(f"{os.getpid()} {name} <- {' <- '.join(reversed(frames))}\n")
        return None  # found by the finders after this one, as always


if os.environ.get("ELAB_TEST_LOOP_IMPORTS"):
    sys.meta_path.insert(0, _LoopImports(os.environ["ELAB_TEST_LOOP_IMPORTS"]))
