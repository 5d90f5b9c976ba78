"""The Quanser HIL adapter against a fake ``quanser.hardware`` that records its calls
(the real package is not installed here, and no board is: untested on hardware)."""

from __future__ import annotations

import math
import sys
import types
from collections.abc import Iterator
from typing import Any, ClassVar

import pytest

from elab.errors import Unavailable
from elab.rig.messages import Action, Status
from elab.rig.quanser import QuanserDriver


class FakeHIL:
    calls: ClassVar[list[tuple[str, tuple[Any, ...]]]] = []
    reload_ok = True

    def __init__(self, card_type: str, card_id: str) -> None:
        self.calls.append(("HIL", (card_type, card_id)))

    def __getattr__(self, name: str) -> Any:
        def call(*args: Any) -> Any:
            self.calls.append((name, args))
            if name == "task_read_encoder":
                args[2][0] = 1024  # a quarter turn
            if name == "read_analog":
                args[2][0] = 0.5  # V
            if name == "watchdog_reload":
                return self.reload_ok
            return "task" if name == "task_create_encoder_reader" else None

        return call


@pytest.fixture
def fake_quanser(monkeypatch: pytest.MonkeyPatch) -> Iterator[type[FakeHIL]]:
    FakeHIL.calls = []
    FakeHIL.reload_ok = True
    package, hardware = types.ModuleType("quanser"), types.ModuleType("quanser.hardware")
    hardware.HIL = FakeHIL  # type: ignore[attr-defined]
    hardware.Clock = types.SimpleNamespace(SYSTEM_CLOCK_1=-1)  # type: ignore[attr-defined]
    package.hardware = hardware  # type: ignore[attr-defined]
    monkeypatch.setitem(sys.modules, "quanser", package)
    monkeypatch.setitem(sys.modules, "quanser.hardware", hardware)
    yield FakeHIL


def names(fake: type[FakeHIL]) -> list[str]:
    return [name for name, _ in fake.calls]


def test_without_the_package_it_says_what_to_install() -> None:
    with pytest.raises(Unavailable, match=r"quanser\.hardware"):
        QuanserDriver()


def test_it_follows_quansers_documented_call_sequence(fake_quanser: type[FakeHIL]) -> None:
    driver = QuanserDriver("q2_usb", "0")
    identity = driver.connect()
    assert not identity.emulated and identity.Ts == 1e-3
    driver.command(Action.ENABLE)
    sample = driver.read(timeout=0.01)
    driver.write(sample.seq, 2.0)
    driver.close()
    assert names(fake_quanser) == [
        "HIL",
        "watchdog_set_analog_expiration_state",  # before watchdog_start, as documented
        "write_analog",
        "task_create_encoder_reader",
        "watchdog_start",
        "task_start",
        "task_read_encoder",
        "read_analog",
        "watchdog_reload",
        "write_analog",
        "write_analog",
        "task_stop",
        "task_delete",
        "watchdog_stop",
        "close",
    ]
    assert fake_quanser.calls[0] == ("HIL", ("q2_usb", "0"))
    start = dict(fake_quanser.calls)["task_start"]
    assert start[1:3] == (-1, 1000.0)  # SYSTEM_CLOCK_1 at 1 kHz
    written = [args[2][0] for name, args in fake_quanser.calls if name == "write_analog"]
    assert written == [0.0, 2.0, 0.0]  # 0 V first and last
    assert sample.theta == pytest.approx(math.pi / 2, rel=1e-12)
    assert sample.alpha == pytest.approx(0.5 * 0.0606, rel=1e-12)
    assert sample.status == Status.MOTOR_ENABLED


def test_an_expired_watchdog_holds_0_V_until_enable_clears_it(
    fake_quanser: type[FakeHIL],
) -> None:
    driver = QuanserDriver()
    driver.connect()
    driver.command(Action.ENABLE)
    fake_quanser.reload_ok = False
    driver.write(0, 5.0)
    assert driver.read(0.01).status == Status.WATCHDOG_TRIPPED
    fake_quanser.reload_ok = True
    driver.command(Action.ENABLE)
    driver.write(1, 5.0)
    later = names(fake_quanser)[names(fake_quanser).index("watchdog_clear") :]
    assert "write_analog" in later
    assert [a[2][0] for n, a in fake_quanser.calls if n == "write_analog"] == [0.0, 5.0]
