"""The messages of the rig's byte protocol (docs/rig-protocol.md), as typed values.

Host to rig: :class:`Hello`, :class:`Voltage`, :class:`Command`. Rig to host:
:class:`RigIdentity`, :class:`Sample`, :class:`Refusal`. :mod:`elab.rig.protocol`
turns them into frames and back.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

PROTOCOL_VERSION = 1


class Status(enum.IntFlag):
    """The status word of a :class:`Sample` (u16)."""

    WATCHDOG_TRIPPED = 0x0001  # the host was silent; 0 V until ENABLE
    AMPLIFIER_SATURATED = 0x0002  # the last voltage was clipped at the amplifier's limit
    MOTOR_ENABLED = 0x0004  # the amplifier drives the motor
    LATE = 0x0008  # the rig's clock missed this sample's deadline (emulator) or dropped samples


class Action(enum.IntEnum):
    """What a :class:`Command` asks of the rig."""

    ZERO = 1  # re-zero the encoder and tare the strain gauge
    STOP = 2  # 0 V and disable the motor
    ENABLE = 3  # enable the motor and clear a tripped watchdog


@dataclass(frozen=True)
class Hello:
    """The host opens a session and says which protocol version it speaks."""

    version: int = PROTOCOL_VERSION


@dataclass(frozen=True)
class Voltage:
    """The host's answer to sample ``seq``: the motor voltage ``u`` (V, float32)."""

    seq: int
    u: float


@dataclass(frozen=True)
class Command:
    """A host command: ZERO, STOP or ENABLE."""

    action: Action


@dataclass(frozen=True)
class RigIdentity:
    """The rig's answer to :class:`Hello`: who it is and how to read its samples.

    θ = ``encoder_counts`` · 2π / ``counts_per_rev`` (rad); α = (gauge reading −
    ``gauge_offset``) · ``gauge_rad_per_count`` (rad). ``Ts`` is the sample period (s);
    ``watchdog_samples`` how many samples the host may leave unanswered before the rig
    trips its watchdog.
    """

    rig_id: str
    firmware: str
    emulated: bool
    counts_per_rev: int
    gauge_rad_per_count: float
    gauge_offset: int
    Ts: float
    watchdog_samples: int


@dataclass(frozen=True)
class Sample:
    """One sample as the rig measured it: raw counts and the status word."""

    seq: int  # u32, wraps
    encoder_counts: int  # i32, servo angle θ
    gauge_reading: int  # i32, strain gauge (link deflection α through the calibration)
    status: Status


@dataclass(frozen=True)
class Refusal:
    """The rig will not serve this connection (busy, wrong version) and closes it."""

    reason: str


HostMessage = Hello | Voltage | Command
RigMessage = RigIdentity | Sample | Refusal
Message = HostMessage | RigMessage
