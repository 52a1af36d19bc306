// The reason counting of stage_report.h.
#include "builder/stage_report.h"

namespace cadinterp::builder {

void count_reason(std::vector<BuildReport::Reason>& reasons, int& other, const std::string& message,
                  const std::vector<double>& x) {
  for (BuildReport::Reason& r : reasons)
    if (r.message == message) {
      ++r.count;
      return;
    }
  if (reasons.size() < BuildReport::kMaxReasons) {
    reasons.push_back({message, 1, x});
    return;
  }
  ++other;
}

std::string reasons_text(const std::vector<BuildReport::Reason>& reasons, int other,
                         std::size_t shown) {
  std::string t;
  int hidden = other;
  for (std::size_t i = 0; i < reasons.size(); ++i) {
    if (i >= shown) {
      hidden += reasons[i].count;
      continue;
    }
    std::string m = reasons[i].message;
    if (m.size() > 200) m = m.substr(0, 197) + "...";
    if (!t.empty()) t += "; ";
    t += "'" + m + "' x" + std::to_string(reasons[i].count);
  }
  if (hidden > 0)
    t += (t.empty() ? "" : "; ") + std::to_string(hidden) + " more with other messages";
  return t;
}

}  // namespace cadinterp::builder
