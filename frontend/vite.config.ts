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
  test: { environment: "jsdom", include: ["src/**/*.test.ts"] },
});
