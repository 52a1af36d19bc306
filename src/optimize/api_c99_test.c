/* A C99 translation unit against cadinterp_optimize.h: the header compiles as C (pedantic,
 * warnings as errors) and the library is usable from C. Minimizes the volume of the
 * conformance case given as argv[1] with the bend parameter fixed, and checks the result. */
#include <math.h>
#include <stdio.h>

#include "cadinterp/cadinterp.h"
#include "cadinterp/cadinterp_optimize.h"

int main(int argc, char** argv) {
  cadinterp_asset* asset = NULL;
  cadinterp_optimize_problem* p = NULL;
  cadinterp_optimize_result r = {0};
  cadinterp_optimize_options o;
  int ok = 0;
  if (argc != 2 || cadinterp_open(argv[1], &asset) != CADINTERP_OK) return 2;
  if (cadinterp_optimize_create(asset, &p) != CADINTERP_OK) return 3;
  cadinterp_optimize_options_init(&o);
  r.struct_size = sizeof r;
  if (cadinterp_optimize_parse(p, 0, "volume + 0.5*integral(temperature)") == CADINTERP_OK &&
      cadinterp_optimize_set_bounds(p, 0, 0.25, 0.25) == CADINTERP_OK &&
      cadinterp_optimize_solve(p, &o, &r) == CADINTERP_OK) {
    printf("x* = (%g, %g), objective %g, %s\n", r.x[0], r.x[1], r.objective, r.status);
    ok = r.x[0] == 0.25 && r.parameter_count == 2 && isfinite(r.objective) && r.path_length > 0;
  } else {
    printf("failed: %s\n", cadinterp_optimize_error(p));
  }
  cadinterp_optimize_destroy(p);
  cadinterp_close(asset);
  return ok ? 0 : 1;
}
