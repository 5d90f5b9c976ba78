"""Python controllers against a real server (engine in its own process, each controller in
its sandbox): upload with the trial report, runs whose samples are the offline ones,
compute times in the record, failures that end only their run, and the limits."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from elab.controllers.sandbox import available
from elab.controllers.templates import python_source
from elab.engines.coded import LATE_SHARE, run_through
from elab.engines.settings import CodeSettings
from elab.laws import CodeController, StateFeedback
from elab.plants import get_plant
from elab.sim import RunSpec, Square, compile_run
from tests.api.server import Server, until
from tests.api.test_controllers import mutated

pytestmark = pytest.mark.skipif(available() is not None, reason=str(available()))

FLEX = get_plant("flexible_link")
SEED_LQR = (20.0, -93.5614, 3.3621, 0.9623)
SOURCE = python_source(FLEX, StateFeedback(SEED_LQR, "velocity_filters"))
# a NUL in what it raises: PostgreSQL's text cannot hold one, and the run's end must be
# stored whatever a controller says (written as \x00, on either store)
RAISES_LATER = (
    "class Controller:\n    def step(self, t, y, r):\n"
    "        if t >= 0.25:\n            raise RuntimeError('gave up\\x00')\n        return 0.0\n"
)


@pytest.fixture(scope="module")
def lab(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Server]:
    srv = Server(tmp_path_factory.mktemp("code") / "data", ELAB_MAX_CODE_RUNS="2").start()
    yield srv
    srv.stop()


#: s a client waits for an upload's answer: past the server's own 60 s for its check
#: (ELAB_TRIAL_TIMEOUT), which beside two CPU hogs took over 30 s
UPLOAD_CAP = 90


def upload(c: object, source: str, plant: str = "flexible_link") -> dict[str, object]:
    r = c.post(  # type: ignore[attr-defined]
        "/controllers",
        json={"plant": plant, "format": "py", "content": source},
        timeout=UPLOAD_CAP,
    )
    assert r.status_code == 201, r.text
    return r.json()  # type: ignore[no-any-return]


def test_a_python_controller_uploads_with_its_trial_and_runs_as_offline(lab: Server) -> None:
    with lab.client() as c:
        r = c.get("/plants/flexible_link/controller-template", params={"format": "py"})
        assert r.status_code == 200 and "class Controller" in r.text
        assert 'filename="flexible_link-controller.py"' in r.headers["content-disposition"]
        up = upload(c, SOURCE)
        assert up["controller"] is None and up["code"] == SOURCE and up["format"] == "py"
        rep = up["report"]
        assert rep["domain"] == "trial" and rep["stable"] and rep["rig_ready"], rep
        assert rep["compute"]["steps"] >= 20_000 and rep["compute"]["median_us"] > 0
        assert "square wave" in rep["trial"]

        body = {"plant": "flexible_link", "pace": "fast", "duration": 3, "seed": 11}
        run = c.post("/runs", json={**body, "controller_id": up["id"]}).json()
        assert run["request"]["controller_id"] == up["id"]
        done = until(lambda: (x := c.get(f"/runs/{run['id']}").json())["finished_at"] and x, 60)
        assert done["status"] == "finished", done
        # not slow (a step preempted on a busy machine may pass the deadline: a few allowed)
        assert done["compute"]["steps"] == 3000
        assert done["compute"]["slow"] <= LATE_SHARE * 3000 + 1, done["compute"]
        got = c.get(f"/runs/{run['id']}/data", params={"format": "json"}).json()["data"]

    signal = Square(float(np.radians(30)), float(FLEX.signal.period))
    spec = RunSpec(FLEX, CodeController(SOURCE), signal, duration=3.0, noise_seed=11)
    offline = run_through(compile_run(spec), CodeSettings()).rows  # the server's settings
    assert np.array_equal(np.asarray(got["u"]), offline[:, 1])  # the same bits
    assert np.array_equal(np.asarray(got["theta"]), offline[:, 2])


def test_a_failing_controller_ends_its_run_with_the_reason_and_the_others_go_on(
    lab: Server,
) -> None:
    with lab.client() as c:
        bad = upload(c, RAISES_LATER)
        assert not bad["report"]["rig_ready"]  # the trial saw it fail
        assert "RuntimeError: gave up" in bad["report"]["problems"][0]
        other = c.post("/runs", json={"plant": "belt_conveyor", "duration": 20}).json()
        run = c.post("/runs", json={"plant": "flexible_link", "controller_id": bad["id"]}).json()
        done = until(lambda: (x := c.get(f"/runs/{run['id']}").json())["finished_at"] and x, 30)
        assert done["status"] == "failed"
        assert "RuntimeError: gave up\\x00 (controller.py: line 4, in step)" in done["error"]
        assert lab.status()["store"]["ok"]
        assert done["n_samples"] == 250 and done["compute"]["steps"] == 250
        assert c.get(f"/runs/{other['id']}").json()["status"] == "running"
        c.post(f"/runs/{other['id']}/stop")

        broken = upload(
            c,
            "class Controller:\n    def reset(self, p):\n        1/0\n"
            "    def step(self, t, y, r):\n        return 0\n",
        )
        r = c.post("/runs", json={"plant": "flexible_link", "controller_id": broken["id"]})
        assert r.status_code == 422, r.text
        err = r.json()["error"]
        assert err["field"] == "controller" and "ZeroDivisionError" in err["message"]


def test_code_runs_are_limited_and_cannot_be_swapped_into_a_live_run(lab: Server) -> None:
    with lab.client() as c:
        cid = upload(c, SOURCE)["id"]
        body = {"plant": "flexible_link", "controller_id": cid, "duration": 60}
        engines = len(lab.status()["engines"])  # the limit is each engine's (2 here)
        runs = [c.post("/runs", json=body) for _ in range(2 * engines + 1)]
        assert [r.status_code for r in runs] == [201] * (2 * engines) + [429]
        assert "ELAB_MAX_CODE_RUNS" in runs[-1].json()["error"]["message"]
        first = runs[0].json()["id"]
        toml = 'version = 1\nkind = "state_feedback"\nK = [20, -93.5614, 3.3621, 0.9623]\n'
        decl = c.post(
            "/controllers", json={"plant": "flexible_link", "format": "toml", "content": toml}
        ).json()["id"]
        r = c.post(f"/runs/{first}/params", json={"controller_id": decl})
        assert r.status_code == 422 and "mid-run" in r.json()["error"]["message"]
        plain = c.post("/runs", json={"plant": "flexible_link", "duration": 60}).json()["id"]
        r = c.post(f"/runs/{plain}/params", json={"controller_id": cid})
        assert r.status_code == 422 and r.json()["error"]["field"] == "controller_id"
        for rid in (*(r.json()["id"] for r in runs[:-1]), plain):
            assert c.post(f"/runs/{rid}/stop").status_code == 200
        r = c.post("/runs", json=body)  # a slot is free again
        assert r.status_code == 201, r.text
        c.post(f"/runs/{r.json()['id']}/stop")


def test_without_a_sandbox_code_is_refused_and_declarative_controllers_still_work(
    tmp_path: Path,
) -> None:
    srv = Server(tmp_path / "data", PATH="/nonexistent").start()  # no bwrap on the PATH
    try:
        with srv.client() as c:
            r = c.post(
                "/controllers",
                json={"plant": "flexible_link", "format": "py", "content": SOURCE},
            )
            assert r.status_code == 503, r.text
            assert "bubblewrap" in r.json()["error"]["message"]
            assert c.get("/controllers").json()["controllers"] == []  # nothing kept
            toml = 'version = 1\nkind = "pid"\nKp = 2\n'
            r = c.post(
                "/controllers", json={"plant": "belt_conveyor", "format": "toml", "content": toml}
            )
            assert r.status_code == 201
    finally:
        srv.stop()


def mutated_python(seed: int) -> str:
    """The Python template with a few random edits (most break its syntax; some change
    numbers, names or indentation and run)."""
    return mutated(seed, SOURCE)


@settings(max_examples=25, deadline=None)
@given(
    content=st.one_of(
        st.integers(0, 10**6).map(mutated_python),
        st.text(min_size=1, max_size=200),
    )
)
def test_random_and_mutated_python_never_crashes_and_refused_files_are_not_kept(
    lab: Server, content: str
) -> None:
    with lab.stranger() as c:
        r = c.post(
            "/controllers",
            json={"plant": "flexible_link", "format": "py", "content": content},
            timeout=UPLOAD_CAP,
        )
        assert r.status_code in (201, 422), r.text[:300]
        kept = c.get("/controllers").json()["controllers"]
        assert len(kept) == (r.status_code == 201)
        if r.status_code == 201:
            report = r.json()["report"]
            assert report["domain"] == "trial" and report["rig_ready"] == (not report["problems"])


HOSTILE = {
    "reads a file": "return float(len(open('/etc/passwd').read()))",
    "loops for ever": "while True:\n                pass",
    "allocates without bound": "self.x = bytearray(1 << 34)\n            return 0.0",
    "returns NaN": "return float('nan')",
    "returns text": "return 'ten volts'",
}
REASONS = {
    "reads a file": "forbids",
    "loops for ever": "did not answer within 1 s",
    "allocates without bound": "MemoryError",
    "returns NaN": "finite number",
    "returns text": "ValueError",
}


def test_hostile_controllers_fail_their_own_runs_and_nothing_else(lab: Server) -> None:
    """Five controllers that turn hostile after 0.2 s, one after another beside an
    ordinary run: each run fails with its reason and the samples before, the ordinary one
    goes on, and the server is healthy."""
    with lab.client() as c:
        plain = c.post("/runs", json={"plant": "belt_conveyor", "duration": 60}).json()["id"]
        for name, body in HOSTILE.items():
            code = (
                "class Controller:\n    def step(self, t, y, r):\n"
                f"        if t >= 0.2:\n            {body}\n        return 0.0\n"
            )
            cid = upload(c, code)["id"]
            rid = c.post("/runs", json={"plant": "flexible_link", "controller_id": cid}).json()
            done = until(
                lambda rid=rid["id"]: (x := c.get(f"/runs/{rid}").json())["finished_at"] and x, 30
            )
            assert done["status"] == "failed", (name, done)
            assert REASONS[name] in done["error"], (name, done["error"])
            assert 200 <= done["n_samples"] <= 211, (name, done["n_samples"])
        assert c.get(f"/runs/{plain}").json()["status"] == "running"
        health = c.get("/health").json()
        assert health["status"] == "ok", health
        c.post(f"/runs/{plain}/stop")
