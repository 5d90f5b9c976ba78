import { defineConfig } from "vitest/config";

// The app is built into the Python package, which serves it (one origin):
// `elab serve` answers /, /plants/..., /runs/... with index.html and /assets/* from here.
export default defineConfig({
  base: "/",
  build: {
    outDir: "../backend/elab/api/static",
    emptyOutDir: true,
    chunkSizeWarningLimit: 1500, // plotly.js (its basic bundle) is one large module, loaded once
  },
  // fs.allow: the wire schema (../shared) is imported by src/wire.ts
  server: { proxy: { "/api": { target: "http://127.0.0.1:8000", ws: true } }, fs: { allow: [".."] } },
  // one jsdom for all test files (isolate: false): a fresh one per file was 28 of the 44 s
  // the app's tests took; src/test.setup.ts empties the page and storage after each test,
  // and the suite passes in any file order (vitest --sequence.shuffle)
  test: {
    environment: "jsdom",
    include: ["src/**/*.test.ts"],
    isolate: false,
    setupFiles: ["src/test.setup.ts"],
  },
});
