// KaTeX and its fonts are most of a page's JavaScript after plotly.js (about 90 KB of
// 525 gzipped on the analysis page): a formula below the fold is typeset when it comes
// near the screen, so a page whose formulas are not looked at does not load it (issue 28).
type Tex = (source: string, displayMode?: boolean) => string;

let markdown: Promise<{ tex: Tex }> | null = null;

/** The typesetter, loaded once on first use. */
function loadTex(): Promise<{ tex: Tex }> {
  markdown ??= import("./markdown");
  return markdown;
}

/**
 * `el` shows `placeholder` (plain text, busy) until it is within a screen of the viewport,
 * then the HTML `render` makes with KaTeX. Without IntersectionObserver at once.
 */
export function typesetWhenNear(el: HTMLElement, placeholder: string, render: (tex: Tex) => string): void {
  el.textContent = placeholder;
  el.setAttribute("aria-busy", "true");
  const typeset = () =>
    void loadTex().then(({ tex }) => {
      el.innerHTML = render(tex);
      el.removeAttribute("aria-busy");
      el.dispatchEvent(new Event("elab:typeset"));
    });
  if (typeof IntersectionObserver === "undefined") return typeset();
  const seen = new IntersectionObserver(
    (entries) => {
      if (!entries.some((e) => e.isIntersecting)) return;
      seen.disconnect();
      typeset();
    },
    { rootMargin: "100% 0px" },
  );
  seen.observe(el);
}
