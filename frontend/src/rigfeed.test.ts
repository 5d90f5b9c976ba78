import { describe, expect, it } from "vitest";
import { ApiError } from "./api";
import type { RigQueueInfo } from "./protocol.gen";
import { RigFeed, type FeedClock, type RigFeedState } from "./rigfeed";

/** A clock the test turns by hand: `fire()` is one poll period; `show()` makes the tab visible. */
function handClock() {
  const timers = new Set<() => void>();
  const visible = new Set<() => void>();
  let hidden = false;
  const clock: FeedClock = {
    now: () => 1000,
    every: (_ms, fn) => (timers.add(fn), () => timers.delete(fn)),
    hidden: () => hidden,
    onVisible: (fn) => (visible.add(fn), () => visible.delete(fn)),
  };
  return {
    clock,
    fire: () => timers.forEach((fn) => fn()),
    hide: () => (hidden = true),
    show: () => ((hidden = false), visible.forEach((fn) => fn())),
    running: () => timers.size > 0 || visible.size > 0,
  };
}

const q = (waiting: number) => ({ waiting }) as RigQueueInfo;
const settle = () => new Promise((resolve) => setTimeout(resolve, 0));

function feed(answers: (RigQueueInfo | Error)[]) {
  let asked = 0;
  const hand = handClock();
  const f = new RigFeed(() => {
    const a = answers[Math.min(asked++, answers.length - 1)];
    return a instanceof Error ? Promise.reject(a) : Promise.resolve(a);
  }, hand.clock);
  return { f, hand, asked: () => asked };
}

const kinds = (seen: RigFeedState[]) => seen.map((s) => (s.kind === "rig" ? `rig ${s.q.waiting}` : s.kind));

describe("RigFeed", () => {
  it("polls while someone listens and the tab is visible, one poll for all", async () => {
    const { f, hand, asked } = feed([q(0), q(1), q(2), q(3)]);
    const a: RigFeedState[] = [];
    const b: RigFeedState[] = [];
    const stopA = f.subscribe((s) => a.push(s));
    await settle();
    const stopB = f.subscribe((s) => b.push(s)); // told the last state at once
    expect(asked()).toBe(1);
    hand.fire();
    await settle();
    expect(kinds(a)).toEqual(["rig 0", "rig 1"]);
    expect(kinds(b)).toEqual(["rig 0", "rig 1"]);
    hand.hide();
    hand.fire(); // hidden: not asked
    await settle();
    expect(asked()).toBe(2);
    hand.show(); // visible again: asked at once
    await settle();
    expect(asked()).toBe(3);
    stopA();
    expect(hand.running()).toBe(true);
    stopB();
    expect(hand.running()).toBe(false); // the view was left: no more polls
  });

  it("tells a server without a rig once, then stops asking", async () => {
    const none = new ApiError(404, { code: "not_found", message: "unknown rig 'on this server (ELAB_RIG is none)'", field: null, errors: [] });
    const { f, hand, asked } = feed([none]);
    const seen: RigFeedState[] = [];
    f.subscribe((s) => seen.push(s));
    await settle();
    hand.fire();
    await f.refresh();
    expect(kinds(seen)).toEqual(["none"]);
    expect(asked()).toBe(1);
    expect(hand.running()).toBe(false);
  });

  it("keeps the last queue through a failed poll", async () => {
    const { f, hand } = feed([q(4), new ApiError(0, { code: "unavailable", message: "not reachable", field: null, errors: [] }), q(5)]);
    const seen: RigFeedState[] = [];
    f.subscribe((s) => seen.push(s));
    await settle();
    hand.fire();
    await settle();
    const failed = seen[1];
    expect(failed.kind === "error" && failed.last?.q.waiting).toBe(4);
    hand.fire();
    await settle();
    expect(kinds(seen)).toEqual(["rig 4", "error", "rig 5"]);
  });

  it("drops a poll's answer that an operation's answer overtook", async () => {
    let release: (v: RigQueueInfo) => void = () => undefined;
    const hand = handClock();
    const f = new RigFeed(() => new Promise<RigQueueInfo>((resolve) => (release = resolve)), hand.clock);
    const seen: RigFeedState[] = [];
    f.subscribe((s) => seen.push(s)); // asks; the answer is held back
    f.set(q(9)); // the join's answer: newer than the poll on its way
    release(q(8));
    await settle();
    expect(kinds(seen)).toEqual(["rig 9"]);
  });
});
