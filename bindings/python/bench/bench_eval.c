/* The C side of bindings/python/bench/bench_eval.py: the same evaluations as the Python side,
 * straight through the C ABI, one workspace reused (the fastest way to call it).
 *   bench_eval_c ASSET POINTS.bin all|none REPEATS INNER
 * POINTS.bin holds N by K doubles. Prints the median time of one cadinterp_eval at the first
 * point (over REPEATS runs of INNER calls) and of a loop over all N points (over REPEATS runs),
 * as "one_us=... batch_ms=...". */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "cadinterp/cadinterp.h"

static double now(void) {
  struct timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

static int by_value(const void* a, const void* b) {
  const double x = *(const double*)a, y = *(const double*)b;
  return (x > y) - (x < y);
}

static double median(double* v, int n) {
  qsort(v, (size_t)n, sizeof *v, by_value);
  return v[n / 2];
}

static int fail(const char* what, cadinterp_status s) {
  fprintf(stderr, "bench_eval_c: %s: %s\n", what, cadinterp_status_string(s));
  return 1;
}

int main(int argc, char** argv) {
  if (argc != 6) {
    fprintf(stderr, "usage: %s ASSET POINTS.bin all|none REPEATS INNER\n", argv[0]);
    return 2;
  }
  cadinterp_asset* asset = NULL;
  cadinterp_workspace* ws = NULL;
  cadinterp_status s = cadinterp_open(argv[1], &asset);
  if (s != CADINTERP_OK) return fail(cadinterp_open_error(), s);
  if ((s = cadinterp_workspace_create(asset, &ws)) != CADINTERP_OK) return fail("workspace", s);
  const int k = cadinterp_parameter_count(asset);
  FILE* f = fopen(argv[2], "rb");
  if (!f) return fail("cannot open the points", CADINTERP_E_IO);
  double* x = NULL;
  size_t n = 0, cap = 0;
  for (;;) {
    if (n == cap) {
      cap = cap ? 2 * cap : 1024;
      x = realloc(x, cap * (size_t)k * sizeof *x);
    }
    if (fread(x + n * (size_t)k, sizeof *x, (size_t)k, f) != (size_t)k) break;
    ++n;
  }
  fclose(f);
  int fields[16], nf = 0;
  if (strcmp(argv[3], "all") == 0)
    for (; nf < cadinterp_field_count(asset) && nf < 16; ++nf) fields[nf] = nf;
  const int repeats = atoi(argv[4]), inner = atoi(argv[5]);
  double* times = malloc((size_t)repeats * sizeof *times);
  cadinterp_mesh m;
  for (size_t i = 0; i < n; ++i) /* warm: every element decoded once, as on the Python side */
    if ((s = cadinterp_eval(ws, x + i * (size_t)k, fields, nf, &m)) != CADINTERP_OK)
      return fail(cadinterp_workspace_error(ws), s);
  for (int r = 0; r < repeats; ++r) {
    const double t0 = now();
    for (int i = 0; i < inner; ++i) cadinterp_eval(ws, x, fields, nf, &m);
    times[r] = (now() - t0) / inner;
  }
  const double one = median(times, repeats);
  for (int r = 0; r < repeats; ++r) {
    const double t0 = now();
    for (size_t i = 0; i < n; ++i) cadinterp_eval(ws, x + i * (size_t)k, fields, nf, &m);
    times[r] = now() - t0;
  }
  printf("one_us=%.4f batch_ms=%.4f\n", 1e6 * one, 1e3 * median(times, repeats));
  free(times);
  free(x);
  cadinterp_workspace_destroy(ws);
  cadinterp_close(asset);
  return 0;
}
