// One static folder, dist/, with relative paths: it works from any static host, from a
// sub-folder, and from `moldgate serve` at /.
import { defineConfig } from "vite";

export default defineConfig({
  base: "./",
  build: {
    outDir: "dist",
    emptyOutDir: true,
    // The .wasm module stays a file of its own (never inlined as base64).
    assetsInlineLimit: 0,
    target: "es2022",
    // three.js is most of the 660 kB script (166 kB gzipped): one chunk on purpose.
    chunkSizeWarningLimit: 800,
  },
  worker: { format: "es" },
});
