"""Server settings from the environment (read once, at start-up).

Every limit a client can push has a setting here; docs/operations.md lists them
with their defaults and the error a client gets at the limit.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

from elab.engines.settings import EngineSettings
from elab.errors import InvalidInput
from elab.rig_queue import QueuePolicy
from elab.runs.limits import Limits
from elab.sim.spec import MAX_SAMPLES
from elab.store import POSTGRES_SCHEMES

#: the stepping thread's SCHED_FIFO priority by default (1..99; the kernel's threads: 50)
REALTIME = 10
#: the URLs a broker may have (redis-py's)
REDIS_SCHEMES = ("redis://", "rediss://", "unix://")
#: the host names a server on one's own machine answers to
LOOPBACK = ("127.0.0.1", "localhost", "::1")


@dataclass(frozen=True)
class Settings:
    """``ELAB_DATA`` (default ``./data``): where the SQLite file lives (and the secret, the
    rig's emergency-stop socket); ``database_url``: ``ELAB_DATABASE_URL``, a
    ``postgresql://user:password@host:port/db`` whose database holds the records instead of
    the file (docs/operations.md, *PostgreSQL*); ``redis_url``: ``ELAB_REDIS_URL``, a broker
    on which the simulation engines are processes of their own (``elab engine``, on any
    host; docs/operations.md, *Engines on a broker*) instead of one this server starts.
    Limits: ``limits`` (runs;
    see :class:`~elab.runs.limits.Limits`), ``max_body`` bytes of a request (``ELAB_MAX_BODY``,
    1 MiB), ``max_upload`` bytes of identification data (``ELAB_MAX_UPLOAD``, 16 MiB),
    ``max_uploads`` large bodies read at once (``ELAB_MAX_UPLOADS``, 4), websocket streams one
    identity may have open ``max_streams_per_identity`` (``ELAB_MAX_STREAMS_PER_IDENTITY``, 32),
    ``body_timeout`` s a body may pause before 408 (``ELAB_BODY_TIMEOUT``, 10),
    ``watcher_frames`` queued per watcher before it skips (``ELAB_WATCHER_FRAMES``, 100 ≈ 2 s).
    The engine: ``engine`` (tick, flush interval, ``ELAB_STORE_RETRY`` s a busy store is
    retried, ``ELAB_STORE_PENDING`` bytes that may wait for it, Python controllers:
    ``ELAB_MAX_CODE_RUNS`` live at once (8), ``ELAB_CODE_DEADLINE`` s per step (0.0005),
    ``ELAB_CODE_MISSES`` late steps in a row that fail a run (10), ``ELAB_CODE_BUDGET`` the
    share of a run's time a controller may compute in all (0.5), ``ELAB_CODE_PATIENCE`` s one
    answer may take (1)), its real-time priority
    (``ELAB_ENGINE_REALTIME``, 10: the stepping thread SCHED_FIFO at 10 and the rest of the
    engine process at 9, where allowed, else ordinary; 0: ordinary), its process's
    ``engine_nice`` when not real-time (``ELAB_ENGINE_NICE``, 0), its queue to the web process
    ``engine_queue`` bytes (``ELAB_ENGINE_QUEUE``, 64 MiB), ``engine_timeout`` s to answer a
    command (``ELAB_ENGINE_TIMEOUT``, 10) and ``engine_stall`` s without a heartbeat before it
    is restarted (``ELAB_ENGINE_STALL``, 30). Identification: ``ident_workers`` processes
    (``ELAB_IDENT_WORKERS``, 1), ``ident_timeout`` s per job (``ELAB_IDENT_TIMEOUT``, 120),
    ``ident_wait`` s a request waits for a worker (``ELAB_IDENT_WAIT``, 30). Controller uploads
    are checked (a Python controller tried in its sandbox) by ``trial_workers`` processes
    (``ELAB_TRIAL_WORKERS``, 2), each check within ``trial_timeout`` s (``ELAB_TRIAL_TIMEOUT``,
    60); the same workers compute runs' predictions, each of the first
    ``prediction_samples`` samples of its run at most (``ELAB_PREDICTION_SAMPLES``, 120,000:
    two minutes at 1 kHz). Per identity at once: identifications ``max_ident_per_identity``
    (``ELAB_MAX_IDENT_PER_IDENTITY``, 2) and large bodies ``max_uploads_per_identity``
    (``ELAB_MAX_UPLOADS_PER_IDENTITY``, 2); API tokens an identity may have
    ``max_tokens_per_identity`` (``ELAB_MAX_TOKENS_PER_IDENTITY``, 20), uploaded controllers it
    may keep ``max_controllers_per_identity`` (``ELAB_MAX_CONTROLLERS_PER_IDENTITY``, 100),
    identified models ``max_models_per_identity`` (``ELAB_MAX_MODELS_PER_IDENTITY``, 100).

    Access (docs/access.md): ``secret`` signs identity cookies (``ELAB_SECRET``; default: made
    once and kept in the data directory), ``hosts`` the ``Host`` names the server answers
    (``ELAB_HOSTS``, loopback names; ``*``: any), ``origins`` other origins whose pages may call
    it (``ELAB_ORIGINS``; default: none but its own), ``instructors`` a file of instructor
    accounts (``ELAB_INSTRUCTORS``), ``secure_cookies`` behind HTTPS (``ELAB_SECURE_COOKIES``,
    0), ``session_hours`` an instructor's sign-in lasts (``ELAB_SESSION_HOURS``, 12).
    ``trusted_proxies``: the addresses of reverse proxies whose ``X-Forwarded-For`` and
    ``X-Forwarded-Proto`` are believed (``ELAB_TRUSTED_PROXIES``; none by default: a client's
    own ``X-Forwarded-For`` never changes its address).

    The rig (docs/rig.md): ``rig`` is ``ELAB_RIG``: ``none`` (the default: no rig; runs in
    mode ``rig`` are refused with 422), ``emulator`` (the server starts one
    ``elab rig-emulator`` process, shown everywhere as emulated; ``make run`` does this) or
    the ``host:port`` of a rig speaking E-Lab's byte protocol; ``rig_seed``
    (``ELAB_RIG_SEED``, 1): the emulated rig's hidden parameters; ``rig_watchdog``
    (``ELAB_RIG_WATCHDOG``, 5): samples the emulated rig waits for an answer before its
    watchdog cuts the motor (a host loop that is not real-time needs more); ``rig_queue``:
    a driver's slot (``ELAB_RIG_SLOT``, 300 s) and how long a seated driver may take to arm
    (``ELAB_RIG_GRACE``, 60 s)."""

    data_dir: Path = Path("data")
    database_url: str | None = None
    redis_url: str | None = None
    limits: Limits = field(default_factory=Limits)
    max_body: int = 1 << 20
    max_head: int = 256 << 10
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
    max_ident_per_identity: int = 2
    max_uploads_per_identity: int = 2
    max_tokens_per_identity: int = 20
    max_controllers_per_identity: int = 100
    max_models_per_identity: int = 100
    secret: str | None = None
    hosts: tuple[str, ...] = LOOPBACK
    origins: tuple[str, ...] = ()
    instructors: Path | None = None
    docs: Path | None = None  # the help pages' markdown (None: the checkout's docs/)
    secure_cookies: bool = False
    session_hours: float = 12.0
    body_timeout: float = 10.0
    trial_workers: int = 2
    max_streams_per_identity: int = 32
    trusted_proxies: tuple[str, ...] = ()
    trial_timeout: float = 60.0
    prediction_samples: int = 120_000
    rig: str = "none"
    rig_seed: int = 1
    rig_watchdog: int = 5
    rig_queue: QueuePolicy = field(default_factory=QueuePolicy)

    @property
    def database(self) -> Path:
        """The embedded store's file (used unless ``database_url`` is given)."""
        return self.data_dir / "elab.sqlite3"

    @property
    def store(self) -> str:
        """Where the records are: the PostgreSQL URL if given, else the SQLite file."""
        return self.database_url or str(self.database)

    @classmethod
    def from_env(cls, env: Mapping[str, str] = os.environ) -> Settings:
        d = Limits()
        limits = Limits(
            max_live=_int(env, "ELAB_MAX_LIVE_RUNS", d.max_live),
            max_live_per_identity=_int(env, "ELAB_MAX_LIVE_PER_IDENTITY", d.max_live_per_identity),
            max_runs_per_identity=_int(env, "ELAB_MAX_RUNS_PER_IDENTITY", d.max_runs_per_identity),
            max_storage_per_identity=_int(
                env, "ELAB_MAX_STORAGE_PER_IDENTITY", d.max_storage_per_identity
            ),
            retention=_float(env, "ELAB_RETENTION", d.retention, zero=True),
            owner_grace=_float(env, "ELAB_OWNER_GRACE", d.owner_grace),
            owner_gone=_float(env, "ELAB_OWNER_GONE", d.owner_gone),
            max_duration=_float(env, "ELAB_MAX_DURATION", d.max_duration),
            max_samples=_int(env, "ELAB_MAX_RUN_SAMPLES", d.max_samples, hi=MAX_SAMPLES),
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
            max_code_runs=_int(env, "ELAB_MAX_CODE_RUNS", e.max_code_runs),
            code_deadline=_float(env, "ELAB_CODE_DEADLINE", e.code_deadline),
            code_misses=_int(env, "ELAB_CODE_MISSES", e.code_misses),
            code_budget=_float(env, "ELAB_CODE_BUDGET", e.code_budget),
            code_patience=_float(env, "ELAB_CODE_PATIENCE", e.code_patience),
        )
        return cls(
            data_dir=Path(env.get("ELAB_DATA", "data")),
            database_url=_database_url(env),
            redis_url=_redis_url(env),
            limits=limits,
            max_body=_int(env, "ELAB_MAX_BODY", 1 << 20),
            max_head=_int(env, "ELAB_MAX_HEAD", 256 << 10),
            max_upload=_int(env, "ELAB_MAX_UPLOAD", 16 << 20),
            max_uploads=_int(env, "ELAB_MAX_UPLOADS", 4),
            body_timeout=_float(env, "ELAB_BODY_TIMEOUT", 10.0),
            trial_workers=_int(env, "ELAB_TRIAL_WORKERS", 2, hi=64),
            max_streams_per_identity=_int(env, "ELAB_MAX_STREAMS_PER_IDENTITY", 32),
            trial_timeout=_float(env, "ELAB_TRIAL_TIMEOUT", 60.0),
            prediction_samples=_int(env, "ELAB_PREDICTION_SAMPLES", 120_000, lo=10, hi=10**7),
            watcher_frames=_int(env, "ELAB_WATCHER_FRAMES", 100),
            engine=engine,
            engine_nice=_int(env, "ELAB_ENGINE_NICE", 0, lo=-20, hi=19),
            engine_queue=_int(env, "ELAB_ENGINE_QUEUE", 64 << 20),
            engine_timeout=_float(env, "ELAB_ENGINE_TIMEOUT", 10.0),
            engine_stall=_float(env, "ELAB_ENGINE_STALL", 30.0),
            ident_workers=_int(env, "ELAB_IDENT_WORKERS", 1, hi=64),
            ident_timeout=_float(env, "ELAB_IDENT_TIMEOUT", 120.0),
            ident_wait=_float(env, "ELAB_IDENT_WAIT", 30.0),
            max_ident_per_identity=_int(env, "ELAB_MAX_IDENT_PER_IDENTITY", 2),
            max_uploads_per_identity=_int(env, "ELAB_MAX_UPLOADS_PER_IDENTITY", 2),
            max_tokens_per_identity=_int(env, "ELAB_MAX_TOKENS_PER_IDENTITY", 20),
            max_controllers_per_identity=_int(env, "ELAB_MAX_CONTROLLERS_PER_IDENTITY", 100),
            max_models_per_identity=_int(env, "ELAB_MAX_MODELS_PER_IDENTITY", 100),
            secret=_secret(env),
            hosts=_names(env, "ELAB_HOSTS", LOOPBACK),
            trusted_proxies=_names(env, "ELAB_TRUSTED_PROXIES", ()),
            origins=tuple(_origin(o) for o in _names(env, "ELAB_ORIGINS", ())),
            instructors=Path(env["ELAB_INSTRUCTORS"]) if env.get("ELAB_INSTRUCTORS") else None,
            docs=Path(env["ELAB_DOCS"]) if env.get("ELAB_DOCS") else None,
            secure_cookies=_int(env, "ELAB_SECURE_COOKIES", 0, lo=0, hi=1) == 1,
            session_hours=_float(env, "ELAB_SESSION_HOURS", 12.0),
            rig=_rig(env),
            rig_seed=_int(env, "ELAB_RIG_SEED", 1, lo=0, hi=(1 << 32) - 1),
            rig_watchdog=_int(env, "ELAB_RIG_WATCHDOG", 5, hi=10_000),
            rig_queue=QueuePolicy(
                slot=_float(env, "ELAB_RIG_SLOT", QueuePolicy.slot),
                grace=_float(env, "ELAB_RIG_GRACE", QueuePolicy.grace),
            ),
        )


def _database_url(env: Mapping[str, str]) -> str | None:
    return _url(
        env,
        "ELAB_DATABASE_URL",
        POSTGRES_SCHEMES,
        "a PostgreSQL URL, postgresql://user:password@host:port/database "
        "(unset: the SQLite file in ELAB_DATA)",
    )


def _redis_url(env: Mapping[str, str]) -> str | None:
    return _url(
        env,
        "ELAB_REDIS_URL",
        REDIS_SCHEMES,
        "a Redis URL, redis://[:password@]host:port/db, rediss://… or unix:///path "
        "(unset: the engine is a process of this server's own)",
    )


def _url(env: Mapping[str, str], name: str, schemes: tuple[str, ...], allowed: str) -> str | None:
    """The URL in ``name``, or ``None`` if unset; one of another scheme is refused, shown
    without its password."""
    url = env.get(name, "").strip()
    if not url:
        return None
    if not url.startswith(schemes):
        scheme, _, rest = url.partition("://")
        shown = f"{scheme}://…@{rest.rsplit('@', 1)[-1]}" if "@" in rest else url
        raise InvalidInput(name, shown, allowed)
    return url


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


def _float(env: Mapping[str, str], name: str, default: float, zero: bool = False) -> float:
    raw = env.get(name)
    if raw is None:
        return default
    try:
        value = float(raw)
    except ValueError:
        value = float("nan")
    if not (value >= 0 if zero else value > 0) or not value < float("inf"):
        raise InvalidInput(name, raw, "a number ≥ 0" if zero else "a positive number")
    return value


def _names(env: Mapping[str, str], name: str, default: tuple[str, ...]) -> tuple[str, ...]:
    raw = env.get(name)
    if raw is None:
        return default
    names = tuple(n.strip() for n in raw.split(",") if n.strip())
    if not names:
        raise InvalidInput(name, raw, "a comma-separated list of names")
    return names


def _origin(raw: str) -> str:
    """``scheme://host[:port]``, as browsers send it in ``Origin``."""
    scheme, sep, rest = raw.partition("://")
    if scheme not in ("http", "https") or not sep or not rest or "/" in rest:
        raise InvalidInput("ELAB_ORIGINS", raw, "origins like https://lab.example.org")
    return raw.lower()


def _secret(env: Mapping[str, str]) -> str | None:
    raw = env.get("ELAB_SECRET")
    if raw is not None and len(raw) < 32:
        raise InvalidInput("ELAB_SECRET", "…", "at least 32 characters of random text")
    return raw


def _rig(env: Mapping[str, str]) -> str:
    raw = env.get("ELAB_RIG", "none").strip()
    if raw in ("none", "emulator"):
        return raw
    host, _, port = raw.rpartition(":")
    if not host or not port.isdigit() or not 0 < int(port) < 65536:
        raise InvalidInput("ELAB_RIG", raw, "none, emulator or a rig's host:port")
    return raw
