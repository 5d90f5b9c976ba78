"""Every limit a client can push has a setting and a clear 4xx naming it: run size (sample
time, samples, recording bytes), live runs per identity, uploads at once, identification time
and workers; an identification whose client leaves stops its work; downloads stream."""

from __future__ import annotations

import json
import threading
import time
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor

import httpx
import numpy as np
import pytest

from tests.api.server import TLS, Server, until

HEAVY_MODELS = [{"kind": "oe", "nb": 8, "nf": 8, "nk": nk} for nk in (1, 2, 3)] + [
    {"kind": "armax", "na": 8, "nb": 8, "nc": 8, "nk": nk} for nk in (1, 2, 3)
]  # ~60 s of CPU here: far past the limited server's 10 s on any machine
IDENT_TIMEOUT = 10  # s: a small job takes a tiny fraction of it, also at a low priority
# beside two CPU hogs


def heavy_file(n: int = 200_000) -> str:
    rng = np.random.default_rng(0)
    u = rng.standard_normal(n)
    y = np.convolve(u, [0, 0.5, 0.3, 0.1])[:n] + 0.1 * rng.standard_normal(n)
    return "# sample time: 0.01 s\nu,y\n" + "\n".join(
        f"{a:.5f},{b:.5f}" for a, b in zip(u, y, strict=True)
    )


def ident_body(text: str, models: list[dict[str, object]]) -> dict[str, object]:
    return {
        "data": {"source": "file", "text": text, "input": ["u"], "output": ["y"]},
        "correlation": False,
        "spectral": False,
        "models": models,
    }


@pytest.fixture(scope="module")
def limited(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Server]:
    srv = Server(
        tmp_path_factory.mktemp("data"),
        ELAB_MAX_LIVE_PER_IDENTITY="2",
        ELAB_MAX_RUN_SAMPLES="100000",
        ELAB_MAX_RECORDING="4000000",
        ELAB_MAX_UPLOADS="1",
        ELAB_IDENT_TIMEOUT=str(IDENT_TIMEOUT),
        ELAB_IDENT_WAIT="1",
    ).start()
    yield srv
    srv.stop()


@pytest.mark.parametrize(
    ("body", "field", "names"),
    [
        ({"plant": "flexible_link", "Ts": 1e-5}, "Ts", "ELAB_TS_RATIO"),
        ({"plant": "flexible_link", "duration": 200}, "duration", "ELAB_MAX_RUN_SAMPLES"),
        (
            {"plant": "double_pendulum", "duration": 90, "Ts": 0.001},
            "duration",
            "ELAB_MAX_RECORDING",
        ),
        ({"plant": "flexible_link", "duration": 4000}, "duration", "ELAB_MAX_DURATION"),
    ],
)
def test_a_run_over_a_size_limit_is_422_naming_field_and_setting(
    limited: Server, body: dict[str, object], field: str, names: str
) -> None:
    with limited.client() as c:
        r = c.post("/runs", json=body)
    assert r.status_code == 422 and r.json()["error"]["field"] == field, r.text
    assert names in r.json()["error"]["message"]


def test_live_runs_per_identity_are_limited_with_retry_after(limited: Server) -> None:
    with limited.client() as c:
        ids = [
            c.post("/runs", json={"plant": "belt_conveyor", "duration": 60}).json()["id"]
            for _ in range(2)
        ]
        r = c.post("/runs", json={"plant": "belt_conveyor"})
        assert r.status_code == 429 and "ELAB_MAX_LIVE_PER_IDENTITY" in r.json()["error"]["message"]
        assert int(r.headers["retry-after"]) > 0
        c.post(f"/runs/{ids[0]}/stop")  # room again
        assert c.post("/runs", json={"plant": "belt_conveyor", "duration": 1}).status_code == 201
        c.post(f"/runs/{ids[1]}/stop")


def test_a_second_upload_while_one_is_received_is_429(limited: Server) -> None:
    body = json.dumps(ident_body(heavy_file(2000), [])).encode()
    head, rest = body[:100], body[100:]
    release = threading.Event()

    def slow_body() -> Iterator[bytes]:
        yield head
        release.wait(30)  # the body stays half-sent: its upload slot is taken
        yield rest

    first: dict[str, httpx.Response] = {}
    sender = threading.Thread(
        target=lambda: first.update(
            r=httpx.post(
                limited.url + "/api/v1/ident",
                content=slow_body(),
                headers={"content-type": "application/json"},
                timeout=60,
            )
        )
    )
    sender.start()
    try:
        until(lambda: limited.status()["uploads"] == {"receiving": 1, "limit": 1}, 60)
        r = httpx.post(limited.url + "/api/v1/ident", json=ident_body("u,y\n1,2\n", []))
        assert r.status_code == 429 and "ELAB_MAX_UPLOADS " in r.text, r.text
    finally:
        release.set()
        sender.join()
    assert first["r"].status_code == 200, first["r"].text[:200]


def test_an_identification_over_the_time_limit_is_422_and_the_next_one_works(
    limited: Server,
) -> None:
    r = httpx.post(
        limited.url + "/api/v1/ident", json=ident_body(heavy_file(), HEAVY_MODELS), timeout=60
    )
    assert r.status_code == 422
    assert f"ELAB_IDENT_TIMEOUT = {IDENT_TIMEOUT} s" in r.json()["error"]["message"]
    # the stopped job's worker is replaced; the next job waits for the new one to start
    until(lambda: limited.status()["ident"] == {"workers": 1, "busy": 0, "starting": 0}, 60)
    small = ident_body(heavy_file(2000), [{"kind": "arx", "na": 2, "nb": 2, "nk": 1}])
    r = httpx.post(limited.url + "/api/v1/ident", json=small, timeout=60)
    assert r.status_code == 200 and r.json()["models"][0]["fit"]["validation_one_step"][0] > 50


def test_an_identification_whose_client_leaves_stops(server: Server) -> None:
    # the shared server: the default time limit (120 s), far past the 2 s read timeout
    body = ident_body(heavy_file(), HEAVY_MODELS)
    for accept in ("application/json", "application/x-ndjson"):
        with pytest.raises(httpx.ReadTimeout):
            httpx.post(
                server.url + "/api/v1/ident",
                json=body,
                timeout=httpx.Timeout(60, read=2),
                headers={"accept": accept},
            )
        t = time.monotonic()
        until(lambda: server.status()["ident"]["busy"] == 0, 10)  # long before ~60 s of work
        assert time.monotonic() - t < 10
    small = ident_body(heavy_file(2000), [{"kind": "arx", "na": 2, "nb": 2, "nk": 1}])
    assert httpx.post(server.url + "/api/v1/ident", json=small, timeout=60).status_code == 200


def test_an_identification_waiting_for_a_worker_says_why_and_how_long(limited: Server) -> None:
    """The one worker busy with a long job: a second identification, of a run's data and
    streamed, first says it waits for a worker, for how long at most (ELAB_IDENT_WAIT) and
    what then; it ends in that 429's error, not silence. (An uploaded table is parsed by
    a worker before the stream begins: that wait is the request's own 429, which says
    the same.)"""
    until(lambda: limited.status()["ident"] == {"workers": 1, "busy": 0, "starting": 0}, 60)
    with limited.client() as c:
        run = c.post("/runs", json={"plant": "flexible_link", "duration": 2, "pace": "fast"})
        rid = run.json()["id"]
        until(lambda: c.get(f"/runs/{rid}").json()["finished_at"], 60)
    heavy = ident_body(heavy_file(), HEAVY_MODELS)
    with ThreadPoolExecutor(1) as pool:
        long_job = pool.submit(
            httpx.post, limited.url + "/api/v1/ident", json=heavy, timeout=120, verify=TLS
        )
        until(lambda: limited.status()["ident"]["busy"] == 1, 60)
        of_run = {
            "data": {"source": "run", "run": rid, "input": ["u"], "output": ["theta"]},
            "models": [{"kind": "arx", "na": 2, "nb": 2, "nk": 1}],
        }
        with limited.client() as c:
            r = c.post("/ident", json=of_run, headers={"accept": "application/x-ndjson"})
        assert r.status_code == 200, r.text
        lines = [json.loads(line) for line in r.text.splitlines()]
        first, last = lines[0]["progress"], lines[-1]
        assert "waiting for a free identification worker: all 1 busy" in first["stage"]
        assert "up to 1 s (ELAB_IDENT_WAIT), then 429" in first["stage"]
        assert last["error"]["code"] == "too_many" and "ELAB_IDENT_WORKERS" in str(last)
        assert long_job.result().status_code == 422  # (its own time limit)
