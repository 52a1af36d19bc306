// Writes .cadi assets (internal C++ API; the builder and the asset generator use it).
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "core/compiled_basis.h"
#include "format/asset_format.h"
#include "format/codec.h"

namespace cadinterp::format {

struct ParameterInfo {
  std::string name, unit;
  double lower = 0.0, upper = 1.0;
};

enum class FieldLocation : std::uint8_t { Vertex = 0, Tet = 1 };

struct FieldInfo {
  // Constructors rather than an aggregate: callers that brace-initialize the first three members
  // (the builder) compile without -Wmissing-field-initializers, `unit` defaulting to empty.
  FieldInfo() = default;
  FieldInfo(std::string name_, FieldLocation location_, int components_, std::string unit_ = {})
      : name(std::move(name_)),
        location(location_),
        components(components_),
        unit(std::move(unit_)) {}
  std::string name;
  FieldLocation location = FieldLocation::Vertex;
  int components = 1;  ///< 1..kMaxComps
  /// Free text ("MPa", "mm", "K"), "" when unknown. Any non-empty unit makes the file format 1.1.
  std::string unit;
};

struct RegionInfo {
  std::string name, kind;  ///< kind: "fixed", "force", "heat", ...
  std::vector<std::int32_t> face_tags;
};

struct WriteOptions {
  Codec float_codec = Codec::QuantDeltaZstd;
  Codec index_codec = Codec::QuantDeltaZstd;
  double position_max_abs_error = 0.0;  ///< 0: lossless
  double field_max_abs_error = 0.0;     ///< 0: lossless
  bool operator==(const WriteOptions& o) const {
    return float_codec == o.float_codec && index_codec == o.index_codec &&
           position_max_abs_error == o.position_max_abs_error &&
           field_max_abs_error == o.field_max_abs_error;
  }
};

/// One blob of an element, encoded: its codec and bytes.
struct EncodedBlob {
  Codec codec = Codec::Raw;
  std::vector<std::uint8_t> bytes;
};

/// An element's mesh arrays encoded as write_asset stores them (encode_element_meshes), so that a
/// builder can hold its elements compressed: a cubic element of a five-parameter CAD model
/// carries hundreds of terms, each a float per vertex coordinate, and the raw arrays of a whole
/// build would be several times the asset's size.
struct EncodedMeshes {
  WriteOptions options;  ///< what encoded them; write_asset refuses other options
  std::uint32_t tet_count = 0, triangle_count = 0;
  std::size_t field_values = 0;  ///< per term (0: no fields)
  EncodedBlob tets, triangles, triangle_tags, canonical;
  std::vector<EncodedBlob> positions, fields;  ///< per term
  /// The bytes held (what a builder keeps of the element).
  std::size_t bytes() const;
};

/// One element's meshes. An infeasible element has vertex_count 0 and no arrays.
struct ElementData {
  std::uint32_t vertex_count = 0;
  std::vector<std::uint32_t> tets;            ///< #tets by 4
  std::vector<std::uint32_t> triangles;       ///< #triangles by 3, outward
  std::vector<std::int32_t> triangle_tags;    ///< #triangles
  std::vector<float> canonical;               ///< #V by 3
  std::vector<std::vector<float>> positions;  ///< per term of the element: #V by 3
  std::vector<std::vector<float>> fields;     ///< per term: the fields concatenated (empty if none)
  double error_estimate = 0.0;
  /// Format 1.3 (error_model.h): (1 + #fields) by (K + 1) errors measured by the builder, finite
  /// (negative: not measured); empty when not measured (a feasible element only).
  std::vector<double> error_model;
  /// Format 1.3 (error_model.h): the geometry's error at the element's own samples, finite and
  /// >= 0; 0 when no stored mesh departs from its sample's own (not written).
  double geometry_floor = 0.0;
  /// Format 1.3 (error_model.h): per field, the part of its error the model's shape does not
  /// explain, finite and >= 0; empty (not written) when every floor is 0.
  std::vector<double> field_floors;
  /// When set, the element's meshes already encoded (encode_element_meshes): write_asset stores
  /// these blobs and ignores tets, triangles, triangle_tags, canonical, positions and fields,
  /// which the holder may then release. vertex_count stays.
  std::shared_ptr<const EncodedMeshes> encoded;
};

/// A point where the builder's host failed.
struct InfeasibleInfo {
  std::vector<double> x;  ///< K values, real coordinates
  std::string message;
};

/// A scalar output: one value per basis sample (format 1.3; NaN where the host failed).
struct OutputInfo {
  std::string name, unit;
  std::vector<double> values;  ///< #S, the basis' sample order
};

struct AssetContent {
  std::vector<ParameterInfo> parameters;  ///< K, in the basis' direction order
  const core::CompiledBasis* basis = nullptr;
  std::vector<FieldInfo> fields;
  std::vector<RegionInfo> regions;
  std::vector<ElementData> elements;  ///< one per basis element, in its order
  std::string builder_version, host, options_json;
  std::vector<InfeasibleInfo> infeasible;  ///< host failures, in the builder's order
  /// Scalar outputs, names unique; any makes the file format 1.3.
  std::vector<OutputInfo> outputs;
};

/// Encodes element `ed`'s mesh arrays (vertex_count > 0) with options `o`, exactly as write_asset
/// would store them: the same blobs, byte for byte, so an asset written from encoded elements is
/// the asset written from their arrays. Thread-safe (pure). Throws FormatError(InvalidArgument)
/// when the arrays are inconsistent with vertex_count or with each other (sizes, a position
/// array per field array), or already encoded; the field layout against the asset's descriptors
/// is checked by write_asset.
EncodedMeshes encode_element_meshes(const ElementData& ed, const WriteOptions& o);

/// The bytes of `ed`'s mesh arrays (topology, canonical, positions, fields): what a holder of its
/// encoded meshes releases. Thread-safe; no failure.
std::size_t element_array_bytes(const ElementData& ed);

/// Serializes `content` to the bytes of a .cadi file. Throws FormatError(InvalidArgument) when
/// the content is inconsistent (counts, term counts, parameter ranges against the basis, output
/// names and value counts, a non-finite output value at a sample a feasible element uses) or an
/// element is encoded (ElementData::encoded) with other options than `options`.
std::vector<std::uint8_t> write_asset(const AssetContent& content, const WriteOptions& options);

/// As write_asset, to `path` (written to `path`.tmp, then renamed, so a crash never leaves a
/// partial asset under the final name). Throws FormatError(Io) when the file cannot be written.
void write_asset_file(const AssetContent& content, const WriteOptions& options,
                      const std::string& path);

/// Creates and removes `path`.tmp, the name write_asset_file writes first: a long build calls
/// this before it starts, so that an output it could not write fails before the work, not after.
/// Throws FormatError(Io) naming the file and the system's reason.
void check_asset_file_writable(const std::string& path);

}  // namespace cadinterp::format
