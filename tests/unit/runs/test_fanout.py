"""Fan-out: a blocked watcher skips frames, is told so, and gets them back on resume."""

from __future__ import annotations

import asyncio

import msgpack
import numpy as np

from elab.runs.fanout import RunChannel, Watcher


def test_blocked_watcher_skips_is_told_and_resumes_completely() -> None:
    async def scenario() -> tuple[list[dict], list[dict]]:
        data = np.arange(2000, dtype=np.float64).reshape(-1, 2) / 7  # 1000 samples, 2 channels
        recording: list[np.ndarray] = []

        async def read(k0: int, k1: int) -> np.ndarray:
            return np.concatenate(recording)[k0:k1]

        ch = RunChannel(("a", "b"), Ts=0.001, read=read)  # F = 20 samples per frame
        gate = asyncio.Event()
        got_fast: list[dict] = []
        got_slow: list[dict] = []

        async def send_fast(b: bytes) -> None:
            got_fast.append(msgpack.unpackb(b))

        async def send_slow(b: bytes) -> None:
            await gate.wait()  # a client that stopped reading
            got_slow.append(msgpack.unpackb(b))

        fast, slow = Watcher(send_fast, max_frames=5), Watcher(send_slow, max_frames=5)
        ch.watchers |= {fast, slow}
        tasks = [asyncio.create_task(ch.serve(w)) for w in (fast, slow)]
        for k0 in range(0, 1000, 20):  # 50 frames, published as the stepper would
            recording.append(data[k0:k0 + 20])
            ch.publish(k0, data[k0:k0 + 20])
            await asyncio.sleep(0)
        await asyncio.sleep(0.01)
        assert len([m for m in got_fast if m["type"] == "frame"]) == 50  # never waited
        gate.set()
        await asyncio.sleep(0.01)
        notice = next(m for m in got_slow if m["type"] == "skipped")
        ch.resume_from(slow, notice["from_seq"])
        await asyncio.sleep(0.05)
        for w, t in zip((fast, slow), tasks, strict=True):
            w.closed = True
            w.wake.set()
            t.cancel()
        return got_fast, got_slow

    _, got_slow = asyncio.run(scenario())
    samples = np.full((1000, 2), np.nan)
    for m in got_slow:
        if m["type"] == "frame":
            cols = [np.frombuffer(m["columns"][c], "<f4") for c in ("a", "b")]
            samples[m["k0"]:m["k0"] + m["n"]] = np.column_stack(cols)
    want = (np.arange(2000, dtype=np.float64).reshape(-1, 2) / 7).astype("<f4")
    np.testing.assert_array_equal(samples, want)  # every sample, after the resume
    skipped = [m for m in got_slow if m["type"] == "skipped"]
    assert len(skipped) == 1 and skipped[0]["to_seq"] == 49
