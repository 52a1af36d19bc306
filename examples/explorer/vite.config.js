// Builds the page into EXPLORER_OUT_DIR (CMake passes its build directory; default dist/).
// base './': the page works from any URL prefix, and finds wasm/ and api/ next to itself.
import { defineConfig } from 'vite';

export default defineConfig({
  base: './',
  logLevel: 'warn',
  build: {
    outDir: process.env.EXPLORER_OUT_DIR || 'dist',
    emptyOutDir: true,
    target: 'es2022',
    chunkSizeWarningLimit: 1024,
  },
});
