import { describe, expect, it } from "vitest";
import { pageHeader } from "./common";

describe("pageHeader", () => {
  it("names the browser tab after the page (issue 15: every tab was titled E-Lab)", () => {
    pageHeader("Flexible link: identification", [["/plants/flexible_link", "Flexible link"]]);
    expect(document.title).toBe("Flexible link: identification · E-Lab");
  });
});
