import { describe, expect, it } from "vitest";
import { columnNames, dataSummary, fileRecord, modelBody, parseModels, tooLarge } from "./ident";
import type { IdentDataOut, IdentOut } from "./protocol.gen";

/** ``text`` is refused with a message containing ``part``. */
function failsWith(text: string, part: string): void {
  const got = parseModels(text);
  expect(got.ok).toBe(false);
  if (!got.ok) expect(got.message).toContain(part);
}

describe("parseModels", () => {
  it("reads the CLI syntax", () => {
    const r = parseModels("arx:4,4,3; armax:2,2,2,3\noe:2,2,3; n4sid:4,16; n4sid; link");
    expect(r).toEqual({
      ok: true,
      models: [
        { kind: "arx", na: 4, nb: 4, nk: 3 },
        { kind: "armax", na: 2, nb: 2, nc: 2, nk: 3 },
        { kind: "oe", nb: 2, nf: 2, nk: 3 },
        { kind: "n4sid", order: 4, horizon: 16 },
        { kind: "n4sid", order: 0, horizon: 0 },
        { kind: "link" },
      ],
    });
    expect(parseModels("  ")).toEqual({ ok: true, models: [] });
  });
  it("names what is wrong", () => {
    failsWith("bj:1,1,1,1", "arx, armax, oe, n4sid or link");
    failsWith("link:4", "write link alone");
    failsWith("arx:4,4", "arx:na,nb,nk");
    failsWith("arx:4,x,3", "nb must be a whole number");
    failsWith("arx:4,0,3", "nb must be in 1");
    failsWith("arx:99,1,1", "0 … 50");
    expect(parseModels(Array(11).fill("arx:1,1,1").join(";"))).toMatchObject({ ok: false });
  });
});

describe("modelBody", () => {
  it("is POST /models's body: the model's state space with the data's names and units", () => {
    const ss = { A: [[0.5]], B: [[1]], C: [[1]], D: [[0]], K: [[0.1]], Ts: 0.08 };
    const out = {
      data: { Ts: 0.08, input_names: ["c1"], input_units: [""], output_names: ["c2"], output_units: ["V"] },
      models: [{ name: "arx 1 1 1", kind: "arx", ss, fit: { headline: [89.5] }, verdicts: [{ topic: "fit", level: "poor", finding: "validation fit 31.7 %", advice: "try other orders" }] }],
    } as unknown as IdentOut;
    expect(modelBody("flexible_link", out, 0, "dryer.dat")).toEqual({
      plant: "flexible_link",
      name: "arx 1 1 1",
      Ts: 0.08,
      A: [[0.5]],
      B: [[1]],
      C: [[1]],
      D: [[0]],
      input: { name: "c1", unit: "" },
      outputs: [{ name: "c2", unit: "V" }],
      source: "dryer.dat",
      kind: "arx",
      fit: [89.5],
      verdicts: [{ topic: "fit", level: "poor", finding: "validation fit 31.7 %", advice: "try other orders" }],
    });
  });
});

describe("files as request records", () => {
  it("reads column lists and the format from the name", () => {
    expect(columnNames(" c1, c2 ,, ")).toEqual(["c1", "c2"]);
    expect(fileRecord("Val.JSON", "{}", ["u"], ["y"], null)).toEqual({ source: "file", name: "Val.JSON", format: "json", text: "{}", input: ["u"], output: ["y"], Ts: null });
    expect(fileRecord("dryer.dat", "1 2", ["c1"], ["c2"], 0.08).format).toBe("csv");
  });
  it("counts every file of a request against the limit", () => {
    expect(tooLarge([{ name: "a.csv", size: 16 << 20 }])).toBeNull();
    expect(tooLarge([{ name: "a.csv", size: 17 << 20 }])).toBe("a.csv is 17.0 MiB: the limit is 16.0 MiB.");
    expect(tooLarge([{ name: "a.csv", size: 10 << 20 }, { name: "b.csv", size: 7 << 20 }])).toBe("a.csv and b.csv are 17.0 MiB together: the limit is 16.0 MiB.");
    expect(tooLarge([], 1)).toBeNull();
  });
});

describe("dataSummary", () => {
  const d = { N: 1000, Ts: 0.08, estimation: 500, validation: "split", step: 1, trend: "mean", t: [0] } as IdentDataOut;
  it("says where validation comes from", () => {
    expect(dataSummary(d)).toBe("1,000 samples at Ts = 80 ms; estimation: the first 500 (to t = 40 s), validation: the rest; detrended: mean.");
    const record = { ...d, validation: "record" } as IdentDataOut;
    expect(dataSummary(record, "val.dat")).toBe("1,000 samples at Ts = 80 ms; estimation: all 500 of the data, validation: the 500 of the separate record val.dat (drawn after them, from t = 40 s); the estimation data's means removed from both.");
    expect(dataSummary({ ...record, trend: "linear" })).toContain("validation: the 500 of a separate record");
    expect(dataSummary({ ...record, trend: "linear" })).toContain("each record's own straight line removed");
    expect(dataSummary({ ...record, trend: "none" })).toContain("kept as recorded");
  });
});
