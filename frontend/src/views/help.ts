// The documentation inside the app: /help lists the pages (with a search over all of
// them), /help/<name> renders one (markdown with math), its links to other pages kept in
// the app. The pages are the checkout's docs/ as the server gives them (GET /help/{name}).
import { api } from "../api";
import { fill, h, link } from "../dom";
import { renderMarkdown } from "../markdown";
import type { HelpEntry, HelpPage } from "../protocol.gen";
import { failure, loading, pageHeader } from "./common";

/** Shown for a search at most, per page and in all. */
const HITS_PER_PAGE = 3;
const HITS = 30;

/** One place a search term occurs: the page, the section (its last heading) and the line. */
export interface Hit {
  page: HelpPage;
  section: string;
  line: string;
}

/** The lines of `pages` holding every word of `query` (case-insensitive), with their
 * section: the first {@link HITS_PER_PAGE} of each page, {@link HITS} in all. */
export function search(pages: HelpPage[], query: string): Hit[] {
  const words = query.toLowerCase().split(/\s+/).filter(Boolean);
  if (!words.length) return [];
  const hits: Hit[] = [];
  for (const page of pages) {
    let section = page.title;
    let found = 0;
    for (const line of page.markdown.split("\n")) {
      const heading = /^#{1,4}\s+(.*)$/.exec(line);
      if (heading) section = heading[1];
      const low = line.toLowerCase();
      if (words.every((w) => low.includes(w)) && found < HITS_PER_PAGE) {
        hits.push({ page, section, line: line.replace(/^[#>*\-\s|]+/, "").trim() });
        found++;
      }
    }
  }
  return hits.slice(0, HITS);
}

/** An anchor for a heading, as the rendered page gives its headings ids. */
export function slug(text: string): string {
  return text
    .toLowerCase()
    .replace(/[^\p{L}\p{N}\s-]/gu, "")
    .trim()
    .replace(/\s+/g, "-");
}

/** Links of a rendered page made the app's: another help page (`controllers.md#x`) →
 * `/help/controllers#x`, handled by the router; files the app does not serve (source
 * files, screenshots) lose their link and keep their text. Headings get ids. */
export function inApp(root: HTMLElement, names: string[]): void {
  for (const a of Array.from(root.querySelectorAll("a[href]"))) {
    const href = a.getAttribute("href") ?? "";
    const m = /^(?:\.\/|docs\/)?([\w-]+)\.md(#.*)?$/.exec(href);
    if (m && names.includes(m[1])) {
      a.setAttribute("href", `/help/${m[1]}${m[2] ?? ""}`);
      a.setAttribute("data-link", "");
    } else if (!/^(https?:|mailto:|#)/.test(href)) {
      a.replaceWith(...Array.from(a.childNodes));
    }
  }
  for (const el of Array.from(root.querySelectorAll("h1, h2, h3, h4"))) el.id ||= slug(el.textContent ?? "");
}

export async function helpPage(root: HTMLElement, params: Record<string, string>): Promise<void> {
  const name = params.name;
  if (!name) return helpIndex(root);
  const body = h("article.help-page.panel", loading());
  const header = pageHeader("Help", [["/help", "Help"]]);
  root.append(header, body);
  try {
    const [page, index] = await Promise.all([api.helpPage(name), api.help()]);
    document.title = `${page.title} · E-Lab`;
    header.querySelector("h1")?.replaceChildren(page.title);
    const html = h("div.markdown");
    html.innerHTML = renderMarkdown(page.markdown); // our own docs, from our own server
    inApp(html, index.pages.map((p) => p.name));
    const first = html.querySelector("h1");
    if (first?.textContent?.trim() === page.title) first.remove(); // the page's header says it
    fill(body, html);
    const hash = decodeURIComponent(location.hash.slice(1));
    if (hash) document.getElementById(hash)?.scrollIntoView();
  } catch (err) {
    fill(body, failure(err));
  }
}

async function helpIndex(root: HTMLElement): Promise<void> {
  const input = h("input", { type: "search", id: "help-search", placeholder: "Search the help (e.g. PRBS, overshoot, Python)", "aria-label": "search the help" });
  const results = h("div.help-results", { "aria-live": "polite", "data-testid": "help-results" });
  const list = h("ul.help-index", loading());
  root.append(
    pageHeader("Help", [["/help", "Help"]], h("p.lead", "How the lab works, in its own words: start with the glossary, or search every page.")),
    h("div.panel", h("label", { for: "help-search" }, "Search "), input, results),
    h("section.panel", { "aria-labelledby": "help-pages-h" }, h("h2#help-pages-h", "Pages"), list),
  );
  // the search listens from the start: what is typed while the index loads is searched
  // once it has (it had listened only after, and a query typed meanwhile was lost)
  const index: Promise<HelpEntry[]> = api.help().then((r) => r.pages);
  let pages: Promise<HelpPage[]> | null = null;
  const run = async () => {
    const query = input.value.trim();
    if (!query) return void fill(results);
    const entries = await index.catch((): HelpEntry[] => []);
    pages ??= Promise.all(entries.map((e) => api.helpPage(e.name))).catch(() => []);
    const found = await pages;
    if (input.value.trim() !== query) return; // a later query answers instead
    const hits = search(found, query);
    fill(
      results,
      hits.length
        ? h("ul", ...hits.map((hit) => h("li", link(`/help/${hit.page.name}#${slug(hit.section)}`, `${hit.page.title} › ${hit.section}`), h("br"), h("small", hit.line.length > 200 ? `${hit.line.slice(0, 200)}…` : hit.line))))
        : h("p.muted", `Nothing in the help says “${query}”.`),
    );
  };
  input.addEventListener("input", () => void run());
  try {
    const entries = await index;
    fill(list, ...entries.map((e) => h("li", link(`/help/${e.name}`, e.name === "glossary" ? "Glossary" : e.name[0].toUpperCase() + e.name.slice(1)), ": ", e.summary)));
  } catch (err) {
    fill(list, failure(err));
  }
}
