// Reads .cadi assets: opens (memory-mapped file or caller's bytes), verifies every byte it uses
// before use, and decodes one element's meshes at a time.
//
// Open touches only the header and the index (cost independent of the blob bytes): magic and
// version, file size, index checksum, FlatBuffers verification with explicit limits, then a
// semantic check of every count, index, range and value (CompiledBasis::from_parts for the
// basis, the checks of asset_reader.cpp for the rest), so that nothing later can read out of
// bounds. Blobs are checked (range at open, XXH64 before decoding, decoded values as they are
// decoded).
//
// Decoding is split by what a caller needs when: decode_element gives the topology and the
// per-term positions (all a cell switch needs), decode_fields the per-term field arrays (needed
// only once a field is asked for). Elements whose topology blobs are shared (SPEC.md, "Layout")
// share one decoded Topology: the reader remembers, without owning, the topologies still in use
// and hands the same one out again instead of decoding it anew.
//
// Thread-safety: an AssetReader is immutable after open but for that topology table, which is
// synchronized; all const methods may be called concurrently.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <new>
#include <string>
#include <utility>
#include <vector>

#include "core/compiled_basis.h"
#include "format/asset_format.h"

namespace cadinterp::fb {
struct Asset;
struct ElementMeshes;
}  // namespace cadinterp::fb

namespace cadinterp::format {

class MappedFile;  // mapped_file.h

/// An allocator whose argument-less construct() default-initializes: a vector of floats or ints
/// resized to n is allocated but not written. Decoders overwrite every value, so std::vector's
/// zero fill would be a wasted pass over tens of megabytes per element, and it would take the
/// page faults of fresh memory in a single thread before the parallel decode. (Allocation stays
/// with std::allocator: no owning new/delete.)
template <class T>
struct DefaultInitAllocator {
  using value_type = T;
  DefaultInitAllocator() = default;
  template <class U>
  DefaultInitAllocator(const DefaultInitAllocator<U>&) noexcept {}
  T* allocate(std::size_t n) { return std::allocator<T>().allocate(n); }
  void deallocate(T* p, std::size_t n) noexcept { std::allocator<T>().deallocate(p, n); }
  template <class U>
  void construct(U* p) noexcept(noexcept(U())) {
    ::new (static_cast<void*>(p)) U;  // default-initialization: no value written for a scalar
  }
  template <class U, class... A>
  void construct(U* p, A&&... a) {
    ::new (static_cast<void*>(p)) U(std::forward<A>(a)...);
  }
  friend bool operator==(const DefaultInitAllocator&, const DefaultInitAllocator&) { return true; }
  friend bool operator!=(const DefaultInitAllocator&, const DefaultInitAllocator&) { return false; }
};

/// A decoded array: a std::vector whose resize() leaves new values uninitialized.
template <class T>
using DecodedArray = std::vector<T, DefaultInitAllocator<T>>;

/// Float arrays a decode may reuse instead of allocating: their values are overwritten, their
/// capacity saves the allocation and, more so, the page faults of fresh memory (one per 4 KiB;
/// measured 2,700 for the positions of a 100k-vertex element, costing more CPU time than their
/// raw decode). The runtime's cache passes the buffers of the elements it released.
using SpareArrays = std::vector<DecodedArray<float>>;

/// An element's mesh combinatorics, decoded. Elements whose topology blobs are the same blobs
/// (the normal case when the model's mesh never changes combinatorics) share one Topology.
struct Topology {
  DecodedArray<std::uint32_t> tets;          ///< #tets by 4
  DecodedArray<std::uint32_t> triangles;     ///< #triangles by 3, outward
  DecodedArray<std::int32_t> triangle_tags;  ///< #triangles
  std::size_t bytes() const;
};

/// One element's meshes except its fields, decoded (see ElementData in asset_writer.h for the
/// shapes); the fields come from AssetReader::decode_fields.
struct DecodedElement {
  std::uint32_t vertex_count = 0;
  std::shared_ptr<const Topology> topology;    ///< null for an infeasible element
  DecodedArray<float> canonical;               ///< #V by 3
  std::vector<DecodedArray<float>> positions;  ///< per term: #V by 3
  /// Bytes held by canonical and positions; the topology, possibly shared, is not included.
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

  /// Decodes element e's topology (or finds it: see decode_topology), canonical positions and
  /// per-term positions; the blobs are decoded by up to hardware_concurrency threads. Throws
  /// FormatError(ChecksumMismatch / CorruptBlob / InvalidArgument).
  /// @param[in,out] spare  nullable: arrays to reuse (those with enough capacity are taken out)
  DecodedElement decode_element(int e, SpareArrays* spare = nullptr) const;

  /// Element e's topology: the Topology another caller still holds if its blobs are the same
  /// blobs (same references, same counts), else decoded and verified now. A failed decode is not
  /// remembered, so every element sharing a corrupt blob reports it. Throws as decode_element.
  std::shared_ptr<const Topology> decode_topology(int e) const;

  /// Decodes element e's field arrays, per term (#V by the per-vertex field values, then #tets
  /// by the per-tet ones, in the index's field order); empty if the asset has no fields or e is
  /// infeasible. Throws as decode_element.
  /// @param[in,out] spare  as for decode_element
  std::vector<DecodedArray<float>> decode_fields(int e, SpareArrays* spare = nullptr) const;

  /// Verifies the XXH64 of every blob, each shared blob once (cadinterp_open_options'
  /// CADINTERP_OPEN_VERIFY_BLOBS): reads the whole blob section. Throws
  /// FormatError(ChecksumMismatch) naming the first bad blob.
  void verify_blobs() const;

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
  std::unique_ptr<MappedFile> map_;        // the mapped file (open_file)
  const fb::Asset* index_ = nullptr;
  std::uint64_t blobs_ = 0;  // file offset of the blob section
  core::CompiledBasis basis_;
  std::uint16_t minor_ = 0;
  std::size_t per_vertex_ = 0, per_tet_ = 0;
  ReadLimits limits_;
  // Topologies handed out and possibly still in use, by what determines their content: the
  // three blob references (offset, size, checksum, codec) and the three counts. Weak: memory
  // belongs to the elements holding them (whose cache budgets count it), never to the reader.
  using TopologyKey = std::array<std::uint64_t, 15>;
  TopologyKey topology_key(int e) const;
  std::shared_ptr<const Topology> find_topology(const TopologyKey& key) const;
  /// Remembers `t` for `key` unless a live topology is there already; returns the one to use.
  std::shared_ptr<const Topology> remember_topology(const TopologyKey& key,
                                                    std::shared_ptr<const Topology> t) const;
  mutable std::mutex topologies_mu_;
  mutable std::map<TopologyKey, std::weak_ptr<const Topology>> topologies_;
};

/// The floor cadinterp_error_estimates adds to quantity q's shaped estimate in element `m`
/// (format 1.3, SPEC.md "Error model"): q 0 (geometry) its geometry_floor, q 1 + f its
/// field_floors[f]; 0 where the file holds none. `m` must have passed the reader's checks (one
/// field floor per field when present), and q must be below 1 + #fields. Thread-safe (reads
/// only); no failure.
double element_error_floor(const fb::ElementMeshes& m, int q);

}  // namespace cadinterp::format
