"""``elab serve | migrate | instructor``: the lab server (REST and the websocket stream),
its store brought to this version's schema, and the ``ELAB_INSTRUCTORS`` line of an
instructor account."""

from __future__ import annotations

import argparse
import contextlib
import sys
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

from elab.errors import InvalidInput

if TYPE_CHECKING:
    from elab.api.settings import Settings


def cmd_instructor(args: argparse.Namespace) -> str:
    import getpass

    from elab.api.auth import hash_password, valid_name

    if not valid_name(args.name):
        raise InvalidInput("name", args.name, "1-40 letters, digits, '.', '_' or '-'")
    if args.password_stdin:
        password = sys.stdin.readline().rstrip("\n")
    else:
        password = getpass.getpass(f"password for {args.name}: ")
        if getpass.getpass("again: ") != password:
            raise InvalidInput("password", "…", "the same password twice")
    if len(password) < 8:
        raise InvalidInput("password", "…", "at least 8 characters")
    return f"{args.name}:{hash_password(password)}"


def cmd_serve(args: argparse.Namespace) -> str:
    import os

    from elab import jobs
    from elab.api import preload

    if args.data:  # before the fork server starts: what it forks inherits its environment
        os.environ["ELAB_DATA"] = args.data
    jobs.start_fork_server(preload.ALL)  # its imports beside the web app's (api/preload.py)

    import uvicorn

    from elab.api.app import create_app
    from elab.api.settings import Settings
    from elab.runtime import return_memory

    return_memory()  # before the app allocates: big requests give their memory back
    settings = Settings.from_env()
    if args.host not in ("0.0.0.0", "::", "") and args.host not in settings.hosts:
        settings = replace(settings, hosts=(*settings.hosts, args.host))
    print(f"E-Lab on http://{args.host}:{args.port}  (data: {_where(settings)})", flush=True)
    # no permessage-deflate: float32 samples hardly compress, and deflating every frame
    # for every watcher cost a third of the server's CPU (docs/benchmarks.md). uvicorn's
    # "auto" loop is uvloop (a dependency): p99 latency 106 -> 60 ms at 300 runs there.
    uvicorn.run(
        create_app(settings),
        host=args.host,
        port=args.port,
        log_level="warning",
        ws_max_size=1 << 20,
        ws_per_message_deflate=False,
        # h11 refuses a head still incomplete past this many bytes, so whether a long one
        # (a 120 KB cookie) was answered depended on how its packets arrived (16 KiB by
        # default): one budget, checked the same way every time
        h11_max_incomplete_event_size=settings.max_head,
        # X-Forwarded-* only from the configured proxies (uvicorn trusts 127.0.0.1 by
        # default: rotating X-Forwarded-For beat the sign-in limit from loopback)
        proxy_headers=bool(settings.trusted_proxies),
        forwarded_allow_ips=list(settings.trusted_proxies) or None,
    )
    return "E-Lab stopped"


def cmd_engine(args: argparse.Namespace) -> str:
    """A simulation engine of its own on the broker (``ELAB_REDIS_URL``), on the store
    (``ELAB_DATABASE_URL``, else the file in ``--data``/``ELAB_DATA``), until SIGTERM or
    Ctrl-C: it interrupts its live runs, stores them and says why it stopped."""
    import json
    import os
    import socket
    from dataclasses import asdict

    from elab.api.settings import Settings

    settings = Settings.from_env({**os.environ, **({"ELAB_DATA": args.data} if args.data else {})})
    if settings.redis_url is None:
        raise InvalidInput(
            "ELAB_REDIS_URL",
            "",
            "a Redis URL (redis://host:port/db): an engine of its own hears its web servers "
            "through a broker; without one, `elab serve` starts its engine itself",
        )
    from elab.engines.broker import NAME

    name = args.name or f"sim-{socket.gethostname()}"
    if not NAME.fullmatch(name) or name == "web":
        raise InvalidInput("--name", name, "1-40 letters, digits, '.', '_' or '-', not 'web'")
    options = {
        **asdict(settings.engine),
        "nice": settings.engine_nice,
        "max_queue": settings.engine_queue,
    }
    print(f"E-Lab engine {name} on {_where(settings)}", flush=True)
    from elab.engines import child

    argv = ["--engine", name, "--kind", "simulation", "--database", settings.store]
    child.main([*argv, "--settings", json.dumps(options), "--redis", settings.redis_url])
    return f"E-Lab engine {name} stopped"


def cmd_migrate(args: argparse.Namespace) -> str:
    """Bring the store (``ELAB_DATABASE_URL``, else the file in ``--data``/``ELAB_DATA``) to
    this version's schema; safe beside web nodes doing the same (they take the same lock).
    ``--from FILE``: then copy an embedded lab's records from that SQLite file into it."""
    import os

    from elab.api.settings import Settings
    from elab.store import SQLiteStore, open_store
    from elab.store._db import SCHEMA_VERSION

    settings = Settings.from_env({**os.environ, **({"ELAB_DATA": args.data} if args.data else {})})
    source = Path(args.source) if args.source else None
    if source is not None:
        _check_store_file(source)
        if settings.database_url is None and source.resolve() == settings.database.resolve():
            raise InvalidInput("--from", str(source), "another store than the one migrated")
    store = open_store(settings.store)
    try:
        found = store.migrated_from
        said = f"{_where(settings)}: schema version " + (
            f"{SCHEMA_VERSION}, current"
            if found == SCHEMA_VERSION
            else f"{found} -> {SCHEMA_VERSION}"
        )
        if source is None:
            return said
        from elab.store.copy import copy_records
        from elab.store.sql.tables import Tables

        assert isinstance(store, Tables)
        # not in use (its web name held before the file is upgraded, if an older E-Lab
        # wrote it: a server of that version must not see its schema change under it)
        with SQLiteStore(source, claim="web") as old:
            copied = copy_records(old, store)
    finally:
        store.close()
    rows = ", ".join(f"{n} {table}" for table, n in copied.items() if n) or "nothing"
    return f"{said}\ncopied from {source}: {rows}"


def _check_store_file(path: Path) -> None:
    """``--from`` names an E-Lab store, read without writing to it: a SQLite file with a
    schema version (an empty or foreign file is refused, not turned into a store)."""
    import sqlite3

    allowed = "an E-Lab store file (elab.sqlite3 in a data directory)"
    if not path.is_file():
        raise InvalidInput("--from", str(path), allowed)
    try:
        with contextlib.closing(sqlite3.connect(f"file:{path}?mode=ro", uri=True)) as db:
            version = int(db.execute("PRAGMA user_version").fetchone()[0])
    except sqlite3.Error as e:
        raise InvalidInput("--from", str(path), f"{allowed}; this is not one ({e})") from None
    if version == 0:
        raise InvalidInput("--from", str(path), f"{allowed}; this one has no E-Lab schema")


def _where(settings: Settings) -> str:
    if settings.database_url:
        from elab.store.postgres.connections import redacted

        return redacted(settings.database_url)
    return str(settings.database)
