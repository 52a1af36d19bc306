/* Compiled as C99 with -Wpedantic -Werror: the public header is C-clean, and the library is
 * callable from C. Checks behaviour that needs no asset file. */
#include <stdio.h>
#include <string.h>

#include "cadinterp/cadinterp.h"

static int failures = 0, checks = 0;
#define CHECK(cond)                                                      \
  do {                                                                   \
    ++checks;                                                            \
    if (!(cond)) {                                                       \
      fprintf(stderr, "%s:%d: failed: %s\n", __FILE__, __LINE__, #cond); \
      ++failures;                                                        \
    }                                                                    \
  } while (0)

int main(void) {
  cadinterp_asset* asset = NULL;
  static const unsigned char garbage[64] = {1, 2, 3};
  const char* unit = "untouched";
  int major = -1, minor = -1, s;

  CHECK(strcmp(cadinterp_version(), "1.0.0") == 0);
  CHECK(cadinterp_version_number() == CADINTERP_VERSION_NUMBER);
  cadinterp_format_version(&major, &minor);
  CHECK(major == 1 && minor == 3); /* 1.3: per-sample scalar outputs */
  CHECK(cadinterp_output_count(NULL) == 0);
  for (s = CADINTERP_OK; s <= CADINTERP_E_NOT_FOUND; ++s)
    CHECK(cadinterp_status_string((cadinterp_status)s) != NULL);
  CHECK(strcmp(cadinterp_status_string((cadinterp_status)999), "unknown status") == 0);

  CHECK(cadinterp_open("/nonexistent/asset.cadi", &asset) == CADINTERP_E_IO);
  CHECK(asset == NULL);
  CHECK(strlen(cadinterp_open_error()) > 0);
  CHECK(cadinterp_open_memory(garbage, sizeof garbage, 0, &asset) == CADINTERP_E_BAD_MAGIC);
  CHECK(cadinterp_open(NULL, &asset) == CADINTERP_E_INVALID_ARGUMENT);
  CHECK(cadinterp_parameter_count(NULL) == 0);
  CHECK(cadinterp_field_unit(NULL, 0, &unit) == CADINTERP_E_INVALID_ARGUMENT);
  CHECK(strcmp(unit, "untouched") == 0);
  {
    cadinterp_mesh m;
    const uint32_t ids[1] = {0};
    const double x[1] = {0.0};
    CHECK(cadinterp_eval_subset(NULL, x, ids, 1, NULL, 0, NULL, 0, &m) ==
          CADINTERP_E_INVALID_ARGUMENT);
  }
  {
    uint32_t nv = 7;
    CHECK(cadinterp_element_mesh_size(NULL, 0, &nv, NULL, NULL) == CADINTERP_E_INVALID_ARGUMENT);
    CHECK(nv == 7);
  }
  cadinterp_close(NULL);
  cadinterp_workspace_destroy(NULL);

  printf("api_c99: %d checks, %d failed\n", checks, failures);
  return failures == 0 ? 0 : 1;
}
