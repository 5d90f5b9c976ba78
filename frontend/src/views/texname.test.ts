import { describe, expect, it } from "vitest";
import { texName } from "./analysis";

describe("texName", () => {
  it("labels the transfer functions' channels as a textbook would", () => {
    expect(texName("theta")).toBe("\\theta");
    expect(texName("beta2")).toBe("\\beta_{2}");
    expect(texName("u")).toBe("u");
    expect(texName("x")).toBe("x");
    expect(texName("speed")).toBe("\\mathrm{speed}");
  });
});
