// The explorer's optimization endpoint (`cadinterp explore`, explore_server.h): runs
// libcadinterp_optimize on the served asset for the page's Optimize panel, with the inputs of
// `cadinterp optimize` (optimize_setup.h).
//
//   GET  /api/optimize  200 {"available": true, "max_iterations": CAP, ...}, or 501 with
//                       {"available": false, "reason": ...} when this build has no optimizer
//   POST /api/optimize  form fields (application/x-www-form-urlencoded): objective, constraint
//                       (repeated), fix ("name=value,..."), start ("v1,v2,..."), max_iterations,
//                       multistart, tolerance. Answers
//                       200 {"parameters": [...], "seconds": S, "result": {...}} (the members of
//                           `cadinterp optimize --json`: x*, objective, constraints, status in
//                           words, iterations, evaluations, error estimate, the path of iterates);
//                       400 {"error", "input", "text", "column"} for a bad input (column: of the
//                           offending token in text, 1-based, 0 when none);
//                       409 while another optimization runs (one at a time; the page retries);
//                       422 when the optimizer cannot run (e.g. no start the runtime evaluates);
//                       501 without the optimizer.
// Bounded work per request: at most kMaxIterations Ipopt iterations per start, kMaxStarts starts,
// and kMaxSeconds of wall time (then the run stops and reports its best point so far).
#pragma once

#include <map>
#include <string>

#include "cadinterp/cadinterp.h"

namespace cadinterp::cli {

constexpr int kOptimizeMaxIterations = 500;
constexpr int kOptimizeMaxStarts = 8;
constexpr double kOptimizeMaxSeconds = 30.0;

struct HttpReply {
  int status = 200;
  std::string body;  ///< JSON
};

/// GET /api/optimize.
HttpReply optimize_capabilities();

/// POST /api/optimize on `asset` (which outlives the call) with the request's form fields.
/// Thread-safe: a call while another runs answers 409 at once.
HttpReply optimize_request(const cadinterp_asset* asset,
                           const std::multimap<std::string, std::string>& form);

}  // namespace cadinterp::cli
