import { describe, expect, it } from "vitest";
import { replayPosition } from "./replay";

describe("replayPosition", () => {
  it("advances speed × real time in samples and stops at the last", () => {
    expect(replayPosition(100, 1000, 1000, 1, 0.001, 9999)).toBe(100);
    expect(replayPosition(100, 1000, 1500, 1, 0.001, 9999)).toBe(600); // 0.5 s at 1 kHz
    expect(replayPosition(100, 1000, 1500, 5, 0.001, 9999)).toBe(2600);
    expect(replayPosition(100, 1000, 1500, 0.5, 0.001, 9999)).toBe(350);
    expect(replayPosition(100, 1000, 9000, 2, 0.001, 9999)).toBe(9999);
    expect(replayPosition(0, 0, 100, 1, 0.02, 500)).toBe(5); // whole samples only
  });
});
