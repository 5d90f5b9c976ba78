"""A :class:`~elab.rig.driver.Driver` for a Quanser HIL board (Q2-USB, Q8-USB) that
drives the flexible link directly, through Quanser's ``quanser.hardware`` Python API.

NOT TESTED ON HARDWARE: the call sequence follows Quanser's documented HIL API
(``HIL(card_type, card_id)``; ``watchdog_set_analog_expiration_state`` then
``watchdog_start``; ``task_create_encoder_reader`` and ``task_start`` on
``Clock.SYSTEM_CLOCK_1`` at 1 kHz; per sample ``task_read_encoder`` (which blocks until
the board's next sample: the board is the clock), ``read_analog`` for the strain
gauge, ``write_analog`` and ``watchdog_reload``; ``task_stop``, ``task_delete``,
``close``), and tests/unit/rig/test_quanser.py checks it against a recording fake.
``quanser.hardware`` is imported only when a driver is made (it is not installed with
E-Lab). Channels: encoder 0 = θ, analog input 0 = strain gauge, analog output 0 = motor.
"""

from __future__ import annotations

import array
import importlib
import math
import time
from dataclasses import dataclass
from typing import Any, assert_never

from elab.errors import Unavailable
from elab.rig.driver import RigSample
from elab.rig.messages import Action, RigIdentity, Status

FOREVER = 2**31 - 1  # task_start's sample count for a task that runs until stopped


@dataclass(frozen=True)
class QuanserCalibration:
    """The rig's calibration (its Quanser setup sheet): counts per revolution of the
    servo encoder, the strain gauge's rad per volt and its offset (V)."""

    counts_per_rev: int = 4096
    gauge_rad_per_volt: float = 0.0606  # public RFL code's GAUGE_TO_RAD
    gauge_offset: float = 0.0
    Ts: float = 1e-3
    watchdog_timeout: float = 5e-3  # s without a reload before the board writes 0 V


class QuanserDriver:
    """The flexible link on a Quanser HIL board (see the module docstring)."""

    def __init__(
        self,
        card_type: str = "q2_usb",
        card_id: str = "0",
        calibration: QuanserCalibration | None = None,
    ) -> None:
        try:
            self._hw: Any = importlib.import_module("quanser.hardware")
        except ImportError:
            raise Unavailable(
                "the Quanser HIL driver needs Quanser's Python API (quanser.hardware); "
                "install the Quanser SDK, or use TcpDriver with a rig or elab rig-emulator"
            ) from None
        self.card_type, self.card_id = card_type, card_id
        self.calibration = calibration or QuanserCalibration()
        self._card: Any = None
        self._task: Any = None
        self._seq = 0
        self._enabled = False
        self._tripped = False
        self._gauge_zero = self.calibration.gauge_offset
        self._ch = array.array("I", [0])
        self._counts = array.array("i", [0])
        self._volts = array.array("d", [0.0])

    def connect(self) -> RigIdentity:
        c, hw = self.calibration, self._hw
        card = hw.HIL(self.card_type, self.card_id)
        self._card = card
        card.watchdog_set_analog_expiration_state(self._ch, 1, array.array("d", [0.0]))
        card.write_analog(self._ch, 1, array.array("d", [0.0]))
        self._task = card.task_create_encoder_reader(int(1 / c.Ts), self._ch, 1)
        card.watchdog_start(c.watchdog_timeout)
        card.task_start(self._task, hw.Clock.SYSTEM_CLOCK_1, 1 / c.Ts, FOREVER)
        return RigIdentity(
            rig_id=f"{self.card_type}:{self.card_id}",
            firmware="quanser-hil",
            emulated=False,
            counts_per_rev=c.counts_per_rev,
            gauge_rad_per_count=c.gauge_rad_per_volt,  # one "count" is one volt here
            gauge_offset=0,
            Ts=c.Ts,
            watchdog_samples=max(1, round(c.watchdog_timeout / c.Ts)),
        )

    def read(self, timeout: float) -> RigSample:
        """The board's next sample. ``timeout`` is not enforced: ``task_read_encoder``
        blocks for at most one sample period while the task runs."""
        card = self._card
        card.task_read_encoder(self._task, 1, self._counts)
        card.read_analog(self._ch, 1, self._volts)
        received = time.monotonic_ns()
        c = self.calibration
        theta = self._counts[0] * 2 * math.pi / c.counts_per_rev
        alpha = (self._volts[0] - self._gauge_zero) * c.gauge_rad_per_volt
        status = (Status.MOTOR_ENABLED if self._enabled else Status(0)) | (
            Status.WATCHDOG_TRIPPED if self._tripped else Status(0)
        )
        self._seq = (self._seq + 1) % 2**32
        return RigSample(self._seq, theta, alpha, status, received)

    def write(self, seq: int, u: float) -> None:
        """Reload the watchdog and write ``u`` (V); 0 V while disabled or tripped."""
        if not self._card.watchdog_reload():
            self._tripped, self._enabled = True, False
        if self._tripped:
            return  # the board holds 0 V and refuses writes until watchdog_clear
        volts = u if self._enabled and math.isfinite(u) else 0.0
        self._card.write_analog(self._ch, 1, array.array("d", [volts]))

    def command(self, action: Action) -> None:
        card = self._card
        match action:
            case Action.ZERO:
                card.set_encoder_counts(self._ch, 1, array.array("i", [0]))
                card.read_analog(self._ch, 1, self._volts)
                self._gauge_zero = self._volts[0]
            case Action.STOP:
                self._enabled = False
                card.write_analog(self._ch, 1, array.array("d", [0.0]))
            case Action.ENABLE:
                if self._tripped:
                    card.watchdog_clear()  # outputs stay at their expiry state until cleared
                self._tripped, self._enabled = False, True
            case _:
                assert_never(action)

    def close(self) -> None:
        card, self._card = self._card, None
        if card is None:
            return
        card.write_analog(self._ch, 1, array.array("d", [0.0]))
        if self._task is not None:
            card.task_stop(self._task)
            card.task_delete(self._task)
        card.watchdog_stop()
        card.close()
