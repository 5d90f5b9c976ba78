import { describe, expect, it, vi } from "vitest";
import type { HelpPage } from "../protocol.gen";
import { helpPage, inApp, search, slug } from "./help";

// the server, held until a test lets it answer
const held = vi.hoisted(() => ({ release: (): void => undefined }));
vi.mock("../api", () => ({
  api: {
    help: () =>
      new Promise((resolve) => {
        held.release = () => resolve({ pages: [{ name: "glossary", summary: "the terms" }] });
      }),
    helpPage: (name: string) => Promise.resolve({ name, title: "Glossary", markdown: "# Glossary\n\n**PRBS.** An input that switches." }),
  },
}));

const page = (name: string, markdown: string): HelpPage => ({ name, title: markdown.split("\n")[0].slice(2), markdown });

describe("help", () => {
  const glossary = page("glossary", "# Glossary\n\n**PRBS (pseudo-random binary sequence).** An input that switches.\n\n## Fit\n\nHow well a model's output follows the data.");
  const controllers = page("controllers", "# Controller files\n\n## Python\n\nA class Controller with step(t, y, r).\n\nSee the glossary for PRBS and fit.");

  it("finds the lines holding every word, with their section", () => {
    const hits = search([glossary, controllers], "prbs");
    expect(hits.map((x) => [x.page.name, x.section])).toEqual([
      ["glossary", "Glossary"],
      ["controllers", "Python"],
    ]);
    expect(search([glossary, controllers], "model output").map((x) => x.section)).toEqual(["Fit"]);
    expect(search([glossary], "  ")).toEqual([]);
    expect(search([glossary], "nothing like this")).toEqual([]);
  });

  it("keeps links to other pages in the app and drops those to files it does not serve", () => {
    const root = document.createElement("div");
    root.innerHTML = '<h2>Python controllers</h2><a href="controllers.md#python">a</a> <a href="docs/glossary.md">b</a> <a href="screenshots/x.png">shot</a> <a href="https://example.org/">c</a> <a href="architecture.md">arch</a>';
    inApp(root, ["controllers", "glossary"]);
    const links = Array.from(root.querySelectorAll("a")).map((a) => [a.getAttribute("href"), a.hasAttribute("data-link")]);
    expect(links).toEqual([
      ["/help/controllers#python", true],
      ["/help/glossary", true],
      ["https://example.org/", false],
    ]);
    expect(root.textContent).toContain("shot"); // its text stays
    expect(root.querySelector("h2")?.id).toBe("python-controllers");
    expect(slug("Run against the model's prediction")).toBe("run-against-the-models-prediction");
  });

  it("searches what was typed while the index loaded, once it has", async () => {
    const root = document.createElement("div");
    const shown = helpPage(root, {});
    const input = root.querySelector<HTMLInputElement>("#help-search")!;
    input.value = "prbs";
    input.dispatchEvent(new Event("input"));
    held.release(); // the index comes after the typing (it had been lost)
    await shown;
    await vi.waitFor(() => expect(root.querySelector("[data-testid=help-results] a")?.textContent).toBe("Glossary › Glossary"));
  });
});
