import { describe, expect, it } from "vitest";
import { discreteStep, parseModels } from "./ident";

/** ``text`` is refused with a message containing ``part``. */
function failsWith(text: string, part: string): void {
  const got = parseModels(text);
  expect(got.ok).toBe(false);
  if (!got.ok) expect(got.message).toContain(part);
}

describe("parseModels", () => {
  it("reads the CLI syntax", () => {
    const r = parseModels("arx:4,4,3; armax:2,2,2,3\noe:2,2,3; n4sid:4,16; n4sid");
    expect(r).toEqual({
      ok: true,
      models: [
        { kind: "arx", na: 4, nb: 4, nk: 3 },
        { kind: "armax", na: 2, nb: 2, nc: 2, nk: 3 },
        { kind: "oe", nb: 2, nf: 2, nk: 3 },
        { kind: "n4sid", order: 4, horizon: 16 },
        { kind: "n4sid", order: 0, horizon: 0 },
      ],
    });
    expect(parseModels("  ")).toEqual({ ok: true, models: [] });
  });
  it("names what is wrong", () => {
    failsWith("bj:1,1,1,1", "arx, armax, oe or n4sid");
    failsWith("arx:4,4", "arx:na,nb,nk");
    failsWith("arx:4,x,3", "nb must be a whole number");
    failsWith("arx:4,0,3", "nb must be in 1");
    failsWith("arx:99,1,1", "0 … 50");
    expect(parseModels(Array(11).fill("arx:1,1,1").join(";"))).toMatchObject({ ok: false });
  });
});

describe("discreteStep", () => {
  it("is the step response of y(k+1) = 0.5 y(k) + u(k)", () => {
    const y = discreteStep({ A: [[0.5]], B: [[1]], C: [[1]], D: [[0]] }, 5)[0];
    expect(y).toEqual([0, 1, 1.5, 1.75, 1.875]);
  });
});
