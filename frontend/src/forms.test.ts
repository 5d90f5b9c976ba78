import { describe, expect, it } from "vitest";
import { FieldSet, NumberField, normaliseField, parseNumber, rangeText } from "./forms";

const spec = { field: "duration", label: "Duration", value: 10, min: 0, minExclusive: true, max: 3600 };

describe("parseNumber", () => {
  it("accepts numbers within the range", () => {
    expect(parseNumber(" 12.5 ", spec)).toEqual({ ok: true, value: 12.5 });
    expect(parseNumber("3600", spec)).toEqual({ ok: true, value: 3600 });
    expect(parseNumber("1e2", spec)).toEqual({ ok: true, value: 100 });
    expect(parseNumber(".5", spec)).toEqual({ ok: true, value: 0.5 });
    expect(parseNumber("+2.", spec)).toEqual({ ok: true, value: 2 });
    expect(parseNumber("\u22121", { ...spec, min: -5 })).toEqual({ ok: true, value: -1 }); // the minus sign −
  });

  it.each([
    ["", /required: a number > 0 and ≤ 3600/],
    ["abc", /"abc" is not a number > 0 and ≤ 3600/],
    ["NaN", /not a number/],
    ["Infinity", /not a number/],
    ["0", /0 is out of range; allowed: a number > 0 and ≤ 3600/],
    ["3600.1", /out of range/],
    ["-1", /out of range/],
    ["0x10", /"0x10" is not a number > 0 and ≤ 3600 \(write it in decimal digits\)/],
    ["0b11", /decimal digits/],
    ["1_000", /"1_000" is not a number/],
    ["1,5", /write 1\.5 with a decimal point/],
    ["12abc", /not a number/],
  ])("refuses %j, naming value and range", (text, message) => {
    const r = parseNumber(text, spec);
    expect(r.ok).toBe(false);
    if (!r.ok) expect(r.message).toMatch(message);
  });

  it("checks whole numbers", () => {
    const s = { field: "order", label: "Order", value: 10, min: 3, max: 20, integer: true };
    expect(parseNumber("4.5", s).ok).toBe(false);
    expect(parseNumber("4", s)).toEqual({ ok: true, value: 4 });
    expect(rangeText(s)).toBe("a whole number ≥ 3 and ≤ 20");
  });
});

describe("fields", () => {
  it("shows the error under the field as the user types, and clears it", () => {
    const f = new NumberField(spec);
    f.input.value = "-3";
    f.input.dispatchEvent(new Event("input"));
    expect(f.root.classList.contains("invalid")).toBe(true);
    expect(f.root.querySelector(".error")?.textContent).toMatch(/out of range/);
    expect(f.input.getAttribute("aria-invalid")).toBe("true");
    f.input.value = "5";
    f.input.dispatchEvent(new Event("input"));
    expect(f.root.classList.contains("invalid")).toBe(false);
  });

  it("routes server field errors to their field and returns the rest", () => {
    const set = new FieldSet();
    const k0 = set.add(new NumberField({ field: "controller.K.0", label: "K1", value: 1 }));
    const rest = set.showErrors(new Map([["controller.state_feedback.K.0", "bad gain"], ["seed", "bad seed"]]));
    expect(k0.root.querySelector(".error")?.textContent).toBe("bad gain");
    expect([...rest.keys()]).toEqual(["seed"]);
    expect(normaliseField("signal.square.period")).toBe("signal.period");
  });

  it("gives no values while any field is invalid", () => {
    const set = new FieldSet();
    set.add(new NumberField(spec));
    const b = set.add(new NumberField({ ...spec, field: "b", label: "B" }));
    expect(set.values()?.get("duration")).toBe(10);
    b.input.value = "x";
    expect(set.values()).toBeNull();
  });
});
