#include "mapping/surface.h"

#include <cmath>
#include <unordered_map>

namespace cadinterp::mapping {

bool build_surface(const builder::Sample& s, Surface& out, std::string& why) {
  out.sample = &s;
  const int H = static_cast<int>(3 * s.triangle_count());
  out.twin.assign(static_cast<std::size_t>(H), -1);
  // Directed edge (a, b) -> half-edge; an oriented manifold has each direction at most once.
  std::unordered_map<std::uint64_t, int> directed;
  directed.reserve(static_cast<std::size_t>(H));
  auto key = [](std::uint32_t a, std::uint32_t b) { return (std::uint64_t(a) << 32) | b; };
  for (int h = 0; h < H; ++h) {
    if (!directed.emplace(key(out.from(h), out.to(h)), h).second) {
      why = "boundary surface is not an oriented manifold (edge " + std::to_string(out.from(h)) +
            "-" + std::to_string(out.to(h)) + " used twice in one direction)";
      return false;
    }
  }
  for (int h = 0; h < H; ++h) {
    auto it = directed.find(key(out.to(h), out.from(h)));
    if (it != directed.end()) out.twin[static_cast<std::size_t>(h)] = it->second;
  }
  return true;
}

double distance(const double* a, const double* b) {
  return std::sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) +
                   (a[2] - b[2]) * (a[2] - b[2]));
}

}  // namespace cadinterp::mapping
