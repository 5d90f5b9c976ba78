"""A contender in the rig-queue race (tests/unit/store/test_rig_queue_store.py): a
process of its own with a store of its own on the shared file or database. Kept apart from the test
module so that a spawned process imports little."""

from __future__ import annotations

from typing import Any

from elab.rig_queue import Join, QueuePolicy
from elab.store import open_store


def contend(target: str, user: str, rounds: int, barrier: Any, results: Any) -> None:
    """Join the queue of rig ``race-k`` for k < ``rounds``, each time together with the
    other contender (``barrier``); put ``(k, user, driver, place)`` as seen by this
    process's join into ``results``."""
    with open_store(target, migrate=False) as store:
        for k in range(rounds):
            barrier.wait()
            q = store.apply_rig(f"race-{k}", Join(user), QueuePolicy(), float(k)).queue
            results.put((k, user, q.driver, q.place(user)))
