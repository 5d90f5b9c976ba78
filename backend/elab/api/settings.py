"""Server settings from the environment (read once, at start-up).

Every limit a client can push has a setting here; docs/operations.md lists them
with their defaults and the error a client gets at the limit.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

from elab.engines.simulation import EngineSettings
from elab.errors import InvalidInput
from elab.runs.limits import Limits

#: the stepping thread's SCHED_FIFO priority by default (1..99; the kernel's threads: 50)
REALTIME = 10


@dataclass(frozen=True)
class Settings:
    """``ELAB_DATA`` (default ``./data``): where the SQLite file lives. Limits: ``limits``
    (runs; see :class:`~elab.runs.limits.Limits`), ``max_body`` bytes of a request
    (``ELAB_MAX_BODY``, 1 MiB), ``max_upload`` bytes of identification data
    (``ELAB_MAX_UPLOAD``, 16 MiB), ``max_uploads`` large bodies read at once
    (``ELAB_MAX_UPLOADS``, 4), ``watcher_frames`` queued per watcher before it skips
    (``ELAB_WATCHER_FRAMES``, 100 ≈ 2 s). The engine: ``engine`` (tick, flush interval,
    ``ELAB_STORE_RETRY`` s a busy store is retried, ``ELAB_STORE_PENDING`` bytes that may
    wait for it), its real-time priority (``ELAB_ENGINE_REALTIME``, 10: the stepping thread
    SCHED_FIFO at 10 and the rest of the engine process at 9, where allowed, else ordinary;
    0: ordinary), its process's ``engine_nice`` when not real-time (``ELAB_ENGINE_NICE``,
    0), its queue to the web process ``engine_queue`` bytes (``ELAB_ENGINE_QUEUE``, 64 MiB),
    ``engine_timeout`` s to answer a command (``ELAB_ENGINE_TIMEOUT``, 10) and
    ``engine_stall`` s without a heartbeat before it is restarted (``ELAB_ENGINE_STALL``,
    30). Identification: ``ident_workers`` processes (``ELAB_IDENT_WORKERS``, 1),
    ``ident_timeout`` s per job (``ELAB_IDENT_TIMEOUT``, 120), ``ident_wait`` s a request
    waits for a worker (``ELAB_IDENT_WAIT``, 30)."""

    data_dir: Path = Path("data")
    limits: Limits = field(default_factory=Limits)
    max_body: int = 1 << 20
    max_upload: int = 16 << 20
    max_uploads: int = 4
    watcher_frames: int = 100
    engine: EngineSettings = field(default_factory=EngineSettings)
    engine_nice: int = 0
    engine_queue: int = 64 << 20
    engine_timeout: float = 10.0
    engine_stall: float = 30.0
    ident_workers: int = 1
    ident_timeout: float = 120.0
    ident_wait: float = 30.0

    @property
    def database(self) -> Path:
        return self.data_dir / "elab.sqlite3"

    @classmethod
    def from_env(cls, env: Mapping[str, str] = os.environ) -> Settings:
        d = Limits()
        limits = Limits(
            max_live=_int(env, "ELAB_MAX_LIVE_RUNS", d.max_live),
            max_live_per_client=_int(env, "ELAB_MAX_LIVE_PER_CLIENT", d.max_live_per_client),
            max_duration=_float(env, "ELAB_MAX_DURATION", d.max_duration),
            max_samples=_int(env, "ELAB_MAX_RUN_SAMPLES", d.max_samples),
            max_recording=_int(env, "ELAB_MAX_RECORDING", d.max_recording),
            ts_ratio=_float(env, "ELAB_TS_RATIO", d.ts_ratio),
        )
        e = EngineSettings()
        engine = EngineSettings(
            realtime=_int(env, "ELAB_ENGINE_REALTIME", REALTIME, lo=0, hi=99),
            tick=e.tick,
            flush_interval=e.flush_interval,
            retry_for=_float(env, "ELAB_STORE_RETRY", e.retry_for),
            max_pending=_int(env, "ELAB_STORE_PENDING", e.max_pending),
        )
        return cls(
            data_dir=Path(env.get("ELAB_DATA", "data")),
            limits=limits,
            max_body=_int(env, "ELAB_MAX_BODY", 1 << 20),
            max_upload=_int(env, "ELAB_MAX_UPLOAD", 16 << 20),
            max_uploads=_int(env, "ELAB_MAX_UPLOADS", 4),
            watcher_frames=_int(env, "ELAB_WATCHER_FRAMES", 100),
            engine=engine,
            engine_nice=_int(env, "ELAB_ENGINE_NICE", 0, lo=-20, hi=19),
            engine_queue=_int(env, "ELAB_ENGINE_QUEUE", 64 << 20),
            engine_timeout=_float(env, "ELAB_ENGINE_TIMEOUT", 10.0),
            engine_stall=_float(env, "ELAB_ENGINE_STALL", 30.0),
            ident_workers=_int(env, "ELAB_IDENT_WORKERS", 1, hi=64),
            ident_timeout=_float(env, "ELAB_IDENT_TIMEOUT", 120.0),
            ident_wait=_float(env, "ELAB_IDENT_WAIT", 30.0),
        )


def _int(env: Mapping[str, str], name: str, default: int, lo: int = 1, hi: int = 1 << 62) -> int:
    raw = env.get(name)
    if raw is None:
        return default
    try:
        value = int(raw, 10)
    except ValueError:
        value = None
    if value is None or not lo <= value <= hi or not raw.strip().lstrip("+-").isascii():
        raise InvalidInput(name, raw, f"an integer in [{lo}, {hi}]")
    return value


def _float(env: Mapping[str, str], name: str, default: float) -> float:
    raw = env.get(name)
    if raw is None:
        return default
    try:
        value = float(raw)
    except ValueError:
        value = float("nan")
    if not 0 < value < float("inf"):
        raise InvalidInput(name, raw, "a positive number")
    return value
