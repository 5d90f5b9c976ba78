"""``elab rig-emulator``: the emulated flexible-link rig as a process of its own."""

from __future__ import annotations

import argparse
import logging
import signal
import sys
from types import FrameType

from elab.errors import InvalidInput


def cmd_rig_emulator(args: argparse.Namespace) -> str:
    from elab.rig.emulator import Emulator, EmulatorConfig

    if not 0 <= args.port <= 65535:
        raise InvalidInput("--port", args.port, "0 (any free port) to 65535")
    if not 1 <= args.watchdog_samples <= 65535:
        raise InvalidInput("--watchdog-samples", args.watchdog_samples, "1 to 65535")
    logging.basicConfig(
        stream=sys.stderr, level=logging.INFO, format="%(asctime)s rig-emulator %(message)s"
    )
    stop = []

    def on_signal(signum: int, frame: FrameType | None) -> None:
        stop.append(signum)

    signal.signal(signal.SIGTERM, on_signal)
    signal.signal(signal.SIGINT, on_signal)
    emulator = Emulator(EmulatorConfig(args.host, args.port, args.rig_seed, args.watchdog_samples))
    host, port = emulator.address
    print(f"listening on {host}:{port}", flush=True)  # the first line: how tests find the port
    emulator.serve(lambda: bool(stop))
    return "rig emulator stopped"
