/* cadinterp-consumer CASE_DIR...: a program built against an installed cadinterp (CMake package
 * or pkg-config, shared or static), as an integrator builds one. For each conformance case
 * (conformance/cases/valid/NAME: asset.cadi and expected.txt, grammar at the top of
 * conformance/runner.cpp) it opens the asset, evaluates it at every point the case lists and
 * compares the status, the element, the positions, field 0 and the field units with the expected
 * values. The derivative lines are the conformance runner's part and are skipped here.
 *
 * It first prints which file the runtime's code was loaded from (the shared library's path, or
 * this executable for a static link), so that a test can tell the installed runtime from a build
 * tree's. Exit status 0 when every case matches, 1 otherwise, 2 on usage errors. C99 + POSIX. */
#if defined(__linux__) || defined(__APPLE__)
#define _GNU_SOURCE /* dladdr */
#include <dlfcn.h>
#endif

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cadinterp/cadinterp.h"

/* The status names expected.txt uses; the index is the code (cadinterp_status.h). */
static const char* const kStatusNames[] = {"CADINTERP_OK",
                                           "CADINTERP_E_INVALID_ARGUMENT",
                                           "CADINTERP_E_OUT_OF_MEMORY",
                                           "CADINTERP_E_IO",
                                           "CADINTERP_E_BAD_MAGIC",
                                           "CADINTERP_E_UNSUPPORTED_VERSION",
                                           "CADINTERP_E_TRUNCATED",
                                           "CADINTERP_E_CORRUPT_INDEX",
                                           "CADINTERP_E_CHECKSUM",
                                           "CADINTERP_E_OUT_OF_RANGE",
                                           "CADINTERP_E_LIMIT",
                                           "CADINTERP_E_CORRUPT_BLOB",
                                           "CADINTERP_E_OUTSIDE_DOMAIN",
                                           "CADINTERP_E_INFEASIBLE",
                                           "CADINTERP_E_INTERNAL",
                                           "CADINTERP_E_NOT_FOUND"};

static const char* status_name(cadinterp_status s) {
  const int n = (int)(sizeof kStatusNames / sizeof kStatusNames[0]);
  return (int)s >= 0 && (int)s < n ? kStatusNames[s] : "(unknown status)";
}

/* The whole file as one NUL-terminated string (caller frees), or NULL. */
static char* read_file(const char* path) {
  FILE* f = fopen(path, "rb");
  char* text = NULL;
  long size;
  if (!f) return NULL;
  if (fseek(f, 0, SEEK_END) == 0 && (size = ftell(f)) >= 0 && fseek(f, 0, SEEK_SET) == 0 &&
      (text = malloc((size_t)size + 1)) != NULL) {
    if (fread(text, 1, (size_t)size, f) != (size_t)size) {
      free(text);
      text = NULL;
    } else {
      text[size] = '\0';
    }
  }
  fclose(f);
  return text;
}

/* Parses the numbers (hex floats included) after the key into a growing array; returns the count.
 */
static size_t parse_numbers(const char* p, double** values, size_t* capacity) {
  size_t n = 0;
  for (;;) {
    char* end;
    const double v = strtod(p, &end);
    if (end == p) return n;
    if (n == *capacity) {
      *capacity = *capacity ? 2 * *capacity : 64;
      *values = realloc(*values, *capacity * sizeof **values);
      if (!*values) {
        fprintf(stderr, "out of memory\n");
        exit(2);
      }
    }
    (*values)[n++] = v;
    p = end;
  }
}

/* |got - want| <= tol (1 + |want|) for every value, as the conformance runner compares. */
static int compare(const char* what, const float* got, const double* want, size_t n, double tol) {
  size_t i;
  for (i = 0; i < n; ++i)
    if (!(fabs(got[i] - want[i]) <= tol * (1.0 + fabs(want[i])))) {
      fprintf(stderr, "  %s[%zu]: got %.9g, expected %.9g\n", what, i, got[i], want[i]);
      return 0;
    }
  return 1;
}

typedef struct {
  cadinterp_asset* asset;
  cadinterp_workspace* ws;
  cadinterp_mesh mesh; /* of the last "status CADINTERP_OK" line */
  int have_mesh;
  double x[16];
  double tol;
  size_t values_checked, points;
  double* numbers;
  size_t capacity;
} case_state;

/* One expected.txt line ("key values..."); returns 0 on a mismatch (and says which). */
static int check_line(case_state* c, const char* dir, const char* line) {
  char key[32], word[64];
  const char* rest;
  int got_n = 0;
  if (sscanf(line, "%31s%n", key, &got_n) != 1 || key[0] == '#') return 1;
  rest = line + got_n;
  if (strcmp(key, "open") == 0) {
    char path[4096];
    cadinterp_status s;
    snprintf(path, sizeof path, "%s/asset.cadi", dir);
    s = cadinterp_open(path, &c->asset);
    if (sscanf(rest, "%63s", word) != 1 || strcmp(word, status_name(s)) != 0) {
      fprintf(stderr, "  open: %s (%s), expected %s\n", status_name(s), cadinterp_open_error(),
              word);
      return 0;
    }
    return s != CADINTERP_OK || cadinterp_workspace_create(c->asset, &c->ws) == CADINTERP_OK;
  }
  if (!c->asset) {
    fprintf(stderr, "  '%s' before a successful open\n", key);
    return 0;
  }
  if (strcmp(key, "tolerance") == 0) return sscanf(rest, "%lf", &c->tol) == 1;
  if (strcmp(key, "unit") == 0) {
    int i = -1;
    const char* unit = NULL;
    if (sscanf(rest, "%d %63s", &i, word) != 2 ||
        cadinterp_field_unit(c->asset, i, &unit) != CADINTERP_OK)
      return 0;
    if (strcmp(word, "-") == 0) word[0] = '\0';
    if (strcmp(word, unit) != 0)
      fprintf(stderr, "  field %d unit '%s', expected '%s'\n", i, unit, word);
    return strcmp(word, unit) == 0;
  }
  if (strcmp(key, "point") == 0) {
    const size_t k = parse_numbers(rest, &c->numbers, &c->capacity);
    if ((int)k != cadinterp_parameter_count(c->asset) || k > 16) return 0;
    memcpy(c->x, c->numbers, k * sizeof c->x[0]);
    ++c->points;
    return 1;
  }
  if (strcmp(key, "status") == 0) {
    const int field0[1] = {0};
    const int nf = cadinterp_field_count(c->asset) > 0 ? 1 : 0;
    const cadinterp_status s = cadinterp_eval(c->ws, c->x, field0, nf, &c->mesh);
    c->have_mesh = s == CADINTERP_OK;
    if (sscanf(rest, "%63s", word) != 1 || strcmp(word, status_name(s)) != 0) {
      fprintf(stderr, "  eval: %s (%s), expected %s\n", status_name(s),
              cadinterp_workspace_error(c->ws), word);
      return 0;
    }
    return 1;
  }
  if (!c->have_mesh) return 1; /* derivative lines of a failed point: nothing to compare */
  if (strcmp(key, "element") == 0) {
    int e = -1;
    if (sscanf(rest, "%d", &e) != 1 || e != c->mesh.element) {
      fprintf(stderr, "  element %d, expected %d\n", c->mesh.element, e);
      return 0;
    }
    return 1;
  }
  if (strcmp(key, "positions") == 0 || strcmp(key, "field0") == 0) {
    const int is_field = key[0] == 'f';
    const size_t n = parse_numbers(rest, &c->numbers, &c->capacity);
    size_t rows = 3 * (size_t)c->mesh.vertex_count;
    if (is_field) {
      cadinterp_field_info info;
      if (cadinterp_field(c->asset, 0, &info) != CADINTERP_OK) return 0;
      rows = (info.location == CADINTERP_PER_TET ? c->mesh.tet_count : c->mesh.vertex_count) *
             (size_t)info.components;
    }
    if (n != rows) {
      fprintf(stderr, "  %s: %zu values, the mesh has %zu\n", key, n, rows);
      return 0;
    }
    c->values_checked += n;
    return compare(key, is_field ? c->mesh.fields[0] : c->mesh.positions, c->numbers, n, c->tol);
  }
  return 1; /* grad_tolerance, dpositions, dfield0: the conformance runner's */
}

static int run_case(const char* dir) {
  char path[4096];
  case_state c;
  char *text, *line, *next;
  int ok = 1;
  memset(&c, 0, sizeof c);
  c.tol = 1e-5;
  snprintf(path, sizeof path, "%s/expected.txt", dir);
  if (!(text = read_file(path))) {
    fprintf(stderr, "%s: cannot read\n", path);
    return 0;
  }
  for (line = text; ok && line && *line; line = next) {
    next = strchr(line, '\n');
    if (next) *next++ = '\0';
    ok = check_line(&c, dir, line);
  }
  printf("%s %s: %zu points, %zu values compared\n", ok ? "PASS" : "FAIL", dir, c.points,
         c.values_checked);
  if (ok && c.values_checked == 0) {
    printf("FAIL %s: no values compared (a case without an evaluated point checks nothing)\n", dir);
    ok = 0;
  }
  cadinterp_workspace_destroy(c.ws);
  cadinterp_close(c.asset);
  free(c.numbers);
  free(text);
  return ok;
}

int main(int argc, char** argv) {
  int i, failed = 0;
  const char* where = "(unknown)";
#if defined(__linux__) || defined(__APPLE__)
  /* ISO C has no cast from a function pointer to void*: copy the bits. */
  const char* (*fn)(void) = cadinterp_version;
  void* addr;
  Dl_info info;
  memcpy(&addr, &fn, sizeof addr);
  if (dladdr(addr, &info) && info.dli_fname) where = info.dli_fname;
#endif
  if (argc < 2) {
    fprintf(stderr, "usage: %s CASE_DIR...  (e.g. conformance/cases/valid/k2_cubic)\n", argv[0]);
    return 2;
  }
  /* The header compiled against and the library linked must be the same release. */
  printf("runtime %s from %s\n", cadinterp_version(), where);
  if (cadinterp_version_number() != CADINTERP_VERSION_NUMBER) {
    printf("FAIL: library version %u, header version %u\n", cadinterp_version_number(),
           (unsigned)CADINTERP_VERSION_NUMBER);
    return 1;
  }
  for (i = 1; i < argc; ++i) failed += !run_case(argv[i]);
  printf("consumer: %d cases, %d failed\n", argc - 1, failed);
  return failed ? 1 : 0;
}
