// The rig's queue as the page reads it (pure): what state the rig is in, the caller's step
// towards a run (join → arm → start), which buttons show for whom, times and latencies in
// words, and what to do after a refused start. The views (views/rigstatus.ts,
// views/rigmode.ts, rigrun.ts) only draw what these say.
import type { RigQueueInfo } from "./protocol.gen";

export type RigInfo = RigQueueInfo["rig"];

/** The rig as one word: nobody may drive it (offline, out of service), it settles after a
 * run, someone holds it, or it is free. */
export type RigCondition = "offline" | "out_of_service" | "settling" | "in_use" | "free";

export function rigCondition(q: RigQueueInfo): RigCondition {
  if (!q.in_service) return "out_of_service";
  if (!q.rig.connected) return "offline";
  if (q.driver !== null) return "in_use";
  if (q.settling || q.rig.settling) return "settling";
  return "free";
}

/** Where the caller stands on the way to a run on the rig. */
export type RigStep = "join" | "wait" | "arm" | "start" | "running";

export function rigStep(q: RigQueueInfo): RigStep {
  const you = q.you;
  if (you.place === null) return "join";
  if (!you.driving) return "wait";
  if (q.phase === "running") return "running";
  if (q.phase === "armed") return "start";
  return "arm";
}

export type Role = "student" | "instructor";

export interface RigButtons {
  join: boolean;
  leave: boolean;
  arm: boolean;
  estop: boolean;
  takeover: boolean;
  extend: boolean;
  clear: boolean;
}

/** The queue's buttons for the caller: the steps for everyone in turn, the emergency stop
 * for the driver and instructors while a run is on the rig, and the instructor's own. */
export function rigButtons(q: RigQueueInfo, role: Role): RigButtons {
  const step = rigStep(q);
  const instructor = role === "instructor";
  return {
    join: step === "join" && q.in_service,
    leave: step !== "join",
    arm: step === "arm" && q.in_service && q.rig.connected,
    estop: q.phase === "running" && (q.you.driving || instructor),
    takeover: instructor && q.in_service && !q.you.driving,
    extend: instructor && q.driver !== null,
    clear: instructor && q.waiting > 0,
  };
}

/** Why Start cannot send a rig run now (null: it may). */
export function startBlocker(q: RigQueueInfo): string | null {
  if (!q.in_service) return `The rig is out of service: ${q.out_of_service ?? "no reason given"}. Run in simulation meanwhile.`;
  if (!q.rig.connected) return `The rig is offline (${q.rig.problem ?? "it does not answer"}). Run in simulation, or wait until the rig status says online.`;
  switch (rigStep(q)) {
    case "join":
      return "Join the rig's queue first (step 1), then arm the rig when it is your turn.";
    case "wait":
      return `It is not your turn yet: you are ${ordinal(q.you.place ?? 0)} in the queue${q.you.wait_s === null ? "" : `, ${waitText(q.you.wait_s)}`}. Arm the rig when your turn comes.`;
    case "arm":
      return "It is your turn: arm the rig first (step 2), then Start.";
    case "running":
      return "Your run is on the rig: stop it (or wait for its end) before starting another.";
    case "start":
      return q.settling || q.rig.settling ? "The rig is settling (after every run and when it connects: 0 V until the link is still, then it re-zeroes): Start in a few seconds." : null;
  }
}

/** What the server's refusal of a rig run means for the user, and what to do. */
export function startRefusal(status: number, message: string): string {
  if (status === 409 && /settl/i.test(message)) return `The rig is settling (${message}). Press Start again in a few seconds.`;
  if (status === 409) return `${message}. Join the queue and arm the rig (steps 1 and 2), then Start.`;
  if (status === 503) return `The rig is not connected (${message}). Run in simulation, or try again when the rig status says online.`;
  return message;
}

/** 1st, 2nd, 3rd, 4th, 11th, 22nd. */
export function ordinal(n: number): string {
  const teen = n % 100 >= 11 && n % 100 <= 13;
  const suffix = teen ? "th" : ({ 1: "st", 2: "nd", 3: "rd" } as Record<number, string>)[n % 10] ?? "th";
  return `${n}${suffix}`;
}

/** A countdown: "4:05", "1:02:09" past an hour; never below 0:00. */
export function clock(seconds: number): string {
  const s = Math.max(0, Math.ceil(seconds));
  const hh = Math.floor(s / 3600);
  const mm = Math.floor((s % 3600) / 60);
  const ss = String(s % 60).padStart(2, "0");
  return hh ? `${hh}:${String(mm).padStart(2, "0")}:${ss}` : `${mm}:${ss}`;
}

/** An estimated wait in words: "your turn now", "about 40 s", "about 4 min", "about 1 h 5 min". */
export function waitText(seconds: number | null): string {
  if (seconds === null) return "wait unknown";
  if (seconds < 1) return "your turn now";
  if (seconds < 60) return `about ${Math.ceil(seconds / 5) * 5} s`;
  const min = Math.round(seconds / 60);
  if (min < 60) return `about ${min} min`;
  return `about ${Math.floor(min / 60)} h${min % 60 ? ` ${min % 60} min` : ""}`;
}

/** Seconds left until `until` (the server's unix s), given the queue as of `receivedMs`
 * (the page's clock when it arrived) and the page's clock now: the server's clock is
 * read through its `now`, so a page clock set wrong does not matter. */
export function remaining(until: number, q: Pick<RigQueueInfo, "now">, receivedMs: number, nowMs: number): number {
  return until - q.now - (nowMs - receivedMs) / 1000;
}

/** "emulated rig emulator-1 (elab rig-emulator, not hardware)" or "rig srv02-7, firmware 2.1". */
export function rigIdentity(rig: RigInfo): string {
  if (rig.emulated) return `emulated rig${rig.rig_id ? ` ${rig.rig_id}` : ""} (elab rig-emulator, not hardware)`;
  return `rig ${rig.rig_id ?? "(identity unknown)"}${rig.firmware ? `, firmware ${rig.firmware}` : ""}`;
}

/** The host loop's response latency over the last 10 s, "p50 42 µs · p99 66 µs · max
 * 328 µs"; null before it has answered samples. */
export function latencyText(rig: RigInfo): string | null {
  if (rig.latency_p99_us === null) return null;
  const us = (x: number | null) => (x === null ? "—" : `${Math.round(x)} µs`);
  return `p50 ${us(rig.latency_p50_us)} · p99 ${us(rig.latency_p99_us)} · max ${us(rig.latency_max_us)}`;
}

/** The rig's state for a status line: a headline and what else there is to know. */
export function rigSummary(q: RigQueueInfo): { condition: RigCondition; headline: string; details: string[] } {
  const condition = rigCondition(q);
  const who = q.you.driving ? "you" : q.driver;
  const holder = q.taken_over ? `${who ?? "an instructor"} (taken over)` : who;
  const doing = q.phase === "running" ? "running a run" : q.phase === "armed" ? "armed, about to start" : "seated, arming";
  const headline = {
    offline: `Offline: ${q.rig.problem ?? "the rig does not answer"}`,
    out_of_service: `Out of service: ${q.out_of_service ?? "no reason given"}`,
    settling: "Settling (after a run or on connecting: 0 V until still, then re-zero)",
    in_use: `In use by ${holder ?? "someone"} (${doing})`,
    free: "Online and free",
  }[condition];
  const details: string[] = [];
  if (condition === "in_use" && q.settling) details.push("settling");
  details.push(q.waiting ? `${q.waiting} waiting` : "nobody waiting");
  const latency = latencyText(q.rig);
  if (q.rig.connected && latency) details.push(`loop latency ${latency} (last 10 s)`);
  return { condition, headline, details };
}

/** Where the caller stands, in a sentence (null: not in the queue). */
export function placeText(q: RigQueueInfo): string | null {
  switch (rigStep(q)) {
    case "join":
      return null;
    case "wait":
      return `You are ${ordinal(q.you.place ?? 0)} in the queue: ${waitText(q.you.wait_s)}.`;
    case "arm":
      return "Your turn: arm the rig to start.";
    case "start":
      return "You drive the rig: armed, start your run.";
    case "running":
      return "You drive the rig: your run is on it.";
  }
}

export interface LatencyStats {
  n: number;
  /** s */
  p50: number;
  p99: number;
  max: number;
  /** answers later than 1 ms */
  late: number;
}

/** A rig run's response latency from its `latency` channel (s per sample; NaN gaps and
 * negative values are left out); null without samples. */
export function latencyStats(values: ArrayLike<number>): LatencyStats | null {
  const v = Float64Array.from(values).filter((x) => Number.isFinite(x) && x >= 0);
  if (!v.length) return null;
  v.sort();
  const at = (p: number) => v[Math.min(v.length - 1, Math.ceil(p * v.length) - 1)];
  // the channel is float32: 1 ms recorded reads 1.00000005 ms, which is not late
  const late = v.filter((x) => x > Math.fround(1e-3)).length;
  return { n: v.length, p50: at(0.5), p99: at(0.99), max: v[v.length - 1], late };
}

/** How a rig run ended, for the banner under it (null: nothing to say). */
export function endText(state: string, reason: string | null): { kind: "trip" | "estop" | "other"; title: string; text: string } | null {
  if (!reason) return null;
  if (/safety trip/i.test(reason)) return { kind: "trip", title: "Safety trip: the supervisor stopped the motor", text: reason };
  if (/emergency stop/i.test(reason)) return { kind: "estop", title: "Emergency stop", text: reason };
  if (state === "failed" || state === "interrupted" || state === "stopped") return { kind: "other", title: `Run ${state}`, text: reason };
  return null;
}
