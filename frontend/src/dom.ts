// A small element builder: h("div.card", {onclick}, child, ...).

type Child = Node | string | number | null | undefined | false;
type Attrs = Record<string, string | number | boolean | EventListener | null | undefined>;

function isAttrs(x: unknown): x is Attrs {
  return typeof x === "object" && x !== null && !(x instanceof Node);
}

/** An element; the first argument after the tag may be its attributes, the rest children. */
export function h<K extends keyof HTMLElementTagNameMap>(tag: K | `${K}.${string}` | `${K}#${string}`, ...rest: (Attrs | Child)[]): HTMLElementTagNameMap[K] {
  const [name, ...classes] = tag.split(".");
  const [tagName, id] = name.split("#");
  const el = document.createElement(tagName as K);
  if (id) el.id = id;
  if (classes.length) el.className = classes.join(" ");
  const attrs = isAttrs(rest[0]) ? (rest.shift() as Attrs) : {};
  for (const [k, v] of Object.entries(attrs)) {
    if (v === null || v === undefined || v === false) continue;
    if (k.startsWith("on") && typeof v === "function") el.addEventListener(k.slice(2), v);
    else if (k === "class") el.className = [el.className, String(v)].filter(Boolean).join(" ");
    else if (v === true) el.setAttribute(k, "");
    else el.setAttribute(k, String(v));
  }
  append(el, ...(rest as Child[]));
  return el;
}

export function append(el: Element, ...children: Child[]): void {
  for (const c of children) {
    if (c === null || c === undefined || c === false) continue;
    el.append(c instanceof Node ? c : String(c));
  }
}

/** Replace an element's content. */
export function fill(el: Element, ...children: Child[]): void {
  el.replaceChildren();
  append(el, ...children);
}

/** A link handled by the app's router (plain navigation when opened in a new tab). */
export function link(href: string, ...children: Child[]): HTMLAnchorElement {
  return h("a", { href, "data-link": true }, ...children);
}

/** Save text as a file. */
export function saveText(filename: string, text: string, type = "text/csv"): void {
  const url = URL.createObjectURL(new Blob([text], { type }));
  const a = h("a", { href: url, download: filename });
  document.body.append(a);
  a.click();
  a.remove();
  setTimeout(() => URL.revokeObjectURL(url), 1000);
}

/** Columns → CSV text with a header line (null, a value that is not finite: an empty cell). */
/** A number for a CSV cell: 15 significant digits, so float noise (6.9590000000000005,
 * 0.30000000000000004) reads as the decimal it stands for. */
export function cell(x: number): string {
  return Number.isFinite(x) ? String(Number(x.toPrecision(15))) : String(x);
}

export function csv(header: string[], columns: ArrayLike<number | null>[]): string {
  const n = Math.max(0, ...columns.map((c) => c.length));
  const lines = [header.join(",")];
  for (let i = 0; i < n; i++) lines.push(columns.map((c) => (i < c.length && c[i] !== null ? cell(c[i] as number) : "")).join(","));
  return lines.join("\n") + "\n";
}

/** Copy text to the clipboard and say so on the button for a moment (without clipboard
 * access, e.g. over plain HTTP from another machine: show the text to copy by hand). */
export async function copyText(text: string, button: HTMLButtonElement, done = "Copied"): Promise<void> {
  const label = button.textContent;
  try {
    await navigator.clipboard.writeText(text);
    button.textContent = done;
  } catch {
    window.prompt("Copy this:", text);
  }
  setTimeout(() => (button.textContent = label), 2000);
}

/** The least time between two draws of a live view (the plot and the schematic): 25 ms,
 * every other frame of a 60 Hz display (30 a second, which looks smooth); 200 ms (5 a
 * second) for a reader whose system asks for less motion (prefers-reduced-motion: the
 * lines step instead of sliding, and a slow machine's CPU is spared: a watched live run
 * cost Chromium's renderer 0.9 of a core at 30 draws a second, docs/benchmarks.md). Read
 * at each draw: a change of the setting applies at once. */
const FRAME_MS = 25;
const CALM_FRAME_MS = 200;
const calm = typeof matchMedia === "function" ? matchMedia("(prefers-reduced-motion: reduce)") : null;
export function frameInterval(): number {
  return calm?.matches ? CALM_FRAME_MS : FRAME_MS;
}

/** Calls `fn` at an animation frame at least frameInterval() after its last call: ask()
 * as often as data arrive, `fn` runs once for all of them (the live plot, the schematic,
 * the progress line). cancel() drops a call asked for and not made yet. */
export class FramePacer {
  private id = 0;
  private last = -Infinity;

  constructor(private readonly fn: () => void) {}

  ask(): void {
    if (this.id) return;
    const frame = (now: number) => {
      if (now - this.last < frameInterval()) {
        this.id = requestAnimationFrame(frame);
        return;
      }
      this.id = 0;
      this.last = now;
      this.fn();
    };
    this.id = requestAnimationFrame(frame);
  }

  cancel(): void {
    if (this.id) cancelAnimationFrame(this.id);
    this.id = 0;
  }
}
