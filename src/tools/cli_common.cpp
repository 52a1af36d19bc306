// The helpers several `cadinterp` commands share (cli_common.h): status messages, number
// formatting, the C ABI handles, the index reader and field selection.
#include "cli_common.h"

#include <algorithm>
#include <cstdarg>
#include <cstdio>

namespace cadinterp::cli {

namespace {

const char* status_enum_name(int s) {
  switch (s) {
    case CADINTERP_OK:
      return "CADINTERP_OK";
    case CADINTERP_E_INVALID_ARGUMENT:
      return "CADINTERP_E_INVALID_ARGUMENT";
    case CADINTERP_E_OUT_OF_MEMORY:
      return "CADINTERP_E_OUT_OF_MEMORY";
    case CADINTERP_E_IO:
      return "CADINTERP_E_IO";
    case CADINTERP_E_BAD_MAGIC:
      return "CADINTERP_E_BAD_MAGIC";
    case CADINTERP_E_UNSUPPORTED_VERSION:
      return "CADINTERP_E_UNSUPPORTED_VERSION";
    case CADINTERP_E_TRUNCATED:
      return "CADINTERP_E_TRUNCATED";
    case CADINTERP_E_CORRUPT_INDEX:
      return "CADINTERP_E_CORRUPT_INDEX";
    case CADINTERP_E_CHECKSUM:
      return "CADINTERP_E_CHECKSUM";
    case CADINTERP_E_OUT_OF_RANGE:
      return "CADINTERP_E_OUT_OF_RANGE";
    case CADINTERP_E_LIMIT:
      return "CADINTERP_E_LIMIT";
    case CADINTERP_E_CORRUPT_BLOB:
      return "CADINTERP_E_CORRUPT_BLOB";
    case CADINTERP_E_OUTSIDE_DOMAIN:
      return "CADINTERP_E_OUTSIDE_DOMAIN";
    case CADINTERP_E_INFEASIBLE:
      return "CADINTERP_E_INFEASIBLE";
    case CADINTERP_E_INTERNAL:
      return "CADINTERP_E_INTERNAL";
    case CADINTERP_E_NOT_FOUND:
      return "CADINTERP_E_NOT_FOUND";
    case CADINTERP_E_CANCELLED:
      return "CADINTERP_E_CANCELLED";
    case CADINTERP_E_STORE_MISMATCH:
      return "CADINTERP_E_STORE_MISMATCH";
    default:
      return "unknown status";
  }
}

}  // namespace

std::string describe(int status, const std::string& detail) {
  std::string s = status_enum_name(status);
  std::string text = cadinterp_status_string(static_cast<cadinterp_status>(status));
  // A runtime older than the builder's statuses has no text for them.
  if (text == "unknown status") {
    if (status == CADINTERP_E_CANCELLED) text = "cancelled";
    if (status == CADINTERP_E_STORE_MISMATCH) text = "sample store of another model or box";
  }
  s += " (" + text + ")";
  if (!detail.empty()) s += ": " + detail;
  return s;
}

std::string fmt(const char* f, ...) {
  va_list a, b;
  va_start(a, f);
  va_copy(b, a);
  const int n = std::vsnprintf(nullptr, 0, f, a);
  va_end(a);
  std::string s(static_cast<std::size_t>(std::max(n, 0)) + 1, '\0');
  std::vsnprintf(s.data(), s.size(), f, b);
  va_end(b);
  s.pop_back();
  return s;
}

std::string human_bytes(std::uint64_t b) {
  if (b < 1024) return fmt("%llu B", static_cast<unsigned long long>(b));
  const char* units[] = {"KiB", "MiB", "GiB", "TiB"};
  double v = static_cast<double>(b) / 1024;
  int u = 0;
  while (v >= 1024 && u < 3) {
    v /= 1024;
    ++u;
  }
  return fmt("%.1f %s", v, units[u]);
}

std::string human_seconds(double s) {
  if (s < 0) return "?";
  if (s == 0) return "0 s";
  if (s < 1e-3) return fmt("%.1f us", s * 1e6);
  if (s < 1) return fmt("%.1f ms", s * 1e3);
  if (s < 120) return fmt("%.1f s", s);
  if (s < 7200) return fmt("%dm%02ds", static_cast<int>(s) / 60, static_cast<int>(s) % 60);
  return fmt("%dh%02dm", static_cast<int>(s) / 3600, static_cast<int>(s) % 3600 / 60);
}

double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

AssetPtr open_asset(const std::string& path) {
  cadinterp_asset* a = nullptr;
  const cadinterp_status s = cadinterp_open(path.c_str(), &a);
  if (s != CADINTERP_OK)
    throw RuntimeFailure("cannot open " + path + ": " + describe(s, cadinterp_open_error()));
  return AssetPtr(a);
}

WorkspacePtr make_workspace(const cadinterp_asset* a) {
  cadinterp_workspace* w = nullptr;
  const cadinterp_status s = cadinterp_workspace_create(a, &w);
  if (s != CADINTERP_OK) throw RuntimeFailure("cannot create a workspace: " + describe(s, ""));
  return WorkspacePtr(w);
}

void check_ws(cadinterp_status s, const cadinterp_workspace* ws, const std::string& what) {
  if (s != CADINTERP_OK)
    throw RuntimeFailure(what + ": " + describe(s, cadinterp_workspace_error(ws)));
}

std::unique_ptr<format::AssetReader> open_index(const std::string& path) {
  try {
    return format::AssetReader::open_file(path);
  } catch (const format::FormatError& e) {
    throw RuntimeFailure("cannot open " + path + ": " +
                         describe(static_cast<int>(e.status), e.what()));
  }
}

std::vector<int> select_fields(const cadinterp_asset* a, const std::string& spec) {
  std::vector<int> idx;
  const int n = cadinterp_field_count(a);
  if (spec == "all") {
    for (int i = 0; i < n; ++i) idx.push_back(i);
    return idx;
  }
  for (const std::string& name : split_list(spec)) {
    int i = -1;
    if (cadinterp_find_field(a, name.c_str(), &i) != CADINTERP_OK) {
      std::string known;
      for (int j = 0; j < n; ++j) {
        cadinterp_field_info f{};
        cadinterp_field(a, j, &f);
        known += (known.empty() ? "" : ", ") + std::string(f.name);
      }
      throw UsageError("unknown field '" + name +
                       "' (the asset's fields: " + (known.empty() ? "none" : known) + ")");
    }
    idx.push_back(i);
  }
  return idx;
}

int unavailable_command(const ArgParser& p, const std::vector<std::string>& args,
                        const std::string& failure) {
  if (std::find(args.begin(), args.end(), "--help") != args.end() ||
      std::find(args.begin(), args.end(), "-h") != args.end()) {
    std::fputs(p.help().c_str(), stdout);
    return kExitOk;
  }
  throw RuntimeFailure(failure);
}

}  // namespace cadinterp::cli
