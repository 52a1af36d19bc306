/* Compiled as C99 with -Wpedantic -Werror: both public headers are C-clean together, and the
 * builder library is callable from C. Checks the builder's ABI surface that needs no host run:
 * versions, the status range, create's failure contract, and the report's struct_size. */
#include <stddef.h>
#include <stdio.h>
#include <string.h>

#include "cadinterp/cadinterp.h"
#include "cadinterp/cadinterp_builder.h"

#if CADINTERP_BUILDER_ABI_VERSION != 0
#error "the builder's SOVERSION is CADINTERP_BUILDER_ABI_VERSION: update this test with it"
#endif

static cadinterp_status never_called(void* user, const double* x, cadinterp_sample* out) {
  (void)user;
  (void)x;
  (void)out;
  return CADINTERP_E_INTERNAL;
}

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
  char expected[32];
  int stale_target = 0;
  cadinterp_builder* builder = (cadinterp_builder*)(void*)&stale_target;
  cadinterp_build_options options;
  cadinterp_build_report report;

  sprintf(expected, "%d.%d.%d", CADINTERP_VERSION_MAJOR, CADINTERP_VERSION_MINOR,
          CADINTERP_VERSION_PATCH);
  CHECK(strcmp(cadinterp_builder_version(), expected) == 0);
  CHECK(cadinterp_builder_version_number() == CADINTERP_VERSION_NUMBER);
  CHECK(CADINTERP_STATUS_MAX_CODE > CADINTERP_E_STORE_MISMATCH);

  cadinterp_build_options_init(&options);
  CHECK(options.struct_size == sizeof options);
  CHECK(options.degree == 1);

  /* A failed create sets *out to NULL and leaves a message for this thread. */
  CHECK(cadinterp_builder_create(NULL, &options, &builder) == CADINTERP_E_INVALID_ARGUMENT);
  CHECK(builder == NULL);
  CHECK(strlen(cadinterp_builder_create_error()) > 0);
  cadinterp_builder_destroy(NULL);

  /* Options no run could use (a negative tolerance, simulate_mapped without a simulate callback)
     are refused by create, before the host is called. */
  {
    const cadinterp_parameter_desc parameter = {"width", "mm", 1.0, 2.0};
    cadinterp_host host;
    memset(&host, 0, sizeof host);
    host.struct_size = sizeof host;
    host.name = "c99";
    host.parameter_count = 1;
    host.parameters = &parameter;
    host.regenerate = never_called;
    CHECK(cadinterp_builder_create(&host, &options, &builder) == CADINTERP_OK);
    cadinterp_builder_destroy(builder);
    options.position_max_abs_error = -1.0;
    CHECK(cadinterp_builder_create(&host, &options, &builder) == CADINTERP_E_INVALID_ARGUMENT);
    CHECK(builder == NULL);
    CHECK(strstr(cadinterp_builder_create_error(), "position_max_abs_error") != NULL);
    options.position_max_abs_error = 0.0;
    options.simulate_mapped = 1; /* the host has no simulate callback */
    CHECK(cadinterp_builder_create(&host, &options, &builder) == CADINTERP_E_INVALID_ARGUMENT);
    CHECK(builder == NULL);
    CHECK(strstr(cadinterp_builder_create_error(), "simulate_mapped") != NULL);
    options.simulate_mapped = 0;
  }

  memset(&report, 0, sizeof report);
  report.struct_size = sizeof report;
  CHECK(cadinterp_builder_report(NULL, &report) == CADINTERP_E_INVALID_ARGUMENT);
  CHECK(report.struct_size == sizeof report);
  CHECK(strlen(cadinterp_builder_error(NULL)) > 0);

  printf("%d checks, %d failures\n", checks, failures);
  return failures == 0 ? 0 : 1;
}
