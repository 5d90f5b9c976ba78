import { describe, expect, it } from "vitest";
import { cell, csv } from "./dom";

describe("csv", () => {
  it("writes clean decimals, not float noise (issue 15)", () => {
    expect(cell(6.9590000000000005)).toBe("6.959");
    expect(cell(0.1 + 0.2)).toBe("0.3");
    expect(cell(1e-20)).toBe("1e-20");
    expect(cell(-123456.789)).toBe("-123456.789");
    expect(csv(["t (s)", "y (rad)"], [[0, 0.001 * 6959], [1, null]])).toBe("t (s),y (rad)\n0,1\n6.959,\n");
  });
});
