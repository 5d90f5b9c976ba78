"""Text the two back-ends hold alike: PostgreSQL's text cannot hold NUL, so a name with one
is refused by name on both, and a message the lab writes (a run's error, which may quote a
user's controller) has its NULs written as ``\\x00`` on both; nothing a user types can make
a write fail as a fault of the store."""

from __future__ import annotations

import pytest

from elab.errors import InvalidInput, NotFound
from elab.store import Pin, Store, StoredController, StoredModel, Token
from tests.unit.store.test_sqlite import record

NUL = "a\x00b"


@pytest.mark.parametrize(
    "write",
    [
        lambda s: s.add_controller(
            StoredController("c-1", "u", "flexible_link", NUL, "toml", {}, {}, 1.7e9)
        ),
        lambda s: s.add_model(StoredModel("m-1", "u", "flexible_link", NUL, {}, 1.7e9)),
        lambda s: s.add_token(Token("t-1", "u", NUL, 1.7e9), "f" * 64),
        lambda s: s.set_pin(Pin(NUL, "r-1", "u", 1.7e9)),
    ],
    ids=["controller", "model", "token", "pin"],
)
def test_a_name_with_a_nul_is_refused_by_name_and_nothing_is_written(store: Store, write) -> None:  # type: ignore[no-untyped-def]
    store.create_run(record("r-1"))
    with pytest.raises(InvalidInput, match=r"name.*without NUL"):
        write(store)
    assert store.list_controllers(None) == [] and store.list_models(None) == []
    assert store.tokens("u") == [] and store.pin("a") is None
    store.probe()  # and the store is fine


def test_a_key_with_a_nul_matches_nothing_on_either(store: Store) -> None:
    """What a client sends as an id or a filter may hold NUL (``%00``, ``\\u0000``): it is
    no stored record's, on SQLite as on PostgreSQL (whose text cannot hold it)."""
    store.create_run(record("r-1", owner="u"))
    for call in (store.get_run, store.delete_run, store.param_changes, store.read,
                 store.get_controller, store.get_model, store.delete_controller):  # fmt: skip
        with pytest.raises(NotFound):
            call(NUL)
    assert store.list_runs(owner=NUL) == ([], 0) and store.list_runs(viewer=NUL)[1] == 1
    assert store.pin(NUL) is None and store.tokens(NUL) == []
    assert store.token_by_digest(NUL) is None and store.list_models(NUL) == []
    assert store.usage(NUL).runs == 0
    store.probe()


def test_a_message_with_a_nul_is_kept_with_it_written_out(store: Store) -> None:
    store.create_run(record("r-1", error="created\x00"))
    store.set_status("r-1", "failed", finished_at=1.7e9, error="RuntimeError: x\x00y")
    assert store.get_run("r-1").error == "RuntimeError: x\\x00y"
    store.create_run(record("r-2", status="running"))
    assert store.mark_interrupted("sim-0", "gone\x00") == ["r-2"]
    assert store.get_run("r-2").error == "gone\\x00"
