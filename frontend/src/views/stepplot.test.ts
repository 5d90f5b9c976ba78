import { describe, expect, it } from "vitest";
import { groupByRange } from "./stepplot";

describe("groupByRange", () => {
  it("puts outputs of very different size on separate axes", () => {
    // the pendulum's closed-loop step: α ≈ 57°, β₁ and β₂ a few thousandths of a degree
    expect(groupByRange([57, 0.004, 0.006])).toEqual([[0], [1, 2]]);
    expect(groupByRange([30, 14])).toEqual([[0, 1]]);
    expect(groupByRange([1, 9, 11])).toEqual([[0, 1], [2]]);
  });

  it("keeps an output that does not move with the first group", () => {
    expect(groupByRange([0, 5, 0.01])).toEqual([[0, 1], [2]]);
    expect(groupByRange([0, 0])).toEqual([[0, 1]]);
    expect(groupByRange([])).toEqual([]);
  });
});
