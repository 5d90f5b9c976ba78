"""``elab rig-emulator``: the emulated flexible-link rig as a process of its own;
``elab rig-estop``: the rig's emergency stop from a shell."""

from __future__ import annotations

import argparse
import logging
import os
import signal
import sys
from pathlib import Path
from types import FrameType

from elab.errors import InvalidInput


def cmd_rig_emulator(args: argparse.Namespace) -> str:
    from elab.rig.emulator import Emulator, EmulatorConfig

    if not 0 <= args.port <= 65535:
        raise InvalidInput("--port", args.port, "0 (any free port) to 65535")
    if not 1 <= args.watchdog_samples <= 65535:
        raise InvalidInput("--watchdog-samples", args.watchdog_samples, "1 to 65535")
    if not 0 <= args.realtime <= 99:
        raise InvalidInput("--realtime", args.realtime, "0 (ordinary) to 99")
    logging.basicConfig(
        stream=sys.stderr, level=logging.INFO, format="%(asctime)s rig-emulator %(message)s"
    )
    if args.realtime:  # hardware keeps its clock whatever the host does
        try:
            os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(args.realtime))
        except OSError as exc:
            logging.warning("real-time scheduling refused (%s): the clock may slip under load", exc)
    stop = []

    def on_signal(signum: int, frame: FrameType | None) -> None:
        stop.append(signum)

    signal.signal(signal.SIGTERM, on_signal)
    signal.signal(signal.SIGINT, on_signal)
    emulator = Emulator(EmulatorConfig(args.host, args.port, args.rig_seed, args.watchdog_samples))
    host, port = emulator.address
    print(f"listening on {host}:{port}", flush=True)  # the first line: how tests find the port
    parent = os.getppid() if args.exit_with_parent else None

    def stopping() -> bool:  # a server killed with -9 leaves no emulator behind
        return bool(stop) or (parent is not None and os.getppid() != parent)

    emulator.serve(stopping)
    return "rig emulator stopped"


def cmd_rig_estop(args: argparse.Namespace) -> str:
    from elab.rig.estop import estop_address, send_estop

    data = Path(args.data or os.environ.get("ELAB_DATA", "data"))
    send_estop(estop_address(data), args.who)  # Unavailable: no rig engine listens
    return f"emergency stop sent to the rig engine of {data}"
