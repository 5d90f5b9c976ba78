"""Server settings from the environment (read once, at start-up)."""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

from elab.errors import InvalidInput


@dataclass(frozen=True)
class Settings:
    """``ELAB_DATA`` (default ``./data``): where the SQLite file lives;
    ``ELAB_MAX_LIVE_RUNS`` (400), ``ELAB_MAX_DURATION`` (3600 s), ``ELAB_MAX_BODY``
    (1 MiB), ``ELAB_MAX_UPLOAD`` (16 MiB: identification data), ``ELAB_WATCHER_FRAMES``
    (100 frames ≈ 2 s queued per watcher)."""

    data_dir: Path = Path("data")
    max_live: int = 400
    max_duration: float = 3600.0
    max_body: int = 1 << 20
    max_upload: int = 16 << 20
    watcher_frames: int = 100
    tick: float = 0.02  # the stepper's period: one 20 ms frame per run per tick
    flush_interval: float = 0.25

    @property
    def database(self) -> Path:
        return self.data_dir / "elab.sqlite3"

    @classmethod
    def from_env(cls) -> Settings:
        env = os.environ
        return cls(data_dir=Path(env.get("ELAB_DATA", "data")),
                   max_live=_int(env, "ELAB_MAX_LIVE_RUNS", 400),
                   max_duration=float(_int(env, "ELAB_MAX_DURATION", 3600)),
                   max_body=_int(env, "ELAB_MAX_BODY", 1 << 20),
                   max_upload=_int(env, "ELAB_MAX_UPLOAD", 16 << 20),
                   watcher_frames=_int(env, "ELAB_WATCHER_FRAMES", 100))


def _int(env: os._Environ[str], name: str, default: int) -> int:
    raw = env.get(name)
    if raw is None:
        return default
    if not raw.isdigit() or int(raw) <= 0:
        raise InvalidInput(name, raw, "a positive integer")
    return int(raw)
