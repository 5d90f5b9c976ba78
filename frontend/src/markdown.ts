// Plant descriptions: markdown with TeX math ($…$ inline, $$…$$ display) → HTML.
import "katex/dist/katex.min.css";
import katex from "katex";
import { marked } from "marked";

/** TeX → HTML (errors shown in place, in red, rather than thrown). */
export function tex(source: string, displayMode = false): string {
  return katex.renderToString(source, { displayMode, throwOnError: false, output: "htmlAndMathml" });
}

/** Markdown with math → HTML. Math is set aside before markdown parsing so that `_` and `\` survive. */
export function renderMarkdown(source: string): string {
  const math: string[] = [];
  const keep = (html: string) => `@@MATH${math.push(html) - 1}@@`;
  const text = source
    .replace(/\$\$([\s\S]+?)\$\$/g, (_, m: string) => keep(tex(m.trim(), true)))
    .replace(/\$([^$\n]+?)\$/g, (_, m: string) => keep(tex(m, false)));
  const html = marked.parse(text, { async: false });
  return html.replace(/@@MATH(\d+)@@/g, (_, i: string) => math[Number(i)]);
}
