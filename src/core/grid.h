// Integer grid coordinates of the normalized parameter domain.
//
// The domain [lo,hi]^K is mapped to the unit box [0,1]^K, and the unit box to integers
// [0, kUnit]^K with kUnit = 2^kMaxLevel. Every K-d tree face, sample and B-spline knot is a
// dyadic point, so it is an exact integer here: deduplicating samples, testing whether a point
// lies on a face or inside a box never needs an epsilon (DESIGN.md, open points).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

namespace cadinterp::core {

/// Largest supported number of parameters.
constexpr int kMaxDim = 8;
/// Deepest refinement level per direction: an element is at least 2^-kMaxLevel wide.
constexpr int kMaxLevel = 30;
/// Integer coordinate type. Cubic B-splines centred outside the domain reach -3 kUnit, so the
/// type is signed and wider than 32 bits.
using Coord = std::int64_t;
constexpr Coord kUnit = Coord(1) << kMaxLevel;

/// A point of the integer grid; only the first K entries are meaningful, the rest stay 0 so that
/// whole-array comparison and hashing are valid.
using IPoint = std::array<Coord, kMaxDim>;

/// A closed box [lo, hi] of the integer grid.
struct IBox {
  IPoint lo{};
  IPoint hi{};
};

/// Width of a cell at `level` in integer units.
constexpr Coord width_at(int level) { return kUnit >> level; }

/// Converts an integer coordinate to the unit interval (exact: kUnit is a power of two).
constexpr double to_unit(Coord c) { return static_cast<double>(c) / static_cast<double>(kUnit); }

/// True when the closed boxes a and b share at least one point (in the first K directions).
inline bool boxes_touch(const IBox& a, const IBox& b, int K) {
  for (int d = 0; d < K; ++d)
    if (a.lo[d] > b.hi[d] || b.lo[d] > a.hi[d]) return false;
  return true;
}

/// True when the open interiors of a and b intersect (positive-measure overlap).
inline bool boxes_overlap(const IBox& a, const IBox& b, int K) {
  for (int d = 0; d < K; ++d)
    if (a.lo[d] >= b.hi[d] || b.lo[d] >= a.hi[d]) return false;
  return true;
}

/// True when point p lies in the closed box b.
inline bool box_contains(const IBox& b, const IPoint& p, int K) {
  for (int d = 0; d < K; ++d)
    if (p[d] < b.lo[d] || p[d] > b.hi[d]) return false;
  return true;
}

/// Corner `mask` of box b: upper in direction d where bit d of mask is set (first K directions).
inline IPoint box_corner(const IBox& b, int mask, int K) {
  IPoint p{};
  for (int d = 0; d < K; ++d) p[d] = (mask >> d) & 1 ? b.hi[d] : b.lo[d];
  return p;
}

struct IPointHash {
  std::size_t operator()(const IPoint& p) const noexcept {
    std::uint64_t h = 0x9e3779b97f4a7c15ull;
    for (Coord c : p) {
      h ^= static_cast<std::uint64_t>(c) + 0x9e3779b97f4a7c15ull + (h << 6) + (h >> 2);
    }
    return static_cast<std::size_t>(h);
  }
};

}  // namespace cadinterp::core
