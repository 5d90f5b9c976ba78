"""Fan-out: a blocked watcher skips frames, is told so, and gets them back on resume."""

from __future__ import annotations

import asyncio
from collections.abc import Awaitable, Callable

import msgpack
import numpy as np

from elab.api.frames import MsgpackCodec, encode_frame, encode_frames
from elab.runs.fanout import RunChannel, Watcher, publish_block

CODEC = MsgpackCodec()


def test_blocked_watcher_skips_is_told_and_resumes_completely() -> None:
    async def scenario() -> tuple[list[dict], list[dict]]:
        data = np.arange(2000, dtype=np.float64).reshape(-1, 2) / 7  # 1000 samples, 2 channels
        recording: list[np.ndarray] = []

        async def read(k0: int, k1: int) -> np.ndarray:
            return np.concatenate(recording)[k0:k1]

        ch = RunChannel(("a", "b"), Ts=0.001, codec=CODEC, read=read)  # F = 20 samples
        gate = asyncio.Event()
        got_fast: list[dict] = []
        got_slow: list[dict] = []

        async def send_fast(b: bytes) -> None:
            got_fast.append(msgpack.unpackb(b))

        async def send_slow(b: bytes) -> None:
            await gate.wait()  # a client that stopped reading
            got_slow.append(msgpack.unpackb(b))

        fast = Watcher(send_fast, CODEC, max_frames=5)
        slow = Watcher(send_slow, CODEC, max_frames=5)
        ch.watchers |= {fast, slow}
        tasks = [asyncio.create_task(ch.serve(w)) for w in (fast, slow)]
        for k0 in range(0, 1000, 20):  # 50 frames, published as the stepper would
            recording.append(data[k0 : k0 + 20])
            ch.publish(data[k0 : k0 + 20])
            await asyncio.sleep(0)
        await asyncio.sleep(0.01)
        assert len([m for m in got_fast if m["type"] == "frame"]) == 50  # never waited
        # what /server reports: the fast watcher is not behind; the blocked one is behind
        # by everything after its oldest queued frame (the 2nd: the 1st is being sent) and
        # is having frames skipped
        assert ch.lag(fast) == 0.0 and slow.skipped is not None
        assert abs(ch.lag(slow) - (1000 - 20) * 0.001) < 1e-9
        gate.set()
        await asyncio.sleep(0.01)
        notice = next(m for m in got_slow if m["type"] == "skipped")
        ch.resume_from(slow, notice["from_seq"])
        await asyncio.sleep(0.05)
        assert ch.lag(slow) == 0.0 and slow.pull_from is None  # caught up
        for w, t in zip((fast, slow), tasks, strict=True):
            w.close()
            t.cancel()
        return got_fast, got_slow

    _, got_slow = asyncio.run(scenario())
    samples = np.full((1000, 2), np.nan)
    for m in got_slow:
        if m["type"] == "frame":
            cols = [np.frombuffer(m["columns"][c], "<f4") for c in ("a", "b")]
            samples[m["k0"] : m["k0"] + m["n"]] = np.column_stack(cols)
    want = (np.arange(2000, dtype=np.float64).reshape(-1, 2) / 7).astype("<f4")
    np.testing.assert_array_equal(samples, want)  # every sample, after the resume
    skipped = [m for m in got_slow if m["type"] == "skipped"]
    assert len(skipped) == 1 and skipped[0]["to_seq"] == 49


def test_catching_up_while_the_edge_moves_ends_in_push_mode_with_every_sample_once() -> None:
    """A watcher resuming from sample 0 while the run publishes a frame during each of its
    reads (a busy server): it reaches the first frame queued meanwhile, goes back to push
    mode, and receives every sample exactly once."""

    async def scenario() -> tuple[list[dict], int, Watcher]:
        data = np.arange(4000, dtype=np.float64).reshape(-1, 2) / 3  # 2000 samples
        published = [0]  # samples published so far
        reads = [0]
        ch = RunChannel(
            ("a", "b"),
            Ts=0.001,
            codec=CODEC,  # F = 20
            read=lambda k0, k1: read(k0, k1),
        )

        def publish_frame() -> None:
            k0 = published[0]
            ch.publish(data[k0 : k0 + 20])
            published[0] += 20

        async def read(k0: int, k1: int) -> np.ndarray:
            reads[0] += 1
            publish_frame()  # the edge moves while the recording is read
            await asyncio.sleep(0)
            return data[k0:k1]

        got: list[dict] = []

        async def send(b: bytes) -> None:
            got.append(msgpack.unpackb(b))
            await asyncio.sleep(0)

        for _ in range(30):  # 600 samples before the watcher joins
            publish_frame()
        w = Watcher(send, CODEC, max_frames=100)
        ch.watchers.add(w)
        ch.resume_from(w, 0)
        task = asyncio.create_task(ch.serve(w))
        for _ in range(40):  # the run goes on: 800 more samples, one frame per tick
            await asyncio.sleep(0.001)
            publish_frame()
        await asyncio.sleep(0.01)
        w.close()
        task.cancel()
        return got, reads[0], w

    got, reads, w = asyncio.run(scenario())
    assert w.pull_from is None  # back in push mode
    assert reads <= 2  # not one read per tick for ever
    ks = np.concatenate([np.arange(m["k0"], m["k0"] + m["n"]) for m in got if m["type"] == "frame"])
    np.testing.assert_array_equal(ks, np.arange(ks.size))  # every sample once, in order
    assert ks.size >= 1400


def test_frames_encoded_together_decode_to_the_samples_and_equal_one_by_one() -> None:
    names = ("r", "u", "theta_with_a_long_name")
    rng = np.random.default_rng(3)
    block = rng.standard_normal((5, 20, 3)) * 1e3
    k0 = np.array([0, 20, 2**40, 77 * 20, 5 * 20])  # seq and k0 of any size
    together = encode_frames(names, 20, k0, block)
    for i, payload in enumerate(together):
        assert payload == encode_frame(names, 20, int(k0[i]), block[i])
        m = msgpack.unpackb(payload)
        assert (m["type"], m["seq"], m["k0"], m["n"]) == ("frame", k0[i] // 20, k0[i], 20)
        for j, name in enumerate(names):
            np.testing.assert_array_equal(
                np.frombuffer(m["columns"][name], "<f4"), block[i, :, j].astype("<f4")
            )


def test_publish_block_gives_each_channel_what_publish_would() -> None:
    """Whole frames at the edge go through the batch; a channel holding a partial frame
    (or getting one) takes the one-by-one path; both end in the same messages."""

    async def scenario() -> tuple[list[list[dict]], list[list[dict]]]:
        async def read(k0: int, k1: int) -> np.ndarray:
            raise AssertionError("not reading")

        rng = np.random.default_rng(4)
        sizes = [[20, 20, 40], [7, 13, 20], [20, 5, 15, 20]]  # samples per tick, per channel
        data = [rng.standard_normal((sum(s), 2)) for s in sizes]
        got: list[list[list[dict]]] = [[], []]
        for mode in (0, 1):
            chans = [RunChannel(("a", "b"), Ts=0.001, codec=CODEC, read=read) for _ in sizes]
            sinks: list[list[dict]] = [[] for _ in sizes]
            for ch, sink in zip(chans, sinks, strict=True):
                w = Watcher(lambda b: None, CODEC)  # type: ignore[arg-type, return-value]
                w.control = lambda p: None  # type: ignore[method-assign]
                w.offer = lambda p, *_, sink=sink: sink.append(msgpack.unpackb(p))  # type: ignore
                ch.watchers.add(w)
            for tick in range(4):
                new = []
                for i, (ch, s) in enumerate(zip(chans, sizes, strict=True)):
                    if tick < len(s):
                        k0 = sum(s[:tick])
                        new.append((ch, data[i][k0 : k0 + s[tick]]))
                if mode:  # as the stepper's blocks come: one per number of samples
                    by_n: dict[int, list[tuple[RunChannel, np.ndarray]]] = {}
                    for ch, d in new:
                        by_n.setdefault(d.shape[0], []).append((ch, d))
                    for group in by_n.values():  # + a run that ended meanwhile: skipped
                        publish_block(
                            [ch for ch, _ in group] + [None],
                            np.stack([d for _, d in group] + [group[0][1]]),
                        )
                else:
                    for ch, d in new:
                        ch.publish(d)
            got[mode] = sinks
        return got[0], got[1]

    one_by_one, together = asyncio.run(scenario())
    assert [[m["k0"] for m in s] for s in together] == [[0, 20, 40], [0, 20], [0, 20, 40]]
    for a, b in zip(one_by_one, together, strict=True):
        assert len(a) == len(b)
        for x, y in zip(a, b, strict=True):
            assert x.keys() == y.keys() and all(x[k] == y[k] for k in x)


def test_one_pass_sends_to_every_watcher_and_a_send_that_waits_delays_nobody() -> None:
    """The sender's pass writes a frame to all watchers in one task (no task per watcher).
    A watcher whose send writes and then waits (a connection that stopped reading) gets
    each message once and in order, from its own task, while the others keep receiving
    every frame in their passes."""

    async def scenario() -> tuple[dict[str, list[tuple[int, object]]], list[int]]:
        async def read(k0: int, k1: int) -> np.ndarray:
            raise AssertionError("not reading")

        ch = RunChannel(("a",), Ts=0.001, codec=CODEC, read=read)  # F = 20
        got: dict[str, list[tuple[int, object]]] = {"f1": [], "f2": [], "slow": []}
        gate = asyncio.Event()

        def sender(name: str, waits: bool) -> Callable[[bytes], Awaitable[None]]:
            async def send(b: bytes) -> None:
                got[name].append((msgpack.unpackb(b)["k0"], asyncio.current_task()))
                if waits and not gate.is_set():
                    await gate.wait()  # written, then the connection's buffer is full

            return send

        watchers = [
            Watcher(sender("f1", False), CODEC),
            Watcher(sender("f2", False), CODEC),
            Watcher(sender("slow", True), CODEC, max_frames=1000),
        ]
        ch.watchers |= set(watchers)
        tasks = [asyncio.create_task(ch.serve(w)) for w in watchers]
        fast_while_blocked = []
        for k0 in range(0, 600, 20):  # 30 frames, one per tick
            ch.publish(np.full((20, 1), k0 / 20))
            await asyncio.sleep(0.001)
            fast_while_blocked.append(len(got["f1"]))
        gate.set()
        await asyncio.sleep(0.02)
        for w, t in zip(watchers, tasks, strict=True):
            w.close()
            t.cancel()
        return got, fast_while_blocked

    got, fast_while_blocked = asyncio.run(scenario())
    assert fast_while_blocked == list(range(1, 31))  # each frame at its tick: never held up
    for name in got:
        assert [k0 for k0, _ in got[name]] == list(range(0, 600, 20)), name  # once, in order
    # the fast watchers' frames went out together, in one task per pass (but where the
    # slow watcher's first wait split a pass)
    together = [t1 is t2 for (_, t1), (_, t2) in zip(got["f1"], got["f2"], strict=True)]
    assert sum(together) >= 29, together


def test_direct_writes_and_waiting_sends_mix_in_order() -> None:
    """A watcher with a direct ``write`` gets its frames written without a coroutine while
    its connection has room; when it has none, the frame goes through ``send`` (which
    waits), and the next ones follow it: each frame once, in order, whichever path."""

    async def scenario() -> tuple[list[tuple[str, int]], int]:
        async def read(k0: int, k1: int) -> np.ndarray:
            raise AssertionError("not reading")

        ch = RunChannel(("a",), Ts=0.001, codec=CODEC, read=read)  # F = 20
        got: list[tuple[str, int]] = []
        room = [True]

        def write(b: bytes) -> bool:
            if not room[0]:
                return False
            got.append(("write", msgpack.unpackb(b)["k0"]))
            return True

        async def send(b: bytes) -> None:
            got.append(("send", msgpack.unpackb(b)["k0"]))
            room[0] = True  # the buffer drained while it waited
            await asyncio.sleep(0)

        w = Watcher(send, CODEC, write=write)
        ch.watchers.add(w)
        task = asyncio.create_task(ch.serve(w))
        for i, k0 in enumerate(range(0, 400, 20)):
            room[0] = i % 5 != 3  # now and then the connection is full
            ch.publish(np.full((20, 1), k0 / 20))
            await asyncio.sleep(0.001)
        w.close()
        task.cancel()
        return got, sum(how == "write" for how, _ in got)

    got, written = asyncio.run(scenario())
    assert [k0 for _, k0 in got] == list(range(0, 400, 20))
    assert {how for how, _ in got} == {"write", "send"}
    assert written >= 15


def test_the_stream_writes_directly_to_uvicorns_default_websocket_protocol() -> None:
    """The direct path relies on uvicorn's sans-I/O protocol (what its "auto" picks) and its
    attributes; an upgrade that changes either fails here, not silently in the speed."""
    from uvicorn.config import Config
    from uvicorn.protocols.websockets.auto import AutoWebSocketsProtocol
    from uvicorn.protocols.websockets.websockets_sansio_impl import WebSocketsSansIOProtocol
    from uvicorn.server import ServerState

    from elab.api.stream import direct_writer

    assert AutoWebSocketsProtocol is WebSocketsSansIOProtocol
    config = Config(app=lambda scope, receive, send: None)
    config.load()
    loop = asyncio.new_event_loop()
    try:
        proto = WebSocketsSansIOProtocol(
            config=config, server_state=ServerState(), app_state={}, _loop=loop
        )
    finally:
        loop.close()
    write = direct_writer(proto.send)
    assert write is not None
    assert direct_writer(lambda message: None) is None

    written: list[bytes] = []

    class Transport:
        def is_closing(self) -> bool:
            return False

        def write(self, data: bytes) -> None:
            written.append(data)

    proto.transport = Transport()  # type: ignore[assignment]
    assert not write(b"x")  # the handshake has not happened: left to uvicorn's send
    from websockets.protocol import State

    proto.conn.state = State.OPEN
    assert write(b"\x01\x02")
    assert written == [b"\x82\x02\x01\x02"]  # one unmasked binary frame
    proto.writable.clear()  # the transport is paused: wait in uvicorn's send
    assert not write(b"x")


def test_the_direct_frames_are_the_frames_websockets_writes() -> None:
    from websockets.frames import Frame, Opcode

    from elab.api.stream import binary_frame

    for n in (0, 1, 125, 126, 127, 65535, 65536, 70000):
        data = bytes(range(256)) * (n // 256) + bytes(n % 256)
        assert binary_frame(data) == Frame(Opcode.BINARY, data).serialize(mask=False), n
