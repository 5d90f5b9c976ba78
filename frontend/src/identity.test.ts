import { describe, expect, it } from "vitest";
import { IdentityStore } from "./identity";
import type { Me } from "./protocol.gen";

const GUEST: Me = { id: "a-3f2a9c", name: "guest 3f2a", role: "student", via: "cookie", account: null, sign_in: true };
const PROF: Me = { id: "i-prof", name: "prof (instructor)", role: "instructor", via: "session", account: "prof", sign_in: true };

function store(answers: (Me | Error)[]) {
  let asked = 0;
  const s = new IdentityStore(() => {
    const a = answers[Math.min(asked++, answers.length - 1)];
    return a instanceof Error ? Promise.reject(a) : Promise.resolve(a);
  });
  return { s, asked: () => asked };
}

describe("IdentityStore", () => {
  it("asks the server once however many ask", async () => {
    const { s, asked } = store([GUEST]);
    const [a, b] = await Promise.all([s.get(), s.get()]);
    expect(a).toEqual(GUEST);
    expect(b).toBe(a);
    await s.get();
    expect(asked()).toBe(1);
  });

  it("tells listeners what it learns, and who signed in", async () => {
    const { s } = store([GUEST]);
    const heard: string[] = [];
    const stop = s.listen((me) => heard.push(me.name));
    await s.get();
    s.set(PROF);
    expect(await s.get()).toEqual(PROF);
    stop();
    s.set(GUEST);
    expect(heard).toEqual(["guest 3f2a", "prof (instructor)"]);
  });

  it("asks again after a failure, and on refresh", async () => {
    const { s, asked } = store([new Error("unreachable"), GUEST, PROF]);
    await expect(s.get()).rejects.toThrow("unreachable");
    expect(await s.get()).toEqual(GUEST);
    expect(await s.refresh()).toEqual(PROF);
    expect(asked()).toBe(3);
  });

  it("keeps a sign-in made while the first answer was on its way", async () => {
    let answer: (me: Me) => void = () => undefined;
    const s = new IdentityStore(() => new Promise<Me>((resolve) => (answer = resolve)));
    const heard: string[] = [];
    s.listen((me) => heard.push(me.name));
    const first = s.get();
    s.set(PROF);
    answer(GUEST);
    await first;
    expect(await s.get()).toEqual(PROF);
    expect(heard).toEqual(["prof (instructor)"]);
  });
});
