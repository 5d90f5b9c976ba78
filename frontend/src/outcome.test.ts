import { describe, expect, it } from "vitest";
import { outcomeChip, outcomeItems, outcomeWords } from "./outcome";
import type { OutcomeMark } from "./protocol.gen";

const marks: OutcomeMark[] = [
  { kind: "saturated", k: 12, t: 0.012, text: "u sat at the actuator's limit ±10 V for 96% of the run" },
  { kind: "ran_away", k: 9999, t: 9.999, text: "theta ended 9688° from the reference" },
];

describe("outcome", () => {
  it("names the marks in short for a table, the server's sentences in its title", () => {
    expect(outcomeWords(marks)).toBe("saturated, ran away");
    const chip = outcomeChip(marks)!;
    expect(chip.textContent).toBe("⚠ saturated, ran away");
    expect(chip.title).toBe(`${marks[0].text}\n${marks[1].text}`);
  });

  it("says nothing for a run with nothing to say or not known yet", () => {
    expect(outcomeChip([])).toBeNull();
    expect(outcomeChip(null)).toBeNull();
    expect(outcomeWords(undefined)).toBe("");
  });

  it("lists each mark with its sentence for the run's page", () => {
    const items = outcomeItems(marks);
    expect(items.map((li) => li.dataset.kind)).toEqual(["saturated", "ran_away"]);
    expect(items[1].textContent).toBe("ran away: theta ended 9688° from the reference");
  });
});
