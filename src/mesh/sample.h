// One host evaluation at a parameter vector: the regenerated tet mesh, its references (control
// points, paths, boundary-condition regions) and simulated fields, or the reason it failed.
// This is what the executor returns, the sample store keeps and the mapping hook consumes.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace cadinterp::mesh {

struct ControlPoint {
  std::vector<std::int64_t> id;  ///< the ID scheme of cadinterp_builder.h
  double position[3] = {0, 0, 0};
};

struct Path {
  std::vector<std::int64_t> a, b;  ///< end control-point IDs
  std::vector<double> polyline;    ///< #P by 3, from a to b
};

struct Region {
  std::string name, kind;
  std::vector<std::int32_t> face_tags;
};

struct Field {
  std::string name;
  std::uint8_t location = 0;  ///< 0 per vertex, 1 per tet (cadinterp_field_location)
  int components = 1;
  std::vector<double> values;  ///< #V (or #T) by components
  std::string unit;            ///< free text, "" when the host gave none
};

/// A scalar the host computed exactly on this sample (B-rep volume, compliance, ...), stored
/// per sample and interpolated with the element's weights (cadinterp_eval_outputs).
struct Output {
  std::string name;
  double value = 0.0;
  std::string unit;  ///< free text, "" when the host gave none
};

struct Sample {
  bool feasible = false;
  std::string message;                      ///< why the host failed (infeasible samples)
  std::vector<double> vertices;             ///< #V by 3
  std::vector<std::uint32_t> tets;          ///< #T by 4
  std::vector<std::uint32_t> triangles;     ///< #F by 3, outward
  std::vector<std::int32_t> triangle_tags;  ///< #F
  std::vector<ControlPoint> points;
  std::vector<Path> paths;
  std::vector<Region> regions;
  std::vector<Field> fields;
  std::vector<Output> outputs;  ///< names unique within the sample
  double host_seconds = 0.0;    ///< not serialized: it differs between runs

  std::size_t vertex_count() const { return vertices.size() / 3; }
  std::size_t tet_count() const { return tets.size() / 4; }
  std::size_t triangle_count() const { return triangles.size() / 3; }
  /// Bounding-box diagonal of the vertices (0 for an empty mesh).
  double bbox_diagonal() const;
};

/// Bounding-box diagonal of #V by 3 coordinates (0 when empty).
double bbox_diagonal(const std::vector<double>& vertices);

/// Checks what the host wrote: non-empty mesh, finite coordinates, indices in range, tets
/// positively oriented and not degenerate (volume above 1e-12 of the bbox diagonal cubed),
/// triangles and tags consistent, field sizes, finite field values, control point IDs unique,
/// output names non-empty and unique, output values finite.
/// Returns "" when valid, else the first problem found.
std::string validate(const Sample& s);

/// Lossless serialization (little-endian, versioned); host_seconds is not kept.
std::vector<std::uint8_t> serialize(const Sample& s);
/// Inverse of serialize. Throws std::runtime_error on malformed bytes.
Sample deserialize(const std::uint8_t* bytes, std::size_t size);

/// True when a and b have the same combinatorics: vertex count, tets, triangles and tags.
bool same_combinatorics(const Sample& a, const Sample& b);

}  // namespace cadinterp::mesh
