// Client-side routes on real paths (shareable URLs): the server answers each with the app.

export type Cleanup = () => void;
export type View = (root: HTMLElement, params: Record<string, string>, query: URLSearchParams) => Cleanup | void | Promise<Cleanup | void>;

interface Route {
  pattern: RegExp;
  keys: string[];
  view: View;
}

export class Router {
  private routes: Route[] = [];
  private cleanup: Cleanup | null = null;
  private token = 0;

  constructor(
    private readonly root: HTMLElement,
    private readonly notFound: View,
  ) {
    window.addEventListener("popstate", () => void this.render());
    document.addEventListener("click", (ev) => {
      const a = (ev.target as Element | null)?.closest?.("a[data-link]") as HTMLAnchorElement | null;
      if (!a || ev.defaultPrevented || ev.button !== 0 || ev.metaKey || ev.ctrlKey || ev.shiftKey || ev.altKey) return;
      ev.preventDefault();
      this.go(a.getAttribute("href") ?? "/");
    });
  }

  add(path: string, view: View): this {
    const keys: string[] = [];
    const pattern = new RegExp("^" + path.replace(/:(\w+)/g, (_, k: string) => (keys.push(k), "([^/]+)")) + "/?$");
    this.routes.push({ pattern, keys, view });
    return this;
  }

  go(href: string, replace = false): void {
    if (replace) history.replaceState(null, "", href);
    else history.pushState(null, "", href);
    void this.render();
  }

  async render(): Promise<void> {
    const token = ++this.token;
    this.cleanup?.();
    this.cleanup = null;
    const path = location.pathname;
    const query = new URLSearchParams(location.search);
    this.root.replaceChildren();
    document.title = "E-Lab"; // a view with a header names the tab after itself
    window.scrollTo(0, 0);
    for (const r of this.routes) {
      const m = r.pattern.exec(path);
      if (!m) continue;
      const params = Object.fromEntries(r.keys.map((k, i) => [k, decodeURIComponent(m[i + 1])]));
      const done = await r.view(this.root, params, query);
      if (token !== this.token) done?.(); // navigated away while loading
      else this.cleanup = done ?? null;
      return;
    }
    await this.notFound(this.root, {}, query);
  }
}
