// The asset's cache of decoded elements: an LRU under a byte budget, and the pool of float
// arrays released elements hand to the next decode. Shared by every workspace of one asset;
// every member is thread-safe.
#pragma once

#include <atomic>
#include <cstddef>
#include <list>
#include <memory>
#include <mutex>
#include <unordered_map>
#include <vector>

#include "format/asset_reader.h"

namespace cadinterp::runtime {

class BufferPool;

// An element as the cache holds it. A cell switch decodes the topology (or shares a neighbour's)
// and the positions; the field arrays, as large again, are decoded by the first call that asks
// for a field, since shape-only calls (eval without fields, mass properties) never read them.
struct CachedElement {
  explicit CachedElement(std::shared_ptr<BufferPool> p);
  CachedElement(const CachedElement&) = delete;
  CachedElement& operator=(const CachedElement&) = delete;
  // The last holder (cache or workspace) releases the element: its buffers go to the pool.
  ~CachedElement();

  std::shared_ptr<BufferPool> pool;
  int index = -1;
  format::DecodedElement mesh;
  // Filled once under fields_mu; fields_ready (release/acquire) publishes them, so calls after the
  // first read them without locking.
  mutable std::mutex fields_mu;
  mutable std::atomic<bool> fields_ready{false};
  mutable std::vector<format::DecodedArray<float>> fields;
  // Largest |value| over all position arrays, measured by the first call that needs it (-1:
  // not yet); racing threads store the same value.
  mutable std::atomic<float> positions_max_abs{-1.0f};
};

// Least-recently-used cache of decoded elements under a byte budget. Elements are shared_ptrs:
// a workspace holding one keeps it alive after eviction. The budget counts each element's own
// arrays (positions, and fields once decoded) and each distinct topology once, however many
// cached elements share it.
class ElementCache {
 public:
  ElementCache();
  ~ElementCache();
  ElementCache(const ElementCache&) = delete;
  ElementCache& operator=(const ElementCache&) = delete;

  // Element e, decoded by `reader` on a miss (throws its FormatError if the decode fails).
  std::shared_ptr<const CachedElement> get(int e, const format::AssetReader& reader);

  // The field arrays of `el`, decoded on the first call. A failed decode throws its FormatError
  // and keeps nothing, so every call that needs the fields reports it.
  const std::vector<format::DecodedArray<float>>& fields(const CachedElement& el,
                                                         const format::AssetReader& reader);

  // 0 keeps only the most recently used element (the one a call is evaluating).
  void set_budget(std::size_t bytes);

 private:
  struct Slot {
    std::shared_ptr<CachedElement> element;
    std::list<int>::iterator lru;
    std::size_t bytes;  // what this entry added to bytes_, topology aside
  };
  void evict();  // under mu_

  const std::shared_ptr<BufferPool> pool_;
  std::mutex mu_;
  std::size_t budget_ = std::size_t(256) << 20, bytes_ = 0;
  std::list<int> lru_;
  std::unordered_map<int, Slot> map_;
  // Cached elements per topology.
  std::unordered_map<const format::Topology*, std::size_t> topology_users_;
};

}  // namespace cadinterp::runtime
