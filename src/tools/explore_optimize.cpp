// The explorer's optimization endpoint (explore_optimize.h). Without libcadinterp_optimize in
// the build, both routes answer 501 and say so.
#include "explore_optimize.h"

#include <chrono>
#include <mutex>
#include <vector>

#include "json_writer.h"
#ifdef CADINTERP_CLI_HAVE_OPTIMIZE
#include "cli_args.h"
#include "cli_common.h"
#include "optimize_setup.h"
#endif

namespace cadinterp::cli {
namespace {

HttpReply error_reply(int status, const std::string& message) {
  HttpReply r{status, ""};
  JsonWriter w(r.body, 0);
  w.begin_object().field("error", message).end_object();
  return r;
}

#ifdef CADINTERP_CLI_HAVE_OPTIMIZE

std::mutex g_running;  // one optimization at a time: they share the machine's cores with the page

std::string form_value(const std::multimap<std::string, std::string>& form, const char* key) {
  const auto it = form.find(key);
  return it == form.end() ? "" : it->second;
}

// An integer form field in [lo, hi], `fallback` when absent; a SpecError otherwise.
int form_int(const std::multimap<std::string, std::string>& form, const char* key, int fallback,
             int lo, int hi) {
  const std::string v = form_value(form, key);
  if (v.empty()) return fallback;
  double d = 0;
  if (!parse_double(v, &d) || d != static_cast<int>(d) || d < lo || d > hi)
    throw SpecError(key, v,
                    std::string(key) + " must be an integer in [" + std::to_string(lo) + ", " +
                        std::to_string(hi) + "], got '" + v + "'");
  return static_cast<int>(d);
}

OptimizeSpec spec_from_form(const std::multimap<std::string, std::string>& form) {
  OptimizeSpec s;
  s.minimize = form_value(form, "objective");
  if (s.minimize.find_first_not_of(" \t") == std::string::npos)
    throw SpecError("objective", s.minimize, "no objective given");
  const auto [b, e] = form.equal_range("constraint");
  for (auto it = b; it != e; ++it)
    if (it->second.find_first_not_of(" \t") != std::string::npos)
      s.subject_to.push_back(it->second);
  s.fix = form_value(form, "fix");
  const std::string start = form_value(form, "start");
  for (const std::string& v : split_list(start)) {
    double d = 0;
    if (!parse_double(v, &d)) throw SpecError("start", start, "'" + v + "' is not a number");
    s.start.push_back(d);
  }
  s.max_iterations = form_int(form, "max_iterations", 100, 0, kOptimizeMaxIterations);
  s.multistart = form_int(form, "multistart", 1, 1, kOptimizeMaxStarts);
  const std::string tol = form_value(form, "tolerance");
  if (!tol.empty() &&
      (!parse_double(tol, &s.tolerance) || !(s.tolerance >= 1e-12) || !(s.tolerance <= 1.0)))
    throw SpecError("tolerance", tol, "tolerance must be a number in [1e-12, 1]");
  return s;
}

// The page's name of an input: "objective", "constraint N" (1-based), "fix", "start".
std::string input_name(const SpecError& e, const OptimizeSpec& s) {
  if (e.input == "--minimize") return "objective";
  if (e.input == "--subject-to") {
    for (std::size_t i = 0; i < s.subject_to.size(); ++i)
      if (s.subject_to[i] == e.text) return "constraint " + std::to_string(i + 1);
    return "constraint";
  }
  if (e.input == "--fix") return "fix";
  if (e.input == "--start") return "start";
  return e.input;
}

HttpReply spec_error_reply(const SpecError& e, const OptimizeSpec& s) {
  HttpReply r{400, ""};
  JsonWriter w(r.body, 0);
  w.begin_object().field("error", std::string(e.what())).field("input", input_name(e, s));
  w.field("text", e.text).field("column", e.column).end_object();
  return r;
}

struct Deadline {
  std::chrono::steady_clock::time_point end;
};

// Stops a start once the request's wall-time budget is spent (Ipopt then reports "stopped by
// the caller" and the best point so far).
int stop_at_deadline(void* user, int, int, const double*, double, double, double) {
  return std::chrono::steady_clock::now() > static_cast<const Deadline*>(user)->end ? 1 : 0;
}

HttpReply run_locked(const cadinterp_asset* asset,
                     const std::multimap<std::string, std::string>& form) {
  OptimizeSpec spec;
  ProblemPtr problem;
  try {
    spec = spec_from_form(form);
    problem = make_problem(asset, spec);
  } catch (const SpecError& e) {
    return spec_error_reply(e, spec);
  }
  const auto t0 = std::chrono::steady_clock::now();
  Deadline deadline{t0 + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                             std::chrono::duration<double>(kOptimizeMaxSeconds))};
  cadinterp_optimize_options o = solve_options(spec);
  o.progress = &stop_at_deadline;
  o.progress_user = &deadline;
  cadinterp_optimize_result r{};
  r.struct_size = sizeof r;
  const cadinterp_status s = cadinterp_optimize_solve(problem.get(), &o, &r);
  if (s == CADINTERP_E_INVALID_ARGUMENT)
    return error_reply(400, cadinterp_optimize_error(problem.get()));
  if (s != CADINTERP_OK)
    return error_reply(422, describe(s, cadinterp_optimize_error(problem.get())));
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  HttpReply reply{200, ""};
  JsonWriter w(reply.body, 0);
  const std::vector<std::string> names = parameter_names(asset);
  w.begin_object();
  w.key("parameters").begin_array();
  for (const std::string& n : names) w.value(n);
  w.end_array();
  w.field("seconds", seconds);
  w.key("result").begin_object();
  write_result_members(w, spec, r, names);
  w.end_object().end_object();
  return reply;
}

#endif

}  // namespace

#ifdef CADINTERP_CLI_HAVE_OPTIMIZE

HttpReply optimize_capabilities() {
  HttpReply r{200, ""};
  JsonWriter w(r.body, 0);
  w.begin_object().field("available", true);
  w.field("max_iterations", kOptimizeMaxIterations).field("max_starts", kOptimizeMaxStarts);
  w.field("max_seconds", kOptimizeMaxSeconds).end_object();
  return r;
}

HttpReply optimize_request(const cadinterp_asset* asset,
                           const std::multimap<std::string, std::string>& form) {
  if (!asset) return error_reply(500, "the server has no asset to optimize");
  std::unique_lock<std::mutex> lock(g_running, std::try_to_lock);
  if (!lock.owns_lock())
    return error_reply(409, "another optimization is running: try again when it has finished");
  try {
    return run_locked(asset, form);
  } catch (const std::bad_alloc&) {
    return error_reply(500, "out of memory");
  }
}

#else

constexpr const char* kUnavailable =
    "this cadinterp was built without the optimizer (libcadinterp_optimize needs Ipopt: Debian's "
    "coinor-libipopt-dev)";

HttpReply optimize_capabilities() {
  HttpReply r{501, ""};
  JsonWriter w(r.body, 0);
  w.begin_object().field("available", false).field("reason", kUnavailable).end_object();
  return r;
}

HttpReply optimize_request(const cadinterp_asset*, const std::multimap<std::string, std::string>&) {
  return error_reply(501, kUnavailable);
}

#endif

}  // namespace cadinterp::cli
