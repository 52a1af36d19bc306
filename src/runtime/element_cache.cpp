// The element cache of element_cache.h and the buffer pool behind it.
#include "runtime/element_cache.h"

#include <algorithm>
#include <new>

namespace cadinterp::runtime {

using format::AssetReader;
using format::DecodedArray;
using format::DecodedElement;
using format::SpareArrays;
using format::Topology;

// Float arrays of released elements, for the next decode to reuse. Memory a decode writes for the
// first time costs a page fault per 4 KiB (measured: about 2,700 faults and as much CPU time as
// the raw decode itself for one 100k-vertex element), and whether freed memory comes back without
// faults is up to malloc's heuristics. Bounded to one element's worth: the largest element
// released so far (positions and fields), outside the cache budget.
class BufferPool {
 public:
  // Moves the arrays of a released element in, as far as the bound allows (the rest are freed).
  void give(DecodedElement& mesh, std::vector<DecodedArray<float>>& fields) noexcept {
    std::size_t element = 0;
    auto count = [&](const DecodedArray<float>& a) { element += a.capacity() * sizeof(float); };
    count(mesh.canonical);
    for (const auto& a : mesh.positions) count(a);
    for (const auto& a : fields) count(a);
    std::lock_guard<std::mutex> lock(mu_);
    cap_ = std::max(cap_, element);
    put(mesh.canonical);
    for (auto& a : mesh.positions) put(a);
    for (auto& a : fields) put(a);
  }
  // Every pooled array, for one decode; what it leaves goes back with give_back.
  SpareArrays take_all() {
    std::lock_guard<std::mutex> lock(mu_);
    bytes_ = 0;
    return std::move(arrays_);
  }
  void give_back(SpareArrays& spare) noexcept {
    std::lock_guard<std::mutex> lock(mu_);
    for (auto& a : spare) put(a);
  }

 private:
  // Under mu_. Runs in destructors: never throws (an array the list has no room for is freed).
  void put(DecodedArray<float>& a) noexcept {
    const std::size_t b = a.capacity() * sizeof(float);
    if (b == 0 || bytes_ + b > cap_) return;
    try {
      arrays_.push_back(std::move(a));
      bytes_ += b;
    } catch (const std::bad_alloc&) {
    }
  }
  std::mutex mu_;
  SpareArrays arrays_;
  std::size_t bytes_ = 0, cap_ = 0;
};

// Returns the arrays a decode did not use to the pool, also when the decode throws.
struct SpareGuard {
  BufferPool& pool;
  SpareArrays spare = pool.take_all();
  ~SpareGuard() { pool.give_back(spare); }
};

CachedElement::CachedElement(std::shared_ptr<BufferPool> p) : pool(std::move(p)) {}

CachedElement::~CachedElement() { pool->give(mesh, fields); }

ElementCache::ElementCache() : pool_(std::make_shared<BufferPool>()) {}

ElementCache::~ElementCache() = default;

std::shared_ptr<const CachedElement> ElementCache::get(int e, const AssetReader& reader) {
  {
    std::lock_guard<std::mutex> lock(mu_);
    auto it = map_.find(e);
    if (it != map_.end()) {
      lru_.splice(lru_.begin(), lru_, it->second.lru);
      return it->second.element;
    }
  }
  // Decode outside the lock: other threads keep evaluating cached elements meanwhile. Two
  // threads missing the same element both decode it; the second insert is dropped.
  auto decoded = std::make_shared<CachedElement>(pool_);
  decoded->index = e;
  {
    SpareGuard g{*pool_};
    decoded->mesh = reader.decode_element(e, &g.spare);
  }
  std::lock_guard<std::mutex> lock(mu_);
  auto it = map_.find(e);
  if (it != map_.end()) return it->second.element;
  lru_.push_front(e);
  const std::size_t own = decoded->mesh.bytes();
  map_.emplace(e, Slot{decoded, lru_.begin(), own});
  bytes_ += own;
  if (const Topology* t = decoded->mesh.topology.get())
    if (topology_users_[t]++ == 0) bytes_ += t->bytes();
  evict();
  return decoded;
}

const std::vector<DecodedArray<float>>& ElementCache::fields(const CachedElement& el,
                                                             const AssetReader& reader) {
  if (el.fields_ready.load(std::memory_order_acquire)) return el.fields;
  std::size_t added = 0;
  {
    std::lock_guard<std::mutex> lock(el.fields_mu);
    if (!el.fields_ready.load(std::memory_order_relaxed)) {
      SpareGuard g{*pool_};
      std::vector<DecodedArray<float>> f = reader.decode_fields(el.index, &g.spare);
      for (const auto& a : f) added += a.size() * sizeof(float);
      el.fields = std::move(f);
      el.fields_ready.store(true, std::memory_order_release);
    }
  }
  if (added) {  // charged only while the element is cached (an evicted one is not counted)
    std::lock_guard<std::mutex> lock(mu_);
    auto it = map_.find(el.index);
    if (it != map_.end() && it->second.element.get() == &el) {
      it->second.bytes += added;
      bytes_ += added;
      evict();
    }
  }
  return el.fields;
}

void ElementCache::set_budget(std::size_t bytes) {
  std::lock_guard<std::mutex> lock(mu_);
  budget_ = bytes;
  evict();
}

// Keeps at least the most recent element.
void ElementCache::evict() {
  while (bytes_ > budget_ && lru_.size() > 1) {
    const int victim = lru_.back();
    lru_.pop_back();
    auto it = map_.find(victim);
    bytes_ -= it->second.bytes;
    // A cached element keeps its topology alive, so the pointer cannot be reused while it is a
    // key here.
    if (const Topology* t = it->second.element->mesh.topology.get()) {
      auto u = topology_users_.find(t);
      if (--u->second == 0) {
        bytes_ -= t->bytes();
        topology_users_.erase(u);
      }
    }
    map_.erase(it);
  }
}

}  // namespace cadinterp::runtime
