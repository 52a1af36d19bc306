// The expression language of cadinterp_optimize_parse (cadinterp_optimize.h documents it): a
// weighted sum of quantities, parsed into terms against an asset's field and region names.
#pragma once

#include <cmath>
#include <string>
#include <vector>

#include "cadinterp/cadinterp.h"
#include "cadinterp/cadinterp_optimize.h"

namespace cadinterp::optimize {

struct Parsed {
  cadinterp_status status = CADINTERP_OK;
  std::string error;  // "column C: ..." on failure
  std::vector<cadinterp_optimize_term> terms;
  // Constraints only: bounds from "<= V", ">= V" or "== V".
  double lower = -HUGE_VAL, upper = HUGE_VAL;
};

// Terms of `text` (a sum of quantities). May throw std::bad_alloc.
Parsed parse_expression(const cadinterp_asset* asset, const char* text);
// Terms and bounds of "EXPR <= V", "EXPR >= V" or "EXPR == V". May throw std::bad_alloc.
Parsed parse_constraint(const cadinterp_asset* asset, const char* text);

}  // namespace cadinterp::optimize
