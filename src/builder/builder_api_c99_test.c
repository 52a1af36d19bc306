/* Compiled as C99 with -Wpedantic -Werror: both public headers are C-clean together, and the
 * builder library is callable from C. Checks the builder's ABI surface that needs no host run:
 * versions, the status range, create's failure contract, the report's struct_size, and a build
 * session's loop driven from C. */
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

/* The header's session loop in C, every request answered as a failure with a message: the
 * build then fails with CADINTERP_E_INFEASIBLE and lists that message for every point. */
static void check_session_loop(cadinterp_builder* builder) {
  cadinterp_build_session* session = NULL;
  cadinterp_build_report report;
  const char* message = NULL;
  int answered = 0, count = 0;
  CHECK(cadinterp_build_session_create(builder, &session) == CADINTERP_OK);
  for (;;) {
    cadinterp_build_request requests[4];
    size_t n = 0, i;
    int done = 0;
    CHECK(cadinterp_build_session_next_requests(session, requests, 4, -1, &n, &done) ==
          CADINTERP_OK);
    if (done) break;
    for (i = 0; i < n; ++i) {
      cadinterp_sample* out = NULL;
      CHECK(requests[i].kind == CADINTERP_REQUEST_SAMPLE && requests[i].parameter_count == 1);
      CHECK(requests[i].x[0] >= 1.0 && requests[i].x[0] <= 2.0);
      CHECK(cadinterp_build_session_sample(session, requests[i].id, &out) == CADINTERP_OK);
      CHECK(cadinterp_sample_set_message(out, "no kernel here") == CADINTERP_OK);
      CHECK(cadinterp_build_session_submit(session, requests[i].id, CADINTERP_E_INTERNAL) ==
            CADINTERP_OK);
      ++answered;
    }
  }
  CHECK(cadinterp_build_session_finish(session, "c99_session.cadi") == CADINTERP_E_INFEASIBLE);
  cadinterp_build_session_destroy(session);
  memset(&report, 0, sizeof report);
  report.struct_size = sizeof report;
  CHECK(cadinterp_builder_report(builder, &report) == CADINTERP_OK);
  CHECK(answered >= 2 && report.infeasible_points == answered);
  CHECK(cadinterp_builder_infeasible_reason(builder, 0, &message, &count) == CADINTERP_OK);
  CHECK(message != NULL && strcmp(message, "no kernel here") == 0 && count == answered);
}

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
    check_session_loop(builder);
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
