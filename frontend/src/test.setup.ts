// The tests share one jsdom (vite.config.ts, isolate: false): each leaves the page and the
// browser's storage as it found them.
import { afterEach } from "vitest";

afterEach(() => {
  document.body.replaceChildren();
  document.head.querySelectorAll("style").forEach((s) => s.remove());
  localStorage.clear();
  sessionStorage.clear();
});
