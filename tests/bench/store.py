"""The store on PostgreSQL against the embedded SQLite file (issue 29), the same operations
through the same protocol, in one process on one machine, interleaved, min / median / max
of 3:

- **flush**: what the engine commits every 0.25 s at 300 live runs at 1 kHz — one
  ``append_many`` of 300 chunks of 250 rows × 5 channels (3 MB) — against its 250 ms
  budget;
- **download**: a 10⁶-row run read back in the 8,192-row parts a download reads;
- **lifecycle**: a run created, started and finished (three transactions);
- **list**: a page of 50 runs, newest first, among 1,000.

PostgreSQL 15 (Debian's) on loopback TCP with its defaults but ``synchronous_commit =
off``: like SQLite's WAL at ``synchronous = NORMAL``, a commit does not wait for its
``fsync`` (a crash of the machine may lose the last commits, never consistency); both
``fsync`` their logs in the background.
"""

from __future__ import annotations

import statistics
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from elab.store import RunRecord, Store, open_store  # noqa: E402
from tests.postgres import PostgresServer  # noqa: E402

REPEAT = 3
RUNS, ROWS, NCH = 300, 250, 5
BIG = 1_000_000
PART = 8_192
CHANNELS = tuple((f"c{i}", "V") for i in range(NCH))


def _record(rid: str, n: int = 10**6, at: float = 1.7e9) -> RunRecord:
    return RunRecord(
        id=rid, plant="flexible_link", mode="simulation", experiment="analysis",
        spec={"plant": "flexible_link"}, status="running", Ts=1e-3, channels=CHANNELS,
        n_planned=n, created_at=at, engine="sim-0", owner="bench",
    )  # fmt: skip


def _timed(fn: Callable[[], object]) -> float:
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


def _measure(store: Store) -> dict[str, list[float]]:
    """One round of every operation on ``store`` (fresh), seconds."""
    rng = np.random.default_rng(1)
    out: dict[str, list[float]] = {"flush": [], "download": [], "lifecycle": [], "list": []}
    ids = [f"live-{i}" for i in range(RUNS)]
    for rid in ids:
        store.create_run(_record(rid))
    block = rng.standard_normal((ROWS, NCH))
    for k in range(20):  # 5 s of 300 live runs
        items = [(rid, k * ROWS, block) for rid in ids]
        out["flush"].append(_timed(lambda items=items: store.append_many(items)))
    store.create_run(_record("big"))
    for k0 in range(0, BIG, 200_000):  # a fast run's chunks
        store.append("big", k0, rng.standard_normal((200_000, NCH)))

    def download() -> None:
        for k0 in range(0, BIG, PART):
            store.read("big", k0, k0 + PART)

    out["download"].append(_timed(download))
    for i in range(200):

        def lifecycle(i: int = i) -> None:
            rid = f"done-{i}"
            store.create_run(_record(rid, 100, 1.7e9 + i))
            store.set_status(rid, "running", started_at=1.7e9 + i)
            store.set_status(rid, "finished", finished_at=1.7e9 + i + 1)

        out["lifecycle"].append(_timed(lifecycle))
    for i in range(RUNS + 201, 1_000):
        store.create_run(_record(f"old-{i}", 100, 1.6e9 + i))
    for _ in range(50):
        out["list"].append(_timed(lambda: store.list_runs(limit=50, offset=100)))
    return out


def bench_store() -> str:
    pg = PostgresServer(durable=True)
    pg.start()
    per: dict[str, dict[str, list[float]]] = {"SQLite": {}, "PostgreSQL": {}}
    try:
        with tempfile.TemporaryDirectory() as tmp:
            for r in range(REPEAT):
                for kind in ("SQLite", "PostgreSQL"):
                    target = str(Path(tmp) / f"s{r}.sqlite3") if kind == "SQLite" else pg.schema()
                    with open_store(target) as store:
                        for op, times in _measure(store).items():
                            per[kind].setdefault(op, []).append(statistics.median(times))
    finally:
        pg.stop()

    def cell(kind: str, op: str, scale: float, fmt: str) -> str:
        v = sorted(x * scale for x in per[kind][op])
        return f"{v[0]:{fmt}} / {statistics.median(v):{fmt}} / {v[-1]:{fmt}}"

    rows = [
        ("flush: 300 chunks of 250 × 5 (ms)", "flush", 1e3, ".1f"),
        ("download: 10⁶ rows in 8,192-row parts (s)", "download", 1, ".2f"),
        ("lifecycle: create, start, finish (ms)", "lifecycle", 1e3, ".2f"),
        ("list: page of 50 among 1,000 (ms)", "list", 1e3, ".2f"),
    ]
    lines = [
        "## The store: PostgreSQL against SQLite (issue 29)",
        "",
        "The same operations through the same protocol in one process (tests/bench/store.py "
        "says what each is); min / median / max over 3 rounds of each round's median. "
        "Ratio: PostgreSQL's median over SQLite's.",
        "",
        "| operation | SQLite | PostgreSQL | ratio |",
        "| --- | ---: | ---: | ---: |",
    ]
    for name, op, scale, fmt in rows:
        ratio = statistics.median(per["PostgreSQL"][op]) / statistics.median(per["SQLite"][op])
        lines.append(
            f"| {name} | {cell('SQLite', op, scale, fmt)} | {cell('PostgreSQL', op, scale, fmt)} "
            f"| {ratio:.2f}× |"
        )
    return "\n".join(lines)


if __name__ == "__main__":
    print(bench_store())
