// Reads .cadi assets: opens (memory-mapped file or caller's bytes), verifies every byte it uses
// before use, and decodes one element's meshes at a time.
//
// Open touches only the header and the index (cost independent of the blob bytes): magic and
// version, file size, index checksum, FlatBuffers verification with explicit limits, then a
// semantic check of every count, index, range and value (CompiledBasis::from_parts for the
// basis, the checks of asset_reader.cpp for the rest), so that nothing later can read out of
// bounds. Blobs are checked (range at open, XXH64 before decoding, decoded values after).
//
// Thread-safety: an AssetReader is immutable after open; all const methods may be called
// concurrently.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/compiled_basis.h"
#include "format/asset_format.h"

namespace cadinterp::fb {
struct Asset;
}

namespace cadinterp::format {

/// One element's meshes, decoded (see ElementData in asset_writer.h for the shapes).
struct DecodedElement {
  std::uint32_t vertex_count = 0;
  std::vector<std::uint32_t> tets, triangles;
  std::vector<std::int32_t> triangle_tags;
  std::vector<float> canonical;
  std::vector<std::vector<float>> positions;  ///< per term
  std::vector<std::vector<float>> fields;     ///< per term (empty when the asset has no fields)
  /// Bytes held by the arrays (for cache budgets).
  std::size_t bytes() const;
};

class AssetReader {
 public:
  /// Maps `path` read-only. Throws FormatError.
  static std::unique_ptr<AssetReader> open_file(const std::string& path,
                                                const ReadLimits& limits = {});
  /// Reads from `size` bytes at `data`. With copy=false the caller keeps them alive and
  /// unchanged for the reader's lifetime (a misaligned index is still copied). Throws FormatError.
  static std::unique_ptr<AssetReader> open_memory(const void* data, std::size_t size, bool copy,
                                                  const ReadLimits& limits = {});
  ~AssetReader();
  AssetReader(const AssetReader&) = delete;
  AssetReader& operator=(const AssetReader&) = delete;

  const fb::Asset& index() const { return *index_; }
  const core::CompiledBasis& basis() const { return basis_; }
  std::uint16_t format_minor() const { return minor_; }
  std::uint64_t file_size() const { return size_; }
  /// Values per vertex and per tet of all fields together (the layout of a field blob).
  std::size_t field_values_per_vertex() const { return per_vertex_; }
  std::size_t field_values_per_tet() const { return per_tet_; }

  /// Decodes element e's meshes. Throws FormatError(ChecksumMismatch / CorruptBlob /
  /// LimitExceeded / InvalidArgument).
  DecodedElement decode_element(int e) const;

 private:
  AssetReader() = default;
  void open(const ReadLimits& limits);
  struct Bytes {
    const std::uint8_t* data;
    std::size_t size;
  };
  Bytes blob(const void* ref) const;  // checksum-verified bytes, in place

  const std::uint8_t* data_ = nullptr;
  std::uint64_t size_ = 0;
  std::vector<std::uint8_t> owned_;        // copied bytes (open_memory with copy)
  std::vector<std::uint64_t> index_copy_;  // 8-aligned copy of a misaligned index
  void* map_ = nullptr;                    // mmap base (open_file)
  const fb::Asset* index_ = nullptr;
  std::uint64_t blobs_ = 0;  // file offset of the blob section
  core::CompiledBasis basis_;
  std::uint16_t minor_ = 0;
  std::size_t per_vertex_ = 0, per_tet_ = 0;
  ReadLimits limits_;
};

}  // namespace cadinterp::format
